"""Stair treads (issue 28): found in the traversable mesh, a flight's and nothing else's,
the same wherever the stairs stand; a footprint put on one is square to it and wholly on
it, moved no more than that needs; a footprint off every tread is left as it is."""

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from benchmarks.scene_generator import Scene, plates_mesh, stairs_turn
from footstep_planner.core.base.angles import wrap
from footstep_planner.core.plan.surface import TIP_ROOM, FootShape, MeshGround, TriMesh
from footstep_planner.core.plan.treads import EDGE_MARGIN, MAX_SQUARE_TURN, find_treads

FOOT = FootShape(back=0.1, front=0.16, half_width=0.05)
STEP = 0.3  # m: the planner's step height


def _ground(plates, yaw: float = 0.0, shift=(0.0, 0.0)) -> MeshGround:
    v, t = plates_mesh(plates)
    c, s = np.cos(yaw), np.sin(yaw)
    v = v @ np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]]) + [shift[0], shift[1], 0.0]
    return MeshGround(TriMesh(v, t.astype(np.int64), np.zeros(len(t), np.int64), ("ground",)))


def _stairs(n: int = 5) -> Scene:
    return stairs_turn(np.random.default_rng(3), "stairs", n)


def test_a_flights_treads_are_found_and_nothing_else():
    sc = _stairs(5)
    g = _ground(sc.plates)
    tr = find_treads(g.mesh, g, STEP)
    assert len(tr) == 8  # (four treads a flight: the fifth riser's top is the landing)
    np.testing.assert_allclose(tr.depth, 0.28, atol=1e-9)
    ups = {tuple(np.round(u, 6)) for u in tr.up}
    assert ups == {(1.0, 0.0), (0.0, 1.0)}  # up along x, then up along y after the turn
    np.testing.assert_allclose(np.sort(tr.z), np.sort([k * 0.17 for k in (1, 2, 3, 4, 6, 7, 8, 9)]), atol=1e-9)


@pytest.mark.parametrize("plates", [
    [(-2, 2, -2, 2, 0, 0, 0), (-1, 1, -0.12, 0.12, 0.1, 0.1, 0)],  # a beam: lower ground on both sides
    [(-2, 0, -2, 2, 0, 0, 0), (0, 3, -2, 2, 0.15, 0.15, 0)],  # a kerb: a wide top
    [(-2, 0, -1, 1, 0, 0, 0), (0, 0.3, -1, 1, 0.6, 0.6, 0), (0.3, 2, -1, 1, 1.2, 1.2, 0)],  # risers too high
    [(-2, 0, -1, 1, 0, 0, 0), (0, 0.3, -1, 1, 0.0, 0.3, 0), (0.3, 2, -1, 1, 0.3, 0.3, 0)],  # a ramp
])
def test_beams_kerbs_ramps_and_walls_of_steps_are_no_treads(plates):
    g = _ground(plates)
    assert len(find_treads(g.mesh, g, STEP)) == 0


@settings(max_examples=25, deadline=None)
@given(yaw=st.floats(-np.pi, np.pi), dx=st.floats(-50, 50), dy=st.floats(-50, 50))
def test_the_treads_are_the_same_wherever_the_stairs_stand(yaw, dx, dy):
    sc = _stairs(4)
    a = find_treads(_ground(sc.plates).mesh, _ground(sc.plates), STEP)
    g = _ground(sc.plates, yaw, (dx, dy))
    b = find_treads(g.mesh, g, STEP)
    assert len(a) == len(b) == 6
    c, s = np.cos(yaw), np.sin(yaw)
    rot = np.array([[c, -s], [s, c]])
    order_a, order_b = np.argsort(a.z), np.argsort(b.z)
    np.testing.assert_allclose(a.center[order_a] @ rot.T + [dx, dy], b.center[order_b], atol=1e-6)
    np.testing.assert_allclose(a.up[order_a] @ rot.T, b.up[order_b], atol=1e-6)
    np.testing.assert_allclose(a.depth[order_a], b.depth[order_b], atol=1e-6)


def _corners(xy, angle, foot=FOOT):
    """(N, 4, 2) the foot rectangle's corners of footprints at ``xy`` turned ``angle``."""
    return foot.corners(xy, angle, np.array([1.0, 0.0]))[:, :4]


@settings(max_examples=60, deadline=None)
@given(k=st.integers(0, 3), along=st.floats(-0.135, 0.135), across=st.floats(-0.95, 0.95),
       turn=st.floats(-0.55, 0.55), down=st.booleans(), left=st.booleans())
def test_a_footprint_on_a_tread_ends_square_and_whole_on_it(k, along, across, turn, down, left):
    sc = _stairs(5)
    g = _ground(sc.plates)
    tr = find_treads(g.mesh, g, STEP)
    i = [j for j in np.argsort(tr.z) if tr.up[j][0] > 0.5][k]  # the k-th tread of the flight up x
    toe = np.radians(6.0) * (1 if left else -1)
    face = 0.0 if not down else np.pi
    xy = (tr.center[i] + [along, across * 0.5 * tr.width[i]])[None]
    angle = np.array([face + toe + turn])
    out, a, moved = tr.square(xy, angle, np.array([tr.z[i] - (0.17 if not down else -0.17)]), np.array([toe]),
                              FOOT, STEP)
    if abs(turn) > MAX_SQUARE_TURN:  # (a step across the flight, not up it)
        assert moved[0] == -1 and np.array_equal(out, xy) and np.array_equal(a, angle)
        return
    assert moved[0] == 1
    assert abs(wrap(a[0] - toe - face)) < 1e-9  # square, its own toe-out kept
    # the foot's rectangle on the tread, EDGE_MARGIN inside its back and sides ...
    rel = _corners(out, a) - tr.center[i]
    x, y = rel[0, :, 0], rel[0, :, 1]
    assert np.all(np.abs(y) <= 0.5 * tr.width[i] - EDGE_MARGIN + 1e-9)
    short = FOOT.back + FOOT.front + TIP_ROOM + EDGE_MARGIN > 0.28
    if down:  # (from the riser behind, the rectangle on the tread; the tip may hang over the nosing)
        assert np.all(x >= -0.14 - 1e-9) and np.all(x <= 0.14 + 1e-9)
    else:  # its toe tip TIP_ROOM from the riser ahead; on a tread shorter than the foot the
        # heel hangs over the nosing behind, the front half on the tread
        tip = FOOT.probes(out, a, np.array([1.0, 0.0]))[0, 7, 0] - tr.center[i][0]  # (TIP_ROOM ahead of it)
        assert tip <= 0.14 + 1e-9
        assert np.all(x[2:] >= -0.14) and (out[0, 0] - tr.center[i][0]) >= -0.14
        assert short or np.all(x >= -0.14 - 1e-9)
    # moved no further along than the tread needs: a square foot already on it stays
    again, a2, _ = tr.square(out, a, np.array([tr.z[i]]), np.array([toe]), FOOT, STEP)
    np.testing.assert_allclose(again, out, atol=1e-12)
    np.testing.assert_allclose(a2, a, atol=1e-12)


def test_a_footprint_off_every_tread_is_left_as_it_is():
    sc = _stairs(5)
    g = _ground(sc.plates)
    tr = find_treads(g.mesh, g, STEP)
    xy = np.array([[-2.0, 0.1], [0.5, 3.0], [2.0, 0.0]])  # the floor, nowhere, and a tread far above reach
    out, a, moved = tr.square(xy, np.array([0.3, -0.2, 0.1]), np.array([0.0, 0.0, 0.0]), np.zeros(3), FOOT,
                              STEP)
    assert not moved.any() and np.array_equal(out, xy) and np.array_equal(a, [0.3, -0.2, 0.1])


def test_the_foot_follows_the_other_one_straight_up_the_flight():
    """With the other foot on a tread of the flight, the foot is set the stance width to
    its side: a flight is climbed in a straight line, whatever sideways step brought it."""
    sc = _stairs(5)
    g = _ground(sc.plates)
    tr = find_treads(g.mesh, g, STEP)
    flight = [j for j in np.argsort(tr.z) if tr.up[j][0] > 0.5]
    right = np.array([tr.center[flight[0]][0], -0.13])
    for sideways in (-0.2, 0.0, 0.15):
        xy = np.array([[tr.center[flight[1]][0], -0.13 + 0.16 + sideways]])
        out, a, moved = tr.square(xy, np.array([0.1]), np.array([tr.z[flight[0]]]), np.array([0.1]), FOOT, STEP,
                                  beside=(right, 0.16, 1.0))
        assert moved[0] == 1 and out[0, 1] == pytest.approx(-0.13 + 0.16)
