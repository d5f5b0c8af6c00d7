"""``surface.ground_heights`` (issue 28): the heights ``ray_down`` finds, with the Blender
layer's BVH ground (its own lean ``heights``) and with the numpy one, on a scene of
steps, a gap and an overhang, a batch of the tree's size and one of the grid's."""

from importlib import import_module

import numpy as np
import pytest

from footstep_planner.core.plan.surface import MeshGround, TriMesh, ground_heights
from tests.conftest import box, plane


def _scene() -> TriMesh:
    return TriMesh.concat([plane(-1, 1, -1, 1), box((1.2, -1, 0), (2, 1, 0.17), "step"),
                           box((0.2, -0.2, 0.5), (0.6, 0.2, 0.6), "shelf"), plane(2, 3, -1, 1, 0.17, 0.1)])


@pytest.mark.parametrize("kind, n", [("bvh", 300), ("bvh", 1500), ("numpy", 1500)])
def test_ground_heights_are_ray_downs(kind, n, fp):
    rng = np.random.default_rng(4)
    pts = np.c_[rng.uniform(-1.5, 3.5, n), rng.uniform(-1.5, 1.5, n), rng.uniform(-0.1, 1.0, n)]
    if kind == "bvh":
        surfaces = import_module(fp.__name__ + ".blender.read.surfaces")
        assert (n < surfaces.GRID_RAYS) == (n == 300)  # (the tree's rays, then the grid's)
        ground = surfaces.BvhGround(_scene())
    else:
        ground = MeshGround(_scene())
    hit = ground.ray_down(pts, 0.4)
    z = ground_heights(ground, pts, 0.4)
    assert hit.hit.any() and not hit.hit.all()
    np.testing.assert_array_equal(np.isfinite(z), hit.hit)
    np.testing.assert_allclose(z[hit.hit], hit.z[hit.hit], atol=1e-6 if kind == "bvh" else 0.0)
