"""The search's heuristic: ``DistanceField``, the walking distance to the goal on a
coarse grid of up to ``LAYERS`` levels per cell, solved over ``FieldCells`` (the grid,
``_Grid``, and its walking edges and bridges across gaps, built once per search, within
the field's ``FieldLimits``), with the
weighted search's preferences it carries (``EDGE_COST``, ``CLIMB_COST``, the way ahead:
``AHEAD_CELLS``, ``FREE_TURN``, ``AHEAD_TURN_COST``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np
from scipy.ndimage import binary_dilation
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra

from .surface import ground_heights


@dataclass(frozen=True)
class FieldLimits:
    """What the distance field's cells are built to: the grid and the body's limits on it.

    cell: m, the grid's cell size.
    clearance: m, how far the body keeps from obstacles for a cell to be walkable.
    jump_reach: m, the longest bridge across a gap of missing ground.
    step_height: m, the most two neighbouring walkable levels' heights differ.
    jump_extra: m, what a bridge costs more than its length.
    edge_cost: a way along cells beside unwalkable ones counts this many times its length.
    scale: the body's (``Settings.body_scale``), for the grid's own lengths (``HEADROOM``, ...).
    """

    cell: float
    clearance: float
    jump_reach: float
    step_height: float
    jump_extra: float = 0.0
    edge_cost: float = 1.0
    scale: float = 1.0


@dataclass
class DistanceField:
    """Walking distance to the goal on a coarse grid: the search's heuristic.

    The grid has up to ``LAYERS`` levels per cell (a bridge over a floor: the floor is a
    second level, found below the first with ``HEADROOM`` between them). A cell's level
    is walkable when the ground is there and the body there keeps its clearance from
    obstacles. Walkable neighbours (8-connected) whose heights differ by no more than a
    step are joined by their distance, and border cells across a gap of missing ground by
    a straight bridge no longer than ``jump_reach`` (never across an obstacle).
    Distances are 5 % short of the grid's, so the heuristic stays below the true
    remaining walk."""

    origin: np.ndarray
    cell: float
    shape: tuple[int, int]
    dist: np.ndarray  # (L, nx, ny), inf where the goal cannot be reached on the grid
    z: np.ndarray = field(default=None, repr=False)  # (L, nx, ny) each level's height, nan where none
    graph: object = field(default=None, repr=False)  # the cells' sparse graph
    ahead: np.ndarray = field(default=None, repr=False)  # (L * nx * ny,) rad: the way to the goal, nan at it

    def _nodes(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(node ids (N,), -1 off the grid, and the levels' distances (N, L)) of points
        (N, >=2); a point with a height (N, 3) takes the level nearest its height, one
        without the level nearest the goal."""
        nx, ny = self.shape
        i = np.floor((p[:, 0] - self.origin[0]) / self.cell).astype(np.int64)
        j = np.floor((p[:, 1] - self.origin[1]) / self.cell).astype(np.int64)
        inside = (i >= 0) & (i < nx) & (j >= 0) & (j < ny)
        ii, jj = np.where(inside, i, 0), np.where(inside, j, 0)
        d = self.dist[:, ii, jj].T  # (N, L)
        if len(self.dist) == 1:  # (one level: it)
            level = 0
        elif p.shape[1] >= 3 and self.z is not None:
            dz = np.abs(self.z[:, ii, jj].T - p[:, 2:3])
            level = np.argmin(np.where(np.isfinite(dz), dz, np.inf), axis=1)
        else:
            level = np.argmin(d, axis=1)
        ids = np.where(inside, level * nx * ny + ii * ny + jj, -1)
        return ids, np.where(inside[:, None], d, np.inf)

    def at_many(self, p: np.ndarray) -> np.ndarray:
        p = np.atleast_2d(np.asarray(p, float))
        ids, _ = self._nodes(p)
        out = np.full(len(p), np.inf)
        ok = ids >= 0
        out[ok] = self.dist.ravel()[ids[ok]]
        return out

    def at_and_ahead(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(distance (N,), the direction (N,) rad, world yaw, of the way to the goal a few
        cells on from each point, nan where unknown) of points (N, >=2)."""
        p = np.atleast_2d(np.asarray(p, float))
        ids, _ = self._nodes(p)
        d, a = np.full(len(p), np.inf), np.full(len(p), np.nan)
        ok = ids >= 0
        d[ok] = self.dist.ravel()[ids[ok]]
        if self.ahead is not None:
            a[ok] = self.ahead[ids[ok]]
        return d, a

    def nearest_reachable(self, start, goal) -> np.ndarray:
        """The centre (x, y, level height) of the cell reachable from ``start`` nearest
        the goal."""
        ids, _ = self._nodes(np.atleast_2d(np.asarray(start, float)))
        nx, ny = self.shape
        if ids[0] < 0:
            return np.asarray(start, float)[:3].copy()
        d = dijkstra(self.graph, directed=False, indices=int(ids[0]))
        ok = np.flatnonzero(np.isfinite(d))
        cx = self.origin[0] + ((ok % (nx * ny)) // ny + 0.5) * self.cell
        cy = self.origin[1] + (ok % ny + 0.5) * self.cell
        k = int(np.argmin(np.hypot(cx - goal[0], cy - goal[1])))
        return np.array([cx[k], cy[k], float(np.nan_to_num(self.z.ravel()[ok[k]]))])

    @staticmethod
    def build(ground, obstacles, goal, limits: FieldLimits, avoid: tuple | None = None,
              support: Callable | None = None) -> "DistanceField":
        """The walking distance (m) to ``goal`` from every cell level of a grid of
        ``limits.cell`` metres over the ground's bounds: walkable levels (ground, body
        clear of obstacles by ``limits.clearance``), joined 8-connected within
        ``limits.step_height`` and, across gaps, by bridges up to ``limits.jump_reach``
        long that cost ``limits.jump_extra`` m more than their length (none with an end
        within ``avoid`` = (point, radius)); a way along cells beside unwalkable ones
        counts ``limits.edge_cost`` times its length; Dijkstra from the goal's cell. With
        ``support`` (footprints (N, 3), headings (N,) -> whether a foot may stand there
        (N,)), a cell where the ground's slope changes (a step's edge) is walkable only
        where a foot fits in it (``_Grid.foot_room``)."""
        cells = FieldCells.build(ground, obstacles, limits, support)
        return DistanceField.solve(cells, goal, avoid)

    @staticmethod
    def solve(cells: "FieldCells", goal, avoid: tuple | None = None) -> "DistanceField":
        """The field to ``goal`` over cells built before (``FieldCells``), without the
        bridges with an end within ``avoid`` = (point, radius): only the graph and
        Dijkstra, so a search that drops jumps where it is stuck builds its cells once."""
        goal = np.asarray(goal, float)
        grid = cells.grid
        edges = [cells.walk_edges] + ([grid.away(*cells.bridge_edges, avoid)] if len(cells.bridge_edges[0]) else [])
        rows, cols, vals = (np.concatenate(e) for e in zip(*edges))
        cell = grid.cell
        n = grid.ids.size
        graph = coo_matrix((vals, (rows, cols)), shape=(n, n)).tocsr()
        probe = DistanceField(grid.lo, cell, (grid.nx, grid.ny), np.zeros(grid.ids.shape), grid.z)
        gi = np.clip(np.floor((goal[:2] - grid.lo) / cell).astype(int), 0, [grid.nx - 1, grid.ny - 1])
        gid, _ = probe._nodes(np.array([[grid.lo[0] + (gi[0] + 0.5) * cell, grid.lo[1] + (gi[1] + 0.5) * cell,
                                         goal[2]]]))
        d, pred = dijkstra(graph, directed=False, indices=int(gid[0]), return_predecessors=True)
        # the way ahead: the cell AHEAD_CELLS on towards the goal along the shortest way
        on = np.where(pred >= 0, pred, np.arange(n))
        for _ in range(AHEAD_CELLS - 1):
            on = np.where(pred[on] >= 0, pred[on], on)
        nn = grid.nx * grid.ny
        to = grid.xy[on % nn] - grid.xy[np.arange(n) % nn]
        ahead = np.where((on != np.arange(n)) & np.isfinite(d), np.arctan2(to[:, 1], to[:, 0]), np.nan)
        # 5 % short, and a cell's own size short, so the heuristic stays a lower bound
        d = np.maximum(0.95 * d - 1.5 * cell, 0.0)
        return DistanceField(grid.lo, cell, (grid.nx, grid.ny), d.reshape(grid.ids.shape), grid.z, graph, ahead)


@dataclass
class FieldCells:
    """The distance field's cells and their edges, whatever the goal: the grid, the walking
    edges (rows, cols, lengths) and the bridges across gaps (with their ``jump_extra``)."""

    grid: "_Grid"
    walk_edges: tuple
    bridge_edges: tuple

    @staticmethod
    def build(ground, obstacles, limits: FieldLimits, support: Callable | None = None,
              steps: tuple = (), islands: Callable | None = None) -> "FieldCells":
        """The cells of ``DistanceField.build`` (same arguments, less the goal and ``avoid``).
        ``steps``: (reach m, extra m) of the library's gaits whose steps cross gaps (a walk
        or run step over a gap it spans from one island of the ground to another,
        ``Planner._bridged``), shortest first: a gap is bridged up to each one's reach at
        its extra, beyond the last by the jump's (up to ``limits.jump_reach``, at
        ``limits.jump_extra``). ``islands``: points (N, 3) -> (N,) the ground's island
        there (-1 none); with it, two cells on one island alone (a floor's notch between
        them) are bridged only by a jump over a metre long, as without ``steps`` (the
        search's steps keep to the ground there)."""
        cell, clearance, step_height = limits.cell, limits.clearance, limits.step_height
        jump_reach, jump_extra, edge_cost = limits.jump_reach, limits.jump_extra, limits.edge_cost
        grid = _Grid.over(ground, cell, step_height, limits.scale)
        has_ground, blocked = grid.ground_and_blocked(obstacles, clearance)
        walk = has_ground & ~blocked
        if support is not None:
            walk = grid.foot_room(support, walk)
        edges = grid.neighbour_edges(walk, step_height, grid.edge_cells(walk, has_ground), edge_cost)
        walk_edges = tuple(np.concatenate(e) for e in zip(*edges))
        gap = grid.gaps(has_ground, step_height)
        bridges, shortest = [], 1.5 * cell  # (beyond the 8 neighbours)
        sole = grid.sole_islands(islands, walk, gap) if steps and islands is not None else None
        if sole is not None and np.unique(sole[sole != -2]).tolist() in ([], [max(sole.max(), 0)]):
            steps, sole = (), None  # (one island alone about the gaps: a jump over a metre, as without steps)
        for k, (reach, extra) in enumerate(list(steps) + [(jump_reach, jump_extra)]):
            jump = k == len(steps)
            # (a jump over one island's void, where steps keep to its ground: over a metre, as ever)
            lo = min(shortest, 1.0) if jump and sole is not None else shortest
            if reach > lo:
                got = grid.bridges(walk, gap, blocked, reach, step_height, lo if steps else 1.0)
                if sole is not None:  # (a step only from island to island)
                    kept = []
                    for a, b, c in got:
                        one = (sole[a] == sole[b]) & (sole[a] >= 0)
                        keep = np.where(one, c > 1.0, c > shortest) if jump else ~one
                        kept.append((a[keep], b[keep], c[keep]))
                    got = kept
                bridges += [(a, b, c + extra) for a, b, c in got]
                shortest = max(shortest, reach)
        if bridges:
            bridge_edges = tuple(np.concatenate(e) for e in zip(*bridges))
        else:
            bridge_edges = (np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0))
        return FieldCells(grid, walk_edges, bridge_edges)


#: How much longer the heuristic counts a way along a cell beside an unwalkable one ...
EDGE_COST = 1.5
#: ... and one up or down a riser of a flight of stairs (``_Grid.flight_cells``: a step
#: of more than CLIMB_STEP m between treads): stairs are climbed in shortened strides,
#: several times a walk's time per metre (weighted search only, as EDGE_COST).
CLIMB_COST = 3.0
CLIMB_STEP = 0.1

#: The weighted search's heuristic adds AHEAD_TURN_COST seconds per radian that a
#: footprint is turned away from the way to the goal (the direction to the cell
#: AHEAD_CELLS on along the map's shortest way) beyond FREE_TURN rad: the search turns
#: towards a bend before it reaches it instead of running into its outer edge. (The
#: library's own turns cost little more than straight steps, ``_turn_cost``; this is a
#: preference of the weighted search, never used by plain A*.)
AHEAD_CELLS = 8
FREE_TURN = 0.25
AHEAD_TURN_COST = 0.1

#: Levels of the distance field per cell, and the headroom (m) between two levels: a
#: surface closer under another than this is that one's underside.
LAYERS = 3
HEADROOM = 1.0


@dataclass
class _Grid:
    """The distance field's cells: origin ``lo`` (2,), ``cell`` m, ``nx`` x ``ny`` cells
    of up to L levels, their ids (L, nx, ny) and heights ``z`` (L, nx, ny) (nan where a
    cell has fewer levels)."""

    lo: np.ndarray
    cell: float
    nx: int
    ny: int
    ids: np.ndarray
    z: np.ndarray
    xy: np.ndarray  # (nx * ny, 2) the cells' centres
    scale: float = 1.0  # the body's (``Settings.body_scale``): this grid's own lengths are a human's times it

    @staticmethod
    def over(ground, cell: float, step_height: float, scale: float = 1.0) -> "_Grid":
        lo, hi = ground.mesh.bounds()
        zlo = lo[2]
        lo = lo[:2] - cell
        nx, ny = (np.ceil((hi[:2] + cell - lo) / cell)).astype(int)
        cx = lo[0] + (np.arange(nx) + 0.5) * cell
        cy = lo[1] + (np.arange(ny) + 0.5) * cell
        xx, yy = np.meshgrid(cx, cy, indexing="ij")
        xy = np.c_[xx.ravel(), yy.ravel()]
        z = np.full((LAYERS, xy.shape[0]), np.nan)
        z[0] = ground_heights(ground, np.c_[xy, np.full(len(xy), hi[2] + step_height)], hi[2] - zlo + 2 * step_height)
        for k in range(1, LAYERS):  # the levels below, where there is room for one
            top = z[k - 1] - HEADROOM * scale
            ask = np.flatnonzero(np.isfinite(top) & (top > zlo - 1e-6))
            if not len(ask):
                break
            z[k, ask] = ground_heights(ground, np.c_[xy[ask], top[ask]], float(top[ask].max() - zlo) + 1e-3)
        used = max(1, int(np.isfinite(z).any(axis=1).sum()))
        z = z[:used].reshape(used, nx, ny)
        return _Grid(lo, cell, int(nx), int(ny), np.arange(z.size).reshape(z.shape), z, xy, scale)

    def foot_room(self, support: Callable, walk: np.ndarray) -> np.ndarray:
        """``walk`` without the cell levels where the ground's slope changes (a step's edge,
        a ramp's end: a second difference of the neighbours' heights over 2 cm) and no
        footprint sampled in the cell may be stood on (its centre, then 8 points 8 cm
        round it, each turned 0, 45, 90 and 135 degrees): steps whose treads no foot
        fits on."""
        z = np.where(np.isfinite(self.z), self.z, np.nan)
        zp = np.pad(z, ((0, 0), (1, 1), (1, 1)), mode="edge")
        d2 = np.stack([zp[:, 2:, 1:-1] - 2 * z + zp[:, :-2, 1:-1], zp[:, 1:-1, 2:] - 2 * z + zp[:, 1:-1, :-2]])
        kink = walk & (np.nan_to_num(np.abs(d2), nan=0.0).max(axis=0) > 0.02 * self.scale)
        cand = np.flatnonzero(kink.ravel())
        if not len(cand):
            return walk
        n = self.nx * self.ny
        heads = np.radians([0.0, 45.0, 90.0, 135.0])
        fits = np.zeros(len(cand), bool)
        r = 0.08 * self.scale
        for off in ([(0.0, 0.0)], [(a, b) for a in (-r, 0.0, r) for b in (-r, 0.0, r) if a or b]):
            todo = np.flatnonzero(~fits)
            if not len(todo):
                break
            c = cand[todo]
            pos = (self.xy[c % n][:, None, None] + np.array(off)[None, :, None]).reshape(-1, 2)
            pos = np.repeat(pos, len(heads), axis=0)
            zz = np.repeat(self.z.ravel()[c], len(off) * len(heads))
            ok = support(np.c_[pos, zz], np.tile(heads, len(c) * len(off)))
            fits[todo] = ok.reshape(len(c), -1).any(axis=1)
        out = walk.copy()
        out.ravel()[cand[~fits]] = False
        return out

    def away(self, a: np.ndarray, b: np.ndarray, c: np.ndarray, avoid: tuple | None) -> tuple:
        """The edges (a, b, c) with neither end's cell within ``avoid`` = (point, radius)."""
        if avoid is None:
            return a, b, c
        p, r = np.asarray(avoid[0], float)[:2], avoid[1]
        n = self.nx * self.ny
        keep = (np.linalg.norm(self.xy[a % n] - p, axis=1) > r) & (np.linalg.norm(self.xy[b % n] - p, axis=1) > r)
        return a[keep], b[keep], c[keep]

    def ground_and_blocked(self, obstacles, clearance: float):
        """(has ground (L, nx, ny), blocked (L, nx, ny)): ground at each level of a cell, and
        an obstacle within the clearance of the body there (at 0.5 and 1.3 m above it)."""
        has_ground = np.isfinite(self.z)
        blocked = np.zeros(self.z.shape, bool)
        if obstacles is not None and obstacles.mesh.n:
            idx = np.flatnonzero(has_ground.ravel())
            cxy = self.xy[idx % (self.nx * self.ny)]
            zz = self.z.ravel()[idx]
            for level in (0.5, 1.3):
                _, d = obstacles.nearest(np.c_[cxy, zz + level * self.scale], max_dist=clearance)
                blocked.ravel()[idx[d < clearance * 0.9]] = True
        return has_ground, blocked

    def edge_cells(self, walk: np.ndarray, has_ground: np.ndarray) -> np.ndarray:
        """(L, nx, ny) walkable cell levels beside an unwalkable cell (no ground, or an
        obstacle too near): a footprint there has little room. One beside an obstacle
        alone (``has_ground`` (L, nx, ny) on its four sides) counts only where an inner
        cell (walkable on its four sides) is among its eight neighbours: between walls two
        cells apart (a corridor a metre wide) the way has to go along them, and counting it
        dearer told the search that each metre there costs more than it does (CMU ran the
        length of a 1 m corridor, its long running steps seeming the cheaper by the map).
        An edge of the ground (a platform's, a stepping stone's) counts always."""
        def on_four_sides(m: np.ndarray) -> np.ndarray:
            pm = np.pad(m, 1)
            return pm[2:, 1:-1] & pm[:-2, 1:-1] & pm[1:-1, 2:] & pm[1:-1, :-2]

        any_walk = walk.any(axis=0)
        inner = any_walk & on_four_sides(any_walk)
        room = binary_dilation(inner, np.ones((3, 3), bool))
        void = ~on_four_sides(has_ground.any(axis=0))
        return walk & ~inner[None] & (room | void)[None]

    def flight_cells(self, walk: np.ndarray, step_height: float) -> np.ndarray:
        """(L, nx, ny) walkable cell levels with a step up or down (more than CLIMB_STEP,
        within ``step_height``) on two or more of their four sides: a stair's treads, not
        the top or the foot of a single kerb."""
        nx, ny = self.nx, self.ny
        z = np.where(walk, self.z, np.nan)
        count = np.zeros(walk.shape, int)
        for di, dj in ((1, 0), (-1, 0), (0, 1), (0, -1)):
            here = (slice(max(0, -di), nx - max(0, di)), slice(max(0, -dj), ny - max(0, dj)))
            there = (slice(max(0, di), nx + min(0, di)), slice(max(0, dj), ny + min(0, dj)))
            near = np.zeros(walk.shape, bool)
            for lb in range(walk.shape[0]):
                dz = np.abs(z[(slice(None),) + here] - z[lb][there][None])
                near[(slice(None),) + here] |= (dz > CLIMB_STEP * self.scale) & (dz <= step_height)
            count += near
        return walk & (count >= 2)

    def neighbour_edges(self, walk: np.ndarray, step_height: float, edge: np.ndarray | None = None,
                        edge_cost: float = 1.0) -> list[tuple]:
        """(rows, cols, lengths) of the edges between 8-connected walkable cell levels
        whose heights differ by at most ``step_height``; an edge touching a cell beside
        an unwalkable one (``edge``) is ``edge_cost`` times as long, so the heuristic's
        way keeps off edges and walls as footprints must, and (with ``edge_cost`` too) one
        up or down a riser between two stair treads (``flight_cells``) CLIMB_COST times:
        stairs are climbed in short steps."""
        nx, ny, out = self.nx, self.ny, []
        nl = walk.shape[0]
        flight = self.flight_cells(walk, step_height) if edge is not None and edge_cost != 1.0 else None
        for di, dj in ((1, 0), (0, 1), (1, 1), (1, -1)):
            sa = (slice(0, nx - di), slice(max(0, -dj), ny - max(0, dj)))
            sb = (slice(di, nx), slice(max(0, dj), ny + min(0, dj)))
            for la in range(nl):
                for lb in range(nl):
                    m = walk[la][sa] & walk[lb][sb]
                    m &= np.abs(np.nan_to_num(self.z[la][sa] - self.z[lb][sb], nan=np.inf)) <= step_height
                    length = np.full(m.sum(), np.hypot(di, dj) * self.cell)
                    if edge is not None and edge_cost != 1.0:
                        length *= np.where(edge[la][sa][m] | edge[lb][sb][m], edge_cost, 1.0)
                        riser = (np.abs(self.z[la][sa][m] - self.z[lb][sb][m]) > CLIMB_STEP * self.scale) \
                            & flight[la][sa][m] & flight[lb][sb][m]
                        length *= np.where(riser, CLIMB_COST, 1.0)
                    out.append((self.ids[la][sa][m], self.ids[lb][sb][m], length))
        return out

    def gaps(self, has_ground: np.ndarray, step_height: float) -> np.ndarray:
        """(nx, ny) the cells of gaps: no ground at all (water between stepping stones), or
        ground more than ``step_height`` below a neighbour's on either side (a gutter's,
        a trench's bottom)."""
        top = np.where(has_ground.any(axis=0), np.nanmax(np.where(has_ground, self.z, -np.inf), axis=0), -np.inf)
        pt = np.pad(top, 1, constant_values=-np.inf)
        sunk = np.zeros(top.shape, bool)
        for a, b in ((pt[2:, 1:-1], pt[:-2, 1:-1]), (pt[1:-1, 2:], pt[1:-1, :-2])):
            sunk |= (top < a - step_height) & (top < b - step_height) & np.isfinite(a) & np.isfinite(b)
        return ~has_ground.any(axis=0) | sunk

    def sole_islands(self, islands: Callable, walk: np.ndarray, void: np.ndarray) -> np.ndarray:
        """(L * nx * ny,) the island of each walkable cell level on a gap's border where the
        ground under nine points of the cell (3 x 3, a third of a cell apart) is of that
        island alone, -1 where of two or none (bridged as any), -2 off the border."""
        cand = np.flatnonzero(_gap_border(walk, void).ravel())
        out = np.full(self.ids.size, -2, np.int64)
        if not len(cand):
            return out
        n = self.nx * self.ny
        u = np.array([-1.0, 0.0, 1.0]) * self.cell / 3
        off = np.array([(a, b) for a in u for b in u])
        xy = (self.xy[cand % n][:, None] + off[None]).reshape(-1, 2)
        z = np.repeat(self.z.ravel()[cand], len(off))
        lab = islands(np.c_[xy, z]).reshape(len(cand), len(off))
        top = lab.max(axis=1)
        low = np.where(lab >= 0, lab, np.iinfo(np.int64).max).min(axis=1)
        out[cand] = np.where((top >= 0) & (top == low), top, -1)
        return out

    def bridges(self, walk: np.ndarray, void: np.ndarray, blocked: np.ndarray, jump_reach: float,
                step_height: float, shortest: float = 1.0) -> list[tuple]:
        """(rows, cols, lengths) of straight bridges longer than ``shortest`` m and up to
        ``jump_reach`` between walkable cell levels on the border of a gap (``void`` (nx,
        ny), ``gaps``), within a step's height of each other, never across an obstacle
        (each border cell with every offset in reach at once, BRIDGE_PAIRS at a time)."""
        nx, ny = self.nx, self.ny
        border = _gap_border(walk, void)
        bl, bi, bj = np.nonzero(border)
        r = int(np.ceil(jump_reach / self.cell))
        a, b = (g.ravel() for g in np.meshgrid(np.arange(-r, r + 1), np.arange(-r, r + 1), indexing="ij"))
        length = np.hypot(a, b) * self.cell
        keep = (shortest < length) & (length <= jump_reach) & (np.maximum(np.abs(a), np.abs(b)) > 1)
        a, b, length = a[keep], b[keep], length[keep]
        out = []
        if not len(bl) or not len(a):
            return out
        per = max(BRIDGE_PAIRS // len(bl), 1)
        z = self.z
        zs = z[bl, bi, bj]  # (B,) the border cells' heights
        for k0 in range(0, len(a), per):  # (offsets in order: the edges come as one offset at a time did)
            ka, kb = a[k0:k0 + per, None], b[k0:k0 + per, None]  # (K, 1)
            ti, tj = bi[None] + ka, bj[None] + kb  # (K, B)
            inside = (ti >= 0) & (ti < nx) & (tj >= 0) & (tj < ny)
            ti, tj = np.where(inside, ti, 0), np.where(inside, tj, 0)
            clear = inside.copy()
            for t in np.linspace(0.2, 0.8, 4):  # the line between crosses void or walkable cells only
                ci = np.clip(np.rint(bi[None] + t * ka).astype(int), 0, nx - 1)
                cj = np.clip(np.rint(bj[None] + t * kb).astype(int), 0, ny - 1)
                clear &= ~blocked[bl[None], ci, cj]
            ok = clear[:, None] & border[:, ti, tj].transpose(1, 0, 2)  # (K, L, B)
            dz = np.abs(z[:, ti, tj].transpose(1, 0, 2) - zs[None, None])
            ok &= np.where(np.isfinite(dz), dz, np.inf) <= step_height
            k, tl, m = np.nonzero(ok)  # (by offset, then level, then border cell)
            out.append((self.ids[bl[m], bi[m], bj[m]], self.ids[tl, ti[k, m], tj[k, m]], length[k0 + k]))
        return [tuple(np.concatenate(e) for e in zip(*out))]


#: (border cell, offset) pairs ``_Grid.bridges`` weighs at a time (memory: about 100 bytes
#: a pair and level)
BRIDGE_PAIRS = 200_000


def _gap_border(walk: np.ndarray, void: np.ndarray) -> np.ndarray:
    """(L, nx, ny) the walkable cell levels (``walk``) beside a gap cell (``void`` (nx,
    ny)) next to it along x or y: where bridges start and end."""
    pv = np.pad(void, 1)
    return walk & (pv[2:, 1:-1] | pv[:-2, 1:-1] | pv[1:-1, 2:] | pv[1:-1, :-2])[None]
