"""A footstep path to a goal: A* over footprints, expanded lazily during the search.

The thesis built a dense graph of sampled footprints up front (seconds to tens of
seconds) and named lazy construction as future work. Here a node is a footprint
reached by the search itself: expanding it applies every step of the library to it
(one batched support query for all its successors), so only footprints near the
explored paths are ever tested. Footprints are merged on a grid (``cell`` metres,
``heading_bins`` headings), and support answers are cached per grid key, so the cache
serves later plans on the same geometry (see ``FootprintCache``).

Cost is time (each step's duration), plus ``turn_penalty`` seconds per radian of
heading change, ``jump_penalty`` seconds per jump and ``run_penalty`` seconds per
running step (so the path walks unless it must run). Steps walk on continuous ground;
jump steps are taken only across a gap (where the ground between take-off and landing
is missing), never on open floor. The heuristic is the walking
distance to the goal on a coarse grid (``DistanceField``: around walls, across gaps only
where a jump reaches) over the cheapest step's metres per second of cost; it never overestimates. The search
weighs it by ``heuristic_weight`` (weighted A*): with weight w the path found costs at
most w times the cheapest, and the search expands far fewer footprints; w = 1 is plain
A*.
"""

from __future__ import annotations

import heapq
import time
from dataclasses import dataclass, field
from typing import Callable, NamedTuple

import numpy as np

from .errors import FootstepError
from .settings import Settings
from .steps import StepSet
from .surface import FootShape, Ground, footprint_support


#: m: the fine grid on which support answers are cached. A footprint takes only the
#: answer of its own fine cell, so it never takes a neighbour's answer near an edge.
FINE_CELL = 0.02

#: Heading bins of the fine grid (2 degrees each).
FINE_HEADING_BINS = 180


def fine_xy(xy: np.ndarray) -> np.ndarray:
    """(N, 2) int64 fine-grid cells of positions (N, >=2) in metres."""
    return np.rint(np.asarray(xy, float)[..., :2] / FINE_CELL).astype(np.int64)


def fine_keys(xy: np.ndarray, heading: np.ndarray) -> list[tuple[int, int, int]]:
    """Fine keys (cell x, cell y, heading bin) of footprints at ``xy`` (N, 2) m turned
    ``heading`` (N,) rad: the keys of ``FootprintCache.table``."""
    c = fine_xy(xy)
    b = np.rint(np.asarray(heading, float) / (2 * np.pi / FINE_HEADING_BINS)).astype(np.int64) % FINE_HEADING_BINS
    return list(zip(c[:, 0].tolist(), c[:, 1].tolist(), b.tolist()))


class PlanError(FootstepError):
    """No path: the message says why, and where the nearest reachable point is.
    ``expanded`` footprints were expanded before the search gave up (0: refused before
    any search), ``explored`` the search's nodes (``SearchNode``)."""

    def __init__(self, message: str, expanded: int = 0, explored: list | None = None):
        super().__init__(message)
        self.expanded = expanded
        self.explored = explored or []


@dataclass(frozen=True)
class PathFootprint:
    """A footprint of a planned path: the foot (0 left, 1 right) planted there, where and
    turned how, when, and the step (its clip, or blend) that carried the foot there."""

    foot: int  # 0 left, 1 right
    position: np.ndarray  # (3,) on the surface
    heading: float  # yaw relative to the rig's rest forward
    time: float  # s since the start
    label: str  # the clip (or "group@tau") that carried the foot here; "start" at first
    gait: str
    jump: bool = False


class SearchNode(NamedTuple):
    """A footprint the search reached: the foot that stands there (0 left, 1 right), the
    gait it arrived in, its position (3,) and heading (rad), the cost (s) of the way
    there, the index of the node it was reached from (-1 at the start) and the index of
    the step (``StepSet`` row) that reached it (-1 at the start)."""

    foot: int
    gait: str
    position: np.ndarray
    heading: float
    cost: float
    parent: int
    step: int


@dataclass
class PlanResult:
    """A search's path and everything about it: counts, times (s) and the explored nodes."""

    footprints: list[PathFootprint]
    expanded: int
    generated: int
    seconds: float
    cost: float
    field_seconds: float = 0.0  # of ``seconds``: building the heuristic's distance field
    explored: list[SearchNode] = field(default_factory=list, repr=False)

    @property
    def explored_positions(self) -> np.ndarray:
        """(N, 3) every footprint the search reached, for review."""
        return np.array([n.position for n in self.explored], float).reshape(-1, 3)

    def to_dict(self) -> dict:
        return {
            "footprints": [{"foot": "LR"[f.foot], "position": [round(float(v), 4) for v in f.position],
                            "heading": round(float(f.heading), 4), "time": round(f.time, 4),
                            "clip": f.label, "gait": f.gait, "jump": f.jump} for f in self.footprints],
            "search": {"expanded": self.expanded, "generated": self.generated,
                       "seconds": round(self.seconds, 4), "field_seconds": round(self.field_seconds, 4),
                       "cost": round(self.cost, 4)},
        }


@dataclass
class FootprintCache:
    """Support answers by fine footprint key, reused by every plan while the tagged
    geometry is unchanged. Geometry is described per object (a hash and its bounds):
    when objects change, only the answers near their old and new bounds are dropped."""

    objects: dict = field(default_factory=dict)  # name -> (hash, lo (3,), hi (3,))
    table: dict = field(default_factory=dict)  # fine key (ix, iy, heading bin) -> (ok, z)
    between: dict = field(default_factory=dict)  # (from fine cell, to fine key) -> (ground, clear)
    margin: float = 0.6  # m around a changed object whose answers are dropped

    def update(self, objects: dict) -> int:
        """Bring the cache to ``objects`` (name -> (hash, lo, hi)); returns how many
        answers were dropped."""
        changed = []
        for name in set(self.objects) | set(objects):
            old, new = self.objects.get(name), objects.get(name)
            if old is None or new is None or old[0] != new[0]:
                changed += [b for b in (old, new) if b is not None]
        self.objects = dict(objects)
        if not changed or not self.table:
            return 0
        # a step's answer goes with either end's region (a step is shorter than 2 m)
        for k in [k for k in self.between
                  if any(lo[0] - self.margin - 2 <= k[0][0] * FINE_CELL <= hi[0] + self.margin + 2
                         and lo[1] - self.margin - 2 <= k[0][1] * FINE_CELL <= hi[1] + self.margin + 2
                         for _, lo, hi in changed)]:
            del self.between[k]
        keys = list(self.table)
        xy = np.array([k[:2] for k in keys], dtype=np.float64) * FINE_CELL
        drop = np.zeros(len(keys), bool)
        for _, lo, hi in changed:
            drop |= ((xy[:, 0] >= lo[0] - self.margin) & (xy[:, 0] <= hi[0] + self.margin)
                     & (xy[:, 1] >= lo[1] - self.margin) & (xy[:, 1] <= hi[1] + self.margin))
        for k in np.flatnonzero(drop):
            del self.table[keys[k]]
        return int(drop.sum())


@dataclass
class _Search:
    """One search's state (never kept on the planner)."""

    goal: np.ndarray
    goal_heading: float | None
    heuristic: Callable[[np.ndarray], np.ndarray]
    base_cost: np.ndarray  # (S,) each step's cost before a gait change
    nodes: list[SearchNode] = field(default_factory=list)
    heap: list = field(default_factory=list)
    best_g: dict = field(default_factory=dict)
    closed: set = field(default_factory=set)
    expanded: int = 0
    generated: int = 0
    nearest: tuple = (np.inf, None)  # (distance to the goal, position) of the closest node

    def push(self, node: SearchNode, h: float) -> None:
        self.nodes.append(node)
        heapq.heappush(self.heap, (node.cost + h, len(self.nodes) - 1))


@dataclass
class Planner:
    """The footstep search over a scene's surfaces with a library's steps. The user's
    tunables (penalties, heuristic weight, goal radius and heading tolerance, the
    expansion budget) come from ``settings``; the fields below them are the search's
    own geometry."""

    ground: Ground
    obstacles: Ground | None
    steps: StepSet
    forward: np.ndarray  # the rig's rest forward (x, y)
    foot: FootShape = FootShape()
    settings: Settings = field(default_factory=Settings)
    cache: FootprintCache = field(default_factory=FootprintCache)
    cell: float = 0.15  # m: footprints closer than this (same foot, gait, heading bin) merge
    heading_bins: int = 36
    max_step_height: float = 0.3  # m up or down between two footprints
    clearance: float = 0.25  # m from obstacles
    field_cell: float = 0.25  # m: the distance field's grid

    def _support(self, pos, heading):
        return footprint_support(self.ground, self.obstacles, pos, heading, self.forward, self.foot,
                                 step_height=self.max_step_height, clearance=self.clearance)

    def _keys(self, foot: int, gaits, xy: np.ndarray, psi: np.ndarray) -> list[tuple]:
        """Merge-grid keys (foot, gait, cell x, cell y, heading bin) of footprints."""
        c = np.rint(xy / self.cell).astype(np.int64)
        b = np.rint(psi / (2 * np.pi) * self.heading_bins).astype(np.int64) % self.heading_bins
        return list(zip([foot] * len(c), list(gaits), c[:, 0].tolist(), c[:, 1].tolist(), b.tolist()))

    def _between(self, a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """For footprint pairs (rows of a, b (N, 3)): (ground continues between them,
        the way between them is clear of obstacles). Three points between are tested:
        the ground must be under each within a step's height; no obstacle may stand
        there below head height, nor closer than half the clearance at the hips."""
        t = np.array([0.25, 0.5, 0.75])
        pts = a[:, None] + (b - a)[:, None] * t[None, :, None]
        top = pts.copy()
        top[..., 2] = np.maximum(a[:, None, 2], b[:, None, 2]) + self.max_step_height
        hit = self.ground.ray_down(top.reshape(-1, 3), 2 * self.max_step_height + 0.2)
        ground = hit.hit.reshape(len(a), 3).all(axis=1)
        clear = np.ones(len(a), bool)
        if self.obstacles is not None and self.obstacles.mesh.n:
            base = np.minimum(a[:, None, 2], b[:, None, 2]) + np.zeros((1, 3))
            head = np.concatenate([pts[..., :2], (base + 1.6)[..., None]], axis=2).reshape(-1, 3)
            inside = self.obstacles.ray_down(head, 1.55).hit.reshape(len(a), 3).any(axis=1)
            hips = head.copy()
            hips[:, 2] -= 0.6
            _, d = self.obstacles.nearest(hips, max_dist=0.5 * self.clearance)
            near = (d < 0.5 * self.clearance).reshape(len(a), 3).any(axis=1)
            clear = ~inside & ~near
        return ground, clear

    # ------------------------------------------------------------------ the search
    def plan(self, start: list[PathFootprint], goal: np.ndarray, goal_heading: float | None = None) -> PlanResult:
        """A footstep path from ``start`` (the character's current footprints, in any
        order: the search may step off either) to ``goal`` (x, y, z), arriving turned
        within the goal heading tolerance of ``goal_heading`` (rad, like the footprints'
        headings) when one is given. Raises PlanError saying what blocks the way."""
        t0 = time.perf_counter()
        goal = np.asarray(goal, dtype=np.float64)
        self._check_goal(goal, goal_heading)
        t_field = time.perf_counter()
        dist = self.distance_field(goal)
        field_seconds = time.perf_counter() - t_field
        self._refuse_unreachable(dist, start, goal)
        search = _Search(goal, goal_heading, self._heuristic(dist, goal), self._base_costs())
        for s in start:
            for gait in ("walk", "run"):
                node = SearchNode(s.foot, gait, np.asarray(s.position, float), float(s.heading), 0.0, -1, -1)
                search.push(node, float(search.heuristic(node.position)[0]))
        while search.heap:
            idx = self._pop(search)
            if idx is None:
                continue
            if self._arrived(search, idx):
                return self._result(search, idx, time.perf_counter() - t0, field_seconds)
            search.expanded += 1
            if search.expanded > self.settings.max_expansions:
                break
            self._expand(search, idx)
        raise self._dead_end(search)

    def distance_field(self, goal: np.ndarray) -> "DistanceField":
        """The walking-distance map to ``goal`` that the search's heuristic reads."""
        return DistanceField.build(self.ground, self.obstacles, np.asarray(goal, float), self.field_cell,
                                   self.clearance, self._jump_reach(), self.max_step_height)

    def _check_goal(self, goal: np.ndarray, goal_heading: float | None) -> None:
        """PlanError when no traversable surface lies under (or near above) the goal."""
        gsup = self._support(goal[None], np.array([goal_heading or 0.0]))
        if not gsup.ok[0] and gsup.reason[0] in ("off surface", "uneven", "steep"):
            hit = self.ground.ray_down(np.array([[goal[0], goal[1], goal[2] + 2.0]]), 10.0)
            if not hit.hit[0]:
                raise PlanError(f"the goal ({goal[0]:.2f}, {goal[1]:.2f}, {goal[2]:.2f}) is off every "
                                "traversable surface")

    def _refuse_unreachable(self, dist: "DistanceField", start: list[PathFootprint], goal: np.ndarray) -> None:
        """PlanError before any search when the walking-distance map has no way from the
        start to the goal."""
        if not np.isfinite(dist.at_many(np.array([f.position for f in start], float))).any():
            near = dist.nearest_reachable(np.asarray(start[0].position, float), goal)
            raise PlanError(
                f"the goal ({goal[0]:.2f}, {goal[1]:.2f}) cannot be reached: no walkable way, nor a "
                f"gap a jump clip can clear, leads there from the start; the nearest reachable "
                f"point is ({near[0]:.2f}, {near[1]:.2f}), {np.linalg.norm(near[:2] - goal[:2]):.2f} m "
                "from the goal")

    def _heuristic(self, dist: "DistanceField", goal: np.ndarray) -> Callable[[np.ndarray], np.ndarray]:
        """Weighted remaining time (s) for points (N, >=2): the walking distance over the
        cheapest step's speed; off the grid's reach, three times the straight distance."""
        vmax = self._cost_speed()
        weight = self.settings.heuristic_weight

        def heuristic(p):
            p = np.atleast_2d(p)
            d = dist.at_many(p)
            d = np.where(np.isfinite(d), d, 3.0 * np.hypot(goal[0] - p[:, 0], goal[1] - p[:, 1]))
            return weight * d / vmax
        return heuristic

    def _base_costs(self) -> np.ndarray:
        """(S,) s: each step's cost, its duration plus the turn, jump and run penalties
        (a gait change is added per successor)."""
        st, cfg = self.steps, self.settings
        return (st.duration + cfg.turn_penalty * np.abs(st.turn)
                + np.where(st.jump, cfg.jump_penalty, 0.0)
                + np.where(st.gait == "run", cfg.run_penalty, 0.0))

    def _pop(self, search: _Search) -> int | None:
        """The cheapest open node's index, closing its merge key (None if already closed)."""
        _, idx = heapq.heappop(search.heap)
        node = search.nodes[idx]
        key = self._keys(node.foot, [node.gait], node.position[None, :2], np.array([node.heading]))[0]
        if key in search.closed:
            return None
        search.closed.add(key)
        return idx

    def _arrived(self, search: _Search, idx: int) -> bool:
        """Whether node ``idx`` ends the path (within the goal radius, heading within
        tolerance, and not a start footprint); keeps the nearest node for messages."""
        node, goal = search.nodes[idx], search.goal
        d_goal = float(np.linalg.norm(goal[:2] - node.position[:2]))
        if d_goal < search.nearest[0]:
            search.nearest = (d_goal, node.position)
        cfg = self.settings
        return d_goal <= cfg.goal_radius and node.parent >= 0 and (
            search.goal_heading is None
            or abs(_wrap(node.heading - search.goal_heading)) <= cfg.goal_heading_tolerance)

    def _expand(self, search: _Search, idx: int) -> None:
        """Push every supported, reachable successor of node ``idx``."""
        node = search.nodes[idx]
        sel, nxt, npsi, keys = self._successors(search, node)
        if not len(sel):
            return
        ok, z = self._supported(node, nxt, npsi)
        ok &= np.abs(z - node.position[2]) <= self.max_step_height
        if ok.any():
            ok[ok] &= self._way_clear(node, sel[ok], np.c_[nxt[ok], z[ok]], fine_keys(nxt[ok], npsi[ok]))
        good = np.flatnonzero(ok)
        if not len(good):
            return
        st = self.steps
        change = np.where(st.gait[sel[good]] != node.gait, self.settings.gait_change_penalty, 0.0)
        cost = node.cost + (search.base_cost[sel[good]] + change)
        h = search.heuristic(nxt[good])
        for j, g, hj in zip(good.tolist(), cost.tolist(), h.tolist()):
            k = keys[j]
            if search.best_g.get(k, np.inf) <= g:
                continue
            search.best_g[k] = g
            i = int(sel[j])
            search.push(SearchNode(1 - node.foot, st.gait[i], np.array([nxt[j, 0], nxt[j, 1], z[j]]),
                                   float(npsi[j]), g, idx, i), hj)
            search.generated += 1

    def _successors(self, search: _Search, node: SearchNode):
        """The steps that may follow ``node`` (indices (K,)), where they land (K, 2) and
        turned how (K,), with their merge keys; merged-away (closed) ones dropped. No
        jump follows a jump, and a jump is entered running."""
        st = self.steps
        sel = np.flatnonzero(st.foot == node.foot)
        if node.step >= 0 and st.jump[node.step]:
            sel = sel[~st.jump[sel]]
        if node.gait == "walk":
            sel = sel[~st.jump[sel]]
        ang = node.heading + np.arctan2(self.forward[1], self.forward[0])
        f_ = np.array([np.cos(ang), np.sin(ang)])
        l_ = np.array([-f_[1], f_[0]])
        nxt = node.position[:2] + st.fwd[sel, None] * f_ + st.left[sel, None] * l_
        npsi = _wrap(node.heading + st.turn[sel])
        keys = self._keys(1 - node.foot, st.gait[sel].tolist(), nxt, npsi)
        todo = [j for j, k in enumerate(keys) if k not in search.closed]
        return sel[todo], nxt[todo], npsi[todo], [keys[j] for j in todo]

    def _supported(self, node: SearchNode, nxt: np.ndarray, npsi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(ok (K,), z (K,)): whether a foot may stand at each successor and the surface
        height there, from the cache where the fine key was seen before."""
        table = self.cache.table
        fine = fine_keys(nxt, npsi)
        ask = [j for j, k in enumerate(fine) if k not in table]
        if ask:
            sup = self._support(np.c_[nxt[ask], np.full(len(ask), node.position[2])], npsi[ask])
            for j, o, zz in zip(ask, sup.ok, sup.z):
                table[fine[j]] = (bool(o), float(zz))
        answers = np.array([table[k] for k in fine], dtype=float).reshape(-1, 2)
        return answers[:, 0].astype(bool), answers[:, 1]

    def _way_clear(self, node: SearchNode, steps: np.ndarray, to: np.ndarray, fine: list) -> np.ndarray:
        """(K,) whether each step from ``node`` to ``to`` (K, 3) may be taken: a walking
        step on continuous ground, a jump only across a gap, neither through an obstacle
        (cached per fine cell pair)."""
        between = self.cache.between
        here = tuple(fine_xy(node.position[:2]).tolist())
        pairs = [(here, k) for k in fine]
        ask = [n for n, k in enumerate(pairs) if k not in between]
        if ask:
            ground, clear = self._between(np.repeat(node.position[None], len(ask), axis=0), to[ask])
            for n, g_, c_ in zip(ask, ground.tolist(), clear.tolist()):
                between[pairs[n]] = (g_, c_)
        gc = np.array([between[k] for k in pairs], dtype=bool).reshape(-1, 2)
        return np.where(self.steps.jump[steps], ~gc[:, 0], gc[:, 0]) & gc[:, 1]

    def _dead_end(self, search: _Search) -> PlanError:
        goal, (d_near, near) = search.goal, search.nearest
        where = "nowhere" if near is None else f"({near[0]:.2f}, {near[1]:.2f}, {near[2]:.2f})"
        why = "the search ran out of its budget" if search.heap else "no step of the library leads further"
        return PlanError(f"the goal ({goal[0]:.2f}, {goal[1]:.2f}) cannot be reached ({why}, "
                         f"{search.expanded} footprints expanded); the nearest reachable point is {where}, "
                         f"{d_near:.2f} m from the goal", search.expanded, search.nodes)

    def _cost_speed(self) -> float:
        """Metres per second of cost of the step that covers ground cheapest: the
        heuristic divides the distance to the goal by it, so it never overestimates."""
        st, cfg = self.steps, self.settings
        cost = st.duration + np.where(st.gait == "run", cfg.run_penalty, 0.0) \
            + np.where(st.jump, cfg.jump_penalty, 0.0)
        return float(np.max(np.hypot(st.fwd, st.left) / cost))

    def _jump_reach(self) -> float:
        j = self.steps.jump
        return float(np.hypot(self.steps.fwd[j], self.steps.left[j]).max()) if j.any() else 0.0

    def _result(self, search: _Search, idx: int, seconds: float, field_seconds: float) -> PlanResult:
        chain = []
        while idx >= 0:
            chain.append(search.nodes[idx])
            idx = search.nodes[idx].parent
        chain.reverse()
        out, tnow = [], 0.0
        for n in chain:
            if n.step >= 0:
                tnow += float(self.steps.duration[n.step])
            out.append(PathFootprint(n.foot, n.position, n.heading, tnow,
                                "start" if n.step < 0 else str(self.steps.label[n.step]),
                                n.gait, bool(n.step >= 0 and self.steps.jump[n.step])))
        return PlanResult(out, search.expanded, search.generated, seconds, chain[-1].cost, field_seconds,
                          search.nodes)


def _wrap(a):
    return (np.asarray(a) + np.pi) % (2 * np.pi) - np.pi


@dataclass
class DistanceField:
    """Walking distance to the goal on a coarse grid: the search's heuristic.

    A cell is walkable when the ground is under its centre and the body there keeps its
    clearance from obstacles. Walkable neighbours (8-connected) are joined by their
    distance, and border cells across a gap of missing ground by a straight bridge no
    longer than ``jump_reach`` (never across an obstacle). Distances are 5 % short of the
    grid's, so the heuristic stays below the true remaining walk."""

    origin: np.ndarray
    cell: float
    shape: tuple[int, int]
    dist: np.ndarray  # (nx, ny), inf where the goal cannot be reached on the grid
    graph: object = field(default=None, repr=False)  # the cells' sparse graph

    def at_many(self, p: np.ndarray) -> np.ndarray:
        i = np.floor((p[:, 0] - self.origin[0]) / self.cell).astype(np.int64)
        j = np.floor((p[:, 1] - self.origin[1]) / self.cell).astype(np.int64)
        inside = (i >= 0) & (i < self.shape[0]) & (j >= 0) & (j < self.shape[1])
        out = np.full(len(p), np.inf)
        out[inside] = self.dist[i[inside], j[inside]]
        return out

    def nearest_reachable(self, start, goal) -> np.ndarray:
        """The centre of the cell reachable from ``start`` that is nearest the goal."""
        from scipy.sparse.csgraph import dijkstra

        i = int(np.clip(np.floor((start[0] - self.origin[0]) / self.cell), 0, self.shape[0] - 1))
        j = int(np.clip(np.floor((start[1] - self.origin[1]) / self.cell), 0, self.shape[1] - 1))
        d = dijkstra(self.graph, directed=False, indices=i * self.shape[1] + j)
        ok = np.flatnonzero(np.isfinite(d))
        cx = self.origin[0] + (ok // self.shape[1] + 0.5) * self.cell
        cy = self.origin[1] + (ok % self.shape[1] + 0.5) * self.cell
        k = int(np.argmin(np.hypot(cx - goal[0], cy - goal[1])))
        return np.array([cx[k], cy[k], 0.0])

    @staticmethod
    def build(ground, obstacles, goal, cell, clearance, jump_reach, step_height) -> "DistanceField":
        """The walking distance (m) to ``goal`` from every cell of a grid of ``cell``
        metres over the ground's bounds: walkable cells (ground under the centre, body
        clear of obstacles by ``clearance``), joined 8-connected and, across gaps, by
        bridges up to ``jump_reach`` long; Dijkstra from the goal's cell."""
        from scipy.sparse import coo_matrix
        from scipy.sparse.csgraph import dijkstra

        grid = _Grid.over(ground, cell, step_height)
        has_ground, blocked = grid.ground_and_blocked(ground, obstacles, clearance)
        walk = has_ground & ~blocked
        edges = grid.neighbour_edges(walk)
        if jump_reach > 0:
            edges += grid.bridges(walk, ~has_ground, blocked, jump_reach)
        rows, cols, vals = (np.concatenate(e) for e in zip(*edges))
        n = grid.nx * grid.ny
        graph = coo_matrix((vals, (rows, cols)), shape=(n, n)).tocsr()
        gi = int(np.clip(np.floor((goal[0] - grid.lo[0]) / cell), 0, grid.nx - 1))
        gj = int(np.clip(np.floor((goal[1] - grid.lo[1]) / cell), 0, grid.ny - 1))
        d = dijkstra(graph, directed=False, indices=grid.ids[gi, gj])
        # 5 % short, and a cell's own size short, so the heuristic stays a lower bound
        d = np.maximum(0.95 * d - 1.5 * cell, 0.0)
        return DistanceField(grid.lo, cell, (grid.nx, grid.ny), d.reshape(grid.nx, grid.ny), graph)


@dataclass
class _Grid:
    """The distance field's cells: origin ``lo`` (2,), ``cell`` m, ``nx`` x ``ny`` cells,
    and their ids (nx, ny)."""

    lo: np.ndarray
    cell: float
    nx: int
    ny: int
    ids: np.ndarray
    top: np.ndarray  # (nx * ny, 3) a point above each cell's centre
    ray: float  # m: from there down past the ground's lowest point

    @staticmethod
    def over(ground, cell: float, step_height: float) -> "_Grid":
        lo, hi = ground.mesh.bounds()
        lo = lo[:2] - cell
        nx, ny = (np.ceil((hi[:2] + cell - lo) / cell)).astype(int)
        cx = lo[0] + (np.arange(nx) + 0.5) * cell
        cy = lo[1] + (np.arange(ny) + 0.5) * cell
        xx, yy = np.meshgrid(cx, cy, indexing="ij")
        top = np.c_[xx.ravel(), yy.ravel(), np.full(xx.size, hi[2] + step_height)]
        ray = hi[2] - ground.mesh.bounds()[0][2] + 2 * step_height
        return _Grid(lo, cell, int(nx), int(ny), np.arange(nx * ny).reshape(nx, ny), top, ray)

    def ground_and_blocked(self, ground, obstacles, clearance: float):
        """(has ground (nx, ny), blocked (nx, ny)): ground under each cell's centre, and an
        obstacle within the clearance of the body (at 0.5 and 1.3 m above the ground)."""
        hit = ground.ray_down(self.top, self.ray)
        has_ground = hit.hit.reshape(self.nx, self.ny)
        blocked = np.zeros((self.nx, self.ny), bool)
        if obstacles is not None and obstacles.mesh.n:
            idx = np.flatnonzero(has_ground.ravel())
            for level in (0.5, 1.3):
                probe = np.c_[self.top[idx, :2], hit.z[idx] + level]
                _, d = obstacles.nearest(probe, max_dist=clearance)
                blocked.ravel()[idx[d < clearance * 0.9]] = True
        return has_ground, blocked

    def neighbour_edges(self, walk: np.ndarray) -> list[tuple]:
        """(rows, cols, lengths) of the edges between 8-connected walkable cells."""
        nx, ny, ids, out = self.nx, self.ny, self.ids, []
        for di, dj in ((1, 0), (0, 1), (1, 1), (1, -1)):
            a = walk[max(0, -di):nx - max(0, di), max(0, -dj):ny - max(0, dj)]
            b = walk[max(0, di):, max(0, dj):][:a.shape[0], :a.shape[1]] if dj >= 0 else \
                walk[max(0, di):, :ny + dj][:a.shape[0], :a.shape[1]]
            ia = ids[max(0, -di):nx - max(0, di), max(0, -dj):ny - max(0, dj)]
            ib = ids[max(0, di):, max(0, dj):][:a.shape[0], :a.shape[1]] if dj >= 0 else \
                ids[max(0, di):, :ny + dj][:a.shape[0], :a.shape[1]]
            m = a & b
            out.append((ia[m], ib[m], np.full(m.sum(), np.hypot(di, dj) * self.cell)))
        return out

    def bridges(self, walk: np.ndarray, void: np.ndarray, blocked: np.ndarray, jump_reach: float) -> list[tuple]:
        """(rows, cols, lengths) of straight bridges up to ``jump_reach`` between walkable
        cells on the border of a gap (missing ground), never across an obstacle."""
        nx, ny = self.nx, self.ny
        border = walk & (np.pad(void, 1)[2:, 1:-1] | np.pad(void, 1)[:-2, 1:-1]
                         | np.pad(void, 1)[1:-1, 2:] | np.pad(void, 1)[1:-1, :-2])
        bi, bj = np.nonzero(border)
        r = int(np.ceil(jump_reach / self.cell))
        offs = [(a, b) for a in range(-r, r + 1) for b in range(-r, r + 1)
                if 1 < np.hypot(a, b) * self.cell <= jump_reach]
        out = []
        for a, b in offs:
            ti, tj = bi + a, bj + b
            ok = (ti >= 0) & (ti < nx) & (tj >= 0) & (tj < ny)
            ti, tj, si, sj = ti[ok], tj[ok], bi[ok], bj[ok]
            ok = border[ti, tj]
            for t in np.linspace(0.2, 0.8, 4):  # the line between crosses void or walkable cells only
                ok &= ~blocked[np.rint(si + t * a).astype(int), np.rint(sj + t * b).astype(int)]
            out.append((self.ids[si[ok], sj[ok]], self.ids[ti[ok], tj[ok]],
                        np.full(ok.sum(), np.hypot(a, b) * self.cell)))
        return out
