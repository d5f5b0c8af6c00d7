"""Traversable surfaces and obstacles, and the ground queries the planner asks of them.

Everything is batched over points. Conventions: world space, metres, Z up; a heading is
a yaw in radians relative to the rig's rest forward ``forward`` (a unit (x, y) vector).

The queries are a small interface (``Ground``) with two implementations: ``MeshGround``
here, pure numpy and brute force (exact, the reference the tests hold the other to), and
the Blender layer's ``BvhGround`` (fast, for real scenes: its rays on
``mathutils.bvhtree`` one call a ray, a large batch of rays at once by ``rays.RayGrid``,
which answers as ``MeshGround`` does to the last bit). A test holds them equal.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from typing import Protocol

import numpy as np

from ..base.errors import FootstepError
from ..base.settings import Settings


class SurfaceError(FootstepError):
    """A scene the planner cannot walk on; the message names the objects at fault."""


@dataclass(frozen=True)
class TriMesh:
    """Triangles in world space: ``verts`` (V, 3), ``tris`` (T, 3) vertex indices, and
    ``owner`` (T,) the index into ``names`` of the object each triangle came from."""

    verts: np.ndarray
    tris: np.ndarray
    owner: np.ndarray
    names: tuple[str, ...] = ()

    @staticmethod
    def empty() -> "TriMesh":
        return TriMesh(np.zeros((0, 3)), np.zeros((0, 3), np.int64), np.zeros(0, np.int64), ())

    @staticmethod
    def concat(meshes) -> "TriMesh":
        verts, tris, owner, names = [], [], [], []
        offset = 0
        for m in meshes:
            verts.append(m.verts)
            tris.append(m.tris + offset)
            owner.append(m.owner + len(names))
            names.extend(m.names)
            offset += len(m.verts)
        if not verts:
            return TriMesh.empty()
        return TriMesh(np.concatenate(verts), np.concatenate(tris), np.concatenate(owner), tuple(names))

    @property
    def n(self) -> int:
        return len(self.tris)

    def corners(self) -> np.ndarray:
        """(T, 3, 3) the triangles' corner positions."""
        return self.verts[self.tris]

    def up_normals(self) -> np.ndarray:
        """(T, 3) each triangle's unit normal, turned to face up (a vertical one's as it is;
        a degenerate one's zero): what a ray down reports for the triangle it hits."""
        c = self.corners()
        n = np.cross(c[:, 1] - c[:, 0], c[:, 2] - c[:, 0])
        n = n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
        return n * np.sign(n[:, 2:3] + (n[:, 2:3] == 0))

    def without_undersides(self, tilt: float = 0.1) -> "TriMesh":
        """The mesh without the downward-facing triangles (normal z under ``-tilt``) of its
        closed solids (objects whose every edge joins exactly two triangles; outward by
        their signed volume, so a solid with flipped normals counts the same): a box's
        underside can't be stood on, and a look down from inside the box (a footprint
        below its top) would take it for ground. An open mesh (a plane, a terrain) keeps
        every triangle, whichever way its normals face."""
        if not self.n:
            return self
        c = self.corners()
        cross = np.cross(c[:, 1] - c[:, 0], c[:, 2] - c[:, 0])
        nz = cross[:, 2] / np.maximum(np.linalg.norm(cross, axis=1), 1e-300)
        # a solid whose normals all face inwards (its signed volume negative) is turned out
        volume = np.bincount(self.owner, weights=np.einsum("ij,ij->i", c[:, 0], cross), minlength=self.owner.max() + 1)
        nz = nz * np.where(volume[self.owner] < 0, -1.0, 1.0)
        keep = ~(self.closed_owners()[self.owner] & (nz < -tilt))
        if keep.all():
            return self
        return TriMesh(self.verts, self.tris[keep], self.owner[keep], self.names)

    def closed_owners(self) -> np.ndarray:
        """(O,) bool: whether each object's triangles close a solid (every edge of them
        joins exactly two of them); an object without triangles counts as closed."""
        e = np.sort(self.tris[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
        owner = np.repeat(self.owner, 3)
        _, inv, counts = np.unique(np.c_[owner, e], axis=0, return_inverse=True, return_counts=True)
        closed = np.ones(len(self.names) or int(self.owner.max(initial=-1)) + 1, bool)
        closed[np.unique(owner[counts[inv.ravel()] != 2])] = False
        return closed

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        if not len(self.verts):
            return np.zeros(3), np.zeros(3)
        return self.verts.min(axis=0), self.verts.max(axis=0)


@dataclass(frozen=True)
class GroundHit:
    hit: np.ndarray  # (N,) bool
    z: np.ndarray  # (N,) height of the surface (nan where no hit)
    normal: np.ndarray  # (N, 3) unit normals, facing up (nan where no hit)
    owner: np.ndarray  # (N,) object index (-1 where no hit)
    face: np.ndarray | None = None  # (N,) the triangle hit (-1 where none), where the ground tells it


class Ground(Protocol):
    mesh: TriMesh

    def ray_down(self, points: np.ndarray, max_dist: float) -> GroundHit:
        """The first surface below each point (N, 3), looking down at most ``max_dist``."""

    def nearest(self, points: np.ndarray, max_dist: float = np.inf) -> tuple[np.ndarray, np.ndarray]:
        """(closest points (N, 3), distances (N,)); inf and nan beyond ``max_dist``."""


def ground_heights(ground: Ground, points: np.ndarray, max_dist: float) -> np.ndarray:
    """(N,) the height of the first surface below each point (N, 3), looking down at most
    ``max_dist`` (nan where there is none): ``ray_down``'s heights."""
    hit = ground.ray_down(points, max_dist)
    return np.where(hit.hit, hit.z, np.nan)


# ----------------------------------------------------------------------------------
# pure numpy implementation

@dataclass
class MeshGround:
    """Ground queries on a TriMesh in numpy: exact, O(points x triangles) in chunks."""

    mesh: TriMesh
    _cache: dict = field(default_factory=dict, repr=False)

    def _tri(self):
        if "tri" not in self._cache:
            c = self.mesh.corners()
            n = np.cross(c[:, 1] - c[:, 0], c[:, 2] - c[:, 0])
            self._cache["tri"] = (c, n)
        return self._cache["tri"]

    def ray_down(self, points: np.ndarray, max_dist: float) -> GroundHit:
        p = np.atleast_2d(np.asarray(points, dtype=np.float64))
        n = len(p)
        z = np.full(n, np.nan)
        nor = np.full((n, 3), np.nan)
        owner = np.full(n, -1)
        face = np.full(n, -1)
        if self.mesh.n and n:
            c, tn = self._tri()
            a, b, d = c[:, 0, :2], c[:, 1, :2], c[:, 2, :2]
            area = (b[:, 0] - a[:, 0]) * (d[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (d[:, 0] - a[:, 0])
            ok_t = np.abs(area) > 1e-14  # vertical triangles cannot be hit from above
            for s in range(0, n, 256):
                q = p[s:s + 256, None, :2]
                w1 = ((d[:, 0] - q[..., 0]) * (a[:, 1] - q[..., 1]) - (d[:, 1] - q[..., 1]) * (a[:, 0] - q[..., 0])) / np.where(ok_t, area, 1)
                w2 = ((a[:, 0] - q[..., 0]) * (b[:, 1] - q[..., 1]) - (a[:, 1] - q[..., 1]) * (b[:, 0] - q[..., 0])) / np.where(ok_t, area, 1)
                w0 = 1 - w1 - w2
                eps = -1e-9
                inside = ok_t & (w0 >= eps) & (w1 >= eps) & (w2 >= eps)
                zz = w0 * c[:, 0, 2] + w1 * c[:, 1, 2] + w2 * c[:, 2, 2]
                below = p[s:s + 256, None, 2] - zz
                valid = inside & (below >= -1e-9) & (below <= max_dist)
                best = np.where(valid, below, np.inf)
                j = np.argmin(best, axis=1)
                got = np.isfinite(best[np.arange(len(j)), j])
                idx = np.arange(s, s + len(j))[got]
                z[idx] = zz[got, j[got]]
                nn = tn[j[got]] / np.linalg.norm(tn[j[got]], axis=1, keepdims=True)
                nn *= np.sign(nn[:, 2:3] + (nn[:, 2:3] == 0))
                nor[idx] = nn
                owner[idx] = self.mesh.owner[j[got]]
                face[idx] = j[got]
        return GroundHit(owner >= 0, z, nor, owner, face)

    def nearest(self, points: np.ndarray, max_dist: float = np.inf):
        p = np.atleast_2d(np.asarray(points, dtype=np.float64))
        out = np.full((len(p), 3), np.nan)
        dist = np.full(len(p), np.inf)
        if self.mesh.n and len(p):
            c, _ = self._tri()
            for s in range(0, len(p), 128):
                q = _closest_on_triangles(p[s:s + 128], c)  # (n, T, 3)
                d = np.linalg.norm(q - p[s:s + 128, None], axis=2)
                j = np.argmin(d, axis=1)
                r = np.arange(len(j))
                dist[s:s + len(j)] = d[r, j]
                out[s:s + len(j)] = q[r, j]
        far = dist > max_dist
        out[far] = np.nan
        dist[far] = np.inf
        return out, dist


def _closest_on_triangles(p: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Closest points (n, T, 3) on triangles c (T, 3, 3) to points p (n, 3) (Ericson's
    region test, vectorized)."""
    a, b, cc = c[None, :, 0], c[None, :, 1], c[None, :, 2]
    p = p[:, None]
    ab, ac, ap = b - a, cc - a, p - a
    d1, d2 = (ab * ap).sum(-1), (ac * ap).sum(-1)
    bp = p - b
    d3, d4 = (ab * bp).sum(-1), (ac * bp).sum(-1)
    cp = p - cc
    d5, d6 = (ab * cp).sum(-1), (ac * cp).sum(-1)
    va = d3 * d6 - d5 * d4
    vb = d5 * d2 - d1 * d6
    vc = d1 * d4 - d3 * d2
    den = np.where(np.abs(va + vb + vc) > 1e-30, va + vb + vc, 1e-30)
    v, w = vb / den, vc / den
    res = a + ab * v[..., None] + ac * w[..., None]  # inside the face
    with np.errstate(divide="ignore", invalid="ignore"):
        # edges
        t_ab = np.clip(d1 / (d1 - d3), 0, 1)
        t_ac = np.clip(d2 / (d2 - d6), 0, 1)
        t_bc = np.clip((d4 - d3) / ((d4 - d3) + (d5 - d6)), 0, 1)
    e_ab = (vc <= 0) & (d1 >= 0) & (d3 <= 0)
    e_ac = (vb <= 0) & (d2 >= 0) & (d6 <= 0)
    e_bc = (va <= 0) & ((d4 - d3) >= 0) & ((d5 - d6) >= 0)
    res = np.where(e_bc[..., None], b + (cc - b) * np.nan_to_num(t_bc)[..., None], res)
    res = np.where(e_ac[..., None], a + ac * np.nan_to_num(t_ac)[..., None], res)
    res = np.where(e_ab[..., None], a + ab * np.nan_to_num(t_ab)[..., None], res)
    # vertices
    res = np.where(((d6 >= 0) & (d5 <= d6))[..., None], cc, res)
    res = np.where(((d3 >= 0) & (d4 <= d3))[..., None], b, res)
    res = np.where(((d1 <= 0) & (d2 <= 0))[..., None], a, res)
    return res


# ----------------------------------------------------------------------------------
# footprints

#: m a foot's toe tip keeps from higher ground ahead (a riser): the foot rolls onto its
#: ball and lifts off without its toes meeting it.
TIP_ROOM = 0.03


@dataclass(frozen=True)
class FootShape:
    """A foot's rectangle on the ground, in the foot's frame: ``back`` and ``front`` (m)
    behind and ahead of the footprint's reference point along the heading, and
    ``half_width`` (m) to either side; ``tip`` (m ahead, when beyond ``front``) where a
    long toe's tip reaches (0: at ``front``). ``scale``: the body's size over a human's
    (``Settings.body_scale``): the lengths this module names (``TIP_ROOM``, the body's
    heights over a footprint, the ground's unevenness under it) are a human's times it."""

    back: float = 0.1
    front: float = 0.16
    half_width: float = 0.05
    tip: float = 0.0
    scale: float = 1.0

    def probes(self, pos: np.ndarray, heading: np.ndarray, forward: np.ndarray) -> np.ndarray:
        """(N, 8, 2) the ground points ``footprint_support`` looks under: the four
        corners and the reference point (``corners``), the rectangle's sides level with
        the reference point, and TIP_ROOM ahead of the toe tip (ahead of the reference,
        at ``tip`` or ``front``)."""
        return self._placed(self._probes_local, pos, heading, forward)

    @cached_property
    def _probes_local(self) -> np.ndarray:
        """(8, 2) ``probes``' points in the foot's frame (made once per shape: the search
        asks for them at every check)."""
        return np.concatenate([self._corners_local(), [[0.0, -self.half_width], [0.0, self.half_width],
                                                       [max(self.tip, self.front) + TIP_ROOM * self.scale, 0.0]]])

    def corners(self, pos: np.ndarray, heading: np.ndarray, forward: np.ndarray) -> np.ndarray:
        """(N, 5, 2) ground points of each footprint: the four corners, then the
        footprint's reference point itself."""
        return self._placed(self._corners_local(), pos, heading, forward)

    def _corners_local(self) -> np.ndarray:
        """(5, 2) the corners and the reference point, (along the heading, to the left)."""
        return np.array([[-self.back, -self.half_width], [-self.back, self.half_width],
                         [self.front, -self.half_width], [self.front, self.half_width], [0.0, 0.0]])

    @staticmethod
    def _placed(local: np.ndarray, pos: np.ndarray, heading: np.ndarray, forward: np.ndarray) -> np.ndarray:
        """(N, K, 2) the points ``local`` (K, 2) of the foot's frame on the ground at each
        footprint (``pos`` (N, >=2), ``heading`` (N,), heading 0 along ``forward``)."""
        ang = np.asarray(heading) + np.arctan2(forward[1], forward[0])
        c, s = np.cos(ang)[..., None], np.sin(ang)[..., None]  # (..., 1): the heading's (cos, sin)
        u, v = local[:, 0], local[:, 1]  # along the heading, to the left (-sin, cos)
        pos = np.asarray(pos)
        out = np.empty(pos.shape[:-1] + (len(local), 2))
        out[..., 0] = pos[..., None, 0] + u * c - v * s
        out[..., 1] = pos[..., None, 1] + u * s + v * c
        return out


#: m: the ground steps (up or down) by more than this between two samples EDGE_SPACING m
#: apart at an edge (a stair's nosing, a kerb) ...
EDGE_STEP = 0.04
#: ... sampled this far apart (a 25 degree slope rises 1.4 cm over it).
EDGE_SPACING = 0.03


def steps_along(height, a: np.ndarray, b: np.ndarray, z: np.ndarray, scale: float = 1.0) -> np.ndarray:
    """(N, K) m how much the ground steps between consecutive samples at most
    EDGE_SPACING (times the body's ``scale``) apart along each way from ``a`` to ``b`` (N,
    3): ``height(points (M, 3)) -> (M,)`` the surface's height under each point (nan where
    none), the points at the heights ``z`` (N,) it looks from; nan where a sample has no
    ground."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    spacing = EDGE_SPACING * scale
    k = max(int(np.ceil(np.max(np.linalg.norm(b[:, :2] - a[:, :2], axis=1), initial=0.0) / spacing)), 1)
    u = np.linspace(0.0, 1.0, k + 1)
    pts = a[:, None] + u[None, :, None] * (b - a)[:, None]
    pts[..., 2] = np.asarray(z, float)[:, None]
    h = np.asarray(height(pts.reshape(-1, 3)), float).reshape(len(a), k + 1)
    return np.abs(np.diff(h, axis=1))


def largest_step_along(height, a: np.ndarray, b: np.ndarray, z: np.ndarray, scale: float = 1.0,
                       missing: float = np.inf) -> np.ndarray:
    """(N,) m the most the ground steps between consecutive samples along each way from
    ``a`` to ``b`` (N, 3) (``steps_along``'s largest), each way sampled by its own length,
    at most EDGE_SPACING (times the body's ``scale``) apart: a short way takes few
    samples, whatever the longest (the cost is the ways' total length, not their number
    times the longest). ``height`` and ``z`` as for ``steps_along``; ``missing`` stands
    for a step to or from a sample without ground."""
    a, b = np.atleast_2d(np.asarray(a, float)), np.atleast_2d(np.asarray(b, float))
    n = len(a)
    if not n:
        return np.zeros(0)
    k = np.maximum(np.ceil(np.linalg.norm(b[:, :2] - a[:, :2], axis=1) / (EDGE_SPACING * scale)), 1).astype(int)
    way = np.repeat(np.arange(n), k + 1)
    first = np.cumsum(k + 1) - (k + 1)  # each way's first sample
    u = (np.arange(len(way)) - first[way]) / k[way]
    pts = a[way] + u[:, None] * (b - a)[way]
    pts[:, 2] = np.broadcast_to(np.asarray(z, float), (n,))[way]
    h = np.asarray(height(pts), float)
    d = np.abs(np.diff(h))
    d[np.isnan(d)] = missing
    d[first[1:] - 1] = 0.0  # (from one way's last sample to the next way's first: no step)
    return np.maximum.reduceat(d, first)


#: ``FootShape.probes`` under the front half of a foot: its front corners, its reference
#: point and the sides level with it.
FRONT_HALF = [2, 3, 4, 5, 6]


@dataclass(frozen=True)
class Support:
    ok: np.ndarray  # (N,) bool: the foot is supported and clear
    z: np.ndarray  # (N,) height of the surface at the footprint's reference point
    normal: np.ndarray  # (N, 3) normal of the plane through the foot's ground points
    reason: np.ndarray  # (N,) str: "" or why not ("off surface", "uneven", "steep", "obstacle")


@dataclass(frozen=True)
class SupportLimits:
    """What ``footprint_support`` holds a footprint to. A length left None is a human's
    (the default in brackets) times the foot's ``FootShape.scale``.

    step_height: m, how far above the footprint its ground points are dropped from (and
        below it they look: twice this) (0.3 m).
    unevenness: m, how far the foot's ground points may lie from their plane (0.05 m).
    max_slope: rad, the steepest plane a foot stands on (30 degrees, whatever the scale).
    clearance: m, how far the body above the footprint keeps from obstacles (0.25 m).
    body_height: m, how high above the footprint that clearance is kept (1.6 m).
    """

    step_height: float | None = None
    unevenness: float | None = None
    max_slope: float = np.radians(30)
    clearance: float | None = None
    body_height: float | None = None

    @staticmethod
    def of(settings: Settings) -> "SupportLimits":
        """The planner's limits: ``Settings.max_step_height`` and ``Settings.clearance``
        (already the character's), the rest a human's times the foot's scale."""
        return SupportLimits(step_height=settings.max_step_height, clearance=settings.clearance)


def footprint_support(ground: Ground, obstacles: Ground | None, pos: np.ndarray,
                      heading: np.ndarray, forward: np.ndarray, foot: FootShape,
                      limits: SupportLimits | None = None) -> Support:
    """Whether each footprint (positions (N, 3), headings (N,)) stands on the traversable
    surface and clear of obstacles, within ``limits`` (``SupportLimits``; a human's
    times the foot's ``scale`` when not given).

    The foot's four corners and centre are dropped onto the surface from
    ``limits.step_height`` above ``pos``: all must land, within ``limits.unevenness`` of
    each other, on a slope no steeper than ``limits.max_slope``. Or, on a step's edge,
    the front half of the foot (its front corners, centre and sides level with it) so,
    with the heel hanging over lower ground (a stair's nosing, going up: a long foot on a
    short tread), never over nothing. The toe tip (``FootShape.tip``) is never inside
    higher ground (a riser); it may hang over lower ground (a nosing, going down). The
    body above the footprint must keep ``limits.clearance`` from every obstacle at the
    ankle, knee, hip, chest and head (up to ``limits.body_height``).
    """
    limits = limits or SupportLimits()
    k = foot.scale
    step_height = 0.3 * k if limits.step_height is None else limits.step_height
    unevenness = 0.05 * k if limits.unevenness is None else limits.unevenness
    clearance = 0.25 * k if limits.clearance is None else limits.clearance
    body_height = 1.6 * k if limits.body_height is None else limits.body_height
    max_slope = limits.max_slope
    pos = np.atleast_2d(np.asarray(pos, dtype=np.float64))
    pts = foot.probes(pos, np.broadcast_to(heading, (len(pos),)), forward)  # (N, 8, 2)
    got, z, nor = _drop_onto(ground, pos, pts, step_height)
    all_hit = got[:, :5].all(axis=1)
    plane_n, uneven, coef = _foot_plane(pts[:, :5], z[:, :5], nor[:, :5], all_hit, unevenness)
    # the heel hanging over a nosing: the front half level, the heel corners on or below it
    half = all_hit & uneven & got[:, 5:7].all(axis=1)
    if half.any():
        pn2, un2, c2 = _foot_plane(pts[:, FRONT_HALF], z[:, FRONT_HALF], nor[:, FRONT_HALF], half, unevenness)
        hangs = (z[:, :2] - _plane_height(c2, pts[:, :2]) <= unevenness).all(axis=1)
        take = half & ~un2 & hangs
        plane_n[take], uneven[take], coef[take] = pn2[take], False, c2[take]
    # the toe tip: never inside higher ground (looked for from above the foot's own height)
    look = np.flatnonzero(all_hit & ~uneven)
    if len(look):
        tip = ground.ray_down(np.concatenate([pts[look, 7], z[look, 4, None] + step_height], axis=1),
                              2 * step_height)
        plane = _plane_height(coef[look], pts[look, 7:8])[:, 0]
        uneven[look] |= tip.hit & (tip.z - plane > unevenness)
    # (the plane's normal faces up: steeper than max_slope where its z is under the cosine)
    steep = all_hit & ~uneven & (plane_n[:, 2] < np.cos(max_slope))
    reason = _reasons(all_hit, uneven, steep)
    zc = z[:, 4]
    ok = all_hit & ~uneven & ~steep
    if obstacles is not None and obstacles.mesh.n and ok.any():
        idx = np.flatnonzero(ok)
        blocked = _blocked(obstacles, pos[idx], pts[idx, :5], zc[idx], clearance, body_height, k)
        ok[idx[blocked]] = False
        reason[idx[blocked]] = "obstacle"
    return Support(ok, zc, plane_n, reason)


def _drop_onto(ground: Ground, pos: np.ndarray, pts: np.ndarray, step_height: float
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(hit (N, K) bool, z (N, K) m, normal (N, K, 3)): the foot's ground points ``pts``
    (N, K, 2) dropped onto ``ground`` from ``step_height`` above the footprints' heights
    ``pos[:, 2]``, looking down twice that far (nan where nothing is hit)."""
    n, k = pts.shape[:2]
    top = np.empty((n, k, 3))
    top[..., :2] = pts
    top[..., 2] = pos[:, None, 2] + step_height
    hit = ground.ray_down(top.reshape(-1, 3), 2 * step_height)
    return hit.hit.reshape(n, k), hit.z.reshape(n, k), hit.normal.reshape(n, k, 3)


def _plane_height(coef: np.ndarray, xy: np.ndarray) -> np.ndarray:
    """(N, K) heights at ``xy`` (N, K, 2) of the planes z = c0 + c1 x + c2 y (``coef``
    (N, 3); nan where a plane is nan)."""
    return coef[:, None, 0] + coef[:, None, 1] * xy[..., 0] + coef[:, None, 2] * xy[..., 1]


def _foot_plane(pts: np.ndarray, z: np.ndarray, nor: np.ndarray, all_hit: np.ndarray,
                unevenness: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(normal (N, 3), uneven (N,) bool, coefficients (N, 3)) of the plane z = c0 + c1 x +
    c2 y fitted (least squares) through each footprint's K ground points ``pts`` (N, K,
    2) at heights ``z`` (N, K), for the footprints whose points all landed (``all_hit``;
    nan normal and coefficients and not uneven for the rest). Uneven: a point is more
    than ``unevenness`` m from the plane, or a surface normal ``nor`` (N, K, 3) under the
    foot is more than 15 degrees from the plane's (a step edge under the foot fits a
    tilted plane where the surface is level)."""
    n, k = pts.shape[:2]
    plane_n = np.full((n, 3), np.nan)
    coef = np.full((n, 3), np.nan)
    uneven = np.zeros(n, bool)
    if all_hit.any():
        i = np.flatnonzero(all_hit)
        # (the least-squares plane in closed form, about the points' centroid: the 2 x 2
        # normal equations of the slopes, then the height)
        x, y, zz = pts[i, :, 0], pts[i, :, 1], z[i]
        xm, ym, zm = x.sum(axis=1) / k, y.sum(axis=1) / k, zz.sum(axis=1) / k
        dx, dy, dz = x - xm[:, None], y - ym[:, None], zz - zm[:, None]
        sxx, syy, sxy = (dx * dx).sum(axis=1), (dy * dy).sum(axis=1), (dx * dy).sum(axis=1)
        sxz, syz = (dx * dz).sum(axis=1), (dy * dz).sum(axis=1)
        det = sxx * syy - sxy * sxy
        c1 = (syy * sxz - sxy * syz) / det
        c2 = (sxx * syz - sxy * sxz) / det
        c0 = zm - c1 * xm - c2 * ym
        resid = np.abs(c1[:, None] * dx + c2[:, None] * dy - dz).max(axis=1)
        norm = np.sqrt(c1 * c1 + c2 * c2 + 1.0)
        pn = np.empty((len(i), 3))
        pn[:, 0], pn[:, 1], pn[:, 2] = -c1 / norm, -c2 / norm, 1.0 / norm
        plane_n[i] = pn
        coef[i, 0], coef[i, 1], coef[i, 2] = c0, c1, c2
        agree = np.einsum("nkc,nc->nk", nor[i], pn).min(axis=1) > _AGREE
        uneven[i] = (resid > unevenness) | ~agree
    return plane_n, uneven, coef


#: cos 15 degrees: the most a surface normal under a foot may lean from the foot's plane.
_AGREE = float(np.cos(np.radians(15)))


def _reasons(all_hit: np.ndarray, uneven: np.ndarray, steep: np.ndarray) -> np.ndarray:
    """(N,) object array of str: "" for a supported footprint, else why not ("off
    surface", "uneven", "steep")."""
    reason = np.full(len(all_hit), "", dtype=object)
    reason[~all_hit] = "off surface"
    reason[uneven] = "uneven"
    reason[steep] = "steep"
    return reason


def _blocked(obstacles: Ground, pos: np.ndarray, pts: np.ndarray, zc: np.ndarray,
             clearance: float, body_height: float, scale: float = 1.0) -> np.ndarray:
    """(M,) bool: the body standing on each of M footprints (positions ``pos`` (M, 3),
    ground points ``pts`` (M, 5, 2), surface heights ``zc`` (M,) m) meets an obstacle:
    within ``clearance`` of one at the ankle, knee, hip, chest or head (0.1, 0.5, 0.9,
    1.3 m, a human's times the body's ``scale``, and ``body_height`` above ``zc``), under
    or inside one (an obstacle surface between the foot and the head), or the foot's
    ground points, 0.02 m up (times ``scale``), within that of one."""
    m = len(pos)
    levels = np.array([0.1 * scale, 0.5 * scale, 0.9 * scale, 1.3 * scale, body_height])
    near = 0.02 * scale
    # the body's points over each footprint, then the foot's own, 2 cm up: one query for both
    probe = np.empty((m, len(levels) + 5, 3))
    probe[:, :len(levels), :2] = pos[:, None, :2]
    probe[:, :len(levels), 2] = zc[:, None] + levels
    probe[:, len(levels):, :2] = pts
    probe[:, len(levels):, 2] = zc[:, None] + near
    _, d = obstacles.nearest(probe.reshape(-1, 3), max_dist=max(clearance, near))
    d = d.reshape(m, -1)
    blocked = (d[:, :len(levels)] < clearance).any(axis=1)
    # the foot itself must not stand in an obstacle either
    blocked |= (d[:, len(levels):] < near).any(axis=1)
    # inside or under an obstacle (a thick wall's inside is far from all its faces)
    head = probe[:, len(levels) - 1]
    blocked |= obstacles.ray_down(head, body_height - 0.05 * scale).hit
    return blocked
