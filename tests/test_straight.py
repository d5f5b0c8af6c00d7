"""Straight is straight (issue 14): the steps' veer and crab, and a straight 10 m walk
as played (``benchmarks/bench_straight.py``)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from conftest import needs_cmu
from footstep_planner.core.steps import StepSet, straight_steps


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


#: s m: the curvature penalty the strip is walked with.
PENALTY = 0.5


@pytest.mark.parametrize("kind", ["mannequin", pytest.param("cmu", marks=needs_cmu)])
def test_a_character_walks_a_straight_strip_straight(fp, kind):
    """With ``curvature_penalty`` 0.5, 10 m straight ahead from standing, the sample
    character and CMU subject 16's library (whose straight walk's steps, read from its
    feet's yaws, would veer 0.056 1/m): the plan's steps are one straight walk, the
    blended curvature stays within 0.05 1/m and the body, as the saved scene plays,
    within 3 cm of the line beyond its own sway."""
    from benchmarks.bench_straight import measure

    from importlib import import_module

    Settings = import_module(fp.__name__ + ".core.settings").Settings
    r = measure(kind, 10.0, Settings(curvature_penalty=PENALTY), fp.__name__)
    assert r["off_label"] == 0, r
    assert r["tau_max"] <= 0.05 and r["drift_max_cm"] < 3.0 and r["goal_cm"] < 5.0, r


def test_a_walk_that_veers_gets_a_straightened_step_when_straightness_is_asked():
    """A library whose straightest walk veers (0.06 1/m, as CMU's captured walk's steps
    do) gets, with ``straighten``, that walk's steps straightened, labelled its group at
    tau 0 and neither veering nor crabbing; without it, nothing (the default plans keep
    their steps); a library whose walk is straight needs none."""
    from footstep_planner.core.analysis import analyze_clip
    from footstep_planner.core.library import propose_library
    from footstep_planner.core.steps import library_steps
    from synth import synthetic_gait

    walk = dict(speed=1.3, stride=1.4, duty=0.62)
    veers = analyze_clip(synthetic_gait(name="walk", cycles=4, curvature=-0.06, **walk)[0])
    lib = propose_library([veers])
    plain, straight = library_steps(lib, [veers]), library_steps(lib, [veers], straighten=True)
    new = sorted(set(straight.label) - set(plain.label))
    assert len(new) == 1 and new[0].endswith("@+0.000"), new
    own = straight.take((straight.label == new[0]) & (straight.stride == 1.0))
    assert sorted(own.foot) == [0, 1]
    np.testing.assert_allclose(straight.veer()[straight.label == new[0]], 0.0, atol=1e-9)
    np.testing.assert_allclose(straight.sidestep()[straight.label == new[0]], 0.0, atol=1e-9)
    assert abs(plain.veer()[plain.label == "walk"]).min() > 0.02  # the clip's own steps veer
    level = analyze_clip(synthetic_gait(name="walk", cycles=4, **walk)[0])
    lib = propose_library([level])
    assert set(library_steps(lib, [level], straighten=True).label) == set(library_steps(lib, [level]).label)
