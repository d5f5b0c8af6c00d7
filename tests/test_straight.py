"""Straight is straight (issue 14): the steps' veer and crab, and a straight 10 m walk
as played (``benchmarks/bench_straight.py``)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from footstep_planner.core.steps import StepSet


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


@pytest.mark.parametrize("penalty", [0.3])
def test_the_sample_character_walks_a_straight_strip_straight(fp, penalty):
    """With ``curvature_penalty`` 0.3, 10 m straight ahead from standing: the plan's steps
    are the straight walk's, the blended curvature stays within 0.05 1/m and the body, as
    the saved scene plays, within 3 cm of the line beyond its own sway."""
    from benchmarks.bench_straight import measure

    from importlib import import_module

    Settings = import_module(fp.__name__ + ".core.settings").Settings
    r = measure("mannequin", 10.0, Settings(curvature_penalty=penalty), fp.__name__)
    assert r["off_label"] == 0, r
    assert r["tau_max"] <= 0.05 and r["drift_max_cm"] < 3.0 and r["goal_cm"] < 5.0, r
