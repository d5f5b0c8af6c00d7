"""A footstep path to a goal: A* over footprints, expanded lazily during the search.

The thesis built a dense graph of sampled footprints up front (seconds to tens of
seconds) and named lazy construction as future work. Here a node is a footprint
reached by the search itself: expanding it pushes every step of the library from it
unchecked, and a successor is checked (one batched support query for it and the
unchecked siblings next in line, ``CHECK_CHUNK`` in all) only when it leaves the open
list, so only footprints the search is about to stand on are ever tested. Footprints
are merged on a grid (``cell`` metres, ``heading_bins`` headings), and support answers
are cached per fine grid key, so the cache serves later plans on the same geometry
(see ``FootprintCache``).

Cost is time (each step's duration), plus ``turn_penalty`` seconds per radian of
heading change, ``jump_penalty`` seconds per jump and ``run_penalty`` seconds per
running step (so the path walks unless it must run); a step set square on a stair's
tread costs its time as placed there (``_tread_costs``: every step on a flight is
shortened, and no stride penalty is charged for it). A walking or running step crosses
any gap its swing clears when both its footprints stand (stepping stones, the gap between
two slabs, a gutter); jump steps are taken only across a gap no such step spans (a
stretch without ground wider than the longest step less the foot's length), never on
open floor. The heuristic is the walking distance to the goal on
a coarse grid of up to three levels per cell (``DistanceField``: a bridge over a floor
is two levels; around walls; up and down no more than a step; over step edges only
where a foot fits; across gaps only where a step or a jump reaches, each counting what it
(a run, a jump and its run-up) costs beyond its length), or the straight distance less the goal radius
where that is longer, over the metres per second of cost (turn penalty included) of the
two cheapest alternating steps; it never overestimates. The search weighs it by
``heuristic_weight`` (weighted A*), starting at ``START_WEIGHT`` of w's excess over 1
and raising it by a quarter every ``RAISE_EVERY`` expansions, so short searches find
near-cheapest paths and long ones turn greedy; a weighted search's map also counts a
way along an edge or a wall ``EDGE_COST`` times (footprints keep off them), and its
heuristic counts a footprint turned away from the map's way ahead (``AHEAD_TURN_COST``),
so it turns into a bend before it runs into its outer edge. (These two preferences make
the w bound on the cost approximate; the planner benchmark measures the cost found
against plain A*'s.) When the search floods a place without getting nearer (``STALL``
expansions), it suspects the jumps the map promised there and takes the map without
them (over the cells built once per search), when the goal can still be reached without
them, dropping the open footprints that those jumps reached; where there is no bridge to
drop, or the goal needs it, it turns greedier sooner (the weight up by ``STALL_RAISE``
of its excess). w = 1 is plain A*. A
refused plan says where the search got to and what blocks the library's steps there
(``Rejections``: the wall and the clearance, the step's height, the treads' depth
against the foot, the gap's width against the jump's reach).

This module holds ``Planner`` (the search loop: its start, heuristic, expansion, checks
as footprints leave the open list, reroutes and result) and ``PlanResult``. Its parts:
``search_state`` (``PlanError``, ``SearchNode``, the open list), ``distance_field`` (the
heuristic's ``DistanceField``), ``support_cache`` (``FootprintCache`` and the grid
keys), ``step_rules`` (``StepRules``: what a step may pass over, how far it may climb,
what it costs) and ``refusals`` (``Refusals``, ``Rejections``: why a plan was refused).
"""

from __future__ import annotations

import heapq
import time
from dataclasses import dataclass, field, replace
from typing import Callable

import numpy as np

from ..base.angles import wrap
from ..base.settings import Settings
from ..base.timing import collection_paused
from ..clips.steps import StepSet
from ..footprint import PathFootprint
from .distance_field import AHEAD_TURN_COST, EDGE_COST, FREE_TURN, DistanceField, FieldCells, FieldLimits
from .islands import Patches
from .others import BODY_RADIUS, STANCE_STEPS, Others
from .refusals import Refusals
from .search_state import PlanError, SearchNode, _Batch, _Search
from .step_rules import CLIMB_DZ, StepRules, _start_gaits
from .support_cache import FINE_CELL, FINE_HEADING_BINS, GAIT_IDS, FootprintCache, _pack, fine_keys, fine_xy
from .surface import FootShape, Ground, SupportLimits, footprint_support
from .treads import Treads, find_treads


#: m: a footprint the distance field samples in a cell stands at the cell's level when
#: the ground under it is this near.
LEVEL_TOL = 0.05

#: m: the merge grid of footprints and the distance field's grid (a human's: scaled to
#: the character, as every length of the planner's is, by ``Settings.length``).
MERGE_CELL = 0.15
FIELD_CELL = 0.25

#: Successors of one expansion checked together when the first of them leaves the open
#: list (``Planner._check_batch``): the popped one and its siblings next in line.
CHECK_CHUNK = 12

#: The search starts with this fraction of the heuristic weight's excess over 1 and
#: adds a quarter of it every RAISE_EVERY footprints expanded (``Planner._weigh``).
START_WEIGHT = 0.2
RAISE_EVERY = 100
#: ... and a sixteenth where it stalls with no bridge to drop (``Planner._reroute``): the
#: stepping stones with CMU in 169 expansions (were 218) on a cheaper path, a jump after
#: a run-up (island_jump) in 136 (were 203). (An eighth took 134 and 113, but the sample
#: character's Jumps, from where it stands, then ran one step out of its second landing
#: where it had walked, and the blend's quick run to walk turned its forearm 2.5 degrees
#: a frame faster than its clips do.)
STALL_RAISE = 0.0625

#: The weighted search ends with the cheapest checked successor that reaches the goal once
#: nothing open costs less than this fraction below it (``Planner._offer_arrivals``):
#: footprints a step short of the goal are many, each nearly as cheap as the arrival, and
#: the search expanded them all before (the planner benchmark's median scene with CMU:
#: 104 expansions then, 52 now, its cost over plain A*'s 1.032 at the median, was 1.031).
#: Plain A* waits until nothing open is cheaper at all.
ARRIVE_SLACK = 0.02

#: Steps a run and a corner (a walk's turn tighter than any run turns: ``StepSet.corner``)
#: keep apart (``Planner._corner_history``): a run walks this many steps before it turns a
#: corner and after it, slowing into the walk's turn and speeding up after it.
CORNER_STEPS = 2

#: m: a stalled search's heuristic drops the jumps this close to where it is stuck.
REROUTE_RADIUS = 3.0

#: m: the hips above the footprints (a human's), where the search puts a body it keeps
#: clear of the other characters' (``Planner._clear_of_others``).
HIPS_HEIGHT = 0.95
#: s: a standing body is checked against the others this often (each check covers the
#: others' slack either side: ``others.TIME_SLACK``)
STAND_SLOT = 0.5


def _cheaper(best: dict, keys: np.ndarray, cost: np.ndarray) -> np.ndarray:
    """Indices of the successors (fine keys ``keys`` (K,) int64, costs ``cost`` (K,)) that
    reach their fine footprint more cheaply than any before them (``best``: key -> least
    cost so far, updated), in order, as a loop over them in turn would keep them: a key
    met twice keeps its later successor only where it is cheaper still."""
    ks = keys.tolist()
    if len(set(ks)) < len(ks):  # (a key met twice in this one expansion: in turn)
        keep = []
        for j, (g, f) in enumerate(zip(cost.tolist(), ks)):
            if best.get(f, np.inf) > g:
                best[f] = g
                keep.append(j)
        return np.array(keep, np.int64)
    keep = np.flatnonzero(np.array(list(map(best.get, ks, [np.inf] * len(ks))), float) > cost)
    best.update(zip([ks[j] for j in keep.tolist()], cost[keep].tolist()))
    return keep


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
    #: (index, s) of each stand to let another character pass (``stands.plan_round``):
    #: after footprint ``index`` (the other foot beside it is the next), or before the
    #: first step (index 0); the footprints' times include the stands
    waits: tuple = ()

    @property
    def explored_positions(self) -> np.ndarray:
        """(N, 3) every footprint the search reached, for review."""
        return np.array([n.position for n in self.explored], float).reshape(-1, 3)

    def to_dict(self) -> dict:
        return {
            "footprints": [{"foot": "LR"[f.foot], "position": [round(float(v), 4) for v in f.position],
                            "heading": round(float(f.heading), 4), "time": round(f.time, 4),
                            "clip": f.label, "gait": f.gait, "jump": f.jump,
                            **({} if f.speed is None else {"blend": round(float(f.speed), 4)})}
                           for f in self.footprints],
            "search": {"expanded": self.expanded, "generated": self.generated,
                       "seconds": round(self.seconds, 4), "field_seconds": round(self.field_seconds, 4),
                       "cost": round(self.cost, 4)},
            # (where: the report's "waypoints" rows, a "stand" per stand on the way, by frame)
            # (each stand's "pause": seconds of the animation the character stands, as a waypoint's pause)
            **({"stands": [{"pause": round(w, 3), "at_start": i == 0} for i, w in self.waits]} if self.waits else {}),
        }



@dataclass
class Planner(StepRules, Refusals):
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
    heading_bins: int = 36
    #: the characters already in the shot, in time (``others.Others``): a step that comes
    #: too near one's body or lands on its footprint at the same time is refused
    others: Others | None = None
    #: s: when the start footprints are stood on, on the others' clock (a plan that leaves
    #: a stand later); the path's footprint times stay from its start
    start_time: float = 0.0
    #: s: a path costing more is not wanted (another plan costs this): a footprint whose way
    #: there and heuristic on cost at least this is not pushed
    cost_limit: float = np.inf

    # The search's geometry, a human's (``Settings``: sizes) scaled to the character.
    @property
    def cell(self) -> float:
        """m: footprints closer than this (same foot, gait, heading bin) merge."""
        return self.settings.length(MERGE_CELL)

    @property
    def fine_cell(self) -> float:
        """m: the fine grid of support answers (``FootprintCache``) and of the open list's
        best costs."""
        return self.settings.length(FINE_CELL)

    def __post_init__(self):
        self.cache.cell = self.fine_cell  # (a cache is kept per foot, so per body: its keys are this planner's)

    @property
    def _gait_ids(self) -> np.ndarray:
        """(S,) int64 each step's gait as a number (``GAIT_IDS``), for the search's keys."""
        ids = getattr(self, "_gait_id_cache", None)
        if ids is None or len(ids) != self.steps.n:
            ids = np.array([GAIT_IDS.get(g, len(GAIT_IDS)) for g in self.steps.gait.tolist()], np.int64)
            self._gait_id_cache = ids
        return ids

    @property
    def field_cell(self) -> float:
        """m: the distance field's grid."""
        return self.settings.length(FIELD_CELL)

    @property
    def max_step_height(self) -> float:
        """m up or down between two footprints (``Settings.max_step_height``)."""
        return self.settings.max_step_height

    @property
    def clearance(self) -> float:
        """m from obstacles (``Settings.clearance``)."""
        return self.settings.clearance

    def _len(self, metres: float) -> float:
        """A human's ``metres`` (this module's constants) for the character."""
        return self.settings.length(metres)

    @property
    def support_limits(self) -> SupportLimits:
        """What a footprint of this planner's stands within (``SupportLimits.of`` its settings:
        ``max_step_height`` and ``clearance``)."""
        return SupportLimits.of(self.settings)

    @property
    def treads(self) -> Treads:
        """The stair treads of the traversable surfaces (``treads.find_treads``), found
        once per planner (its ground does not change), where the search's footprints are
        set square and whole (``_successors``); none with ``Settings.square_on_stairs``
        off."""
        found = getattr(self, "_treads", None)
        if found is None:
            found = (find_treads(self.ground.mesh, self.ground, self.max_step_height, self.settings.body_scale)
                     if self.settings.square_on_stairs else Treads.none())
            self._treads = found
        return found

    def _support(self, pos, heading):
        return footprint_support(self.ground, self.obstacles, pos, heading, self.forward, self.foot,
                                 self.support_limits)

    def _keys(self, foot: int, gaits, xy: np.ndarray, psi: np.ndarray) -> list[int]:
        """Merge-grid keys (foot, gait, cell x, cell y, heading bin, packed in one int:
        ``_pack``) of footprints; ``gaits`` names or ``_gait_ids``."""
        ids = np.array([GAIT_IDS.get(g, len(GAIT_IDS)) for g in gaits], np.int64) \
            if len(gaits) and isinstance(gaits[0], str) else np.asarray(gaits, np.int64)
        return _pack(foot, ids, xy, psi, self.cell, self.heading_bins).tolist()

    # ------------------------------------------------------------------ the search
    @collection_paused()
    def plan(self, start: list[PathFootprint], goal: np.ndarray, goal_heading: float | None = None) -> PlanResult:
        """A footstep path from ``start`` (the character's current footprints, in any
        order: the search may step off either) to ``goal`` (x, y, z), arriving turned
        within the goal heading tolerance of ``goal_heading`` (rad, like the footprints'
        headings) when one is given. Raises PlanError saying what blocks the way."""
        t0 = time.perf_counter()
        goal = np.asarray(goal, dtype=np.float64)
        self._check_goal(goal, goal_heading)
        t_field = time.perf_counter()
        cells = self.field_cells()
        dist = self.distance_field(goal, cells=cells)
        field_seconds = time.perf_counter() - t_field
        if self.steps.jump.any():  # (the map's message measures the gap against the step and the jump)
            self._refuse_unreachable(dist, start, goal)
            self._refuse_apart(start, goal)
        else:  # (ground apart and no jump clip: said by the gap no step spans)
            self._refuse_apart(start, goal)
            self._refuse_unreachable(dist, start, goal)
        search = _Search(goal, goal_heading, self._heuristic(dist, goal), self._base_costs(), self.steps.veer())
        search.cells = cells
        search.field_seconds = field_seconds
        search.weight = 1.0 + START_WEIGHT * (self.settings.heuristic_weight - 1.0)
        for s in start:
            for gait in _start_gaits(s, set(self.steps.gait[~self.steps.jump].tolist())):
                node = SearchNode(s.foot, gait, np.asarray(s.position, float), float(s.heading), 0.0, -1, -1,
                                  float(self.start_time))
                search.push(node, float(search.heuristic(node.position, [node.heading])[0]))
        # (plain A* ends with its arrival once nothing open may be cheaper: it stays exact)
        slack = ARRIVE_SLACK if self.settings.heuristic_weight > 1.0 else 0.0
        while search.heap:
            if search.arrival is not None and search.heap[0][0] >= search.arrival[0] * (1.0 - slack):
                break
            idx = self._pop(search)
            if idx is None:
                continue
            if self._arrived(search, idx):
                return self._result(search, idx, time.perf_counter() - t0, search.field_seconds)
            if self.settings.heuristic_weight > 1.0:
                if search.stalled(idx):
                    self._reroute(search)
                self._weigh(search)
            search.expanded += 1
            if search.expanded > self.settings.max_expansions:
                break
            self._expand(search, idx)
        if search.arrival is not None:
            _, b, j = search.arrival
            return self._result(search, self._take(search, search.batches[b], j), time.perf_counter() - t0,
                                search.field_seconds)
        if not search.heap and self.settings.weave_penalty > 0 and self.cost_limit == np.inf:
            # (every way on ran dry: the weave penalty orders the search, and the footprint
            # reached first closes its merge key, so a search without it may still find one)
            try:
                plain = replace(self, settings=self.settings.replace(weave_penalty=0.0)).plan(start, goal, goal_heading)
            except PlanError:
                pass
            else:
                return replace(plain, seconds=time.perf_counter() - t0, expanded=plain.expanded + search.expanded)
        raise self._dead_end(search)

    def distance_field(self, goal: np.ndarray, avoid: tuple | None = None,
                       cells: "FieldCells | None" = None) -> "DistanceField":
        """The walking-distance map to ``goal`` that the search's heuristic reads (without
        the jumps within ``avoid`` = (point, radius m), when given), over ``cells`` when
        they were built before (``field_cells``). A weighted search's map keeps off edges
        and walls (``EDGE_COST``); plain A*'s (weight 1) stays a lower bound."""
        return DistanceField.solve(cells if cells is not None else self.field_cells(), goal, avoid)

    def field_cells(self) -> "FieldCells":
        """The distance field's cells and edges over this planner's ground (any goal), kept
        in the support cache (``FootprintCache.field_cells``) for the next plan on the same
        geometry built to the same limits, steps, foot and forward."""
        edge_cost = EDGE_COST if self.settings.heuristic_weight > 1.0 else 1.0
        limits = FieldLimits(self.field_cell, self.clearance, self._jump_reach(), self.max_step_height,
                             self._jump_extra(), edge_cost, self.settings.body_scale)
        # (one island: no step leaves its ground)
        steps = self._gap_steps() if self.settings.cross_gaps and len(self.islands) > 1 else None
        key = (limits, None if steps is None else tuple(map(tuple, steps)), self.foot,
               tuple(np.asarray(self.forward, float).tolist()))
        return self.cache.field_cells(key, lambda: self._build_field_cells(limits, steps))

    def _build_field_cells(self, limits: FieldLimits, steps) -> "FieldCells":
        if steps is None:
            return FieldCells.build(self.ground, self.obstacles, limits, self._stands)
        scale, look = self.settings.body_scale, self._len(LEVEL_TOL)
        return FieldCells.build(self.ground, self.obstacles, limits, self._stands, steps=steps,
                                islands=lambda p: self.islands.at(self.ground, p, scale, look))

    def _stands(self, pos: np.ndarray, heading: np.ndarray) -> np.ndarray:
        """(N,) whether a foot may stand on the ground at footprints ``pos`` (N, 3) turned
        ``heading`` (N,), at their own height (a cell's level: not on a step beside it, its
        heel hanging over this one), obstacles aside (the distance field's own test of them)."""
        sup = footprint_support(self.ground, None, pos, heading, self.forward, self.foot,
                                SupportLimits(step_height=self.max_step_height))
        return sup.ok & (np.abs(sup.z - np.asarray(pos, float)[:, 2]) <= self._len(LEVEL_TOL))

    def _reroute(self, search: _Search) -> None:
        """The search floods round where it is stuck: the heuristic promised a jump there
        that the library's steps cannot set up (its run-up, its foot, its direction). Take
        the heuristic without the jumps within ``REROUTE_RADIUS`` of that place, when the
        goal can still be reached from there without them, and re-rank the open
        footprints by it, dropping those reached through such a jump (they stand where
        the search got stuck; the closed stay closed: the path stays valid)."""
        search.reroutes += 1
        where = search.best_h[2]
        avoid = (where, self._len(REROUTE_RADIUS))
        edges = search.cells.bridge_edges
        dist = None
        if len(edges[0]) and len(search.cells.grid.away(*edges, avoid)[0]) < len(edges[0]):
            t = time.perf_counter()
            dist = self.distance_field(search.goal, avoid, search.cells)
            search.field_seconds += time.perf_counter() - t
        if dist is None or not np.isfinite(dist.at_many(np.atleast_2d(where))[0]):
            # (no bridge there, or the goal needs it: the search floods a corner, or a gap's
            # edge it must cross by a step the map prices too cheaply, and turns greedier)
            search.best_h = (search.best_h[0], search.expanded, where)
            self._raise_weight(search, STALL_RAISE)
            return
        search.heuristic = self._heuristic(dist, search.goal)
        self._drop_after_jumps(search, np.asarray(where, float))
        self._rerank(search, fresh=True)
        search.best_h = (np.inf, search.expanded, where)

    def _drop_after_jumps(self, search: _Search, where: np.ndarray) -> None:
        """Take out of the open list the footprints reached through a jump that lands
        within ``REROUTE_RADIUS`` of ``where`` (and the jumps there not yet taken)."""
        if not search.nodes:
            return
        jump = self.steps.jump
        parent = np.array([n.parent for n in search.nodes])
        step = np.array([n.step for n in search.nodes])
        pos = np.array([n.position[:2] for n in search.nodes])
        near = np.linalg.norm(pos - where[:2], axis=1) <= self._len(REROUTE_RADIUS)
        flag = (step >= 0) & jump[np.maximum(step, 0)] & near
        while True:  # and everything reached from them (parents come before children)
            more = flag | ((parent >= 0) & flag[np.maximum(parent, 0)])
            if (more == flag).all():
                break
            flag = more
        if not flag.any() and not jump.any():
            return
        out = []
        for b in search.batches:
            bad = np.full(len(b.g), bool(flag[b.parent]))
            bad |= jump[b.sel] & (np.linalg.norm(b.nxt - where[:2], axis=1) <= self._len(REROUTE_RADIUS))
            out.append(bad.tolist())
        search.requeue(lambda b, j: not (flag[j] if b < 0 else out[b][j]))

    def _rerank(self, search: _Search, fresh: bool = False) -> None:
        """Re-rank the open list by the search's weight now (and, ``fresh``, by its
        heuristic now: each open footprint's is computed again)."""
        if fresh:
            pos = [search.nodes[j].position for j in range(len(search.nodes))]
            if pos:
                psi = [search.nodes[j].heading for j in range(len(search.nodes))]
                for j, hj in enumerate(search.heuristic(np.array(pos, float), psi).tolist()):
                    search.h[j] = hj
            if search.batches:  # every open successor's at once
                nxt = np.concatenate([b.nxt for b in search.batches])
                z = np.concatenate([np.full(len(b.g), search.nodes[b.parent].position[2]) for b in search.batches])
                h = search.heuristic(np.c_[nxt, z], np.concatenate([b.psi for b in search.batches]))
                at = np.cumsum([0] + [len(b.g) for b in search.batches])
                for k, batch in enumerate(search.batches):
                    batch.h[:] = h[at[k]:at[k + 1]]
        search.requeue()

    def _weigh(self, search: _Search) -> None:
        """The weight grows from ``START_WEIGHT`` of the user's excess over 1 by a quarter
        of it every ``RAISE_EVERY`` footprints expanded, up to the user's: a short search
        finds a path near the cheapest; a long one turns greedy, still within the weight."""
        if search.expanded and search.expanded % RAISE_EVERY == 0:
            self._raise_weight(search)

    def _raise_weight(self, search: _Search, by: float = 0.25) -> None:
        """The weight up by ``by`` of the user's excess over 1 (at most the user's), the
        open list re-ranked by it."""
        w = self.settings.heuristic_weight
        if search.weight < w:
            search.weight = min(w, search.weight + by * (w - 1.0))
            self._rerank(search)

    def _heuristic(self, dist: "DistanceField", goal: np.ndarray) -> Callable[[np.ndarray], np.ndarray]:
        """Remaining time (s) for points (N, >=2): the walking distance (less the goal
        radius) over the cheapest step's speed; off the grid's reach, three times the
        straight distance."""
        vmax, slack = self._cost_speed()
        radius = self.settings.goal_radius
        per_rad = AHEAD_TURN_COST if self.settings.heuristic_weight > 1.0 else 0.0
        yaw = float(np.arctan2(self.forward[1], self.forward[0]))

        def heuristic(p, psi=None):
            p = np.atleast_2d(p)
            d, ahead = dist.at_and_ahead(p)
            straight = np.hypot(goal[0] - p[:, 0], goal[1] - p[:, 1])
            # (any footprint within the goal radius ends the path)
            d = np.where(np.isfinite(d), np.maximum(d, straight) - radius, 3.0 * straight)
            h = np.maximum(d - slack, 0.0) / vmax
            if psi is not None and per_rad > 0:
                off = np.abs(wrap(np.asarray(psi, float) + yaw - ahead))
                over = off - FREE_TURN
                h = h + per_rad * np.where(over > 0.0, over, 0.0)  # (nan, where no way ahead is known: 0)
            return h
        return heuristic


    def _pop(self, search: _Search) -> int | None:
        """The cheapest open footprint's node index, its successor checked (support, step
        height, the way there) as it leaves the open list, closing its merge key (None if
        already closed or refused)."""
        f, _, b, j = heapq.heappop(search.heap)
        if b < 0:
            node = search.nodes[j]
            key = self._keys(node.foot, [node.gait], node.position[None, :2], np.array([node.heading]))[0]
            if key in search.closed:
                return None
            search.closed.add(key)
            return j
        search.advance(b)
        batch = search.batches[b]
        key = batch.keys[j]
        if key in search.closed:
            return None
        if batch.state[j] == 0:
            self._check_batch(search, batch, j)
        if batch.state[j] != 1:
            return None
        search.closed.add(key)
        return self._take(search, batch, j)

    def _take(self, search: _Search, batch: _Batch, j: int) -> int:
        """The index of a new node for checked successor ``j`` of ``batch``."""
        parent, i = search.nodes[batch.parent], int(batch.sel[j])
        search.nodes.append(SearchNode(1 - parent.foot, self.steps.gait[i],
                                       np.array([batch.nxt[j, 0], batch.nxt[j, 1], batch.z[j]]),
                                       float(batch.psi[j]), float(batch.g[j]), batch.parent, i, float(batch.t[j])))
        search.h.append(float(batch.h[j]))
        return len(search.nodes) - 1

    def _check_batch(self, search: _Search, batch: _Batch, j: int) -> None:
        """Check, in one batch, successor ``j`` of a batch and the ``CHECK_CHUNK`` - 1 of its
        siblings not checked yet whose merge key is still open that come first in the open
        list (the likeliest to leave it next): whether a foot may stand there, within a
        step's height, and the way there is clear (``_supported``, ``_way_clear``), and
        first, round other characters, clear of them in time (``_clear_of_others``, on the
        footprint's level before its ground is read). Which are checked when changes nothing
        but the work: a successor's answer is its own."""
        shut = search.closed.__contains__
        todo = np.flatnonzero((batch.state == 0) & ~np.fromiter(map(shut, batch.keys), bool, len(batch.keys)))
        node = search.nodes[batch.parent]
        if self.others is not None and len(todo):  # (first, all at once: no rays, and most go where others crowd)
            est = np.c_[batch.nxt[todo], np.full(len(todo), node.position[2])]
            free = self._clear_of_others(search, node, batch.sel[todo], est, batch.t[todo])
            batch.state[todo[~free]] = 2
            todo = todo[free]
            if not len(todo):
                return
        if len(todo) > CHECK_CHUNK:
            f = batch.g[todo] + search.weight * batch.h[todo]
            f[todo == j] = -np.inf
            todo = np.sort(todo[np.argpartition(f, CHECK_CHUNK - 1)[:CHECK_CHUNK]])
        nxt, psi = batch.nxt[todo], batch.psi[todo]
        ok, z = self._supported(node, nxt, psi)
        to = np.empty((len(todo), 3))
        to[:, :2], to[:, 2] = nxt, z
        ok &= np.abs(z - node.position[2]) <= self.max_step_height
        ok &= self._within_climb_reach(search, node, batch.sel[todo], nxt, z)
        if ok.any():
            ok[ok] &= self._way_clear(node, batch.sel[todo][ok], to[ok],
                                      fine_keys(nxt[ok], psi[ok], self.fine_cell))
        walk = ok & ~self.steps.jump[batch.sel[todo]]
        if walk.any() and node.parent >= 0:  # the stepping foot swings from the footprint before
            ok[walk] &= self._no_bump(search.nodes[node.parent].position, to[walk])
        batch.state[todo] = np.where(ok, 1, 2)
        batch.z[todo] = z

    def _clear_of_others(self, search: _Search, node: SearchNode, steps: np.ndarray, to: np.ndarray,
                         t: np.ndarray) -> np.ndarray:
        """(K,) whether steps ``steps`` from ``node`` to ``to`` (K, 3), landing at times ``t``
        (K,) s, keep clear of the other characters in the shot (``others``): the body, between
        the two feet, from where it is at ``node`` to where it will be, never within the two
        bodies' radii and ``Settings.character_clearance`` of another's at the same time, and
        the new footprint never on one another foot stands on during its stance."""
        here = node.position if node.parent < 0 else 0.5 * (node.position + search.nodes[node.parent].position)
        there = 0.5 * (node.position[None, :] + to)
        ok = self._bodies_apart(np.repeat(here[None, :2], len(to), axis=0), there[:, :2], np.full(len(to), node.time),
                                t, there[:, 2])
        if ok.any():
            ok[ok] = self._feet_clear(to[ok], t[ok], t[ok] + STANCE_STEPS * self.steps.duration[steps[ok]])
        return ok

    def _bodies_apart(self, a, b, t0, t1, z) -> np.ndarray:
        """``Others.bodies_apart`` for this character's body (hips ``HIPS_HEIGHT`` over the
        ground at ``z``, ``BODY_RADIUS``; its size and clearance)."""
        cfg = self.settings
        return self.others.bodies_apart(a, b, t0, t1, np.asarray(z, float) + self._len(HIPS_HEIGHT),
                                        self._len(BODY_RADIUS), cfg.character_clearance, cfg.body_scale)

    def _feet_clear(self, at, t0, t1) -> np.ndarray:
        """``Others.feet_clear`` for this character's foot (heel to toe tip)."""
        return self.others.feet_clear(at, t0, t1, self.foot.back + max(self.foot.front, self.foot.tip))

    def clear_in_time(self, path: list[PathFootprint], later: float = 0.0) -> np.ndarray:
        """(N,) per footprint of ``path`` whether the step onto it keeps clear of the other
        characters (``_clear_of_others``' test: the body from between the two footprints
        before to between the last and it, and the foot over its stance), its times from
        ``start_time`` and ``later`` s; the first (the start) True. The last also stands
        clear there to the end of the others' frames (``stand_clear``, the body over it): a
        character stands where its path ends (a bake holds its last pose), and one coming
        by later would walk into it."""
        n, others = len(path), self.others
        ok = np.ones(n, bool)
        if others is None or others.empty or n < 2:
            return ok
        pos = np.array([f.position for f in path], float)
        t = np.array([f.time for f in path], float) + self.start_time + later
        mid = 0.5 * (pos[1:] + pos[:-1])
        before = np.vstack([pos[:1], mid[:-1]])
        body = self._bodies_apart(before[:, :2], mid[:, :2], t[:-1], t[1:], mid[:, 2])
        ok[1:] = body & self._feet_clear(pos[1:], t[1:], t[1:] + STANCE_STEPS * np.maximum(t[1:] - t[:-1], 0.0))
        lead, rate = others.clock
        end = (float(others.times[-1]) - lead) / rate - self.start_time  # (the others' last frame, from start_time)
        arrive = t[-1] - self.start_time
        if ok[-1] and end > arrive:  # (it ends standing with the other foot brought beside the last)
            ok[-1] = self.stand_clear(pos[[-1, -1]], arrive, end)
        return ok

    def stand_clear(self, feet: np.ndarray, t0: float, t1: float) -> bool:
        """Whether a body standing over ``feet`` (2, 3) from ``t0`` to ``t1`` s (from
        ``start_time``) keeps clear of the other characters' bodies (the same clearance,
        every ``STAND_SLOT`` s) and no other foot lands on either footprint meanwhile."""
        if self.others is None or self.others.empty:
            return True
        t0, t1 = t0 + self.start_time, t1 + self.start_time
        centre = np.asarray(feet, float).mean(axis=0)
        slots = np.append(np.arange(t0, t1, STAND_SLOT), t1)
        at = np.repeat(centre[None, :2], len(slots), axis=0)
        return bool(self._bodies_apart(at, at, slots, slots, np.full(len(slots), centre[2])).all()
                    and self._feet_clear(np.asarray(feet, float), np.full(2, t0), np.full(2, t1)).all())

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
            or abs(wrap(node.heading - search.goal_heading)) <= cfg.goal_heading_tolerance)

    def _expand(self, search: _Search, idx: int) -> None:
        """Push the successors of node ``idx`` unchecked (``_pop`` checks each as it
        leaves the open list), but for the ones already pushed as cheaply to the same
        fine footprint."""
        node = search.nodes[idx]
        sel, nxt, npsi, keys, tread = self._successors(search, node)
        if not len(sel):
            return
        st = self.steps
        change = np.where(st.gait[sel] != node.gait, self.settings.gait_change_penalty, 0.0)
        step_cost = search.base_cost[sel] + self._weave(search, node, sel)
        if tread.any():  # (set square on a stair's tread: priced as placed, ``_tread_costs``)
            step_cost = np.where(tread, self._tread_costs()[sel]
                                 + self.settings.turn_penalty * np.abs(wrap(npsi - node.heading)), step_cost)
        cost = node.cost + (step_cost + change)
        fine = _pack(1 - node.foot, self._gait_ids[sel], nxt, npsi, self.fine_cell, FINE_HEADING_BINS)
        keep = _cheaper(search.best_g, fine, cost)
        if not len(keep):
            return
        at = np.empty((len(keep), 3))
        at[:, :2] = nxt[keep]
        at[:, 2] = node.position[2]
        h = search.heuristic(at, npsi[keep])
        if self.cost_limit < np.inf:
            under = cost[keep] + h < self.cost_limit
            if not under.all():
                keep, h, at = keep[under], h[under], at[under]
                if not len(keep):
                    return
        batch = _Batch(idx, sel[keep], nxt[keep], npsi[keep], cost[keep], [keys[j] for j in keep],
                       np.zeros(len(keep), np.int8), np.zeros(len(keep)), h,
                       node.time + self.steps.duration[sel[keep]])
        search.push_batch(batch)
        self._offer_arrivals(search, batch)

    def _offer_arrivals(self, search: _Search, batch: _Batch) -> None:
        """Check at once the successors of ``batch`` that would end the path (``_arrived``'s
        test) and keep the cheapest that may be taken as the search's arrival so far: the
        search ends with it once nothing open is more than ``ARRIVE_SLACK`` cheaper, not
        when it leaves the open list after every footprint near the goal cheaper than it
        (each a step short of it) was expanded."""
        goal, cfg = search.goal, self.settings
        parent = search.nodes[batch.parent].position
        if np.hypot(parent[0] - goal[0], parent[1] - goal[1]) > cfg.goal_radius + self._reach():
            return
        near = np.hypot(batch.nxt[:, 0] - goal[0], batch.nxt[:, 1] - goal[1]) <= cfg.goal_radius
        if search.goal_heading is not None:
            near &= np.abs(wrap(batch.psi - search.goal_heading)) <= cfg.goal_heading_tolerance
        for j in np.flatnonzero(near)[np.argsort(batch.g[near], kind="stable")].tolist():
            if search.arrival is not None and batch.g[j] >= search.arrival[0]:
                break
            if batch.keys[j] in search.closed:
                continue
            if batch.state[j] == 0:
                self._check_batch(search, batch, j)
            if batch.state[j] == 1:
                search.arrival = (float(batch.g[j]), len(search.batches) - 1, j)
                break

    def _reach(self) -> float:
        """m: farther than any successor lands from its footprint: the library's longest
        step (a jump's too), and a metre for a step set square on a tread or wholly on a
        stone."""
        got = self.__dict__.get("_reach_cache")
        if got is None or got[0] != self.steps.n:  # (asked at every expansion: once per planner)
            got = (self.steps.n, float(np.max(self._gait_reach(), initial=0.0)) + self._len(1.0))
            self.__dict__["_reach_cache"] = got
        return got[1]

    def _weave(self, search: _Search, node: SearchNode, sel: np.ndarray) -> np.ndarray | float:
        """(K,) s: the weave penalty of steps ``sel`` after the step that reached ``node``:
        ``Settings.weave_penalty`` per radian of veer the step undoes (the lesser of the
        two veers, where they turn opposite ways), but where both are steps of one clip
        (a captured clip's own steps may veer left and right in turn)."""
        w = self.settings.weave_penalty
        if w <= 0 or node.step < 0:
            return 0.0
        v0, v = search.veer[node.step], search.veer[sel]
        undo = (v * v0 < 0) & (self.steps.label[sel] != self.steps.label[node.step])
        return np.where(undo, w * np.minimum(np.abs(v), abs(v0)), 0.0)

    def _successors(self, search: _Search, node: SearchNode):
        """The steps that may follow ``node`` (indices (K,)), where they land (K, 2) and
        turned how (K,), with their merge keys and whether each was set square on a
        stair's tread (K,); merged-away (closed) ones dropped. No
        jump follows a jump, a jump is entered running, and the first step from a start
        (standing: ``_start_gaits``) keeps its gait and does not jump."""
        st = self.steps
        sel = self._steps_from(node, *self._corner_history(search, node))
        ang = node.heading + np.arctan2(self.forward[1], self.forward[0])
        c, s_ = np.cos(ang), np.sin(ang)
        fwd, left = st.fwd[sel], st.left[sel]
        nxt = np.empty((len(sel), 2))
        nxt[:, 0] = node.position[0] + fwd * c - left * s_
        nxt[:, 1] = node.position[1] + fwd * s_ + left * c
        npsi = wrap(node.heading + st.turn[sel])
        tread = np.zeros(len(sel), bool)
        if len(self.treads) and len(sel):  # (on a stair's tread: square to it, wholly on it)
            yaw0 = ang - node.heading
            side = 1.0 if node.foot == 1 else -1.0  # (a left foot follows a right one)
            toe = np.full(len(sel), self.steps.toe_out() * side)
            nxt, a, state = self.treads.square(nxt, npsi + yaw0, np.full(len(sel), node.position[2]), toe,
                                               self.foot, self.max_step_height,
                                               beside=(node.position, self.steps.stance_width(), side))
            keep = state >= 0  # (no foot askew on a flight)
            sel, nxt, npsi, tread = sel[keep], nxt[keep], wrap(a[keep] - yaw0), state[keep] == 1
        if len(self.patches) and len(sel):  # (partly on a stepping stone: wholly on it)
            nxt = self._onto_patches(node, sel, nxt, npsi)
        keys = self._keys(1 - node.foot, self._gait_ids[sel], nxt, npsi)
        shut = search.closed.__contains__
        todo = [j for j, k in enumerate(keys) if not shut(k)]
        if len(todo) == len(keys):
            return sel, nxt, npsi, keys, tread
        return sel[todo], nxt[todo], npsi[todo], [keys[j] for j in todo], tread[todo]

    def _corner_history(self, search: _Search, node: SearchNode) -> tuple[bool, bool]:
        """(whether a run or a jump, whether a corner (``StepSet.corner``: a walk's turn
        tighter than any run turns)) is among the CORNER_STEPS steps that reached ``node``:
        a corner is taken only that many walking steps after a run, and a run only that
        many steps after a corner, so a run slows into a walk to turn tighter than it can
        and speeds up after it, never one walking step in a run (the blend plays a single
        walk step among runs as a run)."""
        st = self.steps
        has = self.__dict__.get("_has_corners")
        if has is None or has[0] != st.n:
            has = self.__dict__["_has_corners"] = (st.n, bool(st.corner.any()))
        if not has[1]:
            return False, False
        ran = cornered = False
        i = node.step
        at = node
        for _ in range(CORNER_STEPS):
            if i < 0:
                break
            ran |= bool(st.gait[i] == "run")
            cornered |= bool(st.corner[i])
            if at.parent < 0:
                break
            at = search.nodes[at.parent]
            i = at.step
        return ran, cornered

    def _steps_from(self, node: SearchNode, ran: bool = False, cornered: bool = False) -> np.ndarray:
        """(K,) the indices of the steps that may follow ``node`` (``_successors``' rules),
        kept per kind of node: its foot, whether a jump reached it, whether it is a start,
        its gait, and whether a run (then no corner follows) or a corner (then no run
        follows) is among the steps that reached it (``_corner_history``)."""
        st = self.steps
        jumped = bool(node.step >= 0 and st.jump[node.step])
        kind = (st.n, node.foot, jumped, node.parent < 0, node.gait, ran, cornered)
        table = self.__dict__.setdefault("_steps_from_cache", {})
        sel = table.get(kind)
        if sel is None:
            sel = np.flatnonzero(st.foot == node.foot)
            if jumped:
                sel = sel[~st.jump[sel]]
            if node.parent < 0:  # (from standing, or a walk's footprint: the first step walks, and never jumps)
                sel = sel[~st.jump[sel] & (st.gait[sel] == node.gait)]
            elif node.gait == "walk":
                sel = sel[~st.jump[sel]]
            if ran:
                sel = sel[~st.corner[sel]]
            if cornered:
                sel = sel[st.gait[sel] != "run"]
            table[kind] = sel
        return sel

    def _onto_patches(self, node: SearchNode, sel: np.ndarray, nxt: np.ndarray, npsi: np.ndarray) -> np.ndarray:
        """(K, 2) where steps ``sel`` from ``node`` land (``nxt`` (K, 2), turned ``npsi``),
        each partly on a small island (a stepping stone: ``islands.Patches``) moved the
        least that puts its foot wholly on it, but never further from ``node`` than the
        longest step of its gait (a stride lengthened past the library's)."""
        yaw0 = float(np.arctan2(self.forward[1], self.forward[0]))
        moved_xy, moved = self.patches.onto(nxt, npsi + yaw0, np.full(len(sel), node.position[2]), self.foot,
                                            self.max_step_height, self.settings.body_scale)
        if moved.any():
            length = np.linalg.norm(moved_xy - node.position[:2], axis=1)
            moved &= length <= np.maximum(np.linalg.norm(nxt - node.position[:2], axis=1),
                                          self._gait_reach()[sel]) + 1e-9
            nxt = np.where(moved[:, None], moved_xy, nxt)
        return nxt

    def _gait_reach(self) -> np.ndarray:
        """(S,) m: the longest step of each step's gait (jumps: of the jumps)."""
        got = getattr(self, "_gait_reach_cache", None)
        if got is None or len(got) != self.steps.n:
            st = self.steps
            length = np.hypot(st.fwd, st.left)
            got = np.zeros(st.n)
            for g in set(st.gait.tolist()):
                for j in (False, True):
                    own = (st.gait == g) & (st.jump == j)
                    if own.any():
                        got[own] = length[own].max()
            self._gait_reach_cache = got
        return got

    @property
    def patches(self) -> Patches:
        """The ground's small islands (stepping stones: ``islands.Patches``), found once per
        planner, where a successor landing partly on one is moved wholly onto it; none
        without ``Settings.cross_gaps`` (no step crosses to one)."""
        found = getattr(self, "_patches", None)
        if found is None:
            found = Patches.of(self.ground, self.islands, self.settings.body_scale) \
                if self.settings.cross_gaps else Patches.none()
            self._patches = found
        return found

    def _supported(self, node: SearchNode, nxt: np.ndarray, npsi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(ok (K,), z (K,)): whether a foot may stand at each successor and the surface
        height there, from the cache where the fine key was seen before."""
        table = self.cache.table
        fine = fine_keys(nxt, npsi, self.fine_cell)
        ask = [j for j, k in enumerate(fine) if k not in table]
        if ask:
            at = np.empty((len(ask), 3))
            at[:, :2] = nxt[ask]
            at[:, 2] = node.position[2]
            sup = self._support(at, npsi[ask])
            for j, o, zz in zip(ask, sup.ok, sup.z):
                table[fine[j]] = (bool(o), float(zz))
        answers = np.array([table[k] for k in fine], dtype=float).reshape(-1, 2)
        return answers[:, 0].astype(bool), answers[:, 1]

    def _way_clear(self, node: SearchNode, steps: np.ndarray, to: np.ndarray, fine: list) -> np.ndarray:
        """(K,) whether each step from ``node`` to ``to`` (K, 3) may be taken: a walking or
        running step over ground or (``Settings.cross_gaps``) over a gap it spans from one
        island of the ground to another (both its footprints stand: stepping stones, the
        gap between two slabs, a gutter), a jump only across a gap, neither through an
        obstacle (cached per fine cell pair, with whether the way leaves the ground: an
        answer about islands, dropped when the scene changes, ``FootprintCache.update``)."""
        between = self.cache.between
        here = tuple(fine_xy(node.position[:2], self.fine_cell).tolist())
        pairs = [(here, k) for k in fine]
        ask = [n for n, k in enumerate(pairs) if k not in between]
        if ask:
            ground, clear, void = self._between(np.repeat(node.position[None], len(ask), axis=0), to[ask],
                                                with_void=True)
            for n, g_, c_, v_ in zip(ask, ground.tolist(), clear.tolist(), void.tolist()):
                between[pairs[n]] = (g_, c_, v_)
        gc = np.array([between[k][:2] for k in pairs], dtype=bool).reshape(-1, 2)
        return np.where(self.steps.jump[steps], ~gc[:, 0], gc[:, 0]) & gc[:, 1]

    def _result(self, search: _Search, idx: int, seconds: float, field_seconds: float) -> PlanResult:
        chain = []
        while idx >= 0:
            chain.append(search.nodes[idx])
            idx = search.nodes[idx].parent
        chain.reverse()
        out, tnow = [], 0.0
        on = np.zeros(len(chain), bool)
        pos = np.array([n.position for n in chain], float)
        if len(self.treads):  # (the footprints on a tread, which the synthesis keeps where planned)
            on = self.treads.under(pos[:, :2], pos[:, 2], self._len(CLIMB_DZ)) >= 0
        if len(self.patches):  # (and on a stepping stone, wholly: kept where planned too)
            on |= self.patches.under(pos[:, :2], pos[:, 2], self._len(CLIMB_DZ))
        for n, tread in zip(chain, on.tolist()):
            if n.step >= 0:
                tnow += float(self.steps.duration[n.step])
            out.append(PathFootprint(n.foot, n.position, n.heading, tnow,
                                "start" if n.step < 0 else str(self.steps.label[n.step]),
                                n.gait, bool(n.step >= 0 and self.steps.jump[n.step]), tread and n.step >= 0))
        return PlanResult(out, search.expanded, search.generated, seconds, chain[-1].cost, field_seconds,
                          search.nodes)
