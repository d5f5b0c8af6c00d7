"""A jog (issue 30, ``core.perform.stride``): the library's stride against speed between its
walk and its run, a stretch of walking footprints laid again at a blend's stride, and the
performance's marks following the footprints laid again."""

import numpy as np
import pytest
from hypothesis import example, given, settings as hsettings, strategies as st

from footstep_planner.core.clips.steps import StepSet
from footstep_planner.core.footprint import PathFootprint
from footstep_planner.core.perform import stride
from footstep_planner.core.perform.directed import Mark, _Plan

FORWARD = np.array([1.0, 0.0, 0.0])
WALK, RUN = (0.62, 0.55), (1.15, 0.37)  # (step length m, duration s)


def _steps(walk=WALK, run=RUN) -> StepSet:
    """A library's steps: a straight walk and run from each foot, a turning walk, a jump."""
    rows = []
    for gait, (length, duration), label in (("walk", walk, "walk"), ("run", run, "run")):
        for foot in (0, 1):
            rows.append((length, 0.2 if foot else -0.2, 0.0, duration, foot, gait, False, label))
    rows.append((0.5, -0.2, 0.4, 0.6, 0, "walk", False, "walk_left"))
    rows.append((2.0, -0.2, 0.0, 0.8, 0, "run", True, "jump"))
    cols = list(zip(*rows))
    return StepSet(*(np.array(c, dtype=object if k in (5, 7) else None) for k, c in enumerate(cols)))


def _walk(n: int, length: float = 0.6, half: float = 0.1, bend: float = 0.0, z=None) -> list[PathFootprint]:
    """n footprints along a way that turns ``bend`` rad a step, feet alternating left first."""
    out, p, h = [], np.zeros(2), 0.0
    for k in range(n):
        side = 1.0 if k % 2 == 0 else -1.0
        left = np.array([-np.sin(h), np.cos(h)])
        xy = p + side * half * left
        out.append(PathFootprint(k % 2, np.array([xy[0], xy[1], 0.0 if z is None else z[k]]), h, 0.55 * k,
                                 "start" if k == 0 else "walk", "walk"))
        h += bend
        p = p + length * np.array([np.cos(h), np.sin(h)])
    return out


def _everywhere(pos, heading):
    return np.ones(len(pos), bool), np.asarray(pos, float)[:, 2]


def test_the_librarys_walk_and_run_give_the_strides():
    s = stride.Strides.of(_steps())
    assert s.walk == pytest.approx(WALK) and s.run == pytest.approx(RUN)
    assert s.speed(0.0) == pytest.approx(WALK[0] / WALK[1]) and s.speed(1.0) == pytest.approx(RUN[0] / RUN[1])
    walk_only = _steps()
    keep = walk_only.gait == "walk"
    assert stride.Strides.of(StepSet(*(getattr(walk_only, f)[keep] for f in
                                       ("fwd", "left", "turn", "duration", "foot", "gait", "jump", "label")))) is None
    assert stride.Strides.of(_steps(run=(0.62, 0.55))) is None  # (a run no quicker than the walk: nothing to blend)


@hsettings(max_examples=60, deadline=None)
@given(st.floats(0.0, 1.0), st.floats(0.3, 1.0), st.floats(0.4, 0.8), st.floats(0.8, 1.6), st.floats(0.25, 0.45))
def test_the_blend_for_a_speed_goes_at_that_speed(s, lw, dw, lr, dr):
    strides = stride.Strides((lw, dw), (lr, dr))
    if strides.speed(1.0) <= strides.speed(0.0) * 1.05:
        return
    v = strides.speed(s)
    assert strides.blend_for(v) == pytest.approx(s, abs=1e-6)
    assert strides.blend_for(0.5 * strides.speed(0.0)) == 0.0 and strides.blend_for(2 * strides.speed(1.0)) == 1.0
    # (faster, longer: the stride grows with the speed)
    assert strides.at(s)[0] == pytest.approx((1 - s) * lw + s * lr)


@hsettings(max_examples=60, deadline=None)
@given(st.integers(8, 30), st.floats(0.2, 1.0), st.floats(-0.12, 0.12), st.booleans(), st.booleans())
@example(n=9, s=1.0, bend=0.0, ease_in=True, ease_out=True)  # (4 steps and 6 fit it alike badly: the nearer one is kept)
@example(n=9, s=0.84375, bend=0.0, ease_in=False, ease_out=True)
def test_a_stretch_laid_again_keeps_its_ends_and_steps_at_the_stride(n, s, bend, ease_in, ease_out):
    fps = _walk(n, bend=bend)
    strides = stride.Strides(WALK, RUN)
    laid = stride.relay(fps, strides, s, FORWARD, _everywhere, ease_in, ease_out)
    assert laid is not None
    assert laid[0] is fps[0] and np.allclose(laid[-1].position, fps[-1].position) and laid[-1].foot == fps[-1].foot
    assert [f.foot for f in laid] == [(fps[0].foot + k) % 2 for k in range(len(laid))]  # (alternating)
    step = np.linalg.norm(np.diff(stride.way_of(laid, FORWARD)[0], axis=0), axis=1)
    blend = np.array([f.speed for f in laid[1:]])
    own = np.array([strides.at(b)[0] for b in blend])
    # every step as long as its blend's own stride, all scaled alike to fit the way (within a step of it)
    assert np.allclose(step / own, (step / own).mean(), rtol=0.02)  # (the way read again off a bend: 2 %)
    # (the steps' own strides add up to the way within one stride: a count in twos lands within one step of it)
    assert abs(own.sum() - step.sum()) <= 1.1 * own.max() + 1e-6
    # the blend changes by at most a third of s a step, from the walk's leaving standing and to it stopping
    assert np.all(np.abs(np.diff(blend)) <= s / 3 + 1e-9) and blend.max() <= s + 1e-9
    if ease_in:
        assert blend[0] <= s / 3 + 1e-9
    if ease_out:
        assert blend[-1] <= s / 3 + 1e-9
    if not ease_in and not ease_out:
        assert np.allclose(blend, s)
    assert all(f.gait == "walk" and f.label != "start" for f in laid[1:])


@hsettings(max_examples=40, deadline=None)
@given(st.integers(12, 30), st.floats(0.3, 1.0), st.integers(3, 8), st.floats(0.0, 1.0))
def test_a_jog_slows_for_a_corner_and_picks_up_after_it(n, s, at, cap):
    fps = _walk(n)
    caps = np.ones(n)
    caps[at] = cap  # (the step to footprint ``at`` turns too tightly for more than ``cap`` of the run)
    laid = stride.relay(fps, stride.Strides(WALK, RUN), s, FORWARD, _everywhere, caps=caps)
    blend = np.array([f.speed for f in laid[1:]])
    way = stride.way_of(laid, FORWARD)[0]
    land = np.cumsum(np.linalg.norm(np.diff(way, axis=0), axis=1))
    corner = 0.6 * at  # (where the planned footprint stands along the way)
    through = np.flatnonzero((np.r_[0.0, land[:-1]] <= corner + 1e-9) & (land >= corner - 1e-9))
    assert blend[through].max() <= min(cap, s) + 1e-9
    assert np.all(np.abs(np.diff(blend)) <= s / 3 + 1e-9)
    assert blend[-1] == pytest.approx(s) or len(blend) - through.max() <= 3


def test_a_footprint_that_would_not_stand_is_slid_until_it_does_or_the_stretch_is_kept():
    fps = _walk(12)  # (at x = 0, 0.6, ... 6.6)
    hole = lambda p: (np.abs(p[:, 0] - 2.8) < 0.15)  # noqa: E731  (a gutter across the way, between two footprints)
    strides = stride.Strides(WALK, RUN)
    laid = stride.relay(fps, strides, 0.5, FORWARD, lambda p, h: (~hole(p), p[:, 2]))
    assert laid is not None and not hole(np.array([f.position for f in laid])).any()
    planned = np.array([f.position for f in fps])
    only = lambda p: np.linalg.norm(p[:, None, :2] - planned[None, :, :2], axis=2).min(axis=1) < 0.05  # noqa: E731
    assert stride.relay(fps, strides, 0.5, FORWARD, lambda p, h: (only(p), p[:, 2])) is None  # (stones: kept as planned)


def test_only_level_walking_stretches_are_laid_again():
    assert stride.layable(_walk(8))
    assert not stride.layable(_walk(3))  # (too short)
    climbs = _walk(8, z=[0.17 * k for k in range(8)])
    assert not stride.layable(climbs)
    fps = _walk(8)
    ran = fps[:4] + [PathFootprint(f.foot, f.position, f.heading, f.time, "run", "run") for f in fps[4:]]
    assert not stride.layable(ran)
    jumped = fps[:4] + [PathFootprint(fps[4].foot, fps[4].position, 0.0, 0.0, "jump", "walk", jump=True)] + fps[5:]
    assert not stride.layable(jumped)
    assert not stride.layable(fps, specials={"walk"})


def test_the_marks_follow_the_footprints_a_jog_lays_again():
    fps = _walk(40)
    marks = [Mark("A", 14, fps[14].position), Mark("B", 26, fps[26].position),
             Mark("goal", 39, fps[39].position, stop=True)]
    jog = stride.Jog(stride.Strides(WALK, RUN), FORWARD, _everywhere)
    plan = _Plan(list(fps), marks, fps[-1].position, None, None, jog)
    assert [m.index for m in marks] == [14, 26, 39]
    v = jog.strides.speed(0.6)
    plan.set_jog(plan.way(marks[0], marks[1]), v)  # (the stretch from A to B only)
    a, b = marks[0].index, marks[1].index
    assert a == 14 and b - a < 12 and (b - a) % 2 == 0  # (fewer, longer steps, onto the same foot)
    assert np.allclose(plan.path[b].position, fps[26].position)  # (B's footprint stays)
    assert plan.path[:a + 1] == fps[:15] and plan.path[b + 1:] == fps[27:]
    assert marks[2].index == len(plan.path) - 1 and len(plan.pace) == len(plan.path) - 1
    assert plan.legs == [(0, len(plan.path) - 1)]
    assert all(f.speed is not None for f in plan.path[a + 1:b + 1]) and all(f.speed is None for f in plan.path[b + 1:])
    # the jog's steps go at the speed asked for: their pace turns the blend's step into that speed
    length, duration = jog.strides.at(jog.strides.blend_for(v))
    way = stride.way_of(plan.path[a:b + 1], FORWARD)[0]
    laid = np.linalg.norm(np.diff(way, axis=0), axis=1).mean()
    assert laid / (duration / plan.pace[a]) == pytest.approx(v, rel=1e-6)
    plan.set_jog(plan.way(marks[0], marks[1]), None)  # (walked again: as planned)
    assert plan.path == fps and [m.index for m in marks] == [14, 26, 39]


@hsettings(max_examples=60, deadline=None)
@given(st.floats(-3.0, 3.0), st.floats(0.1, 0.8), st.floats(1.0, 2.0))
def test_a_corner_caps_the_blend_as_the_run_turns(tau, run_reach, walk_reach):
    cap = stride.blend_cap(lambda label: None if label == "start" else tau, (-walk_reach, walk_reach),
                           (-run_reach, run_reach))
    fps = [PathFootprint(0, np.zeros(3), 0.0, 0.0, "start", "walk"), PathFootprint(1, np.zeros(3), 0.0, 0.0, "t", "walk")]
    c = cap(fps)
    assert c[0] == 1.0 and 0.0 <= c[1] <= 1.0
    if abs(tau) <= run_reach:
        assert c[1] == 1.0  # (the run turns that tightly itself)
    elif abs(tau) >= walk_reach:
        assert c[1] == 0.0  # (only the walk does)
    else:  # (the share of the run whose blend still turns that tightly)
        s = c[1]
        assert (1 - s) * walk_reach + s * run_reach == pytest.approx(abs(tau), abs=1e-9)
