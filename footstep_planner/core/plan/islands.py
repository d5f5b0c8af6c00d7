"""The ground's islands: its walkable triangles grouped into the pieces a foot can walk
between without leaving the ground, found once per ground.

A walking or running step may cross a gap its swing clears when both its footprints
stand (stepping stones, the gap between two slabs, a gutter), but the same step could cut
over a floor's corner or notch: its line leaves the floor and comes back onto it. The two
are told apart by what the ground is, not by the step: a step crosses void only from one
island to another (``Islands.apart``). An island is a set of walkable triangles (no
steeper than ``MAX_SLOPE``) joined by shared vertices, and by a vertex within ``JOIN`` m
(a human's) across of another walkable triangle and within a step's height of it: slabs
modelled apart that touch (corner to corner, or a corner on the other's edge) are one
island, a flight's treads with their risers between are one with the floors they join,
a gutter's bottom (deeper than a step) is an island of its own between two banks, and
each stepping stone is one. A floor's notch is inside one island, so a step over it is
held to the ground as ever.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from .surface import Ground

#: rad: the steepest triangle of an island (``SupportLimits.max_slope``'s default).
MAX_SLOPE = np.radians(30.0)
#: m (a human's): a vertex this near another walkable triangle, across, joins its island.
JOIN = 0.02
#: m (a human's): a point's island is the triangle's under it looked for from this high.
LOOK = 0.02
#: Most islands ``Islands.linked`` groups (their pairs, I x I, are compared).
MAX_LINKED = 2000


@dataclass(frozen=True)
class Islands:
    """``face`` (T,) each triangle's island (-1 for a triangle too steep to stand on),
    ``area`` (I,) m² each island's area seen from above, and ``lo``, ``hi`` (I, 2) its
    bounds in x and y."""

    face: np.ndarray
    area: np.ndarray
    lo: np.ndarray
    hi: np.ndarray

    @staticmethod
    def of(ground: Ground, step_height: float, scale: float = 1.0) -> "Islands":
        """The islands of ``ground``'s mesh: its walkable triangles joined by shared vertices
        and by a vertex on the mesh's open edges within ``JOIN`` (times ``scale``) across
        of another walkable triangle, within ``step_height`` up or down (looked for under
        eight points round the vertex)."""
        mesh = ground.mesh
        t = mesh.n
        if not t:
            return Islands(np.zeros(0, np.int64), np.zeros(0), np.zeros((0, 2)), np.zeros((0, 2)))
        c = mesh.corners()
        cross = np.cross(c[:, 1] - c[:, 0], c[:, 2] - c[:, 0])
        norm = np.linalg.norm(cross, axis=1)
        walk = np.abs(cross[:, 2]) >= np.cos(MAX_SLOPE) * np.maximum(norm, 1e-300)
        walk &= norm > 1e-14
        tris = mesh.tris[walk]
        nv = len(mesh.verts)
        rows = [tris[:, 0], tris[:, 1]]
        cols = [tris[:, 1], tris[:, 2]]
        # the open edges' vertices (an edge of one walkable triangle only): where islands may touch
        e = np.sort(tris[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1).astype(np.int64)
        uniq, counts = np.unique(e[:, 0] * nv + e[:, 1], return_counts=True)  # (an edge as one int: a 1D sort)
        rim = np.unique(np.r_[uniq[counts == 1] // nv, uniq[counts == 1] % nv])
        if len(rim):
            r = JOIN * scale
            ang = np.arange(8) * np.pi / 4
            off = r * np.c_[np.cos(ang), np.sin(ang)]
            v = mesh.verts[rim]
            pts = np.concatenate([np.repeat(v[:, :2], len(off), axis=0) + np.tile(off, (len(v), 1)),
                                  np.repeat(v[:, 2:3] + step_height, len(off), axis=0)], axis=1)
            hit = ground.ray_down(pts, 2 * step_height)
            f = hit.face if hit.face is not None else np.full(len(pts), -1)
            ok = (f >= 0)
            ok[ok] &= walk[f[ok]]
            src = np.repeat(rim, len(off))
            rows.append(src[ok])
            cols.append(mesh.tris[f[ok], 0])
        rows, cols = np.concatenate(rows), np.concatenate(cols)
        g = coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(nv, nv))
        _, label = connected_components(g, directed=False)
        face = np.full(t, -1, np.int64)
        _, face[walk] = np.unique(label[mesh.tris[walk, 0]], return_inverse=True)
        area = np.bincount(face[walk], weights=0.5 * np.abs(cross[walk, 2]), minlength=int(face.max()) + 1)
        n, xy = len(area), c[walk][..., :2]
        lo, hi = np.full((n, 2), np.inf), np.full((n, 2), -np.inf)
        np.minimum.at(lo, face[walk], xy.min(axis=1))
        np.maximum.at(hi, face[walk], xy.max(axis=1))
        return Islands(face, area, lo, hi)

    def __len__(self) -> int:
        return len(self.area)

    def linked(self, reach: float) -> np.ndarray | None:
        """(I,) each island's group: islands whose extents seen from above (their x and y
        bounds, ``lo``, ``hi``) come within ``reach`` m of each other, directly or through
        others, share one. An island's bounds hold all of it, so two islands nearer than
        ``reach`` are always linked (overlapping ones too: a deck over a floor): a step or
        a jump spanning at most ``reach`` of void never leaves its group. None for more
        than MAX_LINKED islands (not worth the pairs)."""
        n = len(self.area)
        if n <= 1:
            return np.zeros(n, np.int64)
        if n > MAX_LINKED:
            return None
        gap = np.maximum(np.maximum(self.lo[:, None] - self.hi[None], self.lo[None] - self.hi[:, None]), 0.0)
        near = np.hypot(gap[..., 0], gap[..., 1]) <= reach
        return connected_components(coo_matrix(near), directed=False)[1]

    def at(self, ground: Ground, pts: np.ndarray, scale: float = 1.0, look: float | None = None) -> np.ndarray:
        """(N,) the island of the ground at points (N, 3) (footprints, at their ground's
        height: looked for ``look`` m above and below them, ``LOOK`` times ``scale`` when not
        given), -1 where none."""
        pts = np.atleast_2d(np.asarray(pts, float))
        if not len(pts) or not len(self.face):
            return np.full(len(pts), -1, np.int64)
        look = LOOK * scale if look is None else look
        hit = ground.ray_down(pts + [0.0, 0.0, look], 2 * look)
        if hit.face is None:  # (a ground that does not tell its triangles: one island)
            return np.where(hit.hit, 0, -1)
        return np.where(hit.face >= 0, self.face[np.maximum(hit.face, 0)], -1)

    def apart(self, ground: Ground, a: np.ndarray, b: np.ndarray, scale: float = 1.0) -> np.ndarray:
        """(N,) whether footprints ``a`` and ``b`` (N, 3) stand on two islands (a step over
        void between them crosses a gap, not a corner of one floor)."""
        ia, ib = self.at(ground, a, scale), self.at(ground, b, scale)
        return (ia >= 0) & (ib >= 0) & (ia != ib)


#: m² (a human's): an island no larger than this, seen from above, is a small standing
#: patch (a stepping stone), where a successor landing partly off it is moved onto it ...
SMALL_AREA = 1.0
#: ... by at most this (m, a human's) ...
MAX_MOVE = 0.1
#: ... its foot this far (m, a human's) inside the patch's edges.
EDGE_MARGIN = 0.005


@dataclass(frozen=True)
class Patches:
    """The small islands (``SMALL_AREA``) of a ground as P convex patches: ``normal`` (P, K,
    2) and ``offset`` (P, K) their hulls' edges (a point x is inside where normal . x +
    offset <= 0 for every edge; rows past a hull's own are zero with offset -1), ``z``
    (P,) their height (their vertices' mean) and ``lo``, ``hi`` (P, 2) their bounds.

    A stepping stone takes a footprint only in a window of a few centimetres; a library's
    steps are fixed vectors, merged on a grid coarser than that, so left alone the search
    lands few of them wholly on a stone (the sample character walked 20 to 30 cm gaps only,
    from a stone's front edge). A successor landing partly on one is moved the least that
    puts its foot wholly on it (``onto``), as a stair's tread takes one (``treads``)."""

    normal: np.ndarray
    offset: np.ndarray
    z: np.ndarray
    lo: np.ndarray
    hi: np.ndarray

    def __len__(self) -> int:
        return len(self.z)

    @staticmethod
    def none() -> "Patches":
        return Patches(np.zeros((0, 1, 2)), np.zeros((0, 1)), np.zeros(0), np.zeros((0, 2)), np.zeros((0, 2)))

    @staticmethod
    def of(ground: Ground, islands: Islands, scale: float = 1.0) -> "Patches":
        """The convex hulls (seen from above) of ``islands`` no larger than SMALL_AREA (times
        ``scale`` squared)."""
        from scipy.spatial import ConvexHull, QhullError

        small = np.flatnonzero(islands.area <= SMALL_AREA * scale ** 2)
        if not len(small):
            return Patches.none()
        mesh = ground.mesh
        hulls = []
        for k in small.tolist():  # (one hull per small island: a handful of stones, not per footprint)
            v = mesh.verts[np.unique(mesh.tris[islands.face == k])]
            try:
                eq = ConvexHull(v[:, :2]).equations
            except QhullError:
                continue
            hulls.append((eq[:, :2], eq[:, 2], float(v[:, 2].mean()), v[:, :2].min(axis=0), v[:, :2].max(axis=0)))
        if not hulls:
            return Patches.none()
        kmax = max(len(h[1]) for h in hulls)
        normal = np.zeros((len(hulls), kmax, 2))
        offset = np.full((len(hulls), kmax), -1.0)
        for p, (n, o, *_rest) in enumerate(hulls):
            normal[p, :len(o)], offset[p, :len(o)] = n, o
        return Patches(normal, offset, np.array([h[2] for h in hulls]), np.array([h[3] for h in hulls]),
                       np.array([h[4] for h in hulls]))

    def under(self, xy: np.ndarray, z: np.ndarray, reach: float) -> np.ndarray:
        """(N,) whether each point ``xy`` (N, 2) lies on a patch within ``reach`` of its
        height ``z`` (N,)."""
        if not len(self) or not len(xy):
            return np.zeros(len(xy), bool)
        inside = (np.einsum("pkc,nc->npk", self.normal, xy) + self.offset[None] <= 1e-9).all(axis=2)
        return (inside & (np.abs(self.z[None] - np.asarray(z, float)[:, None]) <= reach)).any(axis=1)

    def onto(self, xy: np.ndarray, angle: np.ndarray, z_from: np.ndarray, foot, reach: float,
             scale: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
        """(xy (N, 2), moved (N,) bool): footprints at ``xy`` turned ``angle`` (world yaw,
        rad) whose foot (``FootShape``'s rectangle) lies partly on a patch within ``reach``
        of ``z_from`` (N,), moved the least (at most MAX_MOVE times ``scale``) that puts it
        wholly on it, EDGE_MARGIN inside; the others unchanged. Vectorised over
        footprints and patches."""
        xy = np.array(xy, float, copy=True)
        moved = np.zeros(len(xy), bool)
        if not len(self) or not len(xy):
            return xy, moved
        most = MAX_MOVE * scale
        span = max(foot.back, foot.front, foot.half_width) + most
        near = ((xy[:, None] >= self.lo[None] - span) & (xy[:, None] <= self.hi[None] + span)).all(axis=2)
        near &= np.abs(self.z[None] - np.asarray(z_from, float)[:, None]) <= reach
        n_, p_ = np.nonzero(near)
        if not len(n_):
            return xy, moved
        f = np.stack([np.cos(angle[n_]), np.sin(angle[n_])], axis=1)
        side = np.c_[-f[:, 1], f[:, 0]]
        local = np.array([[-foot.back, -foot.half_width], [-foot.back, foot.half_width],
                          [foot.front, -foot.half_width], [foot.front, foot.half_width], [0.0, 0.0]])
        pts = xy[n_, None] + local[None, :, :1] * f[:, None] + local[None, :, 1:] * side[:, None]  # (M, 5, 2)
        nrm, off = self.normal[p_], self.offset[p_]  # (M, K, 2), (M, K)
        dist = np.einsum("mkc,mjc->mjk", nrm, pts) + off[:, None]  # (M, 5, K) > 0 outside an edge
        partly = (dist.max(axis=2) <= 0).any(axis=1) & (dist[:, :4].max(axis=(1, 2)) > -EDGE_MARGIN * scale)
        if not partly.any():
            return xy, moved
        n_, nrm, off, dist = n_[partly], nrm[partly], off[partly], dist[partly]
        # the moves t that put every corner inside: nrm . t <= r for each edge
        r = -EDGE_MARGIN * scale - dist[:, :4].max(axis=1)
        real = np.abs(nrm).sum(axis=2) > 0
        r = np.where(real, r, np.inf)
        t = _least_move(nrm, r)  # (M, 2), nan where none
        size = np.linalg.norm(t, axis=1)
        good = np.isfinite(size) & (size <= most)
        if not good.any():
            return xy, moved
        n_, t, size = n_[good], t[good], size[good]
        order = np.lexsort((size, n_))  # (the least move of each footprint's patches)
        first = np.r_[True, n_[order][1:] != n_[order][:-1]]
        pick = order[first]
        xy[n_[pick]] += t[pick]
        moved[n_[pick]] = True
        return xy, moved


def _least_move(nrm: np.ndarray, r: np.ndarray) -> np.ndarray:
    """(M, 2) the shortest t with nrm . t <= r (``nrm`` (M, K, 2) unit normals, or zero rows
    with r = inf), nan where none: the origin projected onto each constraint's line and
    onto each two lines' crossing, the shortest that keeps them all."""
    m, k = r.shape
    cands = [np.zeros((m, 1, 2)), (np.where(np.isfinite(r), r, 0.0)[..., None] * nrm)]
    i, j = np.triu_indices(k, 1)
    if len(i):
        a = np.stack([nrm[:, i], nrm[:, j]], axis=2)  # (M, P, 2, 2)
        det = a[..., 0, 0] * a[..., 1, 1] - a[..., 0, 1] * a[..., 1, 0]
        ok = np.abs(det) > 1e-9
        ri, rj = np.where(np.isfinite(r[:, i]), r[:, i], 0.0), np.where(np.isfinite(r[:, j]), r[:, j], 0.0)
        d = np.where(ok, det, 1.0)
        x = (ri * a[..., 1, 1] - rj * a[..., 0, 1]) / d
        y = (a[..., 0, 0] * rj - a[..., 1, 0] * ri) / d
        cands.append(np.where(ok[..., None], np.stack([x, y], axis=-1), np.nan))
    c = np.concatenate(cands, axis=1)  # (M, C, 2)
    feasible = (np.einsum("mkc,mqc->mqk", nrm, np.nan_to_num(c, nan=1e9)) <= r[:, None] + 1e-9).all(axis=2)
    feasible &= np.isfinite(c).all(axis=2)
    size = np.where(feasible, np.linalg.norm(np.nan_to_num(c), axis=2), np.inf)
    best = np.argmin(size, axis=1)
    out = c[np.arange(m), best]
    return np.where(np.isfinite(size[np.arange(m), best])[:, None], out, np.nan)
