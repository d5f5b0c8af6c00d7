"""Adapted strides (issue 14): steps shortened (or lengthened) from the same clip, and
footprints kept on the tread they were planned on. Pure core, no bpy."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from footstep_planner.core.synth.refinement import refine
from footstep_planner.core.clips.steps import STRIDE_RATIO, StepSet, stride_factors, stride_steps


@given(st.floats(0.1, 1.0), st.floats(1.0, 2.0))
@settings(max_examples=60, deadline=None)
def test_stride_factors_reach_both_ends_in_small_ratios(lo, hi):
    k = stride_factors(lo, hi)
    assert np.all(np.diff(k) > 0) and not np.any(np.abs(np.log(k)) < 0.01)
    if lo < 0.99:
        assert np.isclose(k.min(), lo)
    if hi > 1.011:
        assert np.isclose(k.max(), hi)
    ladder = np.r_[k[k < 1], 1.0, k[k > 1]]
    assert np.all(np.diff(np.log(ladder)) <= np.log(STRIDE_RATIO) + 1e-9)


def _steps(n=4):
    rng = np.random.default_rng(1)
    return StepSet(rng.uniform(0.5, 0.8, n), rng.uniform(-0.3, 0.3, n), rng.uniform(-0.3, 0.3, n),
                   rng.uniform(0.4, 0.6, n), np.arange(n) % 2, np.array(["walk"] * n, object),
                   np.zeros(n, bool), np.array([f"c{i}" for i in range(n)], object))


def test_adapted_strides_scale_the_forward_length_only_and_cost_more_than_their_time():
    base = _steps()
    out = stride_steps(base, 0.4, 1.3)
    k = stride_factors(0.4, 1.3)
    assert out.n == base.n * len(k)
    np.testing.assert_allclose(out.fwd, np.tile(base.fwd, len(k)) * np.repeat(k, base.n))
    for f in ("left", "turn", "duration", "foot", "label"):
        assert (getattr(out, f) == np.tile(getattr(base, f), len(k))).all()
    np.testing.assert_array_equal(base.time_cost(2.0), base.duration)  # the clip's own: its time
    cost = out.time_cost(2.0)
    assert (cost > out.duration).all()
    # with a penalty over ~1.2, a longer stride covers a metre dearer than the clip's own
    per_m = cost / out.fwd
    own = np.tile(base.duration / base.fwd, len(k))
    assert (per_m[out.stride > 1] > own[out.stride > 1]).all()


@given(st.floats(-0.2, 0.2), st.integers(3, 8))
@settings(max_examples=40, deadline=None)
def test_refinement_never_moves_a_footprint_across_a_step_edge(shift, n):
    """Treads 0.28 m deep along x: whatever the clips' footprints pull towards, each
    refined footprint stays on the tread it was desired on."""
    tread = 0.28
    desired = np.c_[np.arange(n) * tread + 0.14, np.where(np.arange(n) % 2, -0.1, 0.1), np.zeros(n)]
    desired[:, 2] = np.floor(desired[:, 0] / tread) * 0.17
    orig = desired.copy()
    orig[:, 0] = np.arange(n) * 0.7 + shift  # the clip's own stride: 0.7 m
    head = np.zeros(n)

    def snap(p, h):
        p = np.array(p, float)
        p[:, 2] = np.floor(p[:, 0] / tread) * 0.17
        return p, np.ones(len(p), bool)

    def crosses_edge(a, b):
        return np.floor(np.asarray(a)[:, 0] / tread) != np.floor(np.asarray(b)[:, 0] / tread)

    snap.crosses_edge = crosses_edge
    out = refine(orig, head, desired, head, 10, snap)
    np.testing.assert_array_equal(np.floor(out.position[:, 0] / tread), np.floor(desired[:, 0] / tread))


def test_the_distance_maps_stair_treads_are_a_flight_not_a_kerb():
    """``_Grid.flight_cells``: cells with a riser on two sides (a flight's treads) are a
    flight; a single kerb's top and foot, and level floor, are not."""
    from footstep_planner.core.plan.distance_field import _Grid

    nx, ny = 14, 3
    z = np.zeros((1, nx, ny))
    z[0, 2:] = 0.15  # a 15 cm kerb between cells 1 and 2
    z[0, 8:12] = 0.15 + 0.17 * np.arange(1, 5)[:, None]  # four treads of a flight up
    z[0, 12:] = 0.15 + 0.17 * 5
    grid = _Grid(np.zeros(2), 0.25, nx, ny, np.arange(nx * ny).reshape(1, nx, ny), z, np.zeros((nx * ny, 2)))
    flight = grid.flight_cells(np.ones((1, nx, ny), bool), 0.3)[0]
    assert flight[8:12].all()  # treads: a riser behind and ahead
    assert not flight[:8].any() and not flight[13:].any()  # floor, the kerb's foot and top, the top


@settings(deadline=None, database=None, max_examples=40)
@given(st.lists(st.sampled_from([0.0, 0.17, -0.17, 0.05]), min_size=2, max_size=12),
       st.floats(0.0, 5.0), st.one_of(st.none(), st.floats(0.5, 2.0)))
def test_a_step_up_or_down_is_played_slower_by_its_height(dz, climb_time, pace):
    """``labels._climb_pace``: each step's pace over 1 + climb_time times the height
    its swinging foot climbs or descends (from the footprint before the step's own);
    on level ground the pace is left as it was (None stays None)."""
    from types import SimpleNamespace

    from footstep_planner.core.synth.labels import _climb_pace

    z = np.cumsum([0.0] + dz)
    path = [SimpleNamespace(position=np.array([0.3 * i, 0.0, h])) for i, h in enumerate(z)]
    rate = None if pace is None else np.full(len(path) - 1, pace)
    out = _climb_pace(rate, path, climb_time)
    rise = np.abs(z[1:] - np.r_[z[0], z[:-2]])
    if climb_time * rise.max() < 1e-9:
        assert out is rate
        return
    expect = (1.0 if pace is None else pace) / (1.0 + climb_time * rise)
    np.testing.assert_allclose(out, expect)
    assert (out <= (1.0 if pace is None else pace) + 1e-12).all()
