"""Rays cast straight down onto a triangle mesh, thousands at a time, in numpy.

Reads: a ``TriMesh`` (world space, Z up). Answers ``ray_down(points, max_dist)`` as
``surface.Ground`` does: for each point the first surface below it, looking down at most
``max_dist``. Never imports bpy.

The triangles are binned once by their XY bounds in a uniform grid (``RayGrid``); a
batch of points then tests only the triangles of its cells, every test of the batch in
one array: a ray costs a fraction of a microsecond where a BVH's one call a point costs
one or two, and the answer is exact (float64, the same barycentric test as
``surface.MeshGround``'s, so the two agree to the last bit).
"""

from __future__ import annotations

import numpy as np

from .surface import GroundHit, TriMesh

#: Barycentric slack (unitless): a point this far outside a triangle's edge still hits it,
#: so a ray down a shared edge finds one of its two triangles.
EDGE_SLACK = 1e-9

#: m a surface may lie above the ray's start and still count (a point on the surface).
ABOVE_SLACK = 1e-9

#: The most (triangle, cell) entries the grid holds for each triangle, on average: a
#: scene of a few huge triangles (a floor of two) among small ones (stairs) gets cells
#: large enough that the floor does not fill the grid.
ENTRIES_PER_TRIANGLE = 16

#: Cells along the grid's longer side at most.
MAX_CELLS_PER_SIDE = 4096


class RayGrid:
    """``ray_down`` (``surface.Ground``) on a ``TriMesh``'s triangles binned in an XY grid.
    Vertical triangles are never hit (as from above they have no area)."""

    def __init__(self, mesh: TriMesh):
        self.mesh = mesh
        c = mesh.corners() if mesh.n else np.zeros((0, 3, 3))
        a, b, d = c[:, 0, :2], c[:, 1, :2], c[:, 2, :2]
        area = (b[:, 0] - a[:, 0]) * (d[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (d[:, 0] - a[:, 0])
        keep = np.flatnonzero(np.abs(area) > 1e-14)
        self._corners, self._area = c, area
        self._normal = mesh.up_normals() if mesh.n else np.zeros((0, 3))
        self._build(keep)

    def _build(self, keep: np.ndarray) -> None:
        c = self._corners[keep]
        if not len(keep):
            self._lo, self._hi, self._cell, self._shape = np.zeros(2), np.zeros(2), 1.0, (1, 1)
            self._start, self._tris = np.zeros(2, np.int64), np.zeros(0, np.int64)
            return
        lo_t, hi_t = c[:, :, :2].min(axis=1), c[:, :, :2].max(axis=1)
        # (bounds a hair wider: a point EDGE_SLACK outside an edge is in one of its cells)
        pad = 1e-6 + 1e-9 * float(np.abs(c[:, :, :2]).max())
        lo_t, hi_t = lo_t - pad, hi_t + pad
        lo, hi = lo_t.min(axis=0), hi_t.max(axis=0)
        span = np.maximum(hi - lo, 1e-6)
        # cells about a typical triangle's size, grown until the entries fit their budget
        size = max(float(np.median(np.max(hi_t - lo_t, axis=1))) / 2, float(span.max()) / MAX_CELLS_PER_SIDE, 1e-6)
        budget = ENTRIES_PER_TRIANGLE * len(keep) + 1024
        while True:
            shape = np.maximum(np.ceil(span / size).astype(np.int64), 1)
            i0 = np.clip(((lo_t - lo) / size).astype(np.int64), 0, shape - 1)
            i1 = np.clip(((hi_t - lo) / size).astype(np.int64), 0, shape - 1)
            per = (i1 - i0 + 1).prod(axis=1)
            if per.sum() <= budget:
                break
            size *= 1.5
        # every triangle's cells, in one array: triangle t covers cells i0..i1 in x and y
        tri = np.repeat(np.arange(len(keep)), per)
        k = np.arange(len(tri)) - np.repeat(np.cumsum(per) - per, per)
        nx = (i1 - i0 + 1)[tri, 0]
        ix, iy = i0[tri, 0] + k % nx, i0[tri, 1] + k // nx
        cell = ix * shape[1] + iy
        order = np.argsort(cell, kind="stable")  # (each cell's triangles in the mesh's order)
        self._tris = keep[tri[order]]
        self._start = np.concatenate([[0], np.cumsum(np.bincount(cell, minlength=int(shape.prod())))])
        self._lo, self._hi, self._cell, self._shape = lo, hi, size, (int(shape[0]), int(shape[1]))

    def ray_down(self, points: np.ndarray, max_dist: float):
        p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        n = len(p)
        z = np.full(n, np.nan)
        nor = np.full((n, 3), np.nan)
        owner = np.full(n, -1, np.int64)
        face = np.full(n, -1, np.int64)
        pt, tri = self._candidates(p)
        if len(tri):
            c = np.take(self._corners, tri, axis=0)  # (np.take: a fancy index costs several times as much)
            q = np.take(p, pt, axis=0)
            area = np.take(self._area, tri)
            a, b, d = c[:, 0], c[:, 1], c[:, 2]
            w1 = ((d[:, 0] - q[:, 0]) * (a[:, 1] - q[:, 1]) - (d[:, 1] - q[:, 1]) * (a[:, 0] - q[:, 0])) / area
            w2 = ((a[:, 0] - q[:, 0]) * (b[:, 1] - q[:, 1]) - (a[:, 1] - q[:, 1]) * (b[:, 0] - q[:, 0])) / area
            w0 = 1 - w1 - w2
            zz = w0 * a[:, 2] + w1 * b[:, 2] + w2 * d[:, 2]
            below = q[:, 2] - zz
            ok = np.flatnonzero((w0 >= -EDGE_SLACK) & (w1 >= -EDGE_SLACK) & (w2 >= -EDGE_SLACK)
                                & (below >= -ABOVE_SLACK) & (below <= max_dist))
            if len(ok):
                # the nearest per point, the lowest triangle index among equals: the pairs
                # come grouped by point, each group's triangles in the mesh's order
                pt, tri, zz, below = pt[ok], tri[ok], zz[ok], below[ok]
                start = np.flatnonzero(np.r_[True, pt[1:] != pt[:-1]])
                least = np.repeat(np.minimum.reduceat(below, start), np.diff(np.r_[start, len(pt)]))
                win = np.flatnonzero(below == least)
                win = win[np.r_[True, pt[win[1:]] != pt[win[:-1]]]]
                at, t = pt[win], tri[win]
                z[at] = zz[win]
                nor[at] = np.take(self._normal, t, axis=0)
                owner[at] = np.take(self.mesh.owner, t)
                face[at] = t
        return GroundHit(owner >= 0, z, nor, owner, face)

    def _candidates(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(point index, triangle index) of every triangle in each point's cell."""
        if not len(self._tris) or not len(p):
            return np.zeros(0, np.int64), np.zeros(0, np.int64)
        x, y = p[:, 0], p[:, 1]
        inside = np.flatnonzero((x >= self._lo[0]) & (x <= self._hi[0]) & (y >= self._lo[1]) & (y <= self._hi[1]))
        # (a point on the grid's far edge lies in its last cell, as a triangle there does)
        gx = np.minimum(((x[inside] - self._lo[0]) / self._cell).astype(np.int64), self._shape[0] - 1)
        gy = np.minimum(((y[inside] - self._lo[1]) / self._cell).astype(np.int64), self._shape[1] - 1)
        cell = gx * self._shape[1] + gy
        first, count = self._start[cell], self._start[cell + 1] - self._start[cell]
        pt = np.repeat(inside, count)
        k = np.arange(len(pt)) - np.repeat(np.cumsum(count) - count, count)
        return pt, self._tris[np.repeat(first, count) + k]


__all__ = ["RayGrid"]
