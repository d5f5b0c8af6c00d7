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
running step (so the path walks unless it must run). A walking or running step crosses
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
them, dropping the open footprints that those jumps reached. w = 1 is plain A*. A
refused plan says where the search got to and what blocks the library's steps there
(``Rejections``: the wall and the clearance, the step's height, the treads' depth
against the foot, the gap's width against the jump's reach).
"""

from __future__ import annotations

import heapq
import time
from dataclasses import dataclass, field, replace
from typing import Callable, NamedTuple

import numpy as np

from ..base.errors import FootstepError
from ..base.settings import Settings
from ..clips.steps import StepSet
from ..footprint import PIVOT, STAND_LABEL, START_LABEL, PathFootprint
from .surface import FootShape, Ground, footprint_support


#: m: the fine grid on which support answers are cached. A footprint takes only the
#: answer of its own fine cell, so it never takes a neighbour's answer near an edge.
FINE_CELL = 0.02

#: m: a footprint the distance field samples in a cell stands at the cell's level when
#: the ground under it is this near.
LEVEL_TOL = 0.05

#: Heading bins of the fine grid (2 degrees each).
FINE_HEADING_BINS = 180


def fine_xy(xy: np.ndarray, cell: float = FINE_CELL) -> np.ndarray:
    """(N, 2) int64 fine-grid cells (``cell`` m: FINE_CELL, a human's, or the body's
    ``Planner.fine_cell``) of positions (N, >=2) in metres."""
    return np.rint(np.asarray(xy, float)[..., :2] / cell).astype(np.int64)


#: Gaits as numbers in the search's packed keys (``_pack``); any other gait takes the next.
GAIT_IDS = {"walk": 0, "run": 1}


def _pack(foot: int, gait: np.ndarray, xy: np.ndarray, heading: np.ndarray, cell: float, bins: int) -> np.ndarray:
    """(N,) int64 keys of footprints of ``foot`` in gaits ``gait`` (N,) (``GAIT_IDS``) at
    ``xy`` (N, 2) m turned ``heading`` (N,) rad, on a grid of ``cell`` m and ``bins``
    headings (at most 256): each (foot, gait, cell x, cell y, heading bin) one int, cells
    within 2**20 of the origin (20,000 km on a 2 cm grid)."""
    c = np.rint(np.asarray(xy, float)[..., :2] / cell).astype(np.int64) + (1 << 20)
    b = np.rint(np.asarray(heading, float) / (2 * np.pi) * bins).astype(np.int64) % bins
    return (((c[:, 0] << 21) + c[:, 1]) << 8 | b) << 3 | (np.asarray(gait, np.int64) << 1) | int(foot)


def fine_keys(xy: np.ndarray, heading: np.ndarray, cell: float = FINE_CELL) -> list[tuple[int, int, int]]:
    """Fine keys (cell x, cell y, heading bin) of footprints at ``xy`` (N, 2) m turned
    ``heading`` (N,) rad: the keys of ``FootprintCache.table`` (cells ``cell`` m)."""
    c = fine_xy(xy, cell)
    b = np.rint(np.asarray(heading, float) / (2 * np.pi / FINE_HEADING_BINS)).astype(np.int64) % FINE_HEADING_BINS
    return list(zip(c[:, 0].tolist(), c[:, 1].tolist(), b.tolist()))


#: m: a step's curvature (``Settings.curvature_penalty``) is its veer over its clip's
#: step length, or over this for a shorter one.
MIN_STEP = 0.2

#: m: the ground between two footprints may rise this much above the higher of them
#: (a swinging foot steps over a bump, not up a stair and down again).
MAX_BUMP = 0.1


#: m: a step up or down more than this is a climb, held to ``climb_reach``.
CLIMB_DZ = 0.03


def _start_gaits(fp: "PathFootprint", gaits=("walk", "run")) -> tuple[str, ...]:
    """The gaits a search may leave ``fp`` in, of the library's ``gaits``: a standing foot
    (a start, a turn's pivot step) walks off (a run from standing would have no run-up: the
    sample character ran off from standing, arms popping as the idle pose handed over to
    the run), or runs off where the library has no walk (a runs-only library starts as its
    start clip, or a start made from its standing pose, sets it running); a footprint a
    walk or run reached (a waypoint passed through) goes on in its gait (and changes it at
    the gait change's cost)."""
    if fp.label in (START_LABEL, PIVOT, STAND_LABEL) or fp.gait not in ("walk", "run"):
        return ("walk",) if "walk" in gaits or "run" not in gaits else ("run",)
    return (fp.gait,)


def climb_reach(steps: StepSet) -> np.ndarray:
    """(S,) m: how far over the ground (from footprint to footprint, across included) a
    step may go where it climbs or descends: the longer step of the walk's straightest
    cycle at its clip's own stride (the cycle whose steps veer least; of several, the
    shortest), whatever the gait (a run's steps, over a metre, would leap a flight's
    treads; without a walk, each gait's own). Longer steps are for level ground."""
    out = np.full(steps.n, np.inf)
    veer = np.abs(steps.cycle_mean(steps.veer()))
    length = np.hypot(steps.fwd, steps.left)
    gaits = sorted(set(steps.gait.tolist()), key=lambda g: g != "walk")
    for gait in gaits:
        own = (steps.gait == gait) & ~steps.jump & (steps.stride == 1.0)
        if not own.any():
            continue
        straight = own & (veer <= veer[own].min() + 1e-9)
        walk = min(set(steps.label[straight].tolist()), key=lambda lab: length[straight & (steps.label == lab)].mean())
        limit = float(length[straight & (steps.label == walk)].max())  # (of straight walks, the shortest)
        if gait == "walk":
            return np.full(steps.n, limit)
        out[steps.gait == gait] = limit
    return out


class PlanError(FootstepError):
    """No path: the message says why, and where the nearest reachable point is.
    ``expanded`` footprints were expanded before the search gave up (0: refused before
    any search), ``explored`` the search's nodes (``SearchNode``)."""

    def __init__(self, message: str, expanded: int = 0, explored: list | None = None):
        super().__init__(message)
        self.expanded = expanded
        self.explored = explored or []


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
    cell: float = FINE_CELL  # m: the fine grid of the keys (the planner's ``fine_cell``)

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
                  if any(lo[0] - self.margin - 2 <= k[0][0] * self.cell <= hi[0] + self.margin + 2
                         and lo[1] - self.margin - 2 <= k[0][1] * self.cell <= hi[1] + self.margin + 2
                         for _, lo, hi in changed)]:
            del self.between[k]
        keys = list(self.table)
        xy = np.array([k[:2] for k in keys], dtype=np.float64) * self.cell
        drop = np.zeros(len(keys), bool)
        for _, lo, hi in changed:
            drop |= ((xy[:, 0] >= lo[0] - self.margin) & (xy[:, 0] <= hi[0] + self.margin)
                     & (xy[:, 1] >= lo[1] - self.margin) & (xy[:, 1] <= hi[1] + self.margin))
        for k in np.flatnonzero(drop):
            del self.table[keys[k]]
        return int(drop.sum())


class _Batch(NamedTuple):
    """The successors of one expanded node, not yet checked: the parent's index, the
    steps (K,), where they land (K, 2), turned how (K,), the cost there (K,), their merge
    keys."""

    parent: int
    sel: np.ndarray
    nxt: np.ndarray
    psi: np.ndarray
    g: np.ndarray
    keys: list
    state: np.ndarray  # (K,) int8: 0 unchecked, 1 may be stood on and reached, 2 not
    z: np.ndarray  # (K,) the surface's height there, once checked
    h: np.ndarray  # (K,) the heuristic there (unweighted)


#: Footprints expanded without the heuristic falling before the search suspects the
#: jumps near where it is stuck (``Planner._reroute``), and how often it may.
STALL = 120
MAX_REROUTES = 4

#: Successors of one expansion checked together when the first of them leaves the open
#: list (``Planner._check_batch``): the popped one and its siblings next in line.
CHECK_CHUNK = 12


@dataclass
class _Search:
    """One search's state (never kept on the planner)."""

    goal: np.ndarray
    goal_heading: float | None
    heuristic: Callable[[np.ndarray], np.ndarray]
    base_cost: np.ndarray  # (S,) each step's cost before a gait change
    veer: np.ndarray  # (S,) rad each step's veer (``StepSet.veer``), for the weave penalty
    nodes: list[SearchNode] = field(default_factory=list)
    heap: list = field(default_factory=list)
    best_g: dict = field(default_factory=dict)
    closed: set = field(default_factory=set)
    expanded: int = 0
    generated: int = 0
    nearest: tuple = (np.inf, None)  # (distance to the goal, position) of the closest node
    h: list = field(default_factory=list)  # each node's heuristic
    best_h: tuple = (np.inf, 0, None)  # (least heuristic popped, when, where)
    reroutes: int = 0  # times the heuristic was rebuilt without jumps where the search stalled
    field_seconds: float = 0.0
    climb_reach: np.ndarray | None = None  # (S,) m, ``climb_reach`` of the steps, once per search

    batches: list = field(default_factory=list)  # unchecked successors, one _Batch per expansion
    weight: float = 1.0  # the heuristic's weight now (``Planner._weigh``)
    seq: int = 0  # pushes so far (ties in the heap go first in, first out)
    cells: object = None  # the distance field's cells (``FieldCells``), built once per search
    # each batch's successors still queued behind the one it has in the heap (in the order
    # they leave it, last first), their f at the weight now, and the batch's first sequence
    queued: list = field(default_factory=list)
    f: list = field(default_factory=list)
    seq0: list = field(default_factory=list)

    def push(self, node: SearchNode, h: float) -> None:
        """A checked footprint (a start footprint) into the open list."""
        self.nodes.append(node)
        self.h.append(h)
        self.seq += 1
        heapq.heappush(self.heap, (node.cost + self.weight * h, self.seq, -1, len(self.nodes) - 1))

    def push_batch(self, batch: "_Batch") -> None:
        """A node's successors, unchecked, into the open list (checked when popped). The
        heap holds one entry per batch, its next successor by (f, sequence): the others
        wait in the batch's own order (``queued``) and each takes the heap's place of the
        one before as it leaves (``advance``), so the open list leaves in the order a heap
        of every successor would, with a heap the size of the expansions."""
        self.batches.append(batch)
        n = len(batch.g)
        self.seq0.append(self.seq)
        self.seq += n
        self.f.append([])
        self.queued.append([])
        self._queue(len(self.batches) - 1, np.arange(n))
        self.generated += n

    def _queue(self, b: int, rest: np.ndarray) -> None:
        """Queue successors ``rest`` of batch ``b`` (none of them in the heap) at the weight
        now, and put the first in the heap."""
        batch = self.batches[b]
        f = batch.g + self.weight * batch.h
        self.f[b] = f.tolist()
        rest = np.asarray(rest, np.int64)
        self.queued[b] = rest[np.lexsort((rest, f[rest]))][::-1].tolist()
        self.advance(b)

    def advance(self, b: int) -> None:
        """The next queued successor of batch ``b`` into the heap."""
        if self.queued[b]:
            j = self.queued[b].pop()
            heapq.heappush(self.heap, (self.f[b][j], self.seq0[b] + j + 1, b, j))

    def requeue(self, keep: Callable | None = None) -> None:
        """The open list again at the weight now (and the batches' heuristics now), less
        the entries ``keep(b, j)`` (b -1: a node j) refuses."""
        heads = {e[2]: e[3] for e in self.heap if e[2] >= 0}
        w = self.weight
        self.heap = [(self.nodes[j].cost + w * self.h[j], q, -1, j) for _, q, b, j in self.heap
                     if b < 0 and (keep is None or keep(-1, j))]
        heapq.heapify(self.heap)
        for b, batch in enumerate(self.batches):
            rest = self.queued[b] + ([heads[b]] if b in heads else [])
            if keep is not None:
                rest = [j for j in rest if keep(b, j)]
            self.queued[b] = []
            if rest:
                self._queue(b, np.array(rest))

    def stalled(self, idx: int) -> bool:
        """Whether the search has expanded ``STALL`` footprints since the heuristic of
        the footprints it pops last fell (it is flooding round a local minimum)."""
        h = self.h[idx]
        if h < self.best_h[0] - 1e-9:
            self.best_h = (h, self.expanded, self.nodes[idx].position)
            return False
        return self.expanded - self.best_h[1] > STALL and self.reroutes < MAX_REROUTES


#: m: the ground under a way is sampled this far apart to measure its widest gap
#: (``Planner._widest_gap``).
GAP_SPACING = 0.05

#: m: a step longer than this (a jump) is checked for obstacles all along its way
LONG_WAY = 0.9

#: m: the merge grid of footprints and the distance field's grid (a human's: scaled to
#: the character, as every length of this module is, by ``Settings.length``).
MERGE_CELL = 0.15
FIELD_CELL = 0.25

#: m above a footprint's ground: a standing body's head and hips (``Planner._between``),
#: and the hips of a body in the air along a jump (``Planner._clear_along``).
HEAD_HEIGHT = 1.6
HIPS_HEIGHT = 1.0


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
    heading_bins: int = 36

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

    def _support(self, pos, heading):
        return footprint_support(self.ground, self.obstacles, pos, heading, self.forward, self.foot,
                                 step_height=self.max_step_height, clearance=self.clearance)

    def _keys(self, foot: int, gaits, xy: np.ndarray, psi: np.ndarray) -> list[int]:
        """Merge-grid keys (foot, gait, cell x, cell y, heading bin, packed in one int:
        ``_pack``) of footprints; ``gaits`` names or ``_gait_ids``."""
        ids = np.array([GAIT_IDS.get(g, len(GAIT_IDS)) for g in gaits], np.int64) \
            if len(gaits) and isinstance(gaits[0], str) else np.asarray(gaits, np.int64)
        return _pack(foot, ids, xy, psi, self.cell, self.heading_bins).tolist()

    def _between(self, a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """For footprint pairs (rows of a, b (N, 3)): (no gap lies between them wider than
        the library's steps span, ``_widest_gap``: only a jump may cross one, and a jump
        only that; the way between them is clear of obstacles). Three points between are
        tested: the ground no higher than MAX_BUMP over the higher footprint; no obstacle
        may stand there below head height, nor closer than half the clearance at the hips."""
        pts, z = self._ground_between(a, b)
        ground = self._widest_gap(a, b) <= self._gap_spanned()
        # a step does not pass over ground higher than both its ends (a landing's corner
        # cut from one flight to the other): the swinging foot would have to climb it
        clear = self._under_bump(a, b, z)
        if self.obstacles is not None and self.obstacles.mesh.n:
            base = np.minimum(a[:, None, 2], b[:, None, 2]) + np.zeros((1, 3))
            head = np.concatenate([pts[..., :2], (base + self._len(HEAD_HEIGHT))[..., None]], axis=2).reshape(-1, 3)
            inside = self.obstacles.ray_down(head, self._len(HEAD_HEIGHT - 0.05)).hit.reshape(len(a), 3).any(axis=1)
            hips = head.copy()
            hips[:, 2] -= self._len(HEAD_HEIGHT - HIPS_HEIGHT)
            _, d = self.obstacles.nearest(hips, max_dist=0.5 * self.clearance)
            near = (d < 0.5 * self.clearance).reshape(len(a), 3).any(axis=1)
            clear &= ~inside & ~near
            long = np.flatnonzero(clear & (np.linalg.norm((b - a)[:, :2], axis=1) > self._len(LONG_WAY)))
            if len(long):  # (a jump's three points may all fall inside a thick wall: look all along)
                clear[long] = self._clear_along(a[long], b[long])
        return ground, clear

    def _gap_spanned(self) -> float:
        """m: the widest gap a step of the library that is not a jump spans with both its
        footprints standing: its longest step less the foot's length."""
        return self._step_reach() - (self.foot.back + self.foot.front)

    def _widest_gap(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """(N,) m: the longest stretch without ground (within a step's height) on the way
        from each ``a`` to ``b`` (N, 3), sampled every GAP_SPACING m; 0 for a way no longer
        than the widest gap a step spans (``_gap_spanned``: its gaps are all narrower)."""
        out = np.zeros(len(a))
        length = np.linalg.norm((b - a)[:, :2], axis=1)
        long = np.flatnonzero(length > self._gap_spanned())
        if not len(long):
            return out
        spacing = self._len(GAP_SPACING)
        n = int(np.ceil(length[long].max() / spacing)) + 1
        t = np.linspace(0.0, 1.0, n)
        a_, b_ = a[long], b[long]
        pts = a_[:, None] + (b_ - a_)[:, None] * t[None, :, None]
        pts[..., 2] = np.maximum(a_[:, 2], b_[:, 2])[:, None] + self.max_step_height
        hit = self.ground.ray_down(pts.reshape(-1, 3), 2 * self.max_step_height + self._len(0.2)).hit
        miss = ~hit.reshape(len(long), n)
        # the longest run of misses in each row
        run = np.zeros(len(long), int)
        best = np.zeros(len(long), int)
        for k in range(n):
            run = np.where(miss[:, k], run + 1, 0)
            best = np.maximum(best, run)
        out[long] = (best + 1) * length[long] / (n - 1) * (best > 0)  # (a run of k misses: k + 1 spacings at most)
        return out

    def _ground_between(self, a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(points (N, 3, 3) a quarter, half and three quarters of the way from each ``a``
        to ``b`` (N, 3), the ground's height under them (N, 3), nan where none within a
        step's height)."""
        t = np.array([0.25, 0.5, 0.75])
        pts = a[:, None] + (b - a)[:, None] * t[None, :, None]
        top = pts.copy()
        top[..., 2] = np.maximum(a[:, None, 2], b[:, None, 2]) + self.max_step_height
        hit = self.ground.ray_down(top.reshape(-1, 3), 2 * self.max_step_height + self._len(0.2))
        return pts, np.where(hit.hit, hit.z, np.nan).reshape(len(a), 3)

    def _under_bump(self, a: np.ndarray, b: np.ndarray, z: np.ndarray) -> np.ndarray:
        """(N,) whether the ground ``z`` (N, 3) between each ``a`` and ``b`` (N, 3) stays
        within MAX_BUMP of the higher end."""
        return np.nan_to_num(z, nan=-np.inf).max(axis=1) <= np.maximum(a[:, 2], b[:, 2]) + self._len(MAX_BUMP)

    def _no_bump(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """(K,) whether the ground from ``a`` (3,) to each of ``b`` (K, 3) (a foot's swing,
        from its last footprint to its next) stays within MAX_BUMP of the higher end:
        a foot swings over a tread between two, not over a landing's corner."""
        a = np.broadcast_to(np.asarray(a, float), b.shape)
        return self._under_bump(a, b, self._ground_between(a, b)[1])

    def _clear_along(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """(N,) whether the way from each ``a`` to ``b`` (N, 3) keeps the body's clearance
        of every obstacle at points no further apart than half of it: from inside a wall
        thicker than the clearance the nearest face is out of reach, but the points where
        the way enters and leaves it are not."""
        n = int(np.ceil(np.linalg.norm((b - a)[:, :2], axis=1).max() / (0.5 * self.clearance))) + 1
        t = np.linspace(0.0, 1.0, n + 1)[1:-1]
        pts = a[:, None] + (b - a)[:, None] * t[None, :, None]
        hips = pts.copy()
        hips[..., 2] = np.minimum(a[:, None, 2], b[:, None, 2]) + self._len(HIPS_HEIGHT)
        _, d = self.obstacles.nearest(hips.reshape(-1, 3), max_dist=0.5 * self.clearance)
        return ~(d < 0.5 * self.clearance).reshape(len(a), -1).any(axis=1)

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
        cells = self.field_cells()
        dist = self.distance_field(goal, cells=cells)
        field_seconds = time.perf_counter() - t_field
        self._refuse_unreachable(dist, start, goal)
        search = _Search(goal, goal_heading, self._heuristic(dist, goal), self._base_costs(), self.steps.veer())
        search.cells = cells
        search.field_seconds = field_seconds
        search.weight = 1.0 + START_WEIGHT * (self.settings.heuristic_weight - 1.0)
        for s in start:
            for gait in _start_gaits(s, set(self.steps.gait[~self.steps.jump].tolist())):
                node = SearchNode(s.foot, gait, np.asarray(s.position, float), float(s.heading), 0.0, -1, -1)
                search.push(node, float(search.heuristic(node.position, [node.heading])[0]))
        while search.heap:
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
        if not search.heap and self.settings.weave_penalty > 0:
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
        """The distance field's cells and edges over this planner's ground (any goal)."""
        edge_cost = EDGE_COST if self.settings.heuristic_weight > 1.0 else 1.0
        return FieldCells.build(self.ground, self.obstacles, self.field_cell, self.clearance, self._jump_reach(),
                                self.max_step_height, self._jump_extra(), edge_cost, self._stands,
                                scale=self.settings.body_scale, steps=self._gap_steps())

    def _stands(self, pos: np.ndarray, heading: np.ndarray) -> np.ndarray:
        """(N,) whether a foot may stand on the ground at footprints ``pos`` (N, 3) turned
        ``heading`` (N,), at their own height (a cell's level: not on a step beside it, its
        heel hanging over this one), obstacles aside (the distance field's own test of them)."""
        sup = footprint_support(self.ground, None, pos, heading, self.forward, self.foot,
                                step_height=self.max_step_height)
        return sup.ok & (np.abs(sup.z - np.asarray(pos, float)[:, 2]) <= self._len(LEVEL_TOL))

    def _reroute(self, search: _Search) -> None:
        """The search floods round where it is stuck: the heuristic promised a jump there
        that the library's steps cannot set up (its run-up, its foot, its direction). Take
        the heuristic without the jumps within ``REROUTE_RADIUS`` of that place, when the
        goal can still be reached from there without them, and re-rank the open
        footprints by it, dropping those reached through such a jump (they stand where
        the search got stuck; the closed stay closed: the path stays valid)."""
        search.reroutes += 1
        t = time.perf_counter()
        where = search.best_h[2]
        dist = self.distance_field(search.goal, (where, self._len(REROUTE_RADIUS)), search.cells)
        search.field_seconds += time.perf_counter() - t
        if not np.isfinite(dist.at_many(np.atleast_2d(where))[0]):
            search.best_h = (search.best_h[0], search.expanded, where)
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

    def _check_goal(self, goal: np.ndarray, goal_heading: float | None) -> None:
        """PlanError when no traversable surface lies under (or near above) the goal."""
        gsup = self._support(goal[None], np.array([goal_heading or 0.0]))
        if not gsup.ok[0] and gsup.reason[0] in ("off surface", "uneven", "steep"):
            hit = self.ground.ray_down(np.array([[goal[0], goal[1], goal[2] + self._len(2.0)]]), self._len(10.0))
            if not hit.hit[0]:
                raise PlanError(f"the goal ({goal[0]:.2f}, {goal[1]:.2f}, {goal[2]:.2f}) is off every "
                                "traversable surface")

    def _refuse_unreachable(self, dist: "DistanceField", start: list[PathFootprint], goal: np.ndarray) -> None:
        """PlanError before any search when the walking-distance map has no way from the
        start to the goal, saying what blocks the library's steps at the nearest point
        the map reaches (``Rejections``)."""
        if not np.isfinite(dist.at_many(np.array([f.position for f in start], float))).any():
            near = dist.nearest_reachable(np.asarray(start[0].position, float), goal)
            ang = np.arctan2(goal[1] - near[1], goal[0] - near[0]) - np.arctan2(self.forward[1], self.forward[0])
            left = 0.1 * np.array([-np.sin(ang + np.arctan2(self.forward[1], self.forward[0])),
                                   np.cos(ang + np.arctan2(self.forward[1], self.forward[0])), 0.0])
            nodes = [SearchNode(foot, gait, near + sign * left, float(ang), 0.0, -1, -1)
                     for foot, sign in ((0, 1), (1, -1)) for gait in ("walk", "run")]
            d0 = float(np.linalg.norm(goal[:2] - near[:2]))
            blocker = Rejections.of(self, nodes, goal, d0).words(self, near, goal)
            raise PlanError(
                f"the goal ({goal[0]:.2f}, {goal[1]:.2f}) cannot be reached: no walkable way, nor a "
                f"gap a step or a jump clip can clear, leads there from the start; the nearest reachable "
                f"point is ({near[0]:.2f}, {near[1]:.2f}), {d0:.2f} m from the goal"
                + (f"; {blocker}" if blocker else ""))

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
        w = self.settings.heuristic_weight
        if search.weight < w and search.expanded and search.expanded % RAISE_EVERY == 0:
            search.weight = min(w, search.weight + 0.25 * (w - 1.0))
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
                off = np.abs(_wrap(np.asarray(psi, float) + yaw - ahead))
                h = h + per_rad * np.nan_to_num(np.maximum(off - FREE_TURN, 0.0), nan=0.0)
            return h
        return heuristic

    def _base_costs(self) -> np.ndarray:
        """(S,) s: each step's cost, its duration plus the turn, jump and run penalties
        (a gait change is added per successor)."""
        st, cfg = self.steps, self.settings
        veer = np.abs(st.veer())
        length = np.maximum(np.hypot(st.fwd / st.stride, st.left), self._len(MIN_STEP))  # (shortened: its clip's)
        kappa = (veer + np.abs(st.sidestep()) / length) / length  # 1/m: the way's heading change and a crab's
        return (st.time_cost(cfg.stride_penalty) + cfg.turn_penalty * veer
                + cfg.curvature_penalty * kappa
                + np.where(st.jump, cfg.jump_penalty, 0.0)
                + np.where(st.gait == "run", cfg.run_penalty, 0.0))

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
        parent, i = search.nodes[batch.parent], int(batch.sel[j])
        search.closed.add(key)
        g = float(batch.g[j])
        search.nodes.append(SearchNode(1 - parent.foot, self.steps.gait[i],
                                       np.array([batch.nxt[j, 0], batch.nxt[j, 1], batch.z[j]]),
                                       float(batch.psi[j]), g, batch.parent, i))
        search.h.append(float(batch.h[j]))
        return len(search.nodes) - 1

    def _check_batch(self, search: _Search, batch: _Batch, j: int) -> None:
        """Check, in one batch, successor ``j`` of a batch and the ``CHECK_CHUNK`` - 1 of its
        siblings not checked yet whose merge key is still open that come first in the open
        list (the likeliest to leave it next): whether a foot may stand there, within a
        step's height, and the way there is clear (``_supported``, ``_way_clear``). Which
        are checked when changes nothing but the work: a successor's answer is its own."""
        todo = np.flatnonzero((batch.state == 0) & np.array([k not in search.closed for k in batch.keys]))
        if len(todo) > CHECK_CHUNK:
            f = batch.g[todo] + search.weight * batch.h[todo]
            f[todo == j] = -np.inf
            todo = np.sort(todo[np.argpartition(f, CHECK_CHUNK - 1)[:CHECK_CHUNK]])
        node = search.nodes[batch.parent]
        nxt, psi = batch.nxt[todo], batch.psi[todo]
        ok, z = self._supported(node, nxt, psi)
        ok &= np.abs(z - node.position[2]) <= self.max_step_height
        ok &= self._within_climb_reach(search, node, batch.sel[todo], nxt, z)
        if ok.any():
            ok[ok] &= self._way_clear(node, batch.sel[todo][ok], np.c_[nxt[ok], z[ok]],
                                      fine_keys(nxt[ok], psi[ok], self.fine_cell))
        walk = ok & ~self.steps.jump[batch.sel[todo]]
        if walk.any() and node.parent >= 0:  # the stepping foot swings from the footprint before
            ok[walk] &= self._no_bump(search.nodes[node.parent].position, np.c_[nxt[walk], z[walk]])
        batch.state[todo] = np.where(ok, 1, 2)
        batch.z[todo] = z

    def _within_climb_reach(self, search: _Search, node: SearchNode, steps: np.ndarray, nxt: np.ndarray,
                            z: np.ndarray) -> np.ndarray:
        """(K,) whether each walking or running step from ``node`` to (``nxt``, ``z``) that
        climbs or descends more than CLIMB_DZ goes no further over the ground than the
        walk's straight step (``climb_reach``): a running stride of a metre up or down a
        flight leaps its treads (the planner ran onto the sample Stairs and off them, and
        the legs snapped straight landing), and a stride lengthened for the level has no
        place on a stair; a person takes the walk's steps there, or shorter. Jumps are
        not held to it."""
        dz = np.abs(z - node.position[2])
        if search.climb_reach is None:
            search.climb_reach = climb_reach(self.steps)
        length = np.hypot(nxt[:, 0] - node.position[0], nxt[:, 1] - node.position[1])
        return (dz <= self._len(CLIMB_DZ)) | self.steps.jump[steps] | (length <= search.climb_reach[steps] + 1e-9)

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
        """Push the successors of node ``idx`` unchecked (``_pop`` checks each as it
        leaves the open list), but for the ones already pushed as cheaply to the same
        fine footprint."""
        node = search.nodes[idx]
        sel, nxt, npsi, keys = self._successors(search, node)
        if not len(sel):
            return
        st = self.steps
        change = np.where(st.gait[sel] != node.gait, self.settings.gait_change_penalty, 0.0)
        cost = node.cost + (search.base_cost[sel] + change + self._weave(search, node, sel))
        fine = _pack(1 - node.foot, self._gait_ids[sel], nxt, npsi, self.fine_cell, FINE_HEADING_BINS).tolist()
        best, keep, inf = search.best_g, [], np.inf
        for j, (g, f) in enumerate(zip(cost.tolist(), fine)):
            if best.get(f, inf) > g:
                best[f] = g
                keep.append(j)
        if not keep:
            return
        keep = np.array(keep)
        h = search.heuristic(np.c_[nxt[keep], np.full(len(keep), node.position[2])], npsi[keep])
        search.push_batch(_Batch(idx, sel[keep], nxt[keep], npsi[keep], cost[keep], [keys[j] for j in keep],
                                 np.zeros(len(keep), np.int8), np.zeros(len(keep)), h))

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
        turned how (K,), with their merge keys; merged-away (closed) ones dropped. No
        jump follows a jump, a jump is entered running, and the first step from a start
        (standing: ``_start_gaits``) keeps its gait and does not jump."""
        st = self.steps
        sel = np.flatnonzero(st.foot == node.foot)
        if node.step >= 0 and st.jump[node.step]:
            sel = sel[~st.jump[sel]]
        if node.parent < 0:  # (from standing, or a walk's footprint: the first step walks, and never jumps)
            sel = sel[~st.jump[sel] & (st.gait[sel] == node.gait)]
        elif node.gait == "walk":
            sel = sel[~st.jump[sel]]
        ang = node.heading + np.arctan2(self.forward[1], self.forward[0])
        f_ = np.array([np.cos(ang), np.sin(ang)])
        l_ = np.array([-f_[1], f_[0]])
        nxt = node.position[:2] + st.fwd[sel, None] * f_ + st.left[sel, None] * l_
        npsi = _wrap(node.heading + st.turn[sel])
        keys = self._keys(1 - node.foot, self._gait_ids[sel], nxt, npsi)
        closed = search.closed
        todo = [j for j, k in enumerate(keys) if k not in closed]
        return sel[todo], nxt[todo], npsi[todo], [keys[j] for j in todo]

    def _supported(self, node: SearchNode, nxt: np.ndarray, npsi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(ok (K,), z (K,)): whether a foot may stand at each successor and the surface
        height there, from the cache where the fine key was seen before."""
        table = self.cache.table
        fine = fine_keys(nxt, npsi, self.fine_cell)
        ask = [j for j, k in enumerate(fine) if k not in table]
        if ask:
            sup = self._support(np.c_[nxt[ask], np.full(len(ask), node.position[2])], npsi[ask])
            for j, o, zz in zip(ask, sup.ok, sup.z):
                table[fine[j]] = (bool(o), float(zz))
        answers = np.array([table[k] for k in fine], dtype=float).reshape(-1, 2)
        return answers[:, 0].astype(bool), answers[:, 1]

    def _way_clear(self, node: SearchNode, steps: np.ndarray, to: np.ndarray, fine: list) -> np.ndarray:
        """(K,) whether each step from ``node`` to ``to`` (K, 3) may be taken: a walking or
        running step over ground or over any gap its swing clears (both its footprints
        stand: stepping stones, the gap between two slabs, a gutter), a jump only across a
        gap, neither through an obstacle (cached per fine cell pair)."""
        between = self.cache.between
        here = tuple(fine_xy(node.position[:2], self.fine_cell).tolist())
        pairs = [(here, k) for k in fine]
        ask = [n for n, k in enumerate(pairs) if k not in between]
        if ask:
            ground, clear = self._between(np.repeat(node.position[None], len(ask), axis=0), to[ask])
            for n, g_, c_ in zip(ask, ground.tolist(), clear.tolist()):
                between[pairs[n]] = (g_, c_)
        gc = np.array([between[k] for k in pairs], dtype=bool).reshape(-1, 2)
        return np.where(self.steps.jump[steps], ~gc[:, 0], True) & gc[:, 1]

    def _dead_end(self, search: _Search) -> PlanError:
        """The PlanError of a search that found no path: where it got to (the footprint it
        reached nearest the goal) and what blocks the library's steps from there."""
        goal, (d_near, near) = search.goal, search.nearest
        why = "the search ran out of its budget" if search.heap else "no step of the library leads further"
        msg = (f"the goal ({goal[0]:.2f}, {goal[1]:.2f}) cannot be reached ({why}, "
               f"{search.expanded} footprints expanded)")
        if near is None:
            return PlanError(msg + "; no footprint of the start could be stood on", search.expanded, search.nodes)
        if d_near <= self.settings.goal_radius and search.goal_heading is not None:
            return PlanError(msg + f"; it reached the goal's place ({d_near:.2f} m off) but never facing the "
                             f"goal's heading within {np.degrees(self.settings.goal_heading_tolerance):.0f} deg: "
                             "turn the goal (or give --goal-heading), or raise goal_heading_tolerance",
                             search.expanded, search.nodes)
        at_start = all(n.parent < 0 for n in search.nodes if np.array_equal(n.position, near))
        where = (f"; the nearest reachable point is ({near[0]:.2f}, {near[1]:.2f}, {near[2]:.2f}), "
                 f"{d_near:.2f} m from the goal")
        where += (", the start itself: no step of the library leaves it towards the goal" if at_start
                  else ", where the search got to")
        blocker = self._blocker(search, near)
        return PlanError(msg + where + (f"; {blocker}" if blocker else ""), search.expanded, search.nodes)

    def _blocker(self, search: _Search, near: np.ndarray) -> str:
        """Words for what stops the library's steps from the footprints the search reached
        within 0.6 m of ``near``: the commonest reason their steps towards the goal were
        refused (``Rejections``)."""
        goal = search.goal
        d0 = np.linalg.norm(goal[:2] - near[:2])
        frontier = [n for n in search.nodes if np.linalg.norm(n.position[:2] - near[:2]) < self._len(0.6)]
        rej = Rejections.of(self, frontier[:64], goal, d0)
        return rej.words(self, near, goal)

    def _step_costs(self) -> tuple[np.ndarray, np.ndarray]:
        """(length (S,) m, least cost (S,) s) of each step, its turn penalty aside."""
        return np.hypot(self.steps.fwd, self.steps.left), self._base_costs()

    def _cost_speed(self) -> tuple[float, float]:
        """(v m/s, slack m): the metres per second of cost of the two steps (one of each
        foot: the feet alternate) that cover ground cheapest, and the most one step may
        cover beyond that speed. The heuristic takes (distance - slack) / v, so it never
        overestimates a path of any number of steps."""
        length, cost = self._step_costs()
        a, b = self.steps.foot == 0, self.steps.foot == 1
        if not (a.any() and b.any()):
            v = float(np.max(length / cost))
            return v, 0.0
        v = float(np.max((length[a][:, None] + length[b][None]) / (cost[a][:, None] + cost[b][None])))
        return v, float(max(0.0, np.max(length - cost * v)))

    def _turn_cost(self) -> float:
        """s/rad: the least a radian of turning costs beyond the ground it covers, over
        the pairs of steps (one of each foot) that turn at least 0.5 rad one way."""
        length, cost = self._step_costs()
        st = self.steps
        v, _ = self._cost_speed()
        walk = ~st.jump
        a, b = np.flatnonzero(walk & (st.foot == 0)), np.flatnonzero(walk & (st.foot == 1))
        if not (len(a) and len(b)):
            return 0.0
        turn = st.turn[a][:, None] + st.turn[b][None]
        over = (cost[a][:, None] + cost[b][None]) - (length[a][:, None] + length[b][None]) / v
        ok = np.abs(turn) >= 0.5
        return float(max(np.min(over[ok] / np.abs(turn[ok])), 0.0)) if ok.any() else 0.0

    def _jump_extra(self) -> float:
        """Metres the distance field adds to a jump: what the jump step, and the running
        step it must follow (a jump is entered running, from the other foot), cost beyond
        their length at the heuristic's speed (the least of any such pair), so the
        heuristic knows a jump needs its run-up and still never overestimates."""
        st = self.steps
        run = (st.gait == "run") & ~st.jump
        if not st.jump.any() or not run.any():
            return 0.0
        v, _ = self._cost_speed()
        length, cost = self._step_costs()
        j, r = np.flatnonzero(st.jump), np.flatnonzero(run)
        over = (cost[j][:, None] + cost[r][None]) - (length[j][:, None] + length[r][None]) / v
        over = np.where(st.foot[j][:, None] != st.foot[r][None], over, np.inf)
        return float(max(np.min(over), 0.0) * v) if np.isfinite(over).any() else 0.0

    def _gap_steps(self) -> list[tuple[float, float]]:
        """(reach m, extra m) of the walk's steps and then the run's (where they reach
        further) over a gap, for the distance field's bridges: the gait's longest step,
        from footprint to footprint, and a field cell more (a gap's border cells lie up to
        a cell further apart than the footprints either side), and what the gait's steps
        cost beyond their length at the heuristic's speed (the least of them: a walk's
        nothing, a run's its penalty), so the heuristic stays a lower bound."""
        st = self.steps
        length, cost = self._step_costs()
        v, _ = self._cost_speed()
        out = []
        for gait in ("walk", "run"):
            own = (st.gait == gait) & ~st.jump
            if not own.any():
                continue
            reach = float(length[own].max()) + self.field_cell
            extra = float(max(np.min(cost[own] - length[own] / v), 0.0) * v)
            if not out or reach > out[-1][0]:
                out.append((reach, extra if out else 0.0))
        return out

    def _step_reach(self) -> float:
        """m: the library's longest step that is not a jump, from footprint to footprint."""
        walk = ~self.steps.jump
        return float(np.hypot(self.steps.fwd[walk], self.steps.left[walk]).max()) if walk.any() else 0.0

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


@dataclass
class Rejections:
    """Why steps from some footprints were refused: reason -> (count, a landing point (3,)).
    Reasons: "obstacle" (the body would meet one), "off surface", "uneven" (a step edge
    under the foot), "steep", "step height", "obstacle between", "jump on ground" (a jump
    where no gap is that a step could not span)."""

    counts: dict

    @staticmethod
    def of(planner: "Planner", nodes: list, goal: np.ndarray, d0: float) -> "Rejections":
        """The reasons of every step of ``nodes`` that would land nearer ``goal`` than d0."""
        counts: dict = {}
        st = planner.steps
        for node in nodes:
            sel = np.flatnonzero(st.foot == node.foot)
            ang = node.heading + np.arctan2(planner.forward[1], planner.forward[0])
            f_, l_ = np.array([np.cos(ang), np.sin(ang)]), np.array([-np.sin(ang), np.cos(ang)])
            nxt = node.position[:2] + st.fwd[sel, None] * f_ + st.left[sel, None] * l_
            keep = np.linalg.norm(goal[:2] - nxt, axis=1) < d0
            if node.gait == "walk":
                keep &= ~st.jump[sel]
            sel, nxt = sel[keep], nxt[keep]
            if not len(sel):
                continue
            psi = _wrap(node.heading + st.turn[sel])
            sup = planner._support(np.c_[nxt, np.full(len(sel), node.position[2])], psi)
            reason = np.where(sup.ok, "", sup.reason).astype(object)
            reason[(reason == "") & (np.abs(sup.z - node.position[2]) > planner.max_step_height)] = "step height"
            ok = reason == ""
            if ok.any():
                to = np.c_[nxt[ok], sup.z[ok]]
                ground, clear = planner._between(np.repeat(node.position[None], ok.sum(), axis=0), to)
                jump = st.jump[sel[ok]]
                sub = np.where(~clear, "obstacle between", np.where(jump & ground, "jump on ground",
                               "")).astype(object)
                reason[np.flatnonzero(ok)] = sub
            for r, p, z in zip(reason.tolist(), nxt, sup.z):
                if r:
                    c, _ = counts.get(r, (0, None))
                    counts[r] = (c + 1, np.array([p[0], p[1], node.position[2] if np.isnan(z) else z]))
        return Rejections(counts)

    def words(self, planner: "Planner", near: np.ndarray, goal: np.ndarray) -> str:
        """The commonest reason, in words with its figures (``_explain``)."""
        real = {k: v for k, v in self.counts.items() if k != "jump on ground"}
        if not real:
            return ""
        total = sum(c for c, _ in real.values())
        reason = max(real, key=lambda k: real[k][0])
        share = f"{real[reason][0]} of the {total} refused steps towards the goal"
        stairs = _steps_ahead(planner, near, goal) if reason in ("uneven", "off surface", "step height") else None
        if stairs is not None:
            foot = planner.foot
            return (f"what blocks it: steps ahead, rising {stairs[0]:.2f} m with treads {stairs[1]:.2f} m deep: no "
                    f"step of the library lands the whole foot ({foot.back + foot.front:.2f} m long, "
                    f"{2 * foot.half_width:.2f} m wide) on one tread ({share})")
        return f"what blocks it: {_explain(planner, reason, real[reason][1], near, goal)} ({share})"


def _explain(planner: "Planner", reason: str, at: np.ndarray, near: np.ndarray, goal: np.ndarray) -> str:
    """One reason of ``Rejections`` in words, with the figures that matter: the wall's
    place and the clearance, the step's height, the gap's width against the jump's reach."""
    st = planner.steps
    walk = ~st.jump
    shortest = float(np.hypot(st.fwd[walk], st.left[walk]).min())
    sharpest = float(np.degrees(np.abs(st.turn[walk]).max()))
    if reason == "obstacle":
        _, d = planner.obstacles.nearest(np.array([[near[0], near[1], near[2] + planner._len(0.9)]]))
        p, _ = planner.obstacles.nearest(np.array([[at[0], at[1], at[2] + planner._len(0.9)]]))
        return (f"an obstacle (a wall or an object) at ({p[0, 0]:.2f}, {p[0, 1]:.2f}), {d[0]:.2f} m away: "
                f"every step of the library towards the goal (the shortest goes {shortest:.2f} m, the "
                f"sharpest turns {sharpest:.0f} degrees) brings the body within its clearance "
                f"({planner.clearance:.2f} m) of it")
    if reason in ("off surface", "gap"):
        return _gap_words(planner, at, near, goal, shortest, sharpest)
    if reason == "uneven":
        rise = _rise_ahead(planner, near, goal)
        return (f"a step edge under the foot at ({at[0]:.2f}, {at[1]:.2f}), {rise:.2f} m high: no step of the "
                f"library lands the whole foot ({planner.foot.back + planner.foot.front:.2f} m long) on one side "
                "of it")
    if reason == "step height":
        return (f"a step up or down at ({at[0]:.2f}, {at[1]:.2f}) higher than the "
                f"{planner.max_step_height:.2f} m a step may climb")
    if reason == "steep":
        return f"ground steeper than 30 degrees at ({at[0]:.2f}, {at[1]:.2f})"
    return f"an obstacle between the footprints at ({at[0]:.2f}, {at[1]:.2f}) (through a wall or under a bar)"


def _gap_words(planner: "Planner", at: np.ndarray, near: np.ndarray, goal: np.ndarray, shortest: float,
               sharpest: float) -> str:
    """The edge of the surface towards the goal from ``near`` and the gap beyond it, against
    the library's jump; or, with ground all the way towards the goal, the edge beside the
    way (at ``at``) that the library's steps cannot keep on."""
    d = goal[:2] - near[:2]
    d = d / max(np.linalg.norm(d), 1e-9)
    far_off, spacing = planner._len(6.0), planner._len(0.05)
    t = np.arange(0.0, far_off, spacing)
    pts = np.c_[near[:2] + t[:, None] * d, np.full(len(t), near[2] + planner.max_step_height)]
    hit = planner.ground.ray_down(pts, 2 * planner.max_step_height).hit
    hit[1:-1] |= hit[:-2] & hit[2:]  # a ray lost between two triangles is no gap
    t = t[:int(np.ceil(np.linalg.norm(goal[:2] - near[:2]) / spacing))]
    hit = hit[:len(t)]
    if hit.all():
        return (f"the edge of the surface at ({at[0]:.2f}, {at[1]:.2f}): every step of the library towards "
                f"the goal (the shortest goes {shortest:.2f} m, the sharpest turns {sharpest:.0f} degrees) "
                "puts a foot off it")
    edge = int(np.argmin(hit))
    far = edge + int(np.argmax(hit[edge:])) if hit[edge:].any() else -1
    where = f"the surface ends at ({pts[edge, 0]:.2f}, {pts[edge, 1]:.2f})"
    gap = f"no ground beyond it within {far_off:.0f} m" if far < 0 else f"the gap beyond is {t[far] - t[edge]:.2f} m wide"
    return f"{where} and {gap}; {_reach_words(planner)}"


def _reach_words(planner: "Planner") -> str:
    """What the library's steps span over a gap, in words: its longest step (not a jump)
    less the foot's length, and its jump's reach (or that it has no jump)."""
    step, foot = planner._step_reach(), planner.foot.back + planner.foot.front
    gait = "running" if (planner.steps.gait[~planner.steps.jump] == "run").any() \
        and np.hypot(planner.steps.fwd, planner.steps.left)[~planner.steps.jump & (planner.steps.gait == "run")].max() \
        >= step - 1e-9 else "walking"
    words = (f"the library's longest {gait} step spans a gap of {max(step - foot, 0.0):.2f} m ({step:.2f} m from "
             f"footprint to footprint, less the foot's {foot:.2f} m)")
    reach = planner._jump_reach()
    return words + (f", and its jump reaches {reach:.2f} m from take-off to landing, after a running step"
                    if reach > 0 else ", and it has no jump clip for a wider one")


def _steps_ahead(planner: "Planner", near: np.ndarray, goal: np.ndarray) -> tuple[float, float] | None:
    """(rise m, tread m) of the steps within 2 m of ``near`` towards the goal (the first
    rise, and the shortest run of level ground between two rises), or None where the
    ground ahead rises once at most."""
    t, z = _ground_ahead(planner, near, goal)
    at = np.flatnonzero(np.abs(np.diff(z)) > planner._len(0.02))
    if len(at) < 2:
        return None
    return float(z[at[0] + 1] - z[at[0]]), float(np.diff(t[at]).min())


def _ground_ahead(planner: "Planner", near: np.ndarray, goal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(t (K,) m, z (K,) m): the ground's height every cm within 2 m of ``near`` towards
    the goal, where there is ground."""
    d = goal[:2] - near[:2]
    d = d / max(np.linalg.norm(d), 1e-9)
    t = np.arange(0.0, planner._len(2.0), planner._len(0.01))
    z = planner.ground.ray_down(np.c_[near[:2] + t[:, None] * d, np.full(len(t), near[2] + planner._len(2.0))],
                                planner._len(4.0)).z
    ok = np.isfinite(z)
    return t[ok], z[ok]


def _rise_ahead(planner: "Planner", near: np.ndarray, goal: np.ndarray) -> float:
    """m: the highest step up or down of the ground within 2 m of ``near`` towards the
    goal (0 where it is level)."""
    _, z = _ground_ahead(planner, near, goal)
    return float(np.abs(np.diff(z)).max()) if len(z) > 1 else 0.0


def _wrap(a):
    return (np.asarray(a) + np.pi) % (2 * np.pi) - np.pi


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
        if p.shape[1] >= 3 and self.z is not None:
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
        from scipy.sparse.csgraph import dijkstra

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
    def build(ground, obstacles, goal, cell, clearance, jump_reach, step_height,
              jump_extra: float = 0.0, avoid: tuple | None = None, edge_cost: float = 1.0,
              support: Callable | None = None, scale: float = 1.0) -> "DistanceField":
        """The walking distance (m) to ``goal`` from every cell level of a grid of ``cell``
        metres over the ground's bounds: walkable levels (ground, body clear of obstacles
        by ``clearance``), joined 8-connected within ``step_height`` and, across gaps, by
        bridges up to ``jump_reach`` long that cost ``jump_extra`` m more than their
        length (none with an end within ``avoid`` = (point, radius)); a way along cells
        beside unwalkable ones counts ``edge_cost`` times its length; Dijkstra from the
        goal's cell. With ``support`` (footprints (N, 3), headings (N,) -> whether a foot
        may stand there (N,)), a cell where the ground's slope changes (a step's edge) is
        walkable only where a foot fits in it (``_Grid.foot_room``). ``scale``: the body's
        (``Settings.body_scale``), for the grid's own lengths (``HEADROOM``, ...)."""
        cells = FieldCells.build(ground, obstacles, cell, clearance, jump_reach, step_height, jump_extra,
                                 edge_cost, support, scale)
        return DistanceField.solve(cells, goal, avoid)

    @staticmethod
    def solve(cells: "FieldCells", goal, avoid: tuple | None = None) -> "DistanceField":
        """The field to ``goal`` over cells built before (``FieldCells``), without the
        bridges with an end within ``avoid`` = (point, radius): only the graph and
        Dijkstra, so a search that drops jumps where it is stuck builds its cells once."""
        from scipy.sparse import coo_matrix
        from scipy.sparse.csgraph import dijkstra

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
    def build(ground, obstacles, cell, clearance, jump_reach, step_height, jump_extra: float = 0.0,
              edge_cost: float = 1.0, support: Callable | None = None, scale: float = 1.0,
              steps: tuple = ()) -> "FieldCells":
        """The cells of ``DistanceField.build`` (same arguments, less the goal and ``avoid``).
        ``steps``: (reach m, extra m) of the library's gaits whose steps cross gaps (a walk
        or run step over any gap its swing clears, ``Planner._gap_steps``), shortest
        first: a gap is bridged up to each one's reach at its extra, beyond the last by
        the jump's (up to ``jump_reach``, at ``jump_extra``)."""
        grid = _Grid.over(ground, cell, step_height, scale)
        has_ground, blocked = grid.ground_and_blocked(obstacles, clearance)
        walk = has_ground & ~blocked
        if support is not None:
            walk = grid.foot_room(support, walk)
        edges = grid.neighbour_edges(walk, step_height, grid.edge_cells(walk), edge_cost)
        walk_edges = tuple(np.concatenate(e) for e in zip(*edges))
        gap = grid.gaps(has_ground, step_height)
        bridges, shortest = [], 1.5 * cell  # (beyond the 8 neighbours)
        for reach, extra in list(steps) + [(jump_reach, jump_extra)]:
            if reach > shortest:
                got = grid.bridges(walk, gap, blocked, reach, step_height,
                                   shortest if steps else 1.0)  # (a jump alone: over a metre, as ever)
                bridges += [(a, b, c + extra) for a, b, c in got]
                shortest = reach
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

#: The search starts with this fraction of the heuristic weight's excess over 1 and
#: adds a quarter of it every RAISE_EVERY footprints expanded (``Planner._weigh``).
START_WEIGHT = 0.2
RAISE_EVERY = 100

#: m: a stalled search's heuristic drops the jumps this close to where it is stuck.
REROUTE_RADIUS = 3.0

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
        hit = ground.ray_down(np.c_[xy, np.full(len(xy), hi[2] + step_height)], hi[2] - zlo + 2 * step_height)
        z[0] = hit.z
        for k in range(1, LAYERS):  # the levels below, where there is room for one
            top = z[k - 1] - HEADROOM * scale
            ask = np.flatnonzero(np.isfinite(top) & (top > zlo - 1e-6))
            if not len(ask):
                break
            below = ground.ray_down(np.c_[xy[ask], top[ask]], float(top[ask].max() - zlo) + 1e-3)
            z[k, ask] = below.z
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

    def edge_cells(self, walk: np.ndarray) -> np.ndarray:
        """(L, nx, ny) walkable cell levels beside an unwalkable cell (no ground, or an
        obstacle too near): a footprint there has little room."""
        pw = np.pad(walk.any(axis=0), 1)
        inner = pw[2:, 1:-1] & pw[:-2, 1:-1] & pw[1:-1, 2:] & pw[1:-1, :-2]
        return walk & ~inner[None]

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

    def bridges(self, walk: np.ndarray, void: np.ndarray, blocked: np.ndarray, jump_reach: float,
                step_height: float, shortest: float = 1.0) -> list[tuple]:
        """(rows, cols, lengths) of straight bridges longer than ``shortest`` m and up to
        ``jump_reach`` between walkable cell levels on the border of a gap (``void`` (nx,
        ny), ``gaps``), within a step's height of each other, never across an obstacle."""
        nx, ny = self.nx, self.ny
        pv = np.pad(void, 1)
        near_void = pv[2:, 1:-1] | pv[:-2, 1:-1] | pv[1:-1, 2:] | pv[1:-1, :-2]
        border = walk & near_void[None]
        bl, bi, bj = np.nonzero(border)
        r = int(np.ceil(jump_reach / self.cell))
        offs = [(a, b) for a in range(-r, r + 1) for b in range(-r, r + 1)
                if shortest < np.hypot(a, b) * self.cell <= jump_reach and max(abs(a), abs(b)) > 1]
        out = []
        for a, b in offs:
            ti, tj = bi + a, bj + b
            ok = (ti >= 0) & (ti < nx) & (tj >= 0) & (tj < ny)
            ti, tj, si, sj, sl = ti[ok], tj[ok], bi[ok], bj[ok], bl[ok]
            clear = np.ones(len(si), bool)
            for t in np.linspace(0.2, 0.8, 4):  # the line between crosses void or walkable cells only
                clear &= ~blocked[sl, np.rint(si + t * a).astype(int), np.rint(sj + t * b).astype(int)]
            for tl in range(walk.shape[0]):
                ok = clear & border[tl, ti, tj]
                ok &= np.abs(np.nan_to_num(self.z[tl, ti, tj] - self.z[sl, si, sj], nan=np.inf)) <= step_height
                out.append((self.ids[sl[ok], si[ok], sj[ok]], self.ids[tl, ti[ok], tj[ok]],
                            np.full(ok.sum(), np.hypot(a, b) * self.cell)))
        return out
