"""Properties of footstep_planner.core.synth.blending (thesis 3.4): the blend point, the
schedule and the playback, on hand-made tracks and on synthetic gaits (tests/synth.py)."""

from __future__ import annotations

import functools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from footstep_planner.core.clips.analysis import analyze_clip
from footstep_planner.core.synth.blending import blend_point_alpha, playback
from footstep_planner.core.synth.schedule import PlanStep, Schedule, build_schedule
from footstep_planner.core.synth.tracks import BlendError, ClipTrack, make_track
from footstep_planner.core.clips.steps import clip_steps
from synth import synthetic_gait

HYP = dict(deadline=None, database=None, max_examples=60)


# ----------------------------------------------------------------------------- hand-made tracks

def _track(name, v, yaw, f_left, f_right, rate=100.0, n=201):
    """A track with constant root velocity v (2,) and yaw rate; each foot point moves in
    the root frame so that it is planted in the clip's world: f(t) = R(-psi)(P - r(t))."""
    t = np.arange(n) / rate
    psi = yaw * t
    if abs(yaw) < 1e-12:
        r = t[:, None] * np.asarray(v)[None]
    else:  # constant local velocity on a circle
        c, s = np.cos(psi), np.sin(psi)
        vx, vy = v
        r = np.c_[(vx * s + vy * (c - 1)) / yaw, (vx * (1 - c) + vy * s) / yaw]

    def local(P):
        d = np.asarray(P)[None, :2] - r
        c, s = np.cos(-psi), np.sin(-psi)
        return np.c_[c * d[:, 0] - s * d[:, 1], s * d[:, 0] + c * d[:, 1], np.zeros(n)]

    feet = np.stack([local(f_left), local(f_right)])
    return ClipTrack(name=name, kind="cycle", gait="walk", entry_gait="walk", exit_gait="walk",
                     rate=rate, duration=(n - 1) / rate, vel=np.tile(np.asarray(v, float), (n, 1)),
                     yaw_rate=np.full(n, float(yaw)), heel=feet, toe=feet, contact_point=feet,
                     contact=np.ones((2, n)), hips_in_root=np.tile(np.eye(4), (n, 1, 1)),
                     phase_times=np.array([0.0, 0.5, 1.0]))


def _schedule(names, w_before, w_after, switch, F=60, fps=30.0, rates=None):
    t = np.arange(F) / fps
    W = np.where((np.arange(F) >= switch)[:, None], np.asarray(w_after)[None], np.asarray(w_before)[None])
    rates = np.ones(len(names)) if rates is None else np.asarray(rates, float)
    return Schedule(t=t, u=t, clips=list(names), weights=W, clip_time=t[:, None] * rates[None],
                    clip_rate=np.tile(rates, (F, 1)), footprint_times=np.array([0.0, t[-1]]),
                    feet=np.array([0, 1]), fps=fps)


vec = st.tuples(st.floats(-2, 2), st.floats(-2, 2))
weights = st.floats(0.0, 1.0)


@settings(**HYP)
@given(va=vec, vb=vec, pa=vec, pb=vec, ra=vec, rb=vec, w0=weights, w1=weights,
       switch=st.integers(5, 50))
def test_a_planted_foot_does_not_move_when_the_weights_change(va, vb, pa, pb, ra, rb, w0, w1, switch):
    """Left foot planted in both clips (each at its own spot in the clip), the right one
    swinging: changing the weights in one frame leaves the left foot where it was."""
    A = _track("a", va, 0.0, pa, ra)
    B = _track("b", vb, 0.0, pb, rb)
    # the right foot swings: give it a velocity of its own in each clip
    A = _swinging_right(A, (0.7, -0.3))
    B = _swinging_right(B, (-0.4, 0.9))
    S = _schedule(["a", "b"], [w0, 1 - w0], [w1, 1 - w1], switch)
    pb_ = playback(S, {"a": A, "b": B})
    left = pb_.contact_point[0, :, :2]
    np.testing.assert_allclose(left[switch], left[switch - 1], atol=1e-6)
    np.testing.assert_allclose(left, np.broadcast_to(left[0], left.shape), atol=1e-6)  # and all along: it is planted
    assert np.all(pb_.blend_alpha[1:] < 1e-9)  # the stable point is the left foot


def _swinging_right(tr, v):
    n = tr.n
    cp = tr.contact_point.copy()
    cp[1] = cp[1] + np.c_[np.arange(n)[:, None] / tr.rate * np.asarray(v)[None], np.zeros(n)]
    return ClipTrack(**{**tr.__dict__, "contact_point": cp, "heel": cp, "toe": cp})


@settings(**HYP)
@given(va=vec, vb=vec, pa=vec, pb=vec, ra=vec, rb=vec, ya=st.floats(-1.5, 1.5), yb=st.floats(-1.5, 1.5),
       w0=weights, w1=weights, switch=st.integers(5, 50))
def test_the_blend_point_stays_where_the_old_weights_would_have_put_it(va, vb, pa, pb, ra, rb, ya, yb,
                                                                       w0, w1, switch):
    """In general (turning clips, both feet moving): at the frame the weights change, the
    most stable point is where the unchanged weights would have put it."""
    A = _swinging_right(_track("a", va, ya, pa, ra), (0.3, 0.2))
    B = _swinging_right(_track("b", vb, yb, pb, rb), (-0.2, 0.5))
    tracks = {"a": A, "b": B}
    changed = playback(_schedule(["a", "b"], [w0, 1 - w0], [w1, 1 - w1], switch), tracks)
    kept = playback(_schedule(["a", "b"], [w0, 1 - w0], [w0, 1 - w0], switch), tracks)
    a = changed.blend_alpha[switch]
    ps = lambda p: a * p.contact_point[1, switch, :2] + (1 - a) * p.contact_point[0, switch, :2]  # noqa: E731
    np.testing.assert_allclose(ps(changed), ps(kept), atol=1e-9)
    np.testing.assert_allclose(changed.root[:switch], kept.root[:switch], atol=1e-12)


@settings(**HYP)
@given(vl=vec, vr=vec)
def test_blend_point_alpha_minimises_the_speed_on_the_line(vl, vr):
    vl, vr = np.array([vl]), np.array([vr])
    a = blend_point_alpha(vl, vr)[0]
    assert 0.0 <= a <= 1.0
    grid = np.linspace(0, 1, 201)
    speeds = np.linalg.norm(grid[:, None] * vr + (1 - grid[:, None]) * vl, axis=1)
    assert np.linalg.norm(a * vr + (1 - a) * vl) <= speeds.min() + 1e-6  # m/s


def test_blend_point_alpha_at_a_planted_foot():
    v = np.array([[0.0, 0.0], [1.0, 2.0], [0.5, 0.0]])
    w = np.array([[1.0, 0.0], [0.0, 0.0], [0.5, 0.0]])
    np.testing.assert_allclose(blend_point_alpha(v, w), [0.0, 1.0, 0.5])


# ----------------------------------------------------------------------------- synthetic gaits

@functools.lru_cache(maxsize=None)
def _gait(name, **kw):
    motion, _ = synthetic_gait(name=name, cycles=4, **kw)
    return analyze_clip(motion)


GAITS = {
    "walk": dict(speed=1.3, stride=1.4, duty=0.62),
    "walk_left": dict(speed=1.2, stride=1.35, duty=0.62, curvature=0.5),
    "walk_right": dict(speed=1.2, stride=1.35, duty=0.62, curvature=-0.5),
    "run": dict(speed=3.0, stride=2.4, duty=0.35),
}


def _tracks():
    return {n: make_track(_gait(n, **kw)) for n, kw in GAITS.items()}


TRACKS = None


def tracks():
    global TRACKS
    if TRACKS is None:
        TRACKS = _tracks()
    return TRACKS


def test_playing_one_clip_reproduces_its_steps():
    """Played alone, a clip leaves the footprints it left itself: the same steps
    (relative position and turn from one footprint to the next)."""
    for name in ("walk", "walk_left", "run"):
        tr = tracks()[name]
        steps = [PlanStep(j % 2, None, np.array([1.0])) for j in range(8)]
        S = build_schedule(steps, {name: tr}, [name], fps=60.0, transition=0.3)
        pb = playback(S, {name: tr})
        fwd = tr.rest_forward
        mine = []
        for i in range(len(pb.footprints) - 1):
            a, b = pb.footprints[i], pb.footprints[i + 1]
            ang = pb.footprint_heading[i] + np.arctan2(fwd[1], fwd[0])
            f = np.array([np.cos(ang), np.sin(ang)])
            d = b[:2] - a[:2]
            mine.append((d @ f, d @ np.array([-f[1], f[0]])))
        ref = {s[0]: s[1:3] for s in clip_steps(_gait(name, **GAITS[name]))}
        for i, (fw, lf) in enumerate(mine):
            assert fw == pytest.approx(ref[i % 2][0], abs=0.01), (name, i)
            assert lf == pytest.approx(ref[i % 2][1], abs=0.01), (name, i)


@settings(deadline=None, database=None, max_examples=25)
@given(data=st.data())
def test_schedule_weights_sum_to_one_and_clip_times_stay_in_their_clips(data):
    trs = tracks()
    cyc = ["walk", "walk_left", "walk_right", "run"]
    n = data.draw(st.integers(1, 12))
    steps = []
    for j in range(n):
        w = np.array(data.draw(st.lists(st.floats(0, 1), min_size=4, max_size=4)))
        w = w / w.sum() if w.sum() > 1e-3 else np.array([1.0, 0, 0, 0])
        steps.append(PlanStep(j % 2, None, w))
    fps = data.draw(st.sampled_from([24.0, 30.0, 60.0]))
    S = build_schedule(steps, trs, cyc, fps=fps, transition=data.draw(st.floats(0.0, 0.6)))
    np.testing.assert_allclose(S.weights.sum(axis=1), 1.0, atol=1e-9)
    assert (S.weights >= -1e-12).all()
    assert np.all(np.diff(S.footprint_times) > 0)
    for c, name in enumerate(S.clips):
        assert (S.clip_time[:, c] >= 0).all() and (S.clip_time[:, c] <= trs[name].duration + 1e-9).all()
    pb = playback(S, trs)
    assert np.isfinite(pb.root).all() and np.isfinite(pb.footprints).all()


def test_a_step_weight_change_ramps_over_the_transition_time():
    trs = tracks()
    steps = [PlanStep(j % 2, None, np.array([1.0, 0.0] if j < 4 else [0.0, 1.0])) for j in range(8)]
    S = build_schedule(steps, trs, ["walk", "walk_left"], fps=60.0, transition=0.3)
    w = S.weights[:, 1]
    ramp = S.t[(w > 1e-9) & (w < 1 - 1e-9)]
    # frames strictly inside the ramp span its length less at most two frame steps
    assert 0.3 - 2.0 / 60 - 1e-9 <= ramp.max() - ramp.min() <= 0.3 + 1e-9
    assert np.mean(ramp) == pytest.approx(S.footprint_times[4], abs=1.0 / 60)


def test_bad_weights_are_refused_naming_the_step():
    with pytest.raises(BlendError, match="step 1"):
        build_schedule([PlanStep(0, None, np.array([1.0])), PlanStep(1, None, np.array([0.5]))],
                       {"walk": tracks()["walk"]}, ["walk"], fps=30.0, transition=0.3)


# ----------------------------------------------------------------------------- phase keys

@pytest.mark.parametrize("lead", [0, 1])
@pytest.mark.parametrize("tau", [0.0, 0.4, -1.25])
def test_a_cycle_is_keyed_on_whole_stances_whichever_foot_leads(lead, tau):
    # a clip of two cycles that starts and ends inside a stance of its first foot holds no
    # whole left-right-left triple when the right foot leads: its phase must not be keyed
    # on the stance the clip's start cuts (that made steps of 0.1 s and thigh pops)
    from footstep_planner.core.sample import gait, mannequin
    from footstep_planner.core.clips.clip import clip_motion

    rig = mannequin.rig()
    spec = gait.ClipSpec("w", gait.WALK, tau=tau, lead=lead)
    c = gait.generate(rig, spec, 30.0)
    import dataclasses

    first = analyze_clip(clip_motion(rig, "w", c.basis, 30.0))
    whole = [(s.foot, s.stance) for s in first.stances if not (s.open_start or s.open_end)]
    half = 0.5 * round(gait.WALK.cycle * 30) / 30
    # whichever cycle the analysis finds best (sampled in Blender, it may start later)
    for _, start in whole:
        a = dataclasses.replace(first, best_cycle=(start, start + 2 * half))
        tr = make_track(a)
        assert tr.step_duration(0) == pytest.approx(half, abs=0.02)
        assert tr.step_duration(1) == pytest.approx(half, abs=0.02)
        t, slope = tr.clip_time_of_phase(np.array([0.0, 0.5]))
        assert any(f == 0 and abs(t[0] - ts) < 1e-6 for f, ts in whole)  # phase 0: a left stance
        assert any(f == 1 and abs(t[1] - ts) < 1e-6 for f, ts in whole)  # phase 1/2: a right one
        assert (slope > 0).all()
