"""Property tests of footstep_planner.core.synth.trajectory (thesis 3.6, body trajectory): the
centripetal Catmull-Rom spline (interpolation, C1, straight lines, no overshoot, linear
extrapolation, degenerate chords), the midpoints, and the body transfer (identity, rigid
motion equivariance, sway kept on a bent path, headings across +-pi, vectorisation).

Pure core, no Blender. Tolerances: 1e-9 for identities that hold to rounding; finite
difference checks use a relative tolerance stated where used.
"""

from __future__ import annotations

import math
import sys

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.interpolate import CubicHermiteSpline

from footstep_planner.core.synth import trajectory
from footstep_planner.core.synth.trajectory import (
    body_offset, centripetal_catmull_rom, footprint_spline, midpoints, transfer_body,
)

HYP = dict(deadline=None, database=None)


# ----------------------------------------------------------------------------- helpers

def rot(v, angle):
    """Rows of v (F, 3) turned by R(angle) about Z (angle scalar or (F,))."""
    c, s = np.cos(angle), np.sin(angle)
    return np.stack([c * v[:, 0] - s * v[:, 1], s * v[:, 0] + c * v[:, 1], v[:, 2]], axis=1)


def pyramid(P, alpha, k, u):
    """Reference: Barry-Goldman's pyramid for segment k of P (ends reflected) at the
    fraction u of its knot interval; scalar, straight from the recurrence."""
    ext = np.concatenate([2 * P[:1] - P[1:2], P, 2 * P[-1:] - P[-2:-1]])
    Q = ext[k:k + 4]
    s = [0.0]
    for j in range(3):
        s.append(s[-1] + np.linalg.norm(Q[j + 1] - Q[j]) ** alpha)
    x = s[1] + u * (s[2] - s[1])

    def lerp(a, b, i, j):
        return ((s[j] - x) * a + (x - s[i]) * b) / (s[j] - s[i])

    A1, A2, A3 = lerp(Q[0], Q[1], 0, 1), lerp(Q[1], Q[2], 1, 2), lerp(Q[2], Q[3], 2, 3)
    B1, B2 = lerp(A1, A2, 0, 2), lerp(A2, A3, 1, 3)
    return lerp(B1, B2, 1, 2)


def dist_to_segment(X, a, b):
    ab = b - a
    w = np.clip((X - a) @ ab / (ab @ ab), 0.0, 1.0)
    return np.linalg.norm(X - (a + w[:, None] * ab), axis=1)


def one_sided_velocities(f, t, h=1e-5):
    """(left, right) velocities of f at the times t (K,): one-sided finite differences
    of second order, each from one side only."""
    c = f(t)
    return ((3 * c - 4 * f(t - h) + f(t - 2 * h)) / (2 * h),
            (-3 * c + 4 * f(t + h) - f(t + 2 * h)) / (2 * h))


def velocity_jump(f, t, speed, h=1e-5):
    """Largest |v_right - v_left| at the times t relative to the velocity there (plus
    1e-3 of the curve's typical ``speed``: a turnaround has zero velocity)."""
    vl, vr = one_sided_velocities(f, t, h)
    jump = np.linalg.norm(vr - vl, axis=1)
    scale = np.linalg.norm(vl, axis=1) + np.linalg.norm(vr, axis=1) + 1e-3 * speed
    return np.max(jump / scale)


def typical_speed(P, kt):
    return np.max(np.linalg.norm(np.diff(P, axis=0), axis=1) / np.diff(kt))


def readonly(*arrays):
    out = []
    for a in arrays:
        a = np.array(a, dtype=float)
        a.flags.writeable = False
        out.append(a)
    return out


def walk(n=9, step=0.7, width=0.12, period=0.55, toe_out=0.1, radius=None, t0=0.0,
         heading0=0.0):
    """Footprints of a walk along a straight line (radius None) or a circular arc turning
    left (radius > 0): (positions (n, 3), headings (n,), times (n,)). Footprint i lies
    ``width`` to the side of the path point at arc length i*step/2, alternately left
    and right, its heading the path's heading +- toe_out."""
    s = np.arange(n) * step / 2
    if radius is None:
        c = np.stack([s, np.zeros(n)], axis=1)
        q = np.zeros(n)
    else:
        q = s / radius
        c = np.stack([radius * np.sin(q), radius * (1 - np.cos(q))], axis=1)
    side = np.where(np.arange(n) % 2 == 0, 1.0, -1.0)  # left, right, left, ...
    normal = np.stack([-np.sin(q), np.cos(q)], axis=1)
    xy = c + side[:, None] * width * normal
    pos = np.concatenate([xy, np.zeros((n, 1))], axis=1)
    c0, s0 = math.cos(heading0), math.sin(heading0)
    pos[:, :2] = pos[:, :2] @ np.array([[c0, -s0], [s0, c0]]).T
    return pos, q + heading0 + side * toe_out, t0 + np.arange(n) * period


def sway_body(pos, head, times, t, amp=0.04, bob=0.02, yaw=0.08):
    """A body that sways about the midpoint path: the offset D_p, D_q it is built from,
    and the body R^O, Q^O."""
    period = times[1] - times[0]
    ph = np.pi * (t - times[0]) / period
    Dp = np.stack([0.03 * np.sin(2 * ph), amp * np.sin(ph), 0.95 + bob * np.cos(2 * ph)],
                  axis=1)
    Dq = yaw * np.sin(ph)
    M, Mq = footprint_spline(pos, head, times, t)
    return Dp, Dq, M + rot(Dp, Mq), Mq + Dq


# strategies: polylines with chord lengths in [0.05, 3] m, time steps in [0.2, 1.5] s
def polylines(min_n=2, max_n=8, dim=3):
    return st.integers(min_n, max_n).flatmap(lambda n: st.tuples(
        st.lists(st.tuples(*[st.floats(-1, 1)] * dim), min_size=n - 1, max_size=n - 1),
        st.lists(st.floats(0.05, 3.0), min_size=n - 1, max_size=n - 1),
        st.lists(st.floats(0.2, 1.5), min_size=n - 1, max_size=n - 1),
        st.floats(-5.0, 5.0),
    )).map(_polyline)


def _polyline(args):
    dirs, lengths, gaps, t0 = args
    dirs = np.array(dirs, dtype=float).reshape(len(lengths), -1)
    norm = np.linalg.norm(dirs, axis=1)
    dirs = np.where(norm[:, None] > 1e-3, dirs / np.maximum(norm, 1e-3)[:, None], 0.0)
    dirs[norm <= 1e-3, 0] = 1.0
    steps = dirs * np.array(lengths)[:, None]
    P = np.concatenate([np.zeros((1, dirs.shape[1])), np.cumsum(steps, axis=0)])
    kt = t0 + np.concatenate([[0.0], np.cumsum(gaps)])
    return P, kt


# ----------------------------------------------------------------------------- the spline

@settings(max_examples=40, **HYP)
@given(data=polylines(), smooth=st.booleans())
def test_passes_through_points_at_knot_times(data, smooth):
    P, kt = data
    out = centripetal_catmull_rom(P, kt, kt, smooth_timing=smooth)
    assert np.allclose(out, P, rtol=0, atol=1e-9)


@settings(max_examples=25, **HYP)
@given(data=polylines(max_n=6, dim=2), alpha=st.sampled_from([0.0, 0.5, 1.0]))
def test_is_barry_goldman_pyramid(data, alpha):
    """The Hermite evaluation is the non-uniform Catmull-Rom curve of Barry and Goldman:
    with the literal (linear per segment) timing, point for point; with the default
    timing, the same curve at the knot parameter s(t), the monotone cubic of fc_slopes."""
    P, kt = data
    n = len(P)
    u = np.linspace(0.0, 1.0, 5)
    ref = np.array([pyramid(P, alpha, k, x) for k in range(n - 1) for x in u])
    t = np.concatenate([kt[k] + u * (kt[k + 1] - kt[k]) for k in range(n - 1)])
    out = centripetal_catmull_rom(P, kt, t, alpha, smooth_timing=False)
    assert np.allclose(out, ref, rtol=0, atol=1e-9)

    d = np.linalg.norm(np.diff(P, axis=0), axis=1) ** alpha
    s = np.concatenate([[0.0], np.cumsum(d)])
    st_ = CubicHermiteSpline(kt, s, fc_slopes(kt, s))(t)
    k = np.clip(np.searchsorted(kt, t, side="right") - 1, 0, n - 2)
    ref = np.array([pyramid(P, alpha, kk, (x - s[kk]) / d[kk]) for kk, x in zip(k, st_)])
    out = centripetal_catmull_rom(P, kt, t, alpha)
    assert np.allclose(out, ref, rtol=0, atol=1e-9)


def fc_slopes(x, y):
    """Reference knot slopes of the default time map: Fritsch-Carlson weighted harmonic
    means inside (Brodlie's weights), the end secants at the ends."""
    h, dl = np.diff(x), np.diff(y) / np.diff(x)
    out = [dl[0]]
    for i in range(1, len(x) - 1):
        a, b = dl[i - 1], dl[i]
        w1, w2 = 2 * h[i] + h[i - 1], h[i] + 2 * h[i - 1]
        out.append(0.0 if a <= 0 or b <= 0 else (w1 + w2) / (w1 / a + w2 / b))
    return np.array(out + [dl[-1]])


@settings(max_examples=40, **HYP)
@given(data=polylines(min_n=3))
def test_c1_in_time(data):
    """Velocity is continuous across every knot (one-sided second-order finite differences
    with h = 10 us agree to a relative 1e-4), including the first and last knot where the
    linear extrapolation takes over."""
    P, kt = data
    f = lambda x: centripetal_catmull_rom(P, kt, x)  # noqa: E731
    assert velocity_jump(f, kt, typical_speed(P, kt)) < 1e-4


def test_literal_timing_is_c1_only_with_proportional_knots():
    """The per-segment linear time map (smooth_timing=False, the thesis' reading) has a
    velocity jump where |chord|**alpha / dt changes; the default timing has none. With
    chords proportional to dt**2 (alpha = 1/2: knot intervals proportional to dt) both
    are C1 and agree."""
    P = np.array([[0.0, 0, 0], [1, 0, 0], [2, 0.5, 0], [2.3, 0.6, 0], [3, 1.5, 0]])
    kt = np.array([0.0, 0.5, 1.0, 1.5, 2.0])  # chords 1, 1.1, 0.32, 1.1 over equal dt
    literal = lambda x: centripetal_catmull_rom(P, kt, x, smooth_timing=False)  # noqa: E731
    smooth = lambda x: centripetal_catmull_rom(P, kt, x)  # noqa: E731
    assert velocity_jump(literal, kt[1:-1], typical_speed(P, kt)) > 0.1
    assert velocity_jump(smooth, kt[1:-1], typical_speed(P, kt)) < 1e-4

    dt = np.array([0.4, 0.9, 0.25, 0.6])
    P = np.concatenate([[[0.0, 0, 0]], np.cumsum(
        np.array([[1.0, 0, 0], [0.6, 0.8, 0], [0, 1, 0], [-0.8, 0.6, 0]]) * dt[:, None] ** 2,
        axis=0)])
    kt = np.concatenate([[0.0], np.cumsum(dt)])
    literal = lambda x: centripetal_catmull_rom(P, kt, x, smooth_timing=False)  # noqa: E731
    t = np.linspace(-0.3, kt[-1] + 0.3, 57)
    assert velocity_jump(literal, kt, typical_speed(P, kt)) < 1e-4
    assert np.allclose(literal(t), smooth(t), rtol=0, atol=1e-9)


@settings(max_examples=20, **HYP)
@given(start=st.tuples(st.floats(-10, 10), st.floats(-10, 10), st.floats(-1, 1)),
       step=st.tuples(st.floats(-1, 1), st.floats(-1, 1), st.floats(-0.1, 0.1)),
       n=st.integers(2, 10), dt=st.floats(0.1, 2.0), t0=st.floats(-3, 3),
       smooth=st.booleans())
def test_straight_line_at_constant_speed(start, step, n, dt, t0, smooth):
    """Collinear, evenly spaced points at evenly spaced times: a straight line at constant
    speed, inside the knot range and beyond it."""
    start, step = np.array(start), np.array(step)
    P = start + np.arange(n)[:, None] * step
    kt = t0 + dt * np.arange(n)
    t = np.linspace(kt[0] - 2 * dt, kt[-1] + 2 * dt, 101)
    expect = start + ((t - t0) / dt)[:, None] * step
    assert np.allclose(centripetal_catmull_rom(P, kt, t, smooth_timing=smooth), expect,
                       rtol=0, atol=1e-9)


@settings(max_examples=60, **HYP)
@given(dirs=st.lists(st.tuples(st.floats(-1, 1), st.floats(-1, 1)), min_size=3, max_size=3),
       log_len=st.lists(st.floats(-4, 2), min_size=3, max_size=3),
       gaps=st.lists(st.floats(0.05, 2.0), min_size=3, max_size=3),
       smooth=st.booleans())
def test_centripetal_stays_near_its_chord(dirs, log_len, gaps, smooth):
    """No loop or cusp: the middle segment of any four points, with chord lengths spread
    over six decades, stays within 0.3 of its chord length of the chord (numerically the
    supremum is about 1/4; the uniform spline goes unbounded, see below)."""
    d = np.array(dirs)
    nrm = np.linalg.norm(d, axis=1)
    d = np.where(nrm[:, None] > 1e-3, d / np.maximum(nrm, 1e-3)[:, None], [1.0, 0.0])
    P = np.concatenate([[[0.0, 0.0]], np.cumsum(d * 10.0 ** np.array(log_len)[:, None], 0)])
    kt = np.concatenate([[0.0], np.cumsum(gaps)])
    X = centripetal_catmull_rom(P, kt, np.linspace(kt[1], kt[2], 201), smooth_timing=smooth)
    chord = np.linalg.norm(P[2] - P[1])
    assert dist_to_segment(X, P[1], P[2]).max() <= 0.3 * chord


def test_uniform_overshoots_where_centripetal_does_not():
    """A documented case: a 3 cm chord (a shuffle at a corner) between two 2 m chords.
    The uniform spline (alpha = 0) swings its tangents to half the long chords and loops
    out far beyond the short chord (> 3 chord lengths away); the centripetal one stays
    within a quarter of the chord."""
    P = np.array([[0.0, 0.0], [2.0, 0.0], [2.02, 0.02], [2.02, 2.02]])
    kt = np.arange(4.0)
    t = np.linspace(1.0, 2.0, 401)
    chord = np.linalg.norm(P[2] - P[1])
    centripetal = centripetal_catmull_rom(P, kt, t)
    uniform = centripetal_catmull_rom(P, kt, t, alpha=0.0, smooth_timing=False)
    assert dist_to_segment(centripetal, P[1], P[2]).max() < 0.25 * chord
    assert dist_to_segment(uniform, P[1], P[2]).max() > 3.0 * chord


@settings(max_examples=30, **HYP)
@given(data=polylines(), smooth=st.booleans(), a=st.floats(0.01, 5.0), b=st.floats(0.01, 5.0))
def test_linear_extrapolation(data, smooth, a, b):
    """Before the first and after the last knot time the curve is a straight line at
    constant velocity, continuous with the curve at the end points and with the same
    velocity as the curve has there (one-sided finite difference inside, rel. 1e-5)."""
    P, kt = data
    f = lambda x: centripetal_catmull_rom(P, kt, np.asarray(x, float),  # noqa: E731
                                          smooth_timing=smooth)
    for end, sign, dist in ((0, -1, a), (-1, 1, b)):
        te = kt[end]
        x = te + sign * dist * np.array([0.0, 0.25, 0.5, 1.0])
        c = f(x)
        v = (c[3] - c[0]) / (x[3] - x[0])
        assert np.allclose(c, c[0] + (x - te)[:, None] * v, rtol=0, atol=1e-9)  # linear
        assert np.allclose(c[0], P[end], rtol=0, atol=1e-9)  # continuous
        vl, vr = one_sided_velocities(f, np.array([te]))
        inside = vr[0] if end == 0 else vl[0]
        assert np.linalg.norm(inside - v) <= 1e-5 * (np.linalg.norm(v) + 1e-3)


def test_coincident_points_stay_put():
    """Zero-length chords (a character standing still): finite everywhere, and a segment
    between two equal points stays at that point, with zero velocity at its ends."""
    P = np.array([[0.0, 0, 0], [1, 0, 0], [1, 0, 0], [1, 0, 0], [1, 1, 0], [1, 1, 0]])
    kt = np.arange(6.0) * 0.5
    for smooth in (True, False):
        t = np.linspace(-1.0, 4.0, 1001)
        out = centripetal_catmull_rom(P, kt, t, smooth_timing=smooth)
        assert np.all(np.isfinite(out))
        for k in (1, 2, 4):
            seg = (t >= kt[k]) & (t <= kt[k + 1])
            assert np.allclose(out[seg], P[k], rtol=0, atol=1e-12)
        assert np.allclose(out[t > kt[-1]], P[-1], rtol=0, atol=1e-12)  # v = 0 at the end
    same = np.tile([[0.3, -0.2, 1.0]], (4, 1))
    out = centripetal_catmull_rom(same, np.arange(4.0), np.linspace(-2, 6, 50))
    assert np.all(out == same[0])


def test_few_points_and_bad_input():
    P = np.array([[1.0, 2.0, 3.0]])
    t = np.linspace(-1, 1, 7)
    assert np.all(centripetal_catmull_rom(P, [0.5], t) == P[0])
    with pytest.raises(ValueError, match="no points"):
        centripetal_catmull_rom(np.zeros((0, 3)), np.zeros(0), t)
    with pytest.raises(ValueError, match="knot_times must have shape"):
        centripetal_catmull_rom(np.zeros((3, 3)), np.arange(2.0), t)
    with pytest.raises(ValueError, match="strictly increasing"):
        centripetal_catmull_rom(np.eye(3), [0.0, 1.0, 1.0], t)
    with pytest.raises(ValueError, match="t must have shape"):
        centripetal_catmull_rom(np.eye(3), [0.0, 1.0, 2.0], t[:, None])
    with pytest.raises(ValueError, match="non-finite"):
        centripetal_catmull_rom(np.eye(3), [0.0, 1.0, 2.0], [np.nan])
    with pytest.raises(ValueError, match="alpha"):
        centripetal_catmull_rom(np.eye(3), [0.0, 1.0, 2.0], t, alpha=2.0)


# ----------------------------------------------------------------------------- footprints

def test_midpoints():
    pos = np.array([[0.0, 0.1, 0], [0.35, -0.1, 0], [0.7, 0.1, 0.2]])
    head = np.array([3.1, 3.3, 3.0])
    m, mq, mt = midpoints(pos, head, [0.0, 0.5, 1.2])
    assert np.allclose(m, [[0.175, 0, 0], [0.525, 0, 0.1]])
    assert np.allclose(mq, [3.2, 3.15]) and np.allclose(mt, [0.25, 0.85])
    # wrapped headings across +-pi: the mid-angle, and a continuous sequence
    m, mq, mt = midpoints(pos, _wrapped([3.1, 3.3, 3.5]), [0.0, 0.5, 1.0])
    assert np.allclose(mq, [3.2, 3.4])
    m, mq, mt = midpoints(pos[:1], head[:1], [0.0])
    assert m.shape == (0, 3) and mq.shape == mt.shape == (0,)
    with pytest.raises(ValueError, match="non-decreasing"):
        midpoints(pos, head, [0.0, 1.0, 0.5])
    with pytest.raises(ValueError, match="share a time"):
        midpoints(pos, head, [0.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="footprint heading must have shape"):
        midpoints(pos, head[:, None], [0.0, 1.0, 2.0])
    with pytest.raises(ValueError, match="lengths differ"):
        midpoints(pos, head[:2], [0.0, 1.0])


def _wrapped(a):
    return (np.asarray(a) + np.pi) % (2 * np.pi) - np.pi


def test_footprint_spline_heading_and_degenerate_counts():
    pos, head, times = walk(n=5)
    m, mq, mt = midpoints(pos, head, times)
    t = np.linspace(times[0] - 1, times[-1] + 1, 301)
    M, Mq = footprint_spline(pos, head, times, t)
    assert np.allclose(Mq, np.interp(t, mt, mq), rtol=0, atol=1e-12)
    assert np.allclose(footprint_spline(pos, head, times, mt)[0], m, rtol=0, atol=1e-9)
    # two footprints: one midpoint, constant; one footprint: itself
    M, Mq = footprint_spline(pos[:2], head[:2], times[:2], t)
    assert np.allclose(M, m[0]) and np.allclose(Mq, mq[0])
    M, Mq = footprint_spline(pos[:1], head[:1], times[:1], t)
    assert np.allclose(M, pos[0]) and np.allclose(Mq, head[0])
    with pytest.raises(ValueError, match="no footprints"):
        footprint_spline(np.zeros((0, 3)), [], [], t)


# ----------------------------------------------------------------------------- transfer

@settings(max_examples=25, **HYP)
@given(n=st.integers(2, 12), radius=st.sampled_from([None, 1.5, -3.0, 0.8]),
       heading0=st.floats(-7, 7), t0=st.floats(-2, 2), amp=st.floats(0, 0.2))
def test_transfer_identity(n, radius, heading0, t0, amp):
    pos, head, times = walk(n=n, radius=radius, heading0=heading0, t0=t0)
    t = np.linspace(times[0], times[-1] + 0.3, 200)
    _, _, body, bq = sway_body(pos, head, times, t, amp=amp)
    body = body + np.array([0.05, -0.02, 0.0]) * np.sin(7 * t)[:, None]  # not on any path
    args = readonly(pos, head, pos, head, times, body, bq, t)
    before = [a.copy() for a in args]
    R, Q = transfer_body(*args)
    assert np.allclose(R, body, rtol=0, atol=1e-9)
    assert np.allclose(Q, bq, rtol=0, atol=1e-9)
    assert all(np.array_equal(a, b) for a, b in zip(args, before))


@settings(max_examples=30, **HYP)
@given(a=st.floats(-10, 10), tx=st.floats(-50, 50), ty=st.floats(-50, 50),
       tz=st.floats(-2, 2), radius=st.sampled_from([None, 2.0, -1.2]), n=st.integers(2, 10))
def test_rigid_motion_equivariance(a, tx, ty, tz, radius, n):
    """desired = rigid(original) (turn a about Z, then translate): R^D = rigid(R^O) and
    Q^D = Q^O + a."""
    pos, head, times = walk(n=n, radius=radius)
    t = np.linspace(times[0] - 0.2, times[-1] + 0.2, 150)
    _, _, body, bq = sway_body(pos, head, times, t)
    shift = np.array([tx, ty, tz])
    R, Q = transfer_body(pos, head, rot(pos, a) + shift, head + a, times, body, bq, t)
    assert np.allclose(R, rot(body, a) + shift, rtol=0, atol=1e-9)
    assert np.allclose(Q, bq + a, rtol=0, atol=1e-9)


@pytest.mark.parametrize("radius", [2.5, -1.5, 0.9])
def test_sway_kept_on_a_bent_path(radius):
    """The original walk is straight, the desired one an arc: the body's offset from the
    midpoint path (lateral sway, fore-aft surge, bob, yaw) is the same w.r.t. the desired
    path as it was w.r.t. the original one, and the body does follow the bend."""
    pos, head, times = walk(n=11)
    dpos, dhead, _ = walk(n=11, radius=radius)
    t = np.linspace(times[0], times[-1], 400)
    Dp, Dq, body, bq = sway_body(pos, head, times, t)
    R, Q = transfer_body(pos, head, dpos, dhead, times, body, bq, t)
    Dp2, Dq2 = body_offset(dpos, dhead, times, R, Q, t)
    assert np.allclose(Dp2, Dp, rtol=0, atol=1e-9)
    assert np.allclose(Dq2, Dq, rtol=0, atol=1e-9)
    MD, MqD = footprint_spline(dpos, dhead, times, t)
    assert np.abs(R[:, 1] - body[:, 1]).max() > 0.3  # bent, not the straight body
    assert np.linalg.norm(R - MD, axis=1).max() < 0.1 + np.linalg.norm(Dp, axis=1).max()
    # sway goes to the path's left and right: the lateral offset changes sign
    lateral = np.einsum("ij,ij->i", (R - MD)[:, :2], np.stack([-np.sin(MqD), np.cos(MqD)], 1))
    assert lateral.max() > 0.03 and lateral.min() < -0.03


def test_headings_across_pi():
    """A walk turning left through +-pi (unwrapped headings up to ~3 pi): the transferred
    heading has no 2 pi jumps; footprint headings given wrapped give the same result."""
    pos, head, times = walk(n=31, radius=1.0, heading0=2.5)
    dpos, dhead, _ = walk(n=31, radius=1.6, heading0=2.8)
    assert head.max() > 3 * np.pi
    t = np.linspace(times[0], times[-1], 3000)
    _, _, body, bq = sway_body(pos, head, times, t)
    R, Q = transfer_body(pos, head, dpos, dhead, times, body, bq, t)
    assert np.all(np.isfinite(R)) and np.all(np.isfinite(Q))
    assert np.abs(np.diff(Q)).max() < 0.05
    assert np.linalg.norm(np.diff(R, axis=0), axis=1).max() < 0.05
    R2, Q2 = transfer_body(pos, _wrapped(head), dpos, _wrapped(dhead), times, body, bq, t)
    # the mid headings keep the first footprint's branch: heading0 < pi, so no offset
    assert np.allclose(R2, R, rtol=0, atol=1e-9) and np.allclose(Q2, Q, rtol=0, atol=1e-9)


def test_standing_still_is_finite():
    """Coincident midpoints (the feet planted side by side for several steps, turning on
    the spot) give finite output, and the body stays over the feet."""
    pos = np.array([[0.0, 0.1, 0], [0, -0.1, 0]] * 3 + [[0.3, 0.1, 0], [0.6, -0.1, 0]])
    head = np.array([0.0, 0.0, 0.3, 0.3, 0.6, 0.6, 0.6, 0.6])
    times = np.arange(8) * 0.5
    t = np.linspace(0, 3.5, 500)
    body = np.column_stack([0.02 * np.sin(t), 0.03 * np.cos(3 * t), np.full_like(t, 0.9)])
    bq = 0.1 * np.sin(t)
    dpos = pos + [1.0, 2.0, 0.0]
    R, Q = transfer_body(pos, head, dpos, head, times, body, bq, t)
    assert np.all(np.isfinite(R)) and np.all(np.isfinite(Q))
    assert np.allclose(R, body + [1.0, 2.0, 0.0], rtol=0, atol=1e-9)


def test_transfer_shape_errors():
    pos, head, times = walk(n=5)
    t = np.linspace(0, 2, 10)
    body, bq = np.zeros((10, 3)), np.zeros(10)
    with pytest.raises(ValueError, match="lengths differ"):
        transfer_body(pos, head, pos[:4], head[:4], times, body, bq, t)
    with pytest.raises(ValueError, match="lengths differ"):
        transfer_body(pos, head, pos, head, times, body[:9], bq, t)
    with pytest.raises(ValueError, match="body_pos must have shape"):
        transfer_body(pos, head, pos, head, times, body[:, :2], bq, t)
    with pytest.raises(ValueError, match="desired footprint position must have shape"):
        transfer_body(pos, head, pos[:, :2], head, times, body, bq, t)


# ----------------------------------------------------------------------------- vectorised

def lines_run(fn):
    """Lines of footstep_planner/core/synth/trajectory.py executed while running fn()
    (sys.settrace, line events of that module only): a loop there over frames or
    footprints would make this grow with their number."""
    lines = 0

    def local(frame, event, arg):
        nonlocal lines
        if event == "line":
            lines += 1
        return local

    def trace(frame, event, arg):
        return local if frame.f_code.co_filename == trajectory.__file__ else None

    old = sys.gettrace()
    sys.settrace(trace)
    try:
        fn()
    finally:
        sys.settrace(old)
    return lines


def test_vectorised_over_frames_and_footprints():
    """F = 20000 frames run the same lines of the module as F = 200 (no per-frame loop),
    and 10x the footprints no more either (no per-segment loop). The
    result for a subset of frames is the result for those frames alone."""
    pos, head, times = walk(n=40, radius=3.0)
    dpos, dhead, _ = walk(n=40, radius=-2.0)

    def run(F, p=pos, h=head, dp=dpos, dh=dhead, tt=times):
        t = np.linspace(tt[0] - 0.1, tt[-1] + 0.1, F)
        body = np.column_stack([np.sin(t), np.cos(t), 0.9 + 0.01 * t])
        return lambda: transfer_body(p, h, dp, dh, tt, body, 0.1 * t, t)

    assert lines_run(run(200)) > 0
    assert lines_run(run(20000)) == lines_run(run(200))
    big = walk(n=400, radius=3.0)
    bigd = walk(n=400, radius=-2.0)
    assert lines_run(run(200, big[0], big[1], bigd[0], bigd[1], big[2])) == \
        lines_run(run(200))

    R, Q = run(20000)()
    assert R.shape == (20000, 3) and Q.shape == (20000,)
    assert np.all(np.isfinite(R)) and np.all(np.isfinite(Q))
    t = np.linspace(times[0] - 0.1, times[-1] + 0.1, 20000)
    pick = np.arange(0, 20000, 997)
    body = np.column_stack([np.sin(t), np.cos(t), 0.9 + 0.01 * t])
    Rs, Qs = transfer_body(pos, head, dpos, dhead, times, body[pick], 0.1 * t[pick], t[pick])
    assert np.allclose(Rs, R[pick], rtol=0, atol=1e-12)
    assert np.allclose(Qs, Q[pick], rtol=0, atol=1e-12)
