"""Property tests of footstep_planner.core.clips.analysis on synthetic gaits with a known truth
(tests/synth.py): figures, invariances (mirror, rigid motion, frame rate), contact events,
start/stop and the errors.

A note on contact times: Johansen's rule puts a lift (landing) at the steepest rise of the
slope of the smoothed foot height, i.e. the peak of its second derivative after Gaussian
smoothing of width ``Settings.derivative_smoothing``. The synthetic feet leave the ground
with a jump in that second derivative, so the smoothed peak lies inside the swing: the
detected contact is a little longer than the true one at each end. In a walk the
horizontal (slip) check ends the contact first (about 15 ms late at 120 Hz); in a run it is
the height rule (about 35 ms late). Tolerances below say which bound they use.
"""

from __future__ import annotations

import functools
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.interpolate import CubicSpline

from footstep_planner.core.clips.analysis import AnalysisError, analyze_clip
from footstep_planner.core.base.settings import Settings
from synth import mirror_clip, raise_feet, synthetic_gait

RUN = dict(speed=3.0, stride=2.4, duty=0.35)
FPS_CHOICES = (24, 25, 30, 50, 60, 120)
SIGMA = Settings().derivative_smoothing

HYP = dict(deadline=None, database=None)


# ----------------------------------------------------------------------------- helpers

def rel(a, b):
    return abs(a / b - 1.0)


def wrap(a):
    return (a + math.pi) % (2 * math.pi) - math.pi


def check_event_order(a):
    for s in a.stances:
        assert s.strike <= s.land <= s.stance <= s.lift <= s.liftoff, (
            f"foot {s.foot} events out of order: strike {s.strike:.4f} land {s.land:.4f} "
            f"stance {s.stance:.4f} lift {s.lift:.4f} liftoff {s.liftoff:.4f}")


def match_stances(a, truth):
    """Pairs (detected, true) matched by foot and nearest contact in time (a path that
    closes on itself, such as a fast run round a tight circle, steps twice on one spot, so
    the nearest footprint alone can pick the wrong stance); every true stance inside the
    clip must be detected exactly once."""
    pairs = []
    for s in a.stances:
        cands = truth["stances"][s.foot]
        d = [abs(0.5 * (c["strike"] + c["liftoff"]) - 0.5 * (s.strike + s.liftoff))
             if not (s.open_start or s.open_end) else
             max(0.0, c["strike"] - s.liftoff, s.strike - c["liftoff"]) for c in cands]
        pairs.append((s, cands[int(np.argmin(d))]))
    assert len(a.stances) == len(truth["footprints"]), (
        f"{len(a.stances)} stances detected, {len(truth['footprints'])} in the truth")
    ids = [id(t) for _, t in pairs]
    assert len(set(ids)) == len(ids), "two detected stances match one true stance"
    return pairs


@functools.lru_cache(maxsize=None)
def analysed(**kw):
    """analyze_clip of synthetic_gait(**kw), cached (kw values must be hashable)."""
    motion, truth = synthetic_gait(**kw)
    return analyze_clip(motion), truth


def cached(**kw):
    return analysed(**{k: (tuple(v) if isinstance(v, list) else v) for k, v in kw.items()})


# ----------------------------------------------------------------------------- figures

@pytest.mark.parametrize("speed,stride,duty", [(1.2, 1.4, 0.62), (0.8, 1.1, 0.68), (1.8, 1.7, 0.56)])
def test_straight_walk_figures(speed, stride, duty):
    a, truth = cached(speed=speed, stride=stride, duty=duty)
    assert a.gait == "walk" and truth["gait"] == "walk"
    assert a.kind == "cycle"
    assert a.entry_gait == a.exit_gait == "walk"
    assert not a.starts_at_rest and not a.ends_at_rest
    assert a.flights == [] and a.jump_flights == []
    assert rel(a.speed, speed) < 0.02, (a.speed, speed)
    assert rel(a.cycle, truth["T"]) < 0.02, (a.cycle, truth["T"])
    assert rel(a.stride, truth["stride"]) < 0.03, (a.stride, truth["stride"])
    assert abs(a.tau) < 0.02, a.tau
    assert a.cadence == pytest.approx(120.0 / a.cycle)
    # the feet alternate, one stance per true stance
    feet = [s.foot for s in sorted(a.stances, key=lambda s: s.stance)]
    assert all(f0 != f1 for f0, f1 in zip(feet[:-1], feet[1:])), feet
    match_stances(a, truth)
    check_event_order(a)


def test_run_gait_and_flights():
    a, truth = cached(**RUN)
    T, duty = truth["T"], RUN["duty"]
    assert a.gait == "run" and a.kind == "cycle"
    assert a.entry_gait == a.exit_gait == "run"
    assert rel(a.speed, RUN["speed"]) < 0.02
    assert rel(a.cycle, T) < 0.02
    assert rel(a.stride, truth["stride"]) < 0.03
    assert a.jump_flights == []
    # one flight between each two consecutive steps
    assert len(a.flights) == len(truth["flights"]) == len(a.stances) - 1
    frame = 1.0 / RUN.get("fps", 120.0)
    expected = (0.5 - duty) * T
    for (fa, fb), (ta, tb) in zip(a.flights, truth["flights"]):
        assert tb - ta == pytest.approx(expected)
        # centred on the true flight (the contact bias is symmetric)
        assert abs(0.5 * (fa + fb) - 0.5 * (ta + tb)) < frame + 0.002
        # never longer than the true flight; shorter by at most the outward bias of the
        # two contact edges (2 sigma of derivative smoothing + 1 frame each)
        assert fb - fa <= expected + 2 * frame
        assert fb - fa >= expected - 2 * (2 * SIGMA + frame), (fb - fa, expected)
    check_event_order(a)


@pytest.mark.parametrize("sign", [1, -1])
@pytest.mark.parametrize("radius", [0.8, 1.5, 2.5, 6.0])
def test_arc_curvature(radius, sign):
    kappa = sign / radius
    a, truth = cached(curvature=kappa)
    assert a.gait == "walk" and a.kind == "cycle"
    assert np.sign(a.tau) == sign, a.tau  # positive turning left
    assert rel(a.tau, kappa) < 0.05, (a.tau, kappa)
    assert rel(a.speed, truth["speed"]) < 0.02
    assert rel(a.cycle, truth["T"]) < 0.02
    assert rel(a.stride, truth["stride"]) < 0.03
    check_event_order(a)


def test_turning_left_means_counter_clockwise():
    """Independent of the generator's convention: the path of a positive-tau clip bends to
    the character's left (counter-clockwise seen from above)."""
    a, _ = cached(curvature=0.5)
    p = a.motion.root_pos[:, :2]
    d0, d1 = p[10] - p[0], p[-1] - p[-11]
    assert d0[0] * d1[1] - d0[1] * d1[0] > 0  # z of the cross product: CCW
    assert a.tau > 0


# ----------------------------------------------------------------------------- invariances

@pytest.mark.parametrize("kw", [dict(), dict(curvature=0.4), dict(curvature=-1.25),
                                dict(RUN, curvature=0.3)], ids=["walk", "left", "right", "run"])
def test_mirror(kw):
    motion, truth = synthetic_gait(**kw)
    a = analyze_clip(motion)
    b = analyze_clip(mirror_clip(motion))
    # speed and tau come from the best cycle, the first of the equally good windows: the
    # mirror picks one of the other foot, sampled at other sub-frame times (np.interp
    # of the root between samples): equal to ~1e-5, not to rounding
    assert b.tau == pytest.approx(-a.tau, rel=1e-4, abs=1e-9)
    if abs(kw.get("curvature", 0.0)) > 0:
        assert np.sign(b.tau) == -np.sign(kw["curvature"])
    assert b.speed == pytest.approx(a.speed, rel=1e-4)
    for f in ("cycle", "stride"):
        assert getattr(b, f) == pytest.approx(getattr(a, f), rel=1e-9), f
    assert (b.gait, b.kind) == (a.gait, a.kind)
    assert len(b.flights) == len(a.flights)
    # the mirrored left foot steps where the right foot stepped, mirrored
    fa, fb = a.footprints(), b.footprints()
    assert len(fa) == len(fb)
    for p, q in zip(fa, fb):
        assert q.foot == 1 - p.foot
        assert q.position == pytest.approx(p.position * [-1, 1, 1], abs=1e-9)
        assert abs(wrap(q.heading + p.heading)) < 1e-9
        assert q.time == pytest.approx(p.time, abs=1e-9)


@settings(max_examples=40, **HYP)
@given(rotation=st.floats(-10.0, 10.0),
       ox=st.floats(-100.0, 100.0), oy=st.floats(-100.0, 100.0),
       curvature=st.sampled_from([0.0, 0.5, -1.0]))
def test_rigid_motion_invariance(rotation, ox, oy, curvature):
    base, _ = cached(curvature=curvature)
    motion, _ = synthetic_gait(curvature=curvature, rotation=rotation, offset=(ox, oy))
    a = analyze_clip(motion)
    for f in ("speed", "cycle", "stride"):
        assert rel(getattr(a, f), getattr(base, f)) < 1e-6, f
    assert abs(a.tau - base.tau) < 1e-6
    assert (a.gait, a.kind, len(a.stances), len(a.flights)) == (
        base.gait, base.kind, len(base.stances), len(base.flights))
    c, s = math.cos(rotation), math.sin(rotation)
    R = np.array([[c, -s], [s, c]])
    for p, q in zip(base.stances, a.stances):
        assert q.foot == p.foot
        for e in ("strike", "land", "stance", "lift", "liftoff"):
            assert abs(getattr(q, e) - getattr(p, e)) < 1e-6, e
        # footprints move with the clip
        moved = R @ p.footprint.position[:2] + [ox, oy]
        assert np.allclose(q.footprint.position[:2], moved, atol=1e-6)
        assert abs(wrap(q.footprint.heading - p.footprint.heading - rotation)) < 1e-6


@settings(max_examples=18, **HYP)
@given(fps=st.sampled_from(FPS_CHOICES),
       case=st.sampled_from(["straight", "left", "run_right"]))
def test_frame_rate_invariance(fps, case):
    kw = {"straight": dict(), "left": dict(curvature=0.6),
          "run_right": dict(RUN, curvature=-0.4)}[case]
    ref, _ = cached(fps=120.0, **kw)
    a, _ = cached(fps=float(fps), **kw)
    assert (a.gait, a.kind) == (ref.gait, ref.kind)
    assert len(a.stances) == len(ref.stances)
    assert len(a.flights) == len(ref.flights)
    for f in ("speed", "cycle", "stride"):
        assert rel(getattr(a, f), getattr(ref, f)) < 0.02, (f, getattr(a, f), getattr(ref, f))
    assert abs(a.tau - ref.tau) <= 0.02 * abs(ref.tau) + 1e-3, (a.tau, ref.tau)
    check_event_order(a)


@settings(max_examples=15, **HYP)
@given(dz=st.floats(-0.5, 0.07), run=st.booleans())
def test_feet_height_offset_within_contact_height_changes_nothing(dz, run):
    """Feet sunk below the ground, or floating less than ``contact_height`` above it, are
    analysed exactly as feet standing on it."""
    kw = dict(RUN) if run else {}
    base, _ = cached(**kw)
    motion, _ = synthetic_gait(**kw)
    a = analyze_clip(raise_feet(motion, dz))
    assert (a.gait, a.kind, len(a.stances), len(a.flights)) == (
        base.gait, base.kind, len(base.stances), len(base.flights))
    for f in ("speed", "cycle", "stride", "tau"):
        assert getattr(a, f) == pytest.approx(getattr(base, f), rel=1e-9, abs=1e-12), f
    for p, q in zip(base.stances, a.stances):
        for e in ("strike", "land", "stance", "lift", "liftoff"):
            assert abs(getattr(q, e) - getattr(p, e)) < 1e-9, e
        assert q.footprint.position[:2] == pytest.approx(p.footprint.position[:2], abs=1e-9)
        assert q.footprint.position[2] == pytest.approx(p.footprint.position[2] + dz, abs=1e-9)


@settings(max_examples=40, **HYP)
@given(data=st.data(), run=st.booleans(),
       curvature=st.one_of(st.just(0.0), st.floats(-1.2, 1.2)),
       fps=st.sampled_from(FPS_CHOICES))
def test_random_gaits(data, run, curvature, fps):
    """Figures of arbitrary walks and runs (runs with flights of at least ~0.1 s: shorter
    ones are eaten by the outward contact bias, see the module docstring)."""
    if run:
        speed = data.draw(st.floats(2.5, 5.0), "speed")
        T = data.draw(st.floats(0.65, 0.9), "T")
        duty = data.draw(st.floats(0.25, 0.33), "duty")
    else:
        speed = data.draw(st.floats(0.6, 2.0), "speed")
        T = data.draw(st.floats(0.9, 1.3), "T")
        duty = data.draw(st.floats(0.55, 0.7), "duty")
    motion, truth = synthetic_gait(speed=speed, stride=speed * T, duty=duty,
                                   curvature=curvature, fps=float(fps), cycles=3)
    a = analyze_clip(motion)
    assert a.gait == truth["gait"]
    assert a.kind == "cycle"
    assert rel(a.speed, speed) < 0.02
    assert rel(a.cycle, T) < 0.02
    assert rel(a.stride, truth["stride"]) < 0.03
    assert abs(a.tau - curvature) <= 0.05 * abs(curvature) + 0.01
    assert len(a.flights) == (len(truth["flights"]) if run else 0)
    match_stances(a, truth)
    check_event_order(a)


def test_a_run_round_a_closed_circle_steps_twice_on_one_spot():
    """A fast run round a tight circle (found by test_random_gaits): the clip closes on
    itself, its first and last footprints on one spot; each is still its own stance."""
    speed = 4.957983118480588
    motion, truth = synthetic_gait(speed=speed, stride=speed * 0.65, duty=0.3125,
                                   curvature=0.65, fps=24.0, cycles=3)
    a = analyze_clip(motion)
    first, last = (sorted(a.stances, key=lambda s: s.stance)[i] for i in (0, -1))
    assert np.linalg.norm(first.footprint.position - last.footprint.position) < 0.01
    assert first.open_start and last.open_end
    match_stances(a, truth)
    check_event_order(a)


# ----------------------------------------------------------------------------- contacts

@pytest.mark.parametrize("curvature", [0.0, 0.7])
@pytest.mark.parametrize("fps", [24, 30, 60, 120])
def test_walk_contact_times_and_footprints(fps, curvature):
    a, truth = cached(fps=float(fps), curvature=curvature)
    tol = 2.0 / fps + 0.005
    for s, t in match_stances(a, truth):
        assert s.open_start == t["open_start"] and s.open_end == t["open_end"]
        if not s.open_start:
            assert abs(s.strike - t["strike"]) <= tol, ("strike", s.strike, t["strike"])
            assert s.footprint.strike_part == "heel"  # the synthetic heel lands first
        else:
            assert s.strike == 0.0 and s.footprint.strike_part is None
        if not s.open_end:
            assert abs(s.liftoff - t["liftoff"]) <= tol, ("liftoff", s.liftoff, t["liftoff"])
        else:
            assert s.liftoff == pytest.approx(a.duration, abs=1e-9)
        # the footprint: where the foot stood, pointing along the path
        assert np.linalg.norm(s.footprint.position - t["position"]) < 0.01
        assert np.linalg.norm(s.footprint.heel - t["heel"]) < 0.01
        assert np.linalg.norm(s.footprint.toe - t["toe"]) < 0.01
        assert abs(wrap(s.footprint.heading - t["heading"])) < math.radians(1.0)
        # the stance time lies inside the true contact
        assert t["strike"] - tol <= s.stance <= t["liftoff"] + tol
    check_event_order(a)


@pytest.mark.parametrize("kw", [dict(), dict(RUN), dict(curvature=-0.7)], ids=["walk", "run", "arc"])
def test_land_and_lift_fall_in_the_heel_toe_roll(kw):
    """land lies between the true heel strike and the true toe landing, lift between the
    true heel rise and the true toe-off (give or take the contact tolerance)."""
    a, truth = cached(**kw)
    tol = 2.0 / 120 + 0.005
    for s, t in match_stances(a, truth):
        if not s.open_start:
            assert t["strike"] - tol <= s.land <= t["land"] + tol, (s.land, t["strike"], t["land"])
        if not s.open_end:
            assert t["lift"] - tol <= s.lift <= t["liftoff"] + tol, (s.lift, t["lift"], t["liftoff"])


def test_run_contact_times():
    """In a run the height rule ends the contact: the detected contact contains the true
    one (to a frame) and overshoots it by at most 2 sigma of derivative smoothing + a frame."""
    a, truth = cached(**RUN)
    frame = 1.0 / 120
    for s, t in match_stances(a, truth):
        if not s.open_start:
            assert t["strike"] - (2 * SIGMA + frame) <= s.strike <= t["strike"] + frame, (
                s.strike, t["strike"])
        if not s.open_end:
            assert t["liftoff"] - frame <= s.liftoff <= t["liftoff"] + 2 * SIGMA + frame, (
                s.liftoff, t["liftoff"])
        assert np.linalg.norm(s.footprint.position - t["position"]) < 0.01
    check_event_order(a)


def test_contact_mask_matches_stances():
    a, _ = cached()
    t = a.motion.times
    for k in range(2):
        want = np.zeros(len(t), bool)
        for s0, s1 in a.contact_intervals(k):
            want |= (t >= s0 - 1e-9) & (t <= s1 + 1e-9)
        # the mask is computed at the analysis rate: allow a sample at each edge
        assert np.mean(a.contact[k] != want) < 0.02


# ----------------------------------------------------------------------------- start / stop

def test_start_clip():
    a, truth = cached(start_still=0.5)
    assert a.kind == "start"
    assert a.starts_at_rest and not a.ends_at_rest
    assert a.entry_gait == "stand" and a.exit_gait == "walk"
    assert a.gait == "walk"
    assert rel(a.speed, truth["speed"]) < 0.02
    # both feet are down at the start
    assert all(s.open_start for s in a.stances[:2]) and {s.foot for s in a.stances[:2]} == {0, 1}
    check_event_order(a)


def test_stop_clip():
    a, truth = cached(end_still=0.5)
    assert a.kind == "stop"
    assert a.ends_at_rest and not a.starts_at_rest
    assert a.entry_gait == "walk" and a.exit_gait == "stand"
    assert a.gait == "walk"
    assert rel(a.speed, truth["speed"]) < 0.02
    assert all(s.open_end for s in a.stances[-2:]) and {s.foot for s in a.stances[-2:]} == {0, 1}
    check_event_order(a)


def test_run_start_clip():
    a, _ = cached(start_still=0.5, **RUN)
    assert a.kind == "start" and a.entry_gait == "stand" and a.exit_gait == "run"


def test_standing_clip_is_idle():
    a, _ = cached(cycles=0, start_still=1.0, end_still=1.0)
    assert a.kind == "idle" and a.gait == "stand"
    assert a.speed == 0.0 and a.cycle is None and a.stride is None
    assert len(a.stances) == 2 and all(s.open_start and s.open_end for s in a.stances)


# ----------------------------------------------------------------------------- errors

def test_feet_above_the_ground_raise():
    """Feet that never come within 0.5 m of the ground z = 0: no contact at all. (Before
    commit 4c3e592 contacts were found relative to each foot's own lowest level and this
    clip analysed as a normal walk.)"""
    motion, _ = synthetic_gait(name="floating_walk")
    with pytest.raises(AnalysisError, match="floating_walk"):
        analyze_clip(raise_feet(motion, 0.5))


def test_feet_that_never_stand_still_raise():
    """Heel and toe glued to the moving body (1.2 m/s): no foot is ever planted."""
    from dataclasses import replace
    motion, _ = synthetic_gait(name="skating_clip")
    heel = np.stack([motion.root_pos, motion.root_pos])
    bad = replace(motion, heel=heel, toe=heel + [0.0, -0.2, 0.0])
    with pytest.raises(AnalysisError, match="skating_clip"):
        analyze_clip(bad)


@pytest.mark.parametrize("cycles", [0.5, 0.8, 0.95])
def test_walk_shorter_than_a_cycle_raises(cycles):
    motion, truth = synthetic_gait(cycles=cycles, name="short_walk")
    assert motion.duration < truth["T"]
    with pytest.raises(AnalysisError, match="too short") as err:
        analyze_clip(motion)
    assert "short_walk" in str(err.value)


def test_tiny_clip_raises():
    motion, _ = synthetic_gait(cycles=2.0 / 120 / (1.4 / 1.2), name="blip")
    assert motion.n < 4
    with pytest.raises(AnalysisError, match="too short") as err:
        analyze_clip(motion)
    assert "blip" in str(err.value)


# ----------------------------------------------------------------------------- noise

@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("curvature", [0.0, 0.5])
def test_noise_robustness(seed, curvature):
    motion, truth = synthetic_gait(curvature=curvature, noise=0.003, hnoise=0.002, seed=seed)
    a = analyze_clip(motion)
    assert a.gait == "walk" and a.kind == "cycle" and a.flights == []
    assert rel(a.speed, truth["speed"]) < 0.03
    assert rel(a.cycle, truth["T"]) < 0.03
    assert rel(a.stride, truth["stride"]) < 0.03
    assert abs(a.tau - curvature) <= 0.05 * abs(curvature) + 0.02
    match_stances(a, truth)
    check_event_order(a)


# ------------------------------------------------------------- resampling: one spline for all

@settings(max_examples=25, **HYP)
@given(fps=st.sampled_from(FPS_CHOICES), to=st.sampled_from((24.0, 60.0, 120.0, 97.0)),
       curvature=st.floats(-0.8, 0.8), cycles=st.floats(0.3, 2.0), noise=st.floats(0.0, 0.01))
def test_a_resampled_clip_has_each_channels_own_spline_to_the_bit(fps, to, curvature, cycles, noise):
    """``ClipMotion.resample`` fits one spline through every channel at once; each channel
    is the spline it would have alone, exactly (a plan reads them; a last bit changes one)."""
    from scipy.interpolate import CubicSpline

    m, _ = synthetic_gait(fps=fps, curvature=curvature, cycles=cycles, noise=noise)
    r = m.resample(to)
    alone = lambda a, axis=0: CubicSpline(m.times, a, axis=axis)(r.times)  # noqa: E731
    assert np.array_equal(r.root_pos, alone(m.root_pos)) and np.array_equal(r.root_heading, alone(m.root_heading))
    assert np.array_equal(r.heel, alone(m.heel, 1)) and np.array_equal(r.toe, alone(m.toe, 1))
    assert r.heel.shape == (2, r.n, 3) and r.root_pos.shape == (r.n, 3) and r.fps == to
