"""Ground queries and footprint support on simple meshes (pure core)."""

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from conftest import box, plane
from footstep_planner.core.plan.surface import FootShape, MeshGround, TriMesh, footprint_support

FWD = np.array([0.0, -1.0])


def test_ray_down_finds_the_highest_surface_below():
    g = MeshGround(TriMesh.concat([plane(-5, 5, -5, 5, 0.0, name="floor"),
                                   plane(0, 2, 0, 2, 0.5, name="step")]))
    hit = g.ray_down(np.array([[1, 1, 2.0], [-1, -1, 2.0], [1, 1, 0.3], [9, 9, 1.0]]), 5.0)
    assert hit.hit.tolist() == [True, True, True, False]
    assert hit.z[:3] == pytest.approx([0.5, 0.0, 0.0])
    assert [g.mesh.names[o] for o in hit.owner[:3]] == ["step", "floor", "floor"]
    assert hit.normal[0] == pytest.approx([0, 0, 1])
    assert not g.ray_down(np.array([[1, 1, 2.0]]), 1.0).hit[0]  # 1.5 m down: too far


def test_ray_down_on_a_slope_gives_its_height_and_normal():
    g = MeshGround(plane(-5, 5, -5, 5, 0.0, tilt_x=np.tan(np.radians(15))))
    hit = g.ray_down(np.array([[2.0, 0.0, 5.0]]), 10)
    assert hit.z[0] == pytest.approx(2 * np.tan(np.radians(15)))
    assert np.degrees(np.arccos(hit.normal[0, 2])) == pytest.approx(15)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.floats(-2, 2), min_size=12, max_size=12))
def test_nearest_point_is_on_the_triangle_and_closest(vals):
    v = np.array(vals[:9]).reshape(3, 3)
    p = np.array(vals[9:12])
    if np.linalg.norm(np.cross(v[1] - v[0], v[2] - v[0])) < 1e-3:
        return
    g = MeshGround(TriMesh(v, np.array([[0, 1, 2]]), np.zeros(1, np.int64), ("t",)))
    q, d = g.nearest(p[None])
    # q lies on the triangle: barycentric weights in [0, 1]
    m = np.c_[v[1] - v[0], v[2] - v[0]]
    w, *_ = np.linalg.lstsq(m, q[0] - v[0], rcond=None)
    assert w.min() > -1e-6 and w.sum() < 1 + 1e-6
    assert np.linalg.norm(m @ w + v[0] - q[0]) < 1e-6
    # and no sampled point of the triangle is closer
    r = np.random.default_rng(0).dirichlet([1, 1, 1], 400) @ v
    assert d[0] <= np.linalg.norm(r - p, axis=1).min() + 1e-9


FOOT = FootShape(back=0.1, front=0.16, half_width=0.05)


def support(ground, obstacles, xy, heading=0.0, z=0.0):
    pos = np.array([[xy[0], xy[1], z]])
    return footprint_support(ground, obstacles, pos, np.array([heading]), FWD, FOOT)


def test_a_foot_must_stand_wholly_on_the_platform():
    g = MeshGround(plane(0, 2, 0, 2))
    assert support(g, None, (1, 1)).ok[0]
    # the foot points along -Y: its toe 0.16 m ahead overhangs the edge at y = 0
    s = support(g, None, (1, 0.1))
    assert not s.ok[0] and s.reason[0] == "off surface"
    assert support(g, None, (1, 0.1), heading=np.pi).ok[0]  # turned round, it fits


def test_slopes_steps_and_obstacles():
    steep = MeshGround(plane(-5, 5, -5, 5, tilt_x=np.tan(np.radians(40))))
    assert support(steep, None, (0, 0)).reason[0] == "steep"
    gentle = MeshGround(plane(-5, 5, -5, 5, tilt_x=np.tan(np.radians(15))))
    s = support(gentle, None, (1, 0), heading=np.pi / 2, z=0.27)
    assert s.ok[0] and s.z[0] == pytest.approx(np.tan(np.radians(15)), abs=1e-9)
    floor = MeshGround(TriMesh.concat([plane(-5, 5, -5, 5), plane(0, 5, -5, 5, 0.15, name="step")]))
    assert support(floor, None, (-0.01, 0), heading=np.pi / 2).reason[0] == "uneven"  # on the edge
    assert support(floor, None, (1, 0)).z[0] == pytest.approx(0.15)
    wall = MeshGround(box((1, -5, 0), (1.4, 5, 2.5), "wall"))
    assert not support(floor, wall, (0.9, 0)).ok[0]  # body too close to the wall
    assert support(floor, wall, (0.9, 0)).reason[0] == "obstacle"
    assert support(floor, wall, (-0.5, 0)).ok[0]
    thick = MeshGround(box((-3, -3, 0), (3, 3, 3), "block"))
    assert support(floor, thick, (-0.5, 0)).reason[0] == "obstacle"  # inside a thick block
    high = MeshGround(box((-3, -3, 2.2), (3, 3, 2.5), "ceiling"))
    assert support(floor, high, (-0.5, 0)).ok[0]  # an overhead beam above head height


def test_batched_queries_match_one_by_one():
    rng = np.random.default_rng(3)
    g = MeshGround(TriMesh.concat([plane(-5, 5, -5, 5), plane(0, 2, 0, 2, 0.2, name="step")]))
    obst = MeshGround(box((2.5, -1, 0), (3, 1, 2), "pillar"))
    pos = np.c_[rng.uniform(-4, 4, (50, 2)), np.zeros(50)]
    head = rng.uniform(-np.pi, np.pi, 50)
    batch = footprint_support(g, obst, pos, head, FWD, FOOT)
    for i in range(50):
        one = footprint_support(g, obst, pos[i:i + 1], head[i:i + 1], FWD, FOOT)
        assert one.ok[0] == batch.ok[i] and one.reason[0] == batch.reason[i]


@settings(max_examples=30, deadline=None)
@given(st.floats(-5, 5), st.floats(-5, 5), st.floats(-1, 1), st.floats(0.05, 2.0), st.floats(0.05, 2.0))
def test_a_closed_solid_loses_its_underside_an_open_plane_keeps_both_faces(x, y, z, size, height):
    """A box's downward faces are dropped (a look down from inside it finds no ground,
    not its bottom); a plane keeps its triangles whichever way they face."""
    b = box((x, y, z), (x + size, y + size, z + height))
    walk = b.without_undersides()
    c = walk.corners()
    n = np.cross(c[:, 1] - c[:, 0], c[:, 2] - c[:, 0])
    assert walk.n == b.n - 2 and ((n[:, 2] > -1e-9).all() or (n[:, 2] < 1e-9).all())  # (conftest's box faces in)
    out = TriMesh(b.verts, b.tris[:, ::-1], b.owner, b.names)  # the same box, normals out
    assert np.array_equal(np.sort(out.without_undersides().tris, axis=None), np.sort(walk.tris[:, ::-1], axis=None))
    inside = np.array([[x + size / 2, y + size / 2, z + height / 2]])
    assert not MeshGround(walk).ray_down(inside, 10.0).hit[0]
    assert MeshGround(b).ray_down(inside, 10.0).z[0] == pytest.approx(z)  # (what it did before)
    above = inside + [0.0, 0.0, height]
    assert MeshGround(walk).ray_down(above, 10.0).z[0] == pytest.approx(z + height)
    flipped = plane(x, x + size, y, y + size, z)
    flipped = TriMesh(flipped.verts, flipped.tris[:, ::-1], flipped.owner, flipped.names)
    assert flipped.without_undersides().n == flipped.n


def test_a_heel_may_hang_over_a_nosing_and_a_long_toe_keeps_out_of_a_riser():
    """Floor at 0, a step 0.17 high where y < 0 (the foot points -Y at heading 0). On
    the step facing away from its edge, the heel may hang over the floor below while
    the front half of the foot stands on the step, never the middle; facing the edge,
    the front half must stand on it. On the floor facing the step, a long toe's tip
    (``FootShape.tip``) and TIP_ROOM ahead of it must be clear of the riser; facing
    down off the step it may hang over the floor."""
    from footstep_planner.core.plan.surface import TIP_ROOM

    g = MeshGround(TriMesh.concat([plane(-5, 5, -5, 5), plane(-5, 5, -5, 0.0, 0.17, name="step")]))
    long_toe = FootShape(back=0.1, front=0.16, half_width=0.05, tip=0.25)

    def ok(xy_y, heading, z, foot=FOOT):
        pos = np.array([[0.0, xy_y, z]])
        s = footprint_support(g, None, pos, np.array([heading]), FWD, foot)
        return bool(s.ok[0]), float(s.z[0])

    assert ok(-0.05, 0.0, 0.17) == (True, pytest.approx(0.17))  # the heel over the floor
    assert not ok(0.02, 0.0, 0.17)[0]  # the middle off the step
    assert not ok(-0.05, np.pi, 0.17)[0]  # facing the edge: the toes off the step
    edge = 0.25 + TIP_ROOM
    assert not ok(edge - 0.01, 0.0, 0.0, long_toe)[0]  # the toe tip's room in the riser
    assert ok(edge + 0.01, 0.0, 0.0, long_toe)[0]
    assert ok(edge - 0.01, 0.0, 0.0)[0]  # a short toe stands there
    assert ok(-0.2, np.pi, 0.17, long_toe)[0]  # down off the step: the toes over the floor
