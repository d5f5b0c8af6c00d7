"""Planner-made pops at their causes (issue 14, "No new pops"), on hand-made and synthetic
clips (core only, no Blender): a cyclic clip's loop seam, where its cycle's stances were
keyed, and a special clip's timing beside its own step.

- A cycle of motion capture never ends exactly in the pose it began with: the loop's seam
  is closed by spreading the mismatch over the cycle (``ClipTrack.sample_pose``).
- A foot lying flat holds its heights for a good part of its stance, so a stance time
  falls anywhere in that plateau: the key one cycle on is moved to where the pose repeats
  (``_loop_end``), else the seam jumps by a few frames of swing.
- A special clip (a jump) ramps in over the step before its take-off: it is played in
  step with the cycles there (``_register_special``), its feet coming down with theirs.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from footstep_planner.core.clips.analysis import analyze_clip
from footstep_planner.core.synth.schedule import PlanStep, build_schedule
from footstep_planner.core.synth.tracks import ClipTrack, _seam_closing, loop_seam, make_track
from synth import synthetic_gait

HYP = dict(deadline=None, database=None, max_examples=40)


def _angle(q1: np.ndarray, q2: np.ndarray) -> np.ndarray:
    """(...,) rad between unit quaternions (..., 4)."""
    return 2.0 * np.arccos(np.clip(np.abs(np.sum(q1 * q2, axis=-1)), 0.0, 1.0))


def _posed_track(rate, keys, swing, drift_axis, drift, n=None, bones=3):
    """A cyclic track whose bones swing periodically (amplitude ``swing`` rad, period
    keys[2] - keys[0]) and drift linearly by ``drift`` rad over that period about
    ``drift_axis``: its cycle ends ``drift`` away from where it began."""
    a, b, c = keys
    n = n or int(np.ceil((c + 0.5) * rate)) + 1
    t = np.arange(n) / rate
    period = c - a
    rv = np.zeros((n, bones, 3))
    for k in range(bones):
        rv[:, k, k % 3] = swing * np.sin(2 * np.pi * (t - a) / period + k)
        rv[:, k] += np.asarray(drift_axis)[None] * (drift * (t - a) / period)[:, None]
    quat = Rotation.from_rotvec(rv.reshape(-1, 3)).as_quat().reshape(n, bones, 4)
    hips = np.tile(np.eye(4), (n, 1, 1))
    hips[:, 2, 3] = 0.9 + 0.02 * t / period  # the hips' height drifts too
    seam = loop_seam(np.array(keys))
    rot, hip = _seam_closing(quat, hips, rate, seam)
    zero = np.zeros((n, 2))
    return ClipTrack(name="posed", kind="cycle", gait="walk", entry_gait="walk", exit_gait="walk", rate=rate,
                     duration=(n - 1) / rate, vel=zero, yaw_rate=np.zeros(n), heel=np.zeros((2, n, 3)),
                     toe=np.zeros((2, n, 3)), contact_point=np.zeros((2, n, 3)), contact=np.ones((2, n)),
                     hips_in_root=hips, phase_times=np.array(keys, float), pose_rate=rate, quat=quat, hips=hips,
                     seam=seam, seam_rot=rot, seam_hips=hip)


@settings(**HYP)
@given(drift=st.floats(0.0, 1.5), swing=st.floats(0.0, 0.8),
       axis=st.tuples(st.floats(-1, 1), st.floats(-1, 1), st.floats(0.1, 1)),
       a=st.floats(0.1, 0.6), period=st.floats(0.6, 1.3), rate=st.sampled_from([30.0, 60.0, 120.0]))
def test_the_loop_seam_is_closed_and_the_mismatch_spread_over_the_cycle(drift, swing, axis, a, period, rate):
    """Across the phase's wrap (clip time e back to s) the pose goes on as smoothly as it
    moves elsewhere, whatever the cycle's mismatch (up to 86 degrees here); the closing
    turns no bone faster than the mismatch over the cycle's length."""
    axis = np.asarray(axis) / np.linalg.norm(axis)
    keys = (a, a + 0.5 * period, a + period)
    tr = _posed_track(rate, keys, swing, axis, drift)
    dt = 1.0 / 30.0  # a frame
    eps = 1e-4
    # the frames either side of the wrap, at phases 1 - eps and eps (and a frame apart)
    before, _ = tr.clip_time_of_phase(np.array([1.0 - eps, 1.0 - eps - dt / period]))
    after, _ = tr.clip_time_of_phase(np.array([eps, eps + dt / period]))
    qb, hpb, hqb = tr.sample_pose(before)
    qa, hpa, hqa = tr.sample_pose(after)
    across = _angle(qb[0], qa[0])  # (B,) over the wrap (2 eps of phase)
    elsewhere = np.maximum(_angle(qb[0], qb[1]), _angle(qa[0], qa[1]))  # a frame's motion
    assert np.all(across <= elsewhere + 1e-3), (np.degrees(across), np.degrees(elsewhere))
    assert np.linalg.norm(hpb[0] - hpa[0]) < 1e-3 and _angle(hqb[0], hqa[0]) < 1e-3
    # the spread: each sample turned by its share (at most half the mismatch, any time)
    t = np.linspace(0.0, tr.duration, 200)
    q, _, _ = tr.sample_pose(t)
    raw = tr.quat[np.clip(np.rint(t * rate).astype(int), 0, len(tr.quat) - 1)]
    share = np.abs(tr.seam_share(t))
    mismatch = np.linalg.norm(tr.seam_rot, axis=1)  # (B,)
    step = np.max(_angle(tr.quat[1:], tr.quat[:-1]), axis=0)  # (B,) the nearest-sample error
    assert np.all(_angle(q, raw) <= share[:, None] * mismatch[None] + step[None] + 1e-6)
    assert np.all(share <= 0.5 + 1e-12)


def test_a_closed_cycle_is_played_as_it_is():
    """A cycle that ends in the pose it began with is not changed."""
    tr = _posed_track(60.0, (0.2, 0.7, 1.2), 0.5, (0.0, 0.0, 1.0), 0.0)
    t = np.linspace(0.0, tr.duration, 97)
    q, hp, _ = tr.sample_pose(t)
    untouched = replace(tr, seam=None, seam_rot=None, seam_hips=None).sample_pose(t)
    assert np.all(_angle(q, untouched[0]) < 1e-6)
    np.testing.assert_allclose(hp[:, :2], untouched[1][:, :2], atol=1e-9)


def _periodic_pose(motion, period, amplitude=0.6, bones=4):
    """``motion`` with bones swinging with the gait's period (the legs of a walk)."""
    t = motion.times
    rv = np.zeros((motion.n, bones, 3))
    for k in range(bones):
        rv[:, k, k % 3] = amplitude * np.sin(2 * np.pi * t / period + k)
    return replace(motion, local_rot=Rotation.from_rotvec(rv.reshape(-1, 3)).as_matrix().reshape(motion.n, bones, 3, 3))


def test_the_loop_ends_where_the_pose_repeats_whatever_the_stance_times():
    """Heights with a little noise put the stances anywhere on their flat plateau; the
    key one cycle on is where the pose repeats, so the loop is one cycle long (to a
    quarter of a clip frame) and its seam all but closed already."""
    for seed in range(3):
        m, truth = synthetic_gait(speed=1.3, stride=1.4, fps=30.0, cycles=3.2, noise=0.0015, seed=seed, roll=0.08)
        period = truth["T"]
        m = _periodic_pose(m, period)
        a = analyze_clip(m)
        tr = make_track(a)
        s, e = tr.seam
        assert abs((e - s) - period) <= 0.25 / m.fps + 1e-6, (seed, e - s, period)
        assert np.degrees(np.linalg.norm(tr.seam_rot, axis=1)).max() < 3.0
        # the stances themselves may be further off: that is what the key corrects
        keys = tr.phase_times
        stance_times = [x.stance for x in a.stances]
        assert min(abs(np.subtract(stance_times, keys[0]))) < 1e-9  # the first key is a stance


def _special(stances, rate=100.0, duration=2.0):
    n = int(duration * rate) + 1
    z = np.zeros((2, n, 3))
    return ClipTrack(name="leap", kind="jump", gait="run", entry_gait="run", exit_gait="run", rate=rate,
                     duration=duration, vel=np.zeros((n, 2)), yaw_rate=np.zeros(n), heel=z, toe=z, contact_point=z,
                     contact=np.ones((2, n)), hips_in_root=np.tile(np.eye(4), (n, 1, 1)), phase_times=None,
                     stances=stances)


def _cycle(rate=100.0, n=201):
    z = np.zeros((2, n, 3))
    return ClipTrack(name="run", kind="cycle", gait="run", entry_gait="run", exit_gait="run", rate=rate,
                     duration=(n - 1) / rate, vel=np.tile([0.0, -3.0], (n, 1)), yaw_rate=np.zeros(n), heel=z, toe=z,
                     contact_point=z, contact=np.ones((2, n)), hips_in_root=np.tile(np.eye(4), (n, 1, 1)),
                     phase_times=np.array([0.2, 0.6, 1.0]))


@settings(**HYP)
@given(g0=st.floats(0.15, 0.3), g1=st.floats(0.15, 0.3), flight=st.floats(0.5, 0.6), g2=st.floats(0.15, 0.3))
def test_a_jump_clip_ramps_in_and_out_in_step_with_the_cycles(g0, g1, flight, g2):
    """Over the steps beside its own, the special clip's time runs from its stance before
    the take-off to the take-off, and from the landing to its next stance, stretched over
    the plan's steps (its own run-up of another cadence than the cycles'): its feet come
    down at the footprints' times, with the cycles'."""
    before = 0.1 + g0
    takeoff = before + g1
    landing = takeoff + flight
    after = landing + g2
    leap = _special([(1, 0.1), (0, before), (1, takeoff), (0, landing), (1, after), (0, after + 0.2)])
    tracks = {"run": _cycle(), "leap": leap}
    steps = [PlanStep(0, None, np.array([1.0])), PlanStep(1, None, np.array([1.0])), PlanStep(0, None, np.array([1.0])),
             PlanStep(1, "leap", None), PlanStep(0, None, np.array([1.0])), PlanStep(1, None, np.array([1.0])),
             PlanStep(0, None, np.array([1.0]))]
    S = build_schedule(steps, tracks, ["run"], fps=100.0, transition=0.45)
    c = S.column("leap")
    T = S.footprint_times
    at = lambda time: int(np.argmin(np.abs(S.t - time)))  # noqa: E731
    w = S.weights[:, c]
    for j, want in ((3, takeoff), (4, landing)):
        assert abs(S.clip_time[at(T[j]), c] - want) < 0.02
    # the footprint before the take-off and the one after the landing, where it plays
    k = at(T[2] + 0.5 * (T[3] - T[2]))
    assert w[k] > 0
    assert abs(S.clip_time[k, c] - 0.5 * (before + takeoff)) < 0.02
    k = at(T[4] + 0.5 * (T[5] - T[4]))
    assert w[k] > 0
    assert abs(S.clip_time[k, c] - 0.5 * (landing + after)) < 0.02
    # its time never runs backwards while it plays
    on = np.flatnonzero(w > 0)
    assert np.all(np.diff(S.clip_time[on, c]) >= -1e-9)
