"""Property tests of footstep_planner.core.synth.blend_groups (thesis 3.7): the path curvature tau
(three-point circumcircle, then a smoothing spline), the turning group weights, the walk/run
parameter s and its mixing. Pure core, no Blender.

Conventions as in the module: metres, seconds, tau = 1/r in 1/m positive turning left
(counter-clockwise seen from +Z), u in footsteps.

Figures used below:

- A sinusoid of period P keeps 1 / (1 + (2 pi width / P)^4) of its amplitude under
  ``smooth_signal(width)``, measured here to within 0.005 (absolute) away from the ends.
- The three-point estimate on a trajectory sampled at frames takes points on chords of the
  true path; on an arc that makes a relative error of at most about (h / (2 dt))^2 for a
  frame time h (under 0.5 % for dt >= 0.3 s at 24 fps and up).
- The smoothing spline's kernel decays like exp(-|t| / (sqrt 2 width)), so a transient at
  an end of the trajectory (the first and last ``dt`` hold the nearest full-window
  estimate) fades over a few widths: "away from the ends" means 5 widths in.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from footstep_planner.core.synth.blend_groups import (
    circumcurvature, curvature, group_weights, mix_speed, smooth_signal, speed_parameter,
)
from footstep_planner.core.clips.library import GroupClip, TurnGroup

HYP = dict(deadline=None, database=None)
FPS_CHOICES = (24, 25, 30, 50, 60, 120)


# ----------------------------------------------------------------------------- helpers

def frozen(*arrays):
    """Read-only copies: any in-place write by the code under test raises."""
    out = []
    for a in arrays:
        a = np.array(a, dtype=float)
        a.flags.writeable = False
        out.append(a)
    return out


def arc(r, v, fps, duration, direction, heading=0.0, t0=0.0, centre=(0.0, 0.0)):
    """Frames of a body going round a circle of radius r at speed v: (pos (F, 3), t (F,)).
    direction +1 counter-clockwise (turning left), -1 clockwise. z bobs (ignored)."""
    t = t0 + np.arange(int(round(duration * fps)) + 1) / fps
    phi = heading + direction * v * (t - t0) / r
    pos = np.stack([centre[0] + r * np.cos(phi), centre[1] + r * np.sin(phi),
                    0.9 + 0.03 * np.sin(4 * np.pi * t)], axis=1)
    return pos, t


def kept_amplitude(t, f, period, mask):
    """Least-squares amplitude of the period-``period`` sinusoid in f[mask]."""
    om = 2 * np.pi / period
    a = np.stack([np.sin(om * t[mask]), np.cos(om * t[mask])], axis=1)
    c = np.linalg.lstsq(a, f[mask], rcond=None)[0]
    return float(np.hypot(*c))


def literal_speed(u, pins_u, pins_s, sigma):
    """Thesis 3.7.2 word for word, one value at a time (reference for sections >= sigma)."""
    out = []
    for x in u:
        if x < pins_u[0]:
            out.append(pins_s[0])
            continue
        k = max(i for i, p in enumerate(pins_u) if p <= x)
        if k == len(pins_u) - 1:
            out.append(pins_s[-1])
            continue
        s1, s2 = pins_s[k], pins_s[k + 1]
        d1, d2 = x - pins_u[k], pins_u[k + 1] - x
        if d1 + d2 < 2 * sigma * (s1 + s2):
            out.append((s1 * d2 + s2 * d1) / (d1 + d2))
        else:
            out.append(max(0.0, s1 * (sigma - d1) / sigma, s2 * (sigma - d2) / sigma))
    return np.array(out)


# ----------------------------------------------------------------------------- curvature

@given(heading=st.floats(-math.pi, math.pi), v0=st.floats(0.2, 6.0), acc=st.floats(-0.1, 0.5),
       fps=st.sampled_from(FPS_CHOICES), dt=st.floats(0.1, 1.5))
@settings(max_examples=30, **HYP)
def test_straight_line_has_zero_curvature(heading, v0, acc, fps, dt):
    t = np.arange(0, 8 * fps + 1) / fps
    s = v0 * t + 0.5 * acc * t**2  # speeding up or slowing down, never turning
    d = np.array([math.cos(heading), math.sin(heading)])
    pos = np.c_[3.0 + s * d[0], -2.0 + s * d[1], 0.9 + 0.02 * np.sin(9 * t)]
    tau = curvature(pos, t, dt)
    assert tau.shape == t.shape
    assert np.all(np.abs(tau) < 1e-6), np.abs(tau).max()  # rounding only (r > 1000 km)


@given(r=st.floats(0.5, 10.0), v=st.floats(0.3, 6.0), fps=st.sampled_from(FPS_CHOICES),
       direction=st.sampled_from((1, -1)), dt=st.floats(0.3, 1.0),
       heading=st.floats(-math.pi, math.pi), t0=st.floats(-50.0, 50.0),
       width=st.sampled_from((0.0, 0.5, 1.0, 2.0)))
@settings(max_examples=30, **HYP)
def test_arc_gives_signed_inverse_radius(r, v, fps, direction, dt, heading, t0, width):
    assume(2 * dt * v / r <= 1.5 * math.pi)  # the three points stay apart on the circle
    pos, t = arc(r, v, fps, 6.0, direction, heading, t0, centre=(4.0, -7.0))
    tau = curvature(pos, t, dt)
    want = direction / r  # counter-clockwise (left) positive
    assert np.all(np.abs(tau / want - 1) < 0.01), (tau.min(), tau.max(), want)
    smooth = smooth_signal(t, tau, width)
    assert np.all(np.abs(smooth / want - 1) < 0.01), (smooth.min(), smooth.max(), want)


def test_left_turn_is_positive():
    # walking along +x then bending towards +y: a left turn
    pos, t = arc(2.0, 1.0, 30, 3.0, +1, heading=-math.pi / 2, centre=(0.0, 2.0))
    assert pos[1, 0] > pos[0, 0] and pos[-1, 1] > pos[0, 1]
    assert np.all(curvature(pos, t, 0.5) > 0)
    assert np.all(curvature(pos[:, [1, 0, 2]], t, 0.5) < 0)  # mirrored: x <-> y
    assert np.all(curvature(pos * [1, -1, 1], t, 0.5) < 0)  # mirrored in the x axis


def test_circumcurvature_points():
    a, b, c = frozen([[1, 0], [0, 0], [0, 0], [0, 0]],
                     [[0, 1], [1, 0], [1, 1], [0, 0]],
                     [[-1, 0], [2, 0], [1, 1], [0, 0]])
    k = circumcurvature(a, b, c)
    assert k[0] == pytest.approx(1.0)  # unit circle, counter-clockwise
    assert k[1] == 0.0 and k[2] == 0.0 and k[3] == 0.0  # collinear, coincident, all one
    assert circumcurvature(c[:1], b[:1], a[:1])[0] == pytest.approx(-1.0)


@pytest.mark.parametrize("fps", (24, 60))
@pytest.mark.parametrize("v", (0.8, 1.4))
def test_step_sway_is_smoothed_away(fps, v):
    """A straight walk whose body sways 3 cm sideways at the step frequency (period 1 s):
    the raw tau swings widely, the smoothed one (width 1 s) stays near 0 away from the ends
    (the fundamental keeps 1 / (1 + (2 pi)^4) = 6e-4 of itself)."""
    t = np.arange(0, 30 * fps + 1) / fps
    pos = np.c_[v * t, 0.03 * np.sin(2 * np.pi * t)]
    raw = curvature(pos, t, 0.5)
    smooth = smooth_signal(t, raw, 1.0)
    inner = (t > 5.0) & (t < t[-1] - 5.0)
    swing = np.abs(raw[inner]).max()
    assert swing > 0.2, swing  # about 2 * 2 * 0.03 / (0.5 v)^2 ... i.e. radii of 1.4 to 4 m
    assert raw[inner].min() < -0.9 * swing  # it really oscillates
    assert np.abs(smooth[inner]).max() < 0.01 * swing, np.abs(smooth[inner]).max()
    assert np.all(np.isfinite(smooth))


def test_curvature_window_clamped_at_the_ends():
    # the first and last dt hold the first and last full-window estimate
    t = np.arange(0, 61) / 20.0  # 3 s
    pos = np.c_[t, 0.1 * t**2]  # a parabola: curvature changes along it
    tau = curvature(pos, t, 0.5)
    assert np.all(tau[t <= 0.5] == tau[10]) and np.all(tau[t >= 2.5] == tau[50])
    assert np.all(tau > 0)  # y = 0.1 x^2 walked towards +x bends left


# ----------------------------------------------------------------------------- smoothing

@given(fps=st.sampled_from(FPS_CHOICES), width=st.floats(0.0, 50.0),
       a=st.floats(-5, 5), b=st.floats(-2, 2), jitter=st.booleans(), t0=st.floats(-100, 100))
@settings(max_examples=20, **HYP)
def test_smoothing_keeps_lines(fps, width, a, b, jitter, t0):
    n = 8 * fps
    steps = np.full(n, 1.0 / fps)
    if jitter:
        steps *= np.random.default_rng(n).uniform(0.5, 1.5, n)
    t = t0 + np.cumsum(steps)
    for y in (np.full(n, a), a + b * (t - t0)):
        t_in, y_in = frozen(t, y)
        out = smooth_signal(t_in, y_in, width)
        assert out.shape == (n,)
        assert np.allclose(out, y, rtol=0, atol=1e-6), np.abs(out - y).max()


@pytest.mark.parametrize("fps,width", ((24, 1.0), (60, 0.5), (120, 0.25), (30, 2.0)))
def test_smoothing_frequency_response(fps, width):
    """The documented figures: kept fraction 1 / (1 + (2 pi width / P)^4)."""
    for ratio, table in ((1, 0.0006), (2, 0.010), (2 * np.pi, 0.50), (4 * np.pi, 0.94),
                        (30, 0.998)):
        period = ratio * width
        kept = 1 / (1 + (2 * np.pi / ratio) ** 4)  # the table, rounded
        assert kept == pytest.approx(table, rel=0.07)
        duration = 12 * width + 2 * period
        t = np.arange(0, duration, 1.0 / fps)
        y = np.sin(2 * np.pi * t / period + 0.3)
        out = smooth_signal(t, y, width)
        inner = (t > 6 * width) & (t < duration - 6 * width)
        got = kept_amplitude(t, out, period, inner)
        assert abs(got - kept) < 0.005, (ratio, got, kept)
    assert got > 0.99  # a turn 30 widths long passes


def test_smoothing_degenerate():
    t, y = frozen([0.0, 0.1, 0.2], [1.0, 5.0, 2.0])
    out = smooth_signal(t, y, 1.0)  # too few samples: unchanged
    assert np.array_equal(out, y) and out is not y
    t = np.arange(100) / 24
    y = np.random.default_rng(0).normal(size=100)
    assert np.array_equal(smooth_signal(t, y, 0.0), y)  # width 0: unchanged
    assert np.array_equal(smooth_signal([3.0], [2.0], 5.0), [2.0])
    huge = smooth_signal(t, y, 1e9)  # the least-squares line (trapezoid weights)
    share = np.r_[0.5, np.ones(98), 0.5]
    line = np.polyval(np.polyfit(t, y, 1, w=np.sqrt(share)), t)
    assert np.abs(huge - line).max() < 5e-3 * np.abs(y).max()


# ----------------------------------------------------------------------------- group weights

TAU_VALUES = (-1.5, -0.6, -0.2, 0.0, 0.0 + 1e-13, 0.25, 0.7, 2.0)


@given(taus=st.lists(st.sampled_from(TAU_VALUES) | st.floats(-3, 3), min_size=1, max_size=7),
       tau=st.lists(st.sampled_from(TAU_VALUES) | st.floats(-4, 4), min_size=0, max_size=20))
@settings(max_examples=80, **HYP)
def test_group_weights_match_turn_group(taus, tau):
    taus = sorted(taus)
    tau_in, taus_in = frozen(tau, taus)
    w = group_weights(taus_in, tau_in)
    assert w.shape == (len(tau), len(taus))
    group = TurnGroup("g", "walk", [GroupClip(f"c{i}", x, 1.0) for i, x in enumerate(taus)])
    for f, x in enumerate(tau):
        want = np.zeros(len(taus))
        for name, value in group.weights(x).items():
            want[int(name[1:])] += value
        assert np.allclose(w[f], want, rtol=0, atol=1e-12), (x, w[f], want)
        # invariants of the bracket interpolation
        assert w[f].sum() == pytest.approx(1.0, abs=1e-12)
        assert np.all(w[f] >= 0)
        nz = np.flatnonzero(w[f])
        assert 1 <= len(nz) <= 2 and (len(nz) == 1 or nz[1] == nz[0] + 1)
        if taus[0] <= x <= taus[-1]:
            assert w[f] @ np.array(taus) == pytest.approx(x, abs=1e-9)
        elif x < taus[0]:
            assert w[f, 0] == 1.0
        else:
            assert w[f, -1] == 1.0


def test_group_weights_vectorized():
    taus = np.array([-1.0, 0.0, 0.5, 2.0])
    tau = np.linspace(-3, 3, 5001)
    w = group_weights(taus, tau)
    assert np.allclose(w.sum(axis=1), 1.0)
    inside = (tau >= -1) & (tau <= 2)
    assert np.allclose(w[inside] @ taus, tau[inside])
    assert np.array_equal(group_weights(taus, [0.25]), [[0, 0.5, 0.5, 0]])


# ----------------------------------------------------------------------------- speed

@given(gaps=st.lists(st.floats(0.0, 12.0), min_size=0, max_size=6),
       values=st.lists(st.floats(0.0, 1.0) | st.sampled_from((0.0, 0.5, 1.0)),
                       min_size=7, max_size=7),
       sigma=st.floats(0.5, 4.0), start=st.floats(-3, 3))
@settings(max_examples=60, **HYP)
def test_speed_parameter_properties(gaps, values, sigma, start):
    pins_u = list(start + np.cumsum([0.0] + gaps))
    pins_s = values[:len(pins_u)]
    u = np.linspace(pins_u[0] - 2, pins_u[-1] + 2, 401)
    pu, ps, uu = frozen(pins_u, pins_s, u)
    s = speed_parameter(uu, pu, ps, sigma)
    assert s.shape == u.shape and np.all((s >= 0) & (s <= 1))
    # equal to each pin (the last one given, where several share a u) at its u
    at = speed_parameter(pins_u, pins_u, pins_s, sigma)
    for k, x in enumerate(pins_u):
        last = max(i for i, p in enumerate(pins_u) if p == x)
        assert at[k] == pytest.approx(pins_s[last], abs=1e-12)
    # held outside
    assert np.all(s[u < pins_u[0]] == pins_s[0]) and np.all(s[u > pins_u[-1]] == pins_s[-1])
    # word for word the thesis wherever the section is at least sigma long
    long_ = np.zeros(u.shape, bool)
    for a, b in zip(pins_u[:-1], pins_u[1:]):
        if b - a >= sigma:
            long_ |= (u >= a) & (u < b)
    ref = literal_speed(u[long_], pins_u, pins_s, sigma)
    assert np.allclose(s[long_], ref, atol=1e-12)
    # continuous inside sections: never steeper than the steeper of the ramp (1/sigma)
    # and the linear interpolation over the shortest positive section
    sections = [b - a for a, b in zip(pins_u[:-1], pins_u[1:]) if b > a]
    step = u[1] - u[0]
    bound = max([1 / sigma] + [1 / d for d in sections]) * step + 1e-9
    k = np.searchsorted(pins_u, u, side="right")
    same = k[1:] == k[:-1]  # consecutive samples in one section
    assert np.all(np.abs(np.diff(s))[same] <= bound)


@pytest.mark.parametrize("sigma", (1.0, 2.0, 3.5))
def test_long_run_section_dips_to_walk(sigma):
    u = np.linspace(0, 20, 2001)
    s = speed_parameter(u, [0, 20], [1, 1], sigma)
    assert s[0] == 1 and s[-1] == 1
    walk = u[s == 0]
    assert walk.min() == pytest.approx(sigma) and walk.max() == pytest.approx(20 - sigma)
    ramp = u <= sigma
    assert np.allclose(s[ramp], 1 - u[ramp] / sigma)  # a ramp over exactly sigma steps
    assert np.all(s[(u > 0) & (u < sigma)] > 0)


def test_short_section_interpolates():
    u = np.linspace(3, 6, 301)
    s = speed_parameter(u, [3, 6], [1.0, 0.5], 2.0)  # 3 < 2 * 2 * 1.5: no time to slow down
    assert np.allclose(s, 1.0 - 0.5 * (u - 3) / 3)
    # a section shorter than sigma whose ramp would overshoot the other pin (the guard)
    u = np.linspace(0, 1, 101)
    s = speed_parameter(u, [0, 1], [0.0, 0.1], 2.0)
    assert np.allclose(s, 0.1 * u)


def test_rise_to_a_jump():
    # start walking, take off running at u = 10 (jump), land at 12 walking, stop at 20
    pins_u, pins_s = [0, 10, 12, 20], [0.0, 1.0, 0.0, 0.0]
    u = np.linspace(0, 20, 2001)
    s = speed_parameter(u, pins_u, pins_s, 2.0)
    assert np.all(s[u <= 8] == 0)
    rise = (u >= 8) & (u <= 10)
    assert np.allclose(s[rise], (u[rise] - 8) / 2)
    assert s[u == 10][0] == 1.0
    assert np.all(np.diff(s[(u >= 8) & (u <= 10)]) > 0)
    # the jump itself (10..12, 2 < 2 sigma): linear 1 -> 0 here; the planner plays the clip
    assert np.all(s[u >= 12] == 0)


def test_pins_at_one_u_make_a_step():
    s = speed_parameter([0.0, 4.9, 5.0, 5.1, 10.0], [0, 5, 5, 10], [0.2, 0.4, 0.9, 0.9], 2.0)
    assert s[2] == pytest.approx(0.9)  # the later pin holds at u = 5
    # before: the section 0..5 ends at the earlier pin (0.4); 5 >= 2 sigma (0.2 + 0.4), so
    # it ramps up over the last sigma steps: 0.4 (sigma - 0.1) / sigma
    assert s[1] == pytest.approx(0.4 * 1.9 / 2.0)
    assert s[3] == pytest.approx(0.9)


def test_mix_speed():
    rng = np.random.default_rng(3)
    f = 500
    ww = group_weights([-1.0, 0.0, 1.0], rng.uniform(-2, 2, f))
    wr = group_weights([-0.5, 0.5], rng.uniform(-1, 1, f))
    s = speed_parameter(np.linspace(0, 30, f), [0, 12, 30], [0, 1, 0.5])
    s_in, ww_in, wr_in = frozen(s, ww, wr)
    w = mix_speed(s_in, ww_in, wr_in)
    assert w.shape == (f, 5)
    assert np.allclose(w.sum(axis=1), 1.0) and np.all(w >= 0)
    assert np.allclose(w[:, :3], (1 - s)[:, None] * ww) and np.allclose(w[:, 3:], s[:, None] * wr)


# ----------------------------------------------------------------------------- degenerate

def test_degenerate_inputs_stay_finite():
    assert np.array_equal(curvature([[1.0, 2.0, 0.0]], [0.0], 0.5), [0.0])  # F = 1
    t = np.arange(50) / 24
    still = np.tile([1.0, 2.0, 0.9], (50, 1))  # standing: one point
    assert np.array_equal(curvature(still, t, 0.5), np.zeros(50))
    pos, t = arc(1.0, 1.0, 24, 1.0, -1)  # 1 s of trajectory, dt 10 s
    tau = curvature(pos, t, 10.0)  # every frame uses first, middle and last points
    assert np.allclose(tau, -1.0, rtol=1e-3)
    two = curvature([[0, 0], [1, 0]], [0, 1], 0.5)
    assert np.array_equal(two, [0.0, 0.0])
    jump = np.r_[still[:25], still[:25] + [0.5, 0, 0]]  # stands, teleports, stands
    for out in (curvature(jump, np.arange(50) / 24, 0.3),
                smooth_signal(np.arange(5) / 24.0, [0, 0, 1e6, 0, 0], 0.5),
                speed_parameter([0.0, 1.0], [0.5], [0.3]),
                group_weights([0.0], [-1.0, 0.0, 1.0])):
        assert np.all(np.isfinite(out))
    assert group_weights([0.3], np.zeros(0)).shape == (0, 1)
    assert speed_parameter([], [0.0], [1.0]).shape == (0,)


@pytest.mark.parametrize("call", [
    lambda: curvature(np.zeros((3, 1)), [0, 1, 2], 0.5),
    lambda: curvature(np.zeros((0, 2)), [], 0.5),
    lambda: curvature(np.zeros((3, 2)), [0, 1], 0.5),
    lambda: curvature(np.zeros((3, 2)), [0, 1, 1], 0.5),
    lambda: curvature(np.zeros((3, 2)), [0, 1, 2], 0.0),
    lambda: curvature([[0, 0], [np.nan, 0]], [0, 1], 0.5),
    lambda: circumcurvature(np.zeros((2, 2)), np.zeros((3, 2)), np.zeros((2, 2))),
    lambda: smooth_signal([0, 1, 2], [0, 1], 1.0),
    lambda: smooth_signal([0, 2, 1], [0, 1, 2], 1.0),
    lambda: smooth_signal([0, 1, 2], [0, 1, 2], -1.0),
    lambda: smooth_signal([0, 1, 2], [0, 1, 2], float("inf")),
    lambda: group_weights([], [0.0]),
    lambda: group_weights([1.0, 0.0], [0.0]),
    lambda: group_weights([0.0, 1.0], [[0.0]]),
    lambda: speed_parameter([0.0], [], []),
    lambda: speed_parameter([0.0], [1.0, 0.0], [0.0, 0.0]),
    lambda: speed_parameter([0.0], [0.0, 1.0], [0.0]),
    lambda: speed_parameter([0.0], [0.0], [1.5]),
    lambda: speed_parameter([0.0], [0.0], [0.5], sigma=0.0),
    lambda: mix_speed([0.5], np.ones((2, 1)), np.ones((1, 1))),
    lambda: mix_speed([1.5], np.ones((1, 1)), np.ones((1, 1))),
    lambda: mix_speed([0.5], np.ones(1), np.ones((1, 1))),
])
def test_bad_input_raises_value_error(call):
    with pytest.raises(ValueError):
        call()


def _walk_and_run(walk_taus, run_taus):
    from footstep_planner.core.clips.library import Library

    groups = {"walk": TurnGroup("walk_turn", "walk", [GroupClip(f"w{i}", t, 1.2) for i, t in enumerate(walk_taus)]),
              "run": TurnGroup("run_turn", "run", [GroupClip(f"r{i}", t, 3.0) for i, t in enumerate(run_taus)])}
    return Library(groups)


@settings(max_examples=60, deadline=None)
@given(run_hi=st.floats(0.05, 1.5), run_lo=st.floats(-1.5, -0.05), tau=st.floats(-3.0, 3.0),
       bend=st.sampled_from([0.0, 0.8]))
def test_a_corner_is_a_walks_turn_beyond_every_run_turn(run_hi, run_lo, tau, bend):
    """``Library.corners``: a walking step whose label turns beyond the run group's range
    (out to the bend limit where the runs are bent: no clip of the library turns that far)
    is a corner; a run's step, a walk inside the runs' range, and a label with no tau are
    never one; a library without runs has none."""
    lib = _walk_and_run([-2.0, 0.0, 2.0], sorted([run_lo, 0.0, run_hi]))
    assume(abs(tau - run_hi) > 2e-3 and abs(tau - run_lo) > 2e-3)
    labels = [f"walk_turn@{tau:+.3f}", f"run_turn@{tau:+.3f}", "leap", f"walk_turn@{tau:+.3f}"]
    got = lib.corners(labels, ["walk", "run", "run", "run"], bend)
    assert got.tolist() == [bool(tau > run_hi or tau < run_lo), False, False, False]
    assert lib.run_reach(bend) == (run_lo, run_hi)  # (the walk turns past the bend: no run is bent)
    walk_only = _walk_and_run([-2.0, 0.0, 2.0], [])
    walk_only.turn_groups.pop("run")
    assert not walk_only.corners(labels, ["walk"] * 4, bend).any()
    straight_run = _walk_and_run([-0.3, 0.0, 0.3], [0.0])  # (runs bent out to 0.8 where no clip turns)
    assert straight_run.run_reach(0.8) == (-0.8, 0.8) and straight_run.run_reach(0.0) == (0.0, 0.0)


def test_a_corner_among_runs_is_pinned_walking():
    """``speed_pins``: a corner between runs pins s = 0 in its middle, so the blend slows
    the run into the walk's turn there and speeds up after it (without the pin the few
    walking steps between the runs play as a run: sigma 3 keeps s = 1 between run pins
    under 12 steps apart)."""
    from footstep_planner.core.synth.passes import speed_pins
    from footstep_planner.core.synth.schedule import PlanStep

    steps = [PlanStep(j % 2, None, np.array([1.0])) for j in range(16)]
    gaits = ["walk"] * 2 + ["run"] * 5 + ["walk"] * 3 + ["run"] * 5 + ["walk"]
    corners = np.zeros(16, bool)
    corners[8] = True
    u = np.linspace(0, 16, 1601)
    s_with = speed_parameter(u, *zip(*speed_pins(steps, {}, gaits, corners)), sigma=3.0)
    s_without = speed_parameter(u, *zip(*speed_pins(steps, {}, gaits)), sigma=3.0)
    assert s_with[np.argmin(abs(u - 8.5))] == 0.0 and s_without[np.argmin(abs(u - 8.5))] == 1.0
    assert s_with[np.argmin(abs(u - 5.5))] == 1.0 and s_with[np.argmin(abs(u - 11.5))] == 1.0
    assert np.all(np.diff(s_with[(u > 6.5) & (u < 8.5)]) <= 0) and np.all(np.diff(s_with[(u > 8.5) & (u < 10.5)]) >= 0)
