"""``core.plan.rays.RayGrid``: rays down on a triangle grid answer as the brute-force
``surface.MeshGround`` does, to the last bit (the same test, over the triangles of each
point's cell only), on triangle soups, terrains whose triangles share edges and
vertices, scenes of huge and tiny triangles together, and vertical and degenerate
triangles; and as Blender's BVH tree does, to its float32 precision."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from footstep_planner.core.plan.rays import RayGrid
from footstep_planner.core.plan.surface import MeshGround, TriMesh


def _same(mesh: TriMesh, pts: np.ndarray, max_dist: float) -> None:
    a, b = MeshGround(mesh).ray_down(pts, max_dist), RayGrid(mesh).ray_down(pts, max_dist)
    np.testing.assert_array_equal(b.hit, a.hit)
    np.testing.assert_array_equal(b.z, a.z)
    np.testing.assert_array_equal(b.face, a.face)
    np.testing.assert_array_equal(b.owner, a.owner)
    np.testing.assert_allclose(b.normal, a.normal, rtol=0, atol=1e-15)


def _terrain(n: int, rng, span=2.0) -> TriMesh:
    xs = np.linspace(-span, span, n)
    X, Y = np.meshgrid(xs, xs)
    v = np.c_[X.ravel(), Y.ravel(), rng.uniform(0.0, 0.3, X.size)]
    i, j = np.meshgrid(np.arange(n - 1), np.arange(n - 1))
    a = (i * n + j).ravel()
    tris = np.r_[np.c_[a, a + 1, a + n + 1], np.c_[a, a + n + 1, a + n]]
    return TriMesh(v, tris, rng.integers(0, 2, len(tris)), ("a", "b"))


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**31), count=st.integers(1, 40), dist=st.floats(0.05, 3.0))
def test_a_triangle_soup_answers_as_brute_force(seed, count, dist):
    rng = np.random.default_rng(seed)
    v = rng.uniform(-3, 3, (3 * count, 3)) * [1.0, 1.0, 0.3]
    mesh = TriMesh(v, np.arange(3 * count).reshape(-1, 3), rng.integers(0, 3, count), ("a", "b", "c"))
    pts = np.c_[rng.uniform(-3.5, 3.5, (300, 2)), rng.uniform(-1.0, 1.0, 300)]
    _same(mesh, pts, dist)


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**31), n=st.integers(2, 12))
def test_a_terrain_answers_as_brute_force_on_its_vertices_and_edges(seed, n):
    rng = np.random.default_rng(seed)
    mesh = _terrain(n, rng)
    on_vertex = mesh.verts[rng.integers(0, len(mesh.verts), 100)] + [0.0, 0.0, 0.5]
    xs = np.unique(mesh.verts[:, 0])
    on_edge = np.c_[xs[rng.integers(0, len(xs), 100)], rng.uniform(-2, 2, 100), np.full(100, 0.5)]
    free = np.c_[rng.uniform(-2.5, 2.5, (100, 2)), rng.uniform(-0.2, 0.6, 100)]
    pts = np.r_[on_vertex, on_edge, free]
    _same(mesh, pts, 1.0)
    hit = RayGrid(mesh).ray_down(pts[:200], 1.0)
    assert hit.hit.all()  # (a ray down a shared edge or vertex finds one of its triangles)


def test_huge_and_tiny_triangles_together():
    """A floor of two triangles 100 m across under a fine terrain: the grid's cells grow
    until the floor no longer fills it, and every answer stays exact."""
    rng = np.random.default_rng(3)
    fine = _terrain(40, rng, span=1.0)
    floor = TriMesh(np.array([[-50, -50, -1.0], [50, -50, -1.0], [50, 50, -1.0], [-50, 50, -1.0]]),
                    np.array([[0, 1, 2], [0, 2, 3]]), np.zeros(2, np.int64), ("floor",))
    mesh = TriMesh.concat([fine, floor])
    grid = RayGrid(mesh)
    from footstep_planner.core.plan import rays
    assert len(grid._tris) <= rays.ENTRIES_PER_TRIANGLE * mesh.n + 1024
    pts = np.c_[rng.uniform(-3, 3, (400, 2)), np.full(400, 0.5)]
    _same(mesh, pts, 2.0)
    hit = grid.ray_down(pts, 2.0)
    under_fine = (np.abs(pts[:, :2]) < 1.0).all(axis=1)
    assert (hit.z[under_fine] >= 0.0).all() and np.allclose(hit.z[~under_fine], -1.0)


def test_vertical_degenerate_empty_and_nan():
    wall = TriMesh(np.array([[0, 0, 0], [1, 0, 0], [1, 0, 1], [2, 2, 0], [2, 2, 0], [3, 3, 0]], float),
                   np.array([[0, 1, 2], [3, 4, 5]]), np.zeros(2, np.int64), ("wall",))
    pts = np.array([[0.5, 0.0, 2.0], [2.0, 2.0, 1.0], [np.nan, 0.0, 1.0], [0.5, np.nan, 1.0]])
    _same(wall, pts, 5.0)
    assert not RayGrid(wall).ray_down(pts, 5.0).hit.any()
    empty = TriMesh(np.zeros((0, 3)), np.zeros((0, 3), np.int64), np.zeros(0, np.int64), ())
    hit = RayGrid(empty).ray_down(pts, 5.0)
    assert not hit.hit.any() and np.isnan(hit.z).all()
    assert RayGrid(wall).ray_down(np.zeros((0, 3)), 1.0).hit.shape == (0,)


@pytest.mark.blender
def test_it_answers_as_blenders_bvh_tree(fp):
    """The rays Blender's own BVH tree casts hit what the grid hits, at the heights it
    finds to float32's precision (the tree holds its vertices in float32)."""
    from mathutils.bvhtree import BVHTree

    rng = np.random.default_rng(8)
    mesh = TriMesh.concat([_terrain(12, rng), TriMesh(np.array([[-3, -3, -0.5], [3, -3, -0.5], [0, 3, -0.5]]),
                                                      np.array([[0, 1, 2]]), np.zeros(1, np.int64), ("floor",))])
    tree = BVHTree.FromPolygons(mesh.verts.tolist(), mesh.tris.tolist(), all_triangles=True)
    pts = np.c_[rng.uniform(-2.5, 2.5, (500, 2)), rng.uniform(0.0, 1.0, 500)]
    grid = RayGrid(mesh).ray_down(pts, 1.2)
    for k, p in enumerate(pts):
        loc, _, face, dist = tree.ray_cast(p.tolist(), (0.0, 0.0, -1.0), 1.2)
        if face is None:
            assert not grid.hit[k] or 1.2 - (p[2] - grid.z[k]) < 1e-5, k
        else:
            assert grid.hit[k], k
            assert abs(loc[2] - grid.z[k]) < 1e-5, k
