"""Stair treads: found once in the traversable mesh, and the footprints the search puts on
them set square and whole on the tread.

A person climbs a flight with each foot square to the tread it lands on and wholly on it
(or, on a tread shorter than the foot, the toe to the riser going up, the heel hanging
over the nosing). A library's steps are fixed vectors, and a flight's treads take a
footprint only in a window of a few centimetres along the flight: left alone, the
search lands few of its steps in those windows, turns the feet askew to fit, and takes
thousands of expansions to find a way up (the Stairs sample scene's took 25 s). So a
successor whose reference point falls on a tread is moved the least that puts its foot
on the tread, and turned square to it (its foot's own toe-out kept), before its support
is checked: many near steps land on the same footprint, which the search then merges.

A tread is a horizontal, rectangular patch of the mesh (its triangles joined by shared
vertices), narrower than ``TREAD_DEPTH`` along the flight and at least ``TREAD_ASPECT``
times as wide, with a riser up on one long side and down on the other (each between
``CLIMB_DZ`` and the planner's step height): a flight's tread, never a beam, a kerb or a
landing. Reads the mesh and the ground; returns positions and headings; never changes a
footprint it cannot put wholly on a tread.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import ConvexHull, QhullError

from ..base.angles import wrap
from .step_rules import CLIMB_DZ
from .surface import TIP_ROOM, FootShape, Ground, TriMesh, ground_heights

#: m (a human's): a tread is at most this deep along its flight ...
TREAD_DEPTH = 0.5
#: ... and at least this many times as wide as deep.
TREAD_ASPECT = 1.5
#: m (a human's): the foot is kept this far inside a tread's edges.
EDGE_MARGIN = 0.005
#: rad: a footprint turned further than this from a tread's square is left as it is (a
#: step across a flight, not up it).
MAX_SQUARE_TURN = np.radians(35.0)
#: rad: two treads whose flights' directions differ by less than this are of one flight.
SAME_FLIGHT = np.radians(10.0)
#: a tread's patch fills at least this share of its bounding rectangle.
RECT_FILL = 0.9


@dataclass(frozen=True)
class Treads:
    """P treads: ``center`` (P, 2) m, ``up`` (P, 2) the unit direction across the tread
    toward the higher riser (along the flight, upward), ``depth`` (P,) m along it,
    ``width`` (P,) m across it, ``z`` (P,) m the tread's height."""

    center: np.ndarray
    up: np.ndarray
    depth: np.ndarray
    width: np.ndarray
    z: np.ndarray

    @staticmethod
    def none() -> "Treads":
        return Treads(np.zeros((0, 2)), np.zeros((0, 2)), np.zeros(0), np.zeros(0), np.zeros(0))

    def __len__(self) -> int:
        return len(self.z)

    def under(self, xy: np.ndarray, z_from: np.ndarray, reach: float) -> np.ndarray:
        """(N,) the tread under each point ``xy`` (N, 2) within ``reach`` m up or down of
        ``z_from`` (N,), the highest of several; -1 where none."""
        d = np.asarray(xy, float)[:, None, :] - self.center[None]
        along = np.einsum("npc,pc->np", d, self.up)
        across = d[..., 0] * -self.up[None, :, 1] + d[..., 1] * self.up[None, :, 0]
        inside = ((np.abs(along) <= 0.5 * self.depth) & (np.abs(across) <= 0.5 * self.width)
                  & (np.abs(self.z[None] - np.asarray(z_from, float)[:, None]) <= reach))
        score = np.where(inside, self.z[None], -np.inf)
        best = np.argmax(score, axis=1)
        return np.where(inside.any(axis=1), best, -1)

    def square(self, xy: np.ndarray, angle: np.ndarray, z_from: np.ndarray, toe: np.ndarray,
               foot: FootShape, reach: float, beside: tuple | None = None
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(xy (N, 2), angle (N,), state (N,) int: 0 off every tread, 1 moved onto one, -1
        on one but unable to stand there square): footprints at ``xy`` turned ``angle``
        (world yaw, rad) whose reference point lies on a tread within ``reach`` of
        ``z_from`` (N,), turned square to it (plus their own ``toe`` (N,) rad: the foot's
        turn out) and moved the least along and across the tread that puts the foot on it
        (``FootShape``'s rectangle, EDGE_MARGIN inside; going up, its toe tip TIP_ROOM
        from the riser ahead, and going down the tip free to hang over the nosing, as
        ``footprint_support`` asks; a tread shorter than the foot is taken going up, the
        toe to the riser and the heel over the nosing below); the others unchanged. A
        footprint on a tread that can't be set so (turned further than MAX_SQUARE_TURN from
        its square, a tread too narrow, or going down one shorter than the foot) is -1: no
        foot stands askew on a flight. ``beside``: (the other foot's footprint
        (2,), the stance width m, +1 for a left foot or -1 for a right one): where that
        footprint stands on a tread of the same flight, the foot is set that far to its
        side, square across the flight (a flight is climbed in a straight line, not in the
        sideways steps of turning clips). Vectorised over footprints."""
        xy = np.array(xy, float, copy=True)
        angle = np.array(angle, float, copy=True)
        moved = np.zeros(len(xy), np.int8)
        if not len(self) or not len(xy):
            return xy, angle, moved
        t = self.under(xy, z_from, reach)
        on = np.flatnonzero(t >= 0)
        if not len(on):
            return xy, angle, moved
        moved[on] = -1
        p = t[on]
        up = self.up[p]
        a_up = np.arctan2(up[:, 1], up[:, 0])
        rel = wrap(angle[on] - toe[on] - a_up)
        climbing = np.abs(rel) <= 0.5 * np.pi
        square = np.where(climbing, a_up, a_up + np.pi)
        turn = wrap(square + toe[on] - angle[on])
        ok = np.abs(turn) <= MAX_SQUARE_TURN
        h = np.where(climbing[:, None], up, -up)  # (the way the foot faces, square)
        side = np.c_[-h[:, 1], h[:, 0]]
        d = xy[on] - self.center[p]
        along, across = np.einsum("nc,nc->n", d, h), np.einsum("nc,nc->n", d, side)
        new_along, room, fits = self._room(p, along, climbing, toe[on], foot)
        ok &= fits
        if beside is not None:  # (the other foot on a tread of this flight: a straight line up it)
            across = self._beside(p, side, across, beside, z_from[:1], foot.scale)
        new_across = np.clip(across, -np.maximum(room, 0.0), np.maximum(room, 0.0))
        new_xy = self.center[p] + new_along[:, None] * h + new_across[:, None] * side
        sel = on[ok]
        xy[sel] = new_xy[ok]
        angle[sel] = square[ok] + toe[on][ok]
        moved[sel] = 1
        return xy, angle, moved


    def _room(self, p: np.ndarray, along: np.ndarray, climbing: np.ndarray, toe: np.ndarray, foot: FootShape
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(along (n,) m, room (n,) m, fits (n,) bool) for footprints on treads ``p`` (n,)
        facing square up (``climbing``) or down them, turned out ``toe`` (n,) rad: the
        reference point's place along the tread nearest ``along`` (n,) (from the tread's
        middle, the way the foot faces) where the foot stands on it, how far it may go to
        either side, and whether it can stand there at all. The heel EDGE_MARGIN inside the
        back edge; the front, going up, the toe tip TIP_ROOM from the riser ahead, and going
        down the foot's rectangle on the tread (the tip may hang over the nosing); a foot
        turned out reaches a little further along and across. A tread shorter than the
        foot is taken going up with the toe to the riser, the heel hanging over the nosing
        below; going down it can't be stood on square."""
        k = foot.scale
        m = EDGE_MARGIN * k
        half = 0.5 * self.depth[p]
        c, s = np.cos(toe), np.abs(np.sin(toe))
        front = np.where(climbing, (max(foot.front, foot.tip) + TIP_ROOM * k) * c + m,
                         foot.front * c + foot.half_width * s + m)
        lo, hi = -half + m + foot.back * c + foot.half_width * s, half - front
        short = lo > hi
        room = 0.5 * self.width[p] - m - (foot.half_width * c + max(foot.back, foot.front) * s)
        return np.where(~short, np.clip(along, lo, hi), hi), room, (~short | climbing) & (room >= 0.0)

    def _beside(self, p: np.ndarray, side: np.ndarray, across: np.ndarray, beside: tuple, z_from: np.ndarray,
                scale: float) -> np.ndarray:
        """(n,) m across the treads ``p`` (their ``side`` (n, 2) unit vectors, left of the
        way the foot faces) where the foot goes: ``beside``'s stance width to the side of
        the other foot where that stands on a tread of the same flight (within SAME_FLIGHT),
        else ``across`` as it is."""
        other, width, sign = beside
        other = np.asarray(other, float)[:2]
        o = self.under(other[None], z_from, CLIMB_DZ * scale)[0]
        if o < 0:
            return across
        same = np.abs(self.up[p] @ self.up[o]) > np.cos(SAME_FLIGHT)
        return np.where(same, np.einsum("nc,nc->n", other[None] - self.center[p], side) + sign * width, across)

def find_treads(mesh: TriMesh, ground: Ground, step_height: float, scale: float = 1.0) -> Treads:
    """The stair treads of ``mesh`` (the traversable surfaces; see the module's
    docstring), their risers measured on ``ground`` up to ``step_height`` m; lengths a
    human's times the body's ``scale``."""
    if not mesh.n:
        return Treads.none()
    c = mesh.corners()
    cross = np.cross(c[:, 1] - c[:, 0], c[:, 2] - c[:, 0])
    norm = np.linalg.norm(cross, axis=1)
    flat = np.flatnonzero((norm > 1e-12) & (np.abs(cross[:, 2]) >= np.cos(np.radians(3.0)) * norm))
    if not len(flat):
        return Treads.none()
    # patches: flat triangles joined by a shared edge (its vertices welded; two treads of
    # one height that touch at a corner, as where a flight turns, stay two)
    weld = np.unique(np.rint(mesh.verts / 1e-4).astype(np.int64), axis=0, return_inverse=True)[1].ravel()
    v = weld[mesh.tris[flat]]  # (F, 3)
    edges = np.sort(v[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    _, edge_id = np.unique(edges, axis=0, return_inverse=True)
    rows = np.repeat(np.arange(len(flat)), 3)
    g = coo_matrix((np.ones(len(rows)), (rows, edge_id.ravel())), shape=(len(flat), int(edge_id.max()) + 1)).tocsr()
    n_patch, label = connected_components(g @ g.T, directed=False)
    out = [_tread(c[flat[label == i]], norm[flat[label == i]], scale) for i in range(n_patch)]
    cand = [t for t in out if t is not None]
    if not cand:
        return Treads.none()
    center, axis, depth, width, z = (np.array(x) for x in zip(*cand))
    up, keep = _risers(ground, center, axis, depth, width, z, step_height, scale)
    return Treads(center[keep], up[keep], depth[keep], width[keep], z[keep])


def _tread(tris: np.ndarray, area2: np.ndarray, scale: float):
    """(center (2,), axis (2,), depth, width, z) of a flat patch of triangles ``tris``
    (K, 3, 3) (``area2`` (K,) their doubled areas) that is a narrow rectangle; else
    None. ``axis``: the unit direction of its short side."""
    pts = tris[:, :, :2].reshape(-1, 2)
    try:
        hull = ConvexHull(pts)
    except (QhullError, ValueError):
        return None
    hp = pts[hull.vertices]
    edges = np.diff(np.r_[hp, hp[:1]], axis=0)
    dirs = edges / np.maximum(np.linalg.norm(edges, axis=1, keepdims=True), 1e-12)
    best = None
    for u in dirs:  # (the minimum-area rectangle has a side along a hull edge)
        w = np.array([-u[1], u[0]])
        a, b = hp @ u, hp @ w
        extent = (a.max() - a.min(), b.max() - b.min())
        if best is None or extent[0] * extent[1] < best[0]:
            best = (extent[0] * extent[1], u, w, a, b, extent)
    rect, u, w, a, b, (eu, ew) = best
    if rect <= 0 or 0.5 * area2.sum() < RECT_FILL * rect:
        return None
    axis, depth, width = (u, eu, ew) if eu <= ew else (w, ew, eu)
    if depth > TREAD_DEPTH * scale or width < TREAD_ASPECT * depth:
        return None
    center = 0.5 * (a.max() + a.min()) * u + 0.5 * (b.max() + b.min()) * w
    return center, axis, depth, width, float(tris[:, :, 2].mean())


def _risers(ground: Ground, center, axis, depth, width, z, step_height: float, scale: float):
    """(up (P, 2), tread (P,) bool): for each narrow patch, the direction along ``axis``
    toward its higher side, and whether the ground just beyond its two long edges is a
    riser up on one side and down on the other (CLIMB_DZ to ``step_height``)."""
    k = scale
    reach = 0.5 * depth + 0.04 * k
    side = np.c_[-axis[:, 1], axis[:, 0]]
    offsets = np.array([-0.25, 0.0, 0.25])
    h = []
    for sign in (1.0, -1.0):
        p = (center[:, None] + sign * reach[:, None, None] * axis[:, None]
             + offsets[None, :, None] * width[:, None, None] * side[:, None])
        top = np.c_[p.reshape(-1, 2), np.repeat(z + step_height + 0.01 * k, len(offsets))]
        hz = ground_heights(ground, top, 2.0 * step_height + 0.02 * k).reshape(len(z), len(offsets))
        h.append(np.median(_fill(hz), axis=1))
    dz_pos, dz_neg = h[0] - z, h[1] - z
    lo, hi = CLIMB_DZ * k, step_height
    rise = lambda d: np.isfinite(d) & (d >= lo) & (d <= hi)  # noqa: E731
    pos_up, neg_up = rise(dz_pos) & rise(-dz_neg), rise(dz_neg) & rise(-dz_pos)
    up = np.where(neg_up[:, None], -axis, axis)
    return up, pos_up | neg_up


def _fill(hz: np.ndarray) -> np.ndarray:
    """``hz`` (P, K) with each row's missing heights (nan) set to the row's first seen
    one (a row with none stays nan): a median that ignores the misses, without warnings."""
    seen = np.isfinite(hz)
    first = np.where(seen.any(axis=1), hz[np.arange(len(hz)), np.argmax(seen, axis=1)], np.nan)
    return np.where(seen, hz, first[:, None])


__all__ = ["TREAD_DEPTH", "Treads", "find_treads"]
