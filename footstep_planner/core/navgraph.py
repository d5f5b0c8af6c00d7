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

import numpy as np

from .errors import FootstepError
from .steps import StepSet
from .surface import FootShape, Ground, footprint_support


class PlanError(FootstepError):
    """No path: the message says why, and where the nearest reachable point is."""


@dataclass(frozen=True)
class Footstep:
    foot: int  # 0 left, 1 right
    position: np.ndarray  # (3,) on the surface
    heading: float  # yaw relative to the rig's rest forward
    time: float  # s since the start
    label: str  # the clip (or "group@tau") that carried the foot here; "start" at first
    gait: str
    jump: bool = False


@dataclass
class PlanResult:
    footsteps: list[Footstep]
    expanded: int
    generated: int
    seconds: float
    cost: float
    field_seconds: float = 0.0  # of ``seconds``: building the heuristic's distance field

    def to_dict(self) -> dict:
        return {
            "footprints": [{"foot": "LR"[f.foot], "position": [round(float(v), 4) for v in f.position],
                            "heading": round(float(f.heading), 4), "time": round(f.time, 4),
                            "clip": f.label, "gait": f.gait, "jump": f.jump} for f in self.footsteps],
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
    table: dict = field(default_factory=dict)  # (ix, iy, heading bin) -> (ok, z)
    between: dict = field(default_factory=dict)  # (from key, to key) -> (ground, clear)
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
                  if any(lo[0] - self.margin - 2 <= k[0][0] * 0.02 <= hi[0] + self.margin + 2
                         and lo[1] - self.margin - 2 <= k[0][1] * 0.02 <= hi[1] + self.margin + 2
                         for _, lo, hi in changed)]:
            del self.between[k]
        keys = list(self.table)
        xy = np.array([k[:2] for k in keys], dtype=np.float64) * 0.02
        drop = np.zeros(len(keys), bool)
        for _, lo, hi in changed:
            drop |= ((xy[:, 0] >= lo[0] - self.margin) & (xy[:, 0] <= hi[0] + self.margin)
                     & (xy[:, 1] >= lo[1] - self.margin) & (xy[:, 1] <= hi[1] + self.margin))
        for k in np.flatnonzero(drop):
            del self.table[keys[k]]
        return int(drop.sum())


@dataclass
class Planner:
    ground: Ground
    obstacles: Ground | None
    steps: StepSet
    forward: np.ndarray  # the rig's rest forward (x, y)
    foot: FootShape = FootShape()
    cell: float = 0.15
    heading_bins: int = 36
    turn_penalty: float = 0.1
    jump_penalty: float = 0.5
    gait_change_penalty: float = 0.2
    run_penalty: float = 0.0
    goal_radius: float = 0.35
    goal_heading_tolerance: float = np.radians(30)
    max_step_height: float = 0.3
    max_expansions: int = 20000
    max_seconds: float = 10.0
    clearance: float = 0.25
    field_cell: float = 0.25
    heuristic_weight: float = 2.0
    cache: FootprintCache = field(default_factory=FootprintCache)
    explored: list = field(default_factory=list, repr=False)

    #: The fields the user sets (Settings of the same names; the defaults here are for
    #: the core's own use: a bare Planner plans the fastest path, run_penalty 0).
    FROM_SETTINGS = ("turn_penalty", "jump_penalty", "run_penalty", "gait_change_penalty",
                     "heuristic_weight", "goal_radius")

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

    def plan(self, start: list[Footstep], goal: np.ndarray, goal_heading: float | None = None) -> PlanResult:
        """A footstep path from ``start`` (the character's current footprints, in any
        order: the search may step off either) to ``goal`` (x, y, z)."""
        t0 = time.perf_counter()
        goal = np.asarray(goal, dtype=np.float64)
        table, between = self.cache.table, self.cache.between
        gsup = self._support(goal[None], np.array([goal_heading or 0.0]))
        if not gsup.ok[0] and gsup.reason[0] in ("off surface", "uneven", "steep"):
            hit = self.ground.ray_down(np.array([[goal[0], goal[1], goal[2] + 2.0]]), 10.0)
            if not hit.hit[0]:
                raise PlanError(f"the goal ({goal[0]:.2f}, {goal[1]:.2f}, {goal[2]:.2f}) is off every "
                                "traversable surface")
        vmax = self._cost_speed()
        t_field = time.perf_counter()
        dist = DistanceField.build(self.ground, self.obstacles, goal, self.field_cell, self.clearance,
                                   self._jump_reach(), self.max_step_height)
        self._field_seconds = time.perf_counter() - t_field

        if not np.isfinite(dist.at_many(np.array([f.position for f in start], float))).any():
            near = dist.nearest_reachable(np.asarray(start[0].position, float), goal)
            raise PlanError(
                f"the goal ({goal[0]:.2f}, {goal[1]:.2f}) cannot be reached: no walkable way, nor a "
                f"gap a jump clip can clear, leads there from the start; the nearest reachable "
                f"point is ({near[0]:.2f}, {near[1]:.2f}), {np.linalg.norm(near[:2] - goal[:2]):.2f} m "
                "from the goal")

        def heuristic(p):
            """Weighted remaining time for points (N, >=2); off the grid's reach, three
            times the straight distance."""
            p = np.atleast_2d(p)
            d = dist.at_many(p)
            d = np.where(np.isfinite(d), d, 3.0 * np.hypot(goal[0] - p[:, 0], goal[1] - p[:, 1]))
            return self.heuristic_weight * d / vmax
        fwd_angle = np.arctan2(self.forward[1], self.forward[0])
        st = self.steps
        nodes = []  # (foot, gait, pos, psi, g, parent, step index or -1)
        heap = []
        best_g = {}
        for s in start:
            for gait in ("walk", "run"):
                idx = len(nodes)
                nodes.append((s.foot, gait, np.asarray(s.position, float), float(s.heading), 0.0, -1, -1))
                heapq.heappush(heap, (float(heuristic(np.asarray(s.position, float))[0]), idx))
        self.explored = nodes  # for review: every footprint the search reached
        expanded = generated = 0
        best_near = (np.inf, None)
        closed = set()
        while heap:
            f, idx = heapq.heappop(heap)
            foot, gait, pos, psi, g, parent, si = nodes[idx]
            key = self._keys(foot, [gait], pos[None, :2], np.array([psi]))[0]
            if key in closed:
                continue
            closed.add(key)
            d_goal = float(np.linalg.norm(goal[:2] - pos[:2]))
            if d_goal < best_near[0]:
                best_near = (d_goal, pos)
            if d_goal <= self.goal_radius and parent >= 0 and (
                    goal_heading is None or abs(_wrap(psi - goal_heading)) <= self.goal_heading_tolerance):
                return self._result(nodes, idx, expanded, generated, t0, g)
            expanded += 1
            if expanded > self.max_expansions or time.perf_counter() - t0 > self.max_seconds:
                break
            # successors: every step starting from this foot, from this gait or changing gait
            sel = np.flatnonzero(st.foot == foot)
            if si >= 0 and st.jump[si]:
                sel = sel[~st.jump[sel]]  # no jump straight after a jump
            if gait == "walk":
                sel = sel[~st.jump[sel]]  # a jump is entered running
            ang = psi + fwd_angle
            f_ = np.array([np.cos(ang), np.sin(ang)])
            l_ = np.array([-f_[1], f_[0]])
            nxt = pos[:2] + st.fwd[sel, None] * f_ + st.left[sel, None] * l_
            npsi = _wrap(psi + st.turn[sel])
            keys = self._keys(1 - foot, st.gait[sel].tolist(), nxt, npsi)
            todo = [j for j, k in enumerate(keys) if k not in closed]
            if not todo:
                continue
            sel, nxt, npsi = sel[todo], nxt[todo], npsi[todo]
            keys = [keys[j] for j in todo]
            # support, from the cache where the key was seen before
            ok = np.zeros(len(sel), bool)
            z = np.zeros(len(sel))
            # (a fine key: a footprint never takes a neighbour's answer near an edge)
            fx = np.rint(nxt / 0.02).astype(np.int64)
            fb = np.rint(npsi / (np.pi / 90)).astype(np.int64) % 180
            fine = list(zip(fx[:, 0].tolist(), fx[:, 1].tolist(), fb.tolist()))
            ask = [j for j, k in enumerate(fine) if k not in table]
            if ask:
                p3 = np.c_[nxt[ask], np.full(len(ask), pos[2])]
                sup = self._support(p3, npsi[ask])
                for j, o, zz in zip(ask, sup.ok, sup.z):
                    table[fine[j]] = (bool(o), float(zz))
            for j, k in enumerate(fine):
                ok[j], z[j] = table[k]
            ok &= np.abs(z - pos[2]) <= self.max_step_height
            # a step walks on continuous ground; a jump is only taken across a gap; and
            # neither passes through an obstacle
            if ok.any():
                here = (int(round(pos[0] / 0.02)), int(round(pos[1] / 0.02)))
                j = np.flatnonzero(ok)
                pairs = [(here, fine[i]) for i in j]
                ask = [n for n, k in enumerate(pairs) if k not in between]
                if ask:
                    ja = j[ask]
                    ground, clear = self._between(np.repeat(pos[None], len(ja), axis=0), np.c_[nxt[ja], z[ja]])
                    for n, g_, c_ in zip(ask, ground.tolist(), clear.tolist()):
                        between[pairs[n]] = (g_, c_)
                gc = np.array([between[k] for k in pairs], dtype=bool).reshape(-1, 2)
                ok[j] &= np.where(st.jump[sel[j]], ~gc[:, 0], gc[:, 0]) & gc[:, 1]
            good = np.flatnonzero(ok)
            hs = heuristic(nxt[good]) if len(good) else ()
            for j, h in zip(good, hs):
                i = sel[j]
                cost = (st.duration[i] + self.turn_penalty * abs(st.turn[i])
                        + (self.jump_penalty if st.jump[i] else 0.0)
                        + (self.run_penalty if st.gait[i] == "run" else 0.0)
                        + (self.gait_change_penalty if st.gait[i] != gait else 0.0))
                ng = g + cost
                k = keys[j]
                if best_g.get(k, np.inf) <= ng:
                    continue
                best_g[k] = ng
                p = np.array([nxt[j, 0], nxt[j, 1], z[j]])
                nodes.append((1 - foot, st.gait[i], p, float(npsi[j]), ng, idx, int(i)))
                heapq.heappush(heap, (ng + float(h), len(nodes) - 1))
                generated += 1
        near = best_near[1]
        where = "nowhere" if near is None else f"({near[0]:.2f}, {near[1]:.2f}, {near[2]:.2f})"
        why = "the search ran out of its budget" if heap else "no step of the library leads further"
        raise PlanError(f"the goal ({goal[0]:.2f}, {goal[1]:.2f}) cannot be reached ({why}, "
                        f"{expanded} footprints expanded); the nearest reachable point is {where}, "
                        f"{best_near[0]:.2f} m from the goal")

    def _cost_speed(self) -> float:
        """Metres per second of cost of the step that covers ground cheapest: the
        heuristic divides the distance to the goal by it, so it never overestimates."""
        st = self.steps
        cost = st.duration + np.where(st.gait == "run", self.run_penalty, 0.0) \
            + np.where(st.jump, self.jump_penalty, 0.0)
        return float(np.max(np.hypot(st.fwd, st.left) / cost))

    def _jump_reach(self) -> float:
        j = self.steps.jump
        return float(np.hypot(self.steps.fwd[j], self.steps.left[j]).max()) if j.any() else 0.0

    def _result(self, nodes, idx, expanded, generated, t0, cost) -> PlanResult:
        chain = []
        while idx >= 0:
            chain.append(nodes[idx])
            idx = nodes[idx][5]
        chain.reverse()
        out, tnow = [], 0.0
        for foot, gait, pos, psi, g, parent, si in chain:
            if si >= 0:
                tnow += float(self.steps.duration[si])
            out.append(Footstep(foot, pos, psi, tnow, "start" if si < 0 else str(self.steps.label[si]),
                                gait, bool(si >= 0 and self.steps.jump[si])))
        return PlanResult(out, expanded, generated, time.perf_counter() - t0, cost, self._field_seconds)


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

    def at(self, p) -> float:
        i = int(np.floor((p[0] - self.origin[0]) / self.cell))
        j = int(np.floor((p[1] - self.origin[1]) / self.cell))
        if 0 <= i < self.shape[0] and 0 <= j < self.shape[1]:
            return float(self.dist[i, j])
        return np.inf

    @staticmethod
    def build(ground, obstacles, goal, cell, clearance, jump_reach, step_height) -> "DistanceField":
        from scipy.sparse import coo_matrix
        from scipy.sparse.csgraph import dijkstra

        lo, hi = ground.mesh.bounds()
        lo = lo[:2] - cell
        nx, ny = (np.ceil((hi[:2] + cell - lo) / cell)).astype(int)
        cx = lo[0] + (np.arange(nx) + 0.5) * cell
        cy = lo[1] + (np.arange(ny) + 0.5) * cell
        xx, yy = np.meshgrid(cx, cy, indexing="ij")
        top = np.c_[xx.ravel(), yy.ravel(), np.full(xx.size, hi[2] + step_height)]
        hit = ground.ray_down(top, hi[2] - ground.mesh.bounds()[0][2] + 2 * step_height)
        has_ground = hit.hit.reshape(nx, ny)
        blocked = np.zeros((nx, ny), bool)
        if obstacles is not None and obstacles.mesh.n:
            idx = np.flatnonzero(has_ground.ravel())
            for level in (0.5, 1.3):
                probe = np.c_[top[idx, :2], hit.z[idx] + level]
                _, d = obstacles.nearest(probe, max_dist=clearance)
                blocked.ravel()[idx[d < clearance * 0.9]] = True
        walk = has_ground & ~blocked
        # 8-connected edges between walkable cells
        rows, cols, vals = [], [], []
        ids = np.arange(nx * ny).reshape(nx, ny)
        for di, dj in ((1, 0), (0, 1), (1, 1), (1, -1)):
            a = walk[max(0, -di):nx - max(0, di), max(0, -dj):ny - max(0, dj)]
            b = walk[max(0, di):, max(0, dj):][:a.shape[0], :a.shape[1]] if dj >= 0 else \
                walk[max(0, di):, :ny + dj][:a.shape[0], :a.shape[1]]
            ia = ids[max(0, -di):nx - max(0, di), max(0, -dj):ny - max(0, dj)]
            ib = ids[max(0, di):, max(0, dj):][:a.shape[0], :a.shape[1]] if dj >= 0 else \
                ids[max(0, di):, :ny + dj][:a.shape[0], :a.shape[1]]
            m = a & b
            rows.append(ia[m])
            cols.append(ib[m])
            vals.append(np.full(m.sum(), np.hypot(di, dj) * cell))
        # bridges across gaps (missing ground, not obstacles) for jumps
        if jump_reach > 0:
            void = ~has_ground
            border = walk & (np.pad(void, 1)[2:, 1:-1] | np.pad(void, 1)[:-2, 1:-1]
                             | np.pad(void, 1)[1:-1, 2:] | np.pad(void, 1)[1:-1, :-2])
            bi, bj = np.nonzero(border)
            r = int(np.ceil(jump_reach / cell))
            offs = [(a, b) for a in range(-r, r + 1) for b in range(-r, r + 1)
                    if 1 < np.hypot(a, b) * cell <= jump_reach]
            for a, b in offs:
                ti, tj = bi + a, bj + b
                ok = (ti >= 0) & (ti < nx) & (tj >= 0) & (tj < ny)
                ti, tj, si, sj = ti[ok], tj[ok], bi[ok], bj[ok]
                ok = border[ti, tj]
                # the straight line between may only cross void or walkable cells
                for t in np.linspace(0.2, 0.8, 4):
                    mi = np.rint(si + t * a).astype(int)
                    mj = np.rint(sj + t * b).astype(int)
                    ok &= ~blocked[mi, mj]
                rows.append(ids[si[ok], sj[ok]])
                cols.append(ids[ti[ok], tj[ok]])
                vals.append(np.full(ok.sum(), np.hypot(a, b) * cell))
        rows, cols, vals = np.concatenate(rows), np.concatenate(cols), np.concatenate(vals)
        graph = coo_matrix((vals, (rows, cols)), shape=(nx * ny, nx * ny)).tocsr()
        gi = int(np.clip(np.floor((goal[0] - lo[0]) / cell), 0, nx - 1))
        gj = int(np.clip(np.floor((goal[1] - lo[1]) / cell), 0, ny - 1))
        d = dijkstra(graph, directed=False, indices=ids[gi, gj])
        # 5 % short, and a cell's own size short, so the heuristic stays a lower bound
        d = np.maximum(0.95 * d - 1.5 * cell, 0.0)
        return DistanceField(lo, cell, (int(nx), int(ny)), d.reshape(nx, ny), graph)
