"""Straight is straight (issue 14): the steps' veer and crab, and a straight 10 m walk
as played (``benchmarks/bench_straight.py``)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from conftest import needs_cmu
from footstep_planner.core.clips.steps import StepSet, straight_steps


def _walk(toe, half, fwd=0.6, extra=None):
    """A straight walk whose feet turn out ``toe`` rad and stand ``half`` m either side of
    the way (as StepSet rows: from the left foot, then from the right; a step goes 2
    ``half`` across), plus ``extra`` rows (foot, fwd, left, turn, label)."""
    rows = []
    for foot, sign in ((0, 1.0), (1, -1.0)):
        a = sign * toe  # the start foot's heading from the way
        way = np.array([fwd, -sign * 2 * half])  # the step in the way's frame: forward, across
        c, s = np.cos(-a), np.sin(-a)
        rows.append((foot, c * way[0] - s * way[1], s * way[0] + c * way[1], -2 * a, "walk"))
    rows += extra or []
    f, x, y, t, lab = zip(*rows)
    n = len(rows)
    return StepSet(np.array(x), np.array(y), np.array(t), np.full(n, 0.55), np.array(f),
                   np.array(["walk"] * n, object), np.zeros(n, bool), np.array(lab, object))


@given(st.floats(-0.2, 0.2), st.floats(0.03, 0.15), st.floats(-0.3, 0.3), st.floats(-0.1, 0.1))
@settings(max_examples=60, deadline=None)
def test_a_straight_walk_neither_veers_nor_crabs_and_others_do(toe, half, turn, side):
    steps = _walk(toe, half, extra=[(0, 0.6, -2 * half + side, -2 * toe + turn, "other")])
    assert steps.toe_out() == pytest.approx(toe, abs=1e-9)
    np.testing.assert_allclose(steps.veer()[:2], 0.0, atol=1e-9)
    np.testing.assert_allclose(steps.sidestep()[:2], 0.0, atol=1e-9)
    assert steps.veer()[2] == pytest.approx(turn, abs=1e-9)
    # the other step, given in its foot's frame: its move across the way, less the walk's
    across = np.sin(toe) * 0.6 + np.cos(toe) * (-2 * half + side)
    assert steps.sidestep()[2] == pytest.approx(across + 2 * half, abs=1e-9)


def _chain(steps, n):
    """Footprints (n + 1, 3): x, y, heading, from the left foot at the origin heading 0,
    taking ``steps`` (from the left foot, from the right) in turn."""
    out = [np.zeros(3)]
    for k in range(n):
        x, y, h = out[-1]
        f, l, t = steps[k % 2][:3]
        out.append(np.array([x + np.cos(h) * f - np.sin(h) * l, y + np.sin(h) * f + np.cos(h) * l, h + t]))
    return np.array(out)


mean_step = st.tuples(st.floats(0.3, 0.9), st.floats(0.0, 0.3), st.floats(-0.4, 0.4), st.floats(0.3, 0.9))


@given(mean_step, mean_step)
@settings(max_examples=100, deadline=None)
def test_a_straightened_clip_walks_a_straight_line_with_its_toe_out_and_durations(a, b):
    """Whatever a clip's two mean steps (a captured walk's differ between the feet and
    need not cancel over a stride), straightened they chain into footprints on two
    parallel lines along the way, each foot turned out from it by the clip's own toe-out,
    every step forward."""
    m = {0: np.array([a[0], -a[1], a[2], a[3]]), 1: np.array([b[0], b[1], b[2], b[3]])}
    s0, s1 = straight_steps(m)
    toe = 0.25 * (m[1][2] - m[0][2])
    assert s0[2] + s1[2] == pytest.approx(0.0, abs=1e-12)  # no veer over a stride
    assert 0.25 * (s1[2] - s0[2]) == pytest.approx(toe, abs=1e-12)
    assert (s0[3], s1[3]) == (m[0][3], m[1][3])
    fp = _chain((s0, s1), 8)
    way = -toe  # the left foot stands turned toe left of the way
    d, across = np.array([np.cos(way), np.sin(way)]), np.array([-np.sin(way), np.cos(way)])
    off = fp[:, :2] @ across
    np.testing.assert_allclose(off[0::2], 0.0, atol=1e-9)  # the left foot's line
    np.testing.assert_allclose(off[1::2], off[1], atol=1e-9)  # the right foot's, parallel
    assert np.all(np.diff(fp[:, :2] @ d) > 0)  # forward, step by step
    np.testing.assert_allclose(fp[0::2, 2], 0.0, atol=1e-9)


@given(st.floats(-0.2, 0.2), st.floats(0.03, 0.15), st.floats(0.3, 0.9))
@settings(max_examples=60, deadline=None)
def test_a_straight_walk_is_its_own_straightening(toe, half, fwd):
    steps = _walk(toe, half, fwd)
    m = {f: np.array([steps.fwd[f], steps.left[f], steps.turn[f], steps.duration[f]]) for f in (0, 1)}
    s0, s1 = straight_steps(m)
    np.testing.assert_allclose(s0, m[0], atol=1e-9)
    np.testing.assert_allclose(s1, m[1], atol=1e-9)
    assert steps.stance_width() == pytest.approx(2 * half, abs=1e-9)


@pytest.mark.parametrize("kind", ["mannequin", pytest.param("cmu", marks=needs_cmu)])
@pytest.mark.parametrize("penalty", [0.0, 0.5])
def test_a_character_walks_a_straight_strip_straight(fp, kind, penalty):
    """With the default settings (the weave penalty; and with ``curvature_penalty`` 0.5
    too), 10 m straight ahead from standing, the sample character and CMU subject 16's
    library (whose straight walk's steps, read from its feet's yaws, would veer 0.056
    1/m, and whose turning clips' steps veer left and right in turn): the plan's steps
    are one straight walk, the blended curvature stays within 0.05 1/m and the body, as
    the saved scene plays, within 3 cm of the line beyond its own sway."""
    from benchmarks.bench_straight import measure

    from importlib import import_module

    Settings = import_module(fp.__name__ + ".core.base.settings").Settings
    r = measure(kind, 10.0, Settings(curvature_penalty=penalty), fp.__name__)
    assert r["off_label"] == 0, r
    assert r["tau_max"] <= 0.05 and r["drift_max_cm"] < 3.0 and r["goal_cm"] < 5.0, r


def test_a_walk_that_veers_gets_a_straightened_step_when_straightness_is_asked():
    """A library whose straightest walk veers (0.06 1/m, as CMU's captured walk's steps
    do) gets, with ``straighten``, that walk's steps straightened, labelled its group at
    tau 0 and neither veering nor crabbing; without it, nothing (the default plans keep
    their steps); a library whose walk is straight needs none."""
    from footstep_planner.core.clips.analysis import analyze_clip
    from footstep_planner.core.clips.library import propose_library
    from footstep_planner.core.clips.steps import library_steps
    from synth import synthetic_gait

    walk = dict(speed=1.3, stride=1.4, duty=0.62)
    veers = analyze_clip(synthetic_gait(name="walk", cycles=4, curvature=-0.06, **walk)[0])
    lib = propose_library([veers])
    plain, straight = library_steps(lib, [veers], straighten=False), library_steps(lib, [veers], straighten=True)
    new = sorted(set(straight.label) - set(plain.label))
    assert len(new) == 1 and new[0].endswith("@+0.000"), new
    own = straight.take((straight.label == new[0]) & (straight.stride == 1.0))
    assert sorted(own.foot) == [0, 1]
    np.testing.assert_allclose(straight.veer()[straight.label == new[0]], 0.0, atol=1e-9)
    np.testing.assert_allclose(straight.sidestep()[straight.label == new[0]], 0.0, atol=1e-9)
    assert abs(plain.veer()[plain.label == "walk"]).min() > 0.02  # the clip's own steps veer
    level = analyze_clip(synthetic_gait(name="walk", cycles=4, **walk)[0])
    lib = propose_library([level])
    straightened = library_steps(lib, [level], straighten=True)
    assert set(straightened.label) == set(library_steps(lib, [level], straighten=False).label)


def _sharp_library(quick=0.0):
    """The sample character's straight walk and sharp turns (steps as its library reads
    them, 0.533 s each): a sharp turn's outer foot reaches 0.72 m, its inner 0.51 m, so
    a left turn's step from the left foot then a right turn's from the right walks 1.43 m
    where the straight walk walks 1.22 m. With ``quick``, the turns' steps from the left
    foot take that much less time and those from the right that much more (a captured
    clip's quicker half)."""
    deg = np.radians
    rows = [(0, 0.611, -0.219, deg(-12), 0.533, "walk"), (1, 0.611, 0.219, deg(12), 0.533, "walk")]
    for sign, lab in ((1, "left"), (-1, "right")):
        long_, short = (0.715, sign * 0.114, sign * deg(36)), (0.507, sign * 0.552, sign * deg(60))
        rows += [(0, *(long_ if sign > 0 else short), 0.533 - quick, lab),
                 (1, *(short if sign > 0 else long_), 0.533 + quick, lab)]
        wide = [(0.663, -0.053, deg(12)), (0.559, 0.386, deg(36))]  # (the blend halfway to the sharp turn)
        wide = wide if sign > 0 else [(0.559, -0.386, deg(-36)), (0.663, 0.053, deg(-12))]
        rows += [(0, *wide[0], 0.533, f"half {lab}"), (1, *wide[1], 0.533, f"half {lab}")]
    f, x, y, t, d, lab = zip(*rows)
    n = len(rows)
    return StepSet(np.array(x), np.array(y), np.array(t), np.array(d), np.array(f),
                   np.array(["walk"] * n, object), np.zeros(n, bool), np.array(lab, object))


@pytest.mark.parametrize("quick", [0.0, 0.15])
def test_a_straight_way_is_not_walked_in_sharp_turns_left_and_right(quick):
    """On an open floor, 10 m straight ahead: with the weave penalty the plan walks the
    straight walk; without it, the cheapest path (plain A*'s) takes sharp turns' long
    outer steps, left and right in turn (cheaper: 8.29 s against 8.53), as the default
    planner did (issue 14). With the turns' halves of unequal time, a step costs its
    cycle's mean time, so the quick halves are no shortcut either."""
    from dataclasses import replace

    from conftest import plane, standing
    from footstep_planner.core.plan.navgraph import Planner
    from footstep_planner.core.base.settings import Settings
    from footstep_planner.core.plan.surface import MeshGround

    fwd = np.array([1.0, 0.0])
    ground = MeshGround(plane(-2.0, 13.0, -3.0, 3.0))
    goal = np.array([10.0, 0.0, 0.0])
    toed_out = [replace(f, heading=np.radians(6.0) * (1 - 2 * f.foot)) for f in standing(0.0, 0.0, 0.0, fwd)]
    labels = {}
    for weave in (2.0, 0.0):
        # (without the penalty, plain A*: the weighted search ends within 2 % of the
        # cheapest arrival it has, navgraph.ARRIVE_SLACK, and may keep the straight walk)
        own = Settings(weave_penalty=weave, stride_min=1.0, stride_max=1.0,
                       heuristic_weight=Settings().heuristic_weight if weave else 1.0)
        pl = Planner(ground, None, _sharp_library(quick), fwd, settings=own)
        res = pl.plan(toed_out, goal)
        labels[weave] = [f.label for f in res.footprints[1:]]
    assert labels[2.0].count("walk") >= len(labels[2.0]) - 1, labels[2.0]
    assert labels[0.0].count("left") + labels[0.0].count("right") >= 2, labels[0.0]


@given(st.lists(st.tuples(st.sampled_from(["a", "b", "c"]), st.floats(0.2, 1.0), st.floats(0.2, 1.0)),
                min_size=1, max_size=6))
@settings(max_examples=60, deadline=None)
def test_a_cycle_mean_is_one_per_clip_and_keeps_the_cycle_time(clips):
    """``StepSet.cycle_mean``: every step of a clip gets the clip's mean, and a cycle (a
    step from each foot) keeps its clip's total."""
    rows = {lab: (d0, d1) for lab, d0, d1 in clips}
    lab = np.array([k for k in rows for _ in (0, 1)], object)
    dur = np.array([d for k in rows for d in rows[k]])
    n = len(lab)
    s = StepSet(np.ones(n), np.zeros(n), np.zeros(n), dur, np.tile([0, 1], n // 2), np.array(["walk"] * n, object),
                np.zeros(n, bool), lab)
    m = s.cycle_mean(s.duration)
    for k, (d0, d1) in rows.items():
        np.testing.assert_allclose(m[lab == k], 0.5 * (d0 + d1))
        assert m[lab == k].sum() == pytest.approx(d0 + d1)
