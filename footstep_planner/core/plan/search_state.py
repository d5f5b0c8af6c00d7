"""One search's vocabulary and state: ``PlanError`` (no path, and why; ``BlockedError``
where only the other characters stop it), ``SearchNode``
(a footprint the search reached), ``_Batch`` (one expansion's successors, not yet
checked) and ``_Search`` (the open list, its weights and counts), with the stall limits
(``STALL``, ``MAX_REROUTES``). The planner (``navgraph``) and its refusals both use it.
"""

from __future__ import annotations

import heapq
from dataclasses import dataclass, field
from typing import Callable, NamedTuple

import numpy as np

from ..base.errors import FootstepError


class PlanError(FootstepError):
    """No path: the message says why, and where the nearest reachable point is.
    ``expanded`` footprints were expanded before the search gave up (0: refused before
    any search), ``explored`` the search's nodes (``SearchNode``)."""

    def __init__(self, message: str, expanded: int = 0, explored: list | None = None):
        super().__init__(message)
        self.expanded = expanded
        self.explored = explored or []


class BlockedError(PlanError):
    """No path round the other characters where alone there is one: they block the way
    and no stand lets them pass (``stands.plan_round``). ``others`` names them. A shot
    planned together plans a blocked character before them (``batch.together_steps``)."""

    def __init__(self, message: str, expanded: int = 0, explored: list | None = None, others: tuple = ()):
        super().__init__(message, expanded, explored)
        self.others = tuple(others)


class SearchNode(NamedTuple):
    """A footprint the search reached: the foot that stands there (0 left, 1 right), the
    gait it arrived in, its position (3,) and heading (rad), the cost (s) of the way
    there, the index of the node it was reached from (-1 at the start) and the index of
    the step (``StepSet`` row) that reached it (-1 at the start), and when it lands (s
    from the start, the sum of its path's step durations)."""

    foot: int
    gait: str
    position: np.ndarray
    heading: float
    cost: float
    parent: int
    step: int
    time: float = 0.0


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
    t: np.ndarray  # (K,) s when each lands (the parent's time and the step's duration)


#: Footprints expanded without the heuristic falling before the search suspects the
#: jumps near where it is stuck (``Planner._reroute``), and how often it may. (40: on the
#: bridge scenes CMU's paths cost 1.08 of plain A*'s, were 1.17 at 60, in fewer expansions;
#: nothing else of the planner benchmark's 36 scenes changes with CMU, the sample
#: character's bridge_up2 costs 2.7% more.)
STALL = 40
MAX_REROUTES = 4


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
    # (cost, batch, successor) of the cheapest checked successor that ends the path, or None
    arrival: tuple | None = None

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
        """The next queued successor of batch ``b`` into the heap (but the ones refused
        already: a batch checked at once round other characters)."""
        queued, state = self.queued[b], self.batches[b].state
        while queued:
            j = queued.pop()
            if state[j] != 2:
                heapq.heappush(self.heap, (self.f[b][j], self.seq0[b] + j + 1, b, j))
                return

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
