"""In-place clips (footstep_planner.core.clips.inplace): a clip whose hips stay over one spot while
its feet step is recognised, its root motion is reconstructed from its planted feet, and
its analysis gives the figures of the travelling clip it was made from.

The in-place clips are made from travelling ones: synthetic gaits (tests/synth.py) and
CMU motion capture, with the root's horizontal travel (and, for some turning ones, its
yaw) taken out of the whole clip, the pose kept.
"""

from __future__ import annotations

import functools
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from footstep_planner.core.clips import inplace
from footstep_planner.core.clips.analysis import AnalysisError, _analyze, analyze_clip
from footstep_planner.core.base.errors import FootstepError
from footstep_planner.core.base.settings import Settings
from synth import synthetic_gait

from conftest import analyse_bvh, cmu, needs_cmu

RUN = dict(speed=3.0, stride=2.4, duty=0.35)


def in_place(motion, yaw=False, keep_sway=False):
    """``motion`` with its root's horizontal travel taken out of the whole clip (root,
    heel and toe; the pose and the heights stay): the root stays at its first position,
    or on it plus its sway about the straight line it travels along (``keep_sway``);
    with ``yaw`` its heading stays at its first too."""
    r = motion.root_pos[:, :2]
    if keep_sway:  # remove the straight-line travel only (least squares)
        a = np.stack([np.ones(motion.n), motion.times], axis=1)
        coef, *_ = np.linalg.lstsq(a, r, rcond=None)
        target = r - (a @ coef - a[:1] @ coef)
    else:
        target = np.repeat(r[:1], motion.n, axis=0)
    theta = (motion.root_heading[0] - motion.root_heading) if yaw else np.zeros(motion.n)
    c, s = np.cos(theta), np.sin(theta)
    turned = np.stack([c * r[:, 0] - s * r[:, 1], s * r[:, 0] + c * r[:, 1]], axis=1)
    return motion.moved(theta, target - turned)


@functools.lru_cache(maxsize=None)
def pair(yaw=False, **kw):
    """(travelling analysis, in-place analysis, truth) of synthetic_gait(**kw)."""
    motion, truth = synthetic_gait(**kw)
    return analyze_clip(motion), analyze_clip(in_place(motion, yaw=yaw)), truth


def assert_same_figures(a, b, speed=0.03, tau_rel=0.10, tau_abs=0.05):
    """``b`` (in place) tells what ``a`` (travelling) does."""
    assert (b.gait, b.kind, b.entry_gait, b.exit_gait) == (a.gait, a.kind, a.entry_gait, a.exit_gait)
    assert b.speed == pytest.approx(a.speed, rel=speed)
    if a.stride is not None:
        assert b.stride == pytest.approx(a.stride, rel=speed)
        assert b.cadence == pytest.approx(a.cadence, rel=speed)
    assert abs(b.tau - a.tau) <= max(tau_rel * abs(a.tau), tau_abs)


# ----------------------------------------------------------------------------- synthetic

CASES = {
    "walk": dict(),
    "slow walk": dict(speed=0.8, stride=1.1, duty=0.68),
    "run": RUN,
    "walk at 30 fps": dict(fps=30.0),
    "noisy walk": dict(noise=0.003, hnoise=0.002),
    "turning walk": dict(curvature=0.8),
    "sharp turning walk": dict(speed=1.2, stride=1.4, curvature=-1.3),
    "turning run": dict(curvature=-0.6, **RUN),
}


@pytest.mark.parametrize("case,yaw", [(c, False) for c in CASES] + [
    (c, True) for c in CASES if CASES[c].get("curvature")])
def test_in_place_clip_gives_the_travelling_figures(case, yaw):
    """yaw: the turning clip's yaw is removed too (its root keeps one heading), and the
    feet's turning gives it back; else the hips keep their yaw (as an in-place download
    does)."""
    a, b, truth = pair(yaw=yaw, **CASES[case])
    assert not a.in_place and b.in_place
    assert_same_figures(a, b)
    assert b.speed == pytest.approx(truth["speed"], rel=0.03)
    assert b.tau == pytest.approx(truth["curvature"], rel=0.1, abs=0.05)
    # the same steps: as many stances of each foot, the same contact times
    assert [s.foot for s in b.stances] == [s.foot for s in a.stances]
    for sa, sb in zip(a.stances, b.stances):
        assert sb.strike == pytest.approx(sa.strike, abs=0.03)
        assert sb.liftoff == pytest.approx(sa.liftoff, abs=0.03)


@pytest.mark.parametrize("case", ["walk", "run", "sharp turning walk"])
def test_reconstructed_planted_feet_stand_still(case):
    """While a foot stands flat (land to lift), its ground point moves under 2 cm in the
    reconstructed clip (it slides a stride's length in the in-place one)."""
    _, b, _ = pair(yaw=True, **CASES[case])
    m = b.motion
    for s in b.stances:
        i = (m.times >= s.land) & (m.times <= s.lift)
        if i.sum() < 2:
            continue
        p = 0.5 * (m.heel[s.foot, i, :2] + m.toe[s.foot, i, :2])
        assert np.ptp(p, axis=0).max() < 0.02, (case, s.foot, s.stance)


def test_travelling_clips_are_analysed_as_before():
    """Bit for bit: the travelling path (Johansen's analysis alone) is what analyze_clip
    gives, and the clip is not in place."""
    for kw in (dict(), RUN, dict(curvature=0.8), dict(start_still=0.5), dict(end_still=0.5)):
        motion, _ = synthetic_gait(**kw)
        a = analyze_clip(motion)
        b = _analyze(motion, Settings())
        assert a.in_place is False and a.motion is motion
        assert a.to_dict() == b.to_dict()
        assert np.array_equal(a.contact, b.contact) and np.array_equal(a.balance, b.balance)


def test_in_place_is_reported():
    a, b, _ = pair(**CASES["walk"])
    assert a.to_dict()["in_place"] is False and b.to_dict()["in_place"] is True
    assert a.gait_text == "walk" and b.gait_text == "walk (in place)"


def test_the_analysis_plays_the_reconstructed_clip():
    """Its motion is the in-place clip carried along: the root travels, the pose (bone
    rotations, the hips in the root frame) and the heights are the clip's own."""
    motion, truth = synthetic_gait(curvature=0.8)
    length = truth["speed"] * (truth["t_move"][1] - truth["t_move"][0])
    m = in_place(motion, yaw=True)
    r = analyze_clip(m).motion
    assert np.linalg.norm(np.diff(r.root_pos[:, :2], axis=0), axis=1).sum() == pytest.approx(length, rel=0.05)
    assert r.root_heading[-1] - r.root_heading[0] == pytest.approx(0.8 * length, rel=0.05)
    assert np.array_equal(r.hips_in_root, m.hips_in_root) and np.array_equal(r.local_rot, m.local_rot)
    assert np.array_equal(r.heel[..., 2], m.heel[..., 2]) and np.array_equal(r.times, m.times)


def test_check_in_place_figures():
    motion, truth = synthetic_gait()
    c = inplace.check_in_place(motion)
    assert not c.in_place and c.root_speed == pytest.approx(truth["speed"], rel=0.02) and c.slide < 0.1
    c = inplace.check_in_place(in_place(motion))
    assert c.in_place and c.steps and c.root_speed < 1e-9
    assert c.slide == pytest.approx(truth["speed"], rel=0.05)


def test_hips_sway_is_kept():
    """Hips that sway about the spot they stay over (side to side and back and forth):
    still in place, the same speed."""
    motion, truth = synthetic_gait()
    m = in_place(motion)
    sway = np.zeros_like(m.root_pos)
    sway[:, 0] = 0.03 * np.sin(2 * np.pi * m.times / truth["T"])
    sway[:, 1] = 0.02 * np.sin(4 * np.pi * m.times / truth["T"])
    b = analyze_clip(replace(m, root_pos=m.root_pos + sway))
    assert b.in_place and b.speed == pytest.approx(truth["speed"], rel=0.03)


HYP = dict(deadline=None, database=None, max_examples=15)


@settings(**HYP)
@given(speed=st.floats(0.8, 2.0), cadence=st.floats(90, 125), curvature=st.floats(-0.6, 0.6),
       fps=st.sampled_from([24, 30, 60, 120]))
def test_any_walk_round_trips(speed, cadence, curvature, fps):
    """Any synthetic walk of 0.8-2 m/s, taken in place (travel and yaw), gives back its
    speed, stride and cadence within 3 % and its curvature within 0.05 1/m."""
    stride = speed * 120.0 / cadence
    duty = 0.66 - 0.06 * (speed - 0.8)
    motion, truth = synthetic_gait(speed=speed, stride=stride, duty=duty, curvature=curvature,
                                   fps=float(fps), cycles=3)
    a = analyze_clip(motion)
    b = analyze_clip(in_place(motion, yaw=True))
    assert b.in_place and not a.in_place
    assert_same_figures(a, b)
    assert b.speed == pytest.approx(speed, rel=0.03)


# ----------------------------------------------------------------------------- not in place

def test_an_idle_stays_an_idle():
    motion, _ = synthetic_gait(cycles=0, start_still=1.0, end_still=1.0)
    for m in (motion, in_place(motion)):
        a = analyze_clip(m)
        assert a.kind == "idle" and a.gait == "stand" and not a.in_place
        assert not inplace.check_in_place(m).in_place


def test_feet_that_never_plant_raise():
    """In place, feet that step but shake from side to side (6 Hz) whenever they are
    down: never planted, an error naming the clip."""
    motion, _ = synthetic_gait(name="shaky_in_place")
    m = in_place(motion)
    shake = np.zeros_like(m.heel)
    shake[..., 0] = 0.05 * np.sin(2 * np.pi * 6.0 * m.times)
    bad = replace(m, heel=m.heel + shake, toe=m.toe + shake)
    assert inplace.check_in_place(bad).in_place
    with pytest.raises(AnalysisError, match="shaky_in_place.*never planted") as err:
        analyze_clip(bad)
    assert isinstance(err.value, FootstepError)


# ----------------------------------------------------------------------------- real motion capture

@pytest.fixture(scope="module")
def cmu120(fp):
    return analyse_bvh(fp, [cmu(n) for n in ("16_16", "16_35", "16_01")], 120)


@needs_cmu
@pytest.mark.parametrize("name", ["cmu_16_16_walk", "cmu_16_35_run_jog"])
def test_cmu_in_place(cmu120, name):
    """The hips' horizontal travel removed (the straight line they progress along; their
    vertical bob and their sway about that line kept): the speed within 5 % of the
    original's. Real planted feet creep forward a little (3-4 % of the speed in these
    walks), which the reconstruction cannot know."""
    a = cmu120[name]
    b = analyze_clip(in_place(a.motion, keep_sway=True))
    assert b.in_place and not a.in_place
    assert (b.gait, b.kind) == (a.gait, a.kind)
    assert b.speed == pytest.approx(a.speed, rel=0.05)
    assert b.stride == pytest.approx(a.stride, rel=0.05)
    assert b.cadence == pytest.approx(a.cadence, rel=0.05)
    assert abs(b.tau - a.tau) < 0.05


@needs_cmu
@pytest.mark.parametrize("name", ["cmu_16_16_walk", "cmu_16_35_run_jog"])
def test_cmu_hips_pinned(cmu120, name):
    """The hips' horizontal motion removed entirely (pinned over one spot): the speed
    within 10 %. Under the original's: a jogger's hips move faster in flight than over
    the planted foot, and the flight is bridged from the stances."""
    a = cmu120[name]
    b = analyze_clip(in_place(a.motion))
    assert b.in_place and (b.gait, b.kind) == (a.gait, a.kind)
    assert b.speed == pytest.approx(a.speed, rel=0.10)
    assert abs(b.tau - a.tau) < 0.05


@needs_cmu
def test_cmu_jump_on_the_spot_is_not_in_place(cmu120):
    a = cmu120["cmu_16_01_jump_in_place"]
    b = analyze_clip(in_place(a.motion))
    for x in (a, b):
        assert not x.in_place and x.kind == "jump" and (x.entry_gait, x.exit_gait) == ("stand", "stand")

