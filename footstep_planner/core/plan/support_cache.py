"""The support cache and the search's grid keys: the fine grid (``FINE_CELL``,
``FINE_HEADING_BINS``) on which a footprint's support answer is cached, its keys
(``fine_xy``, ``fine_keys``), the packed merge and best-cost keys of the search
(``GAIT_IDS``, ``_pack``) and ``FootprintCache``, the answers kept between plans while the
tagged geometry is unchanged.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


#: m: the fine grid on which support answers are cached. A footprint takes only the
#: answer of its own fine cell, so it never takes a neighbour's answer near an edge.
FINE_CELL = 0.02

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


@dataclass
class FootprintCache:
    """Support answers by fine footprint key, reused by every plan while the tagged
    geometry is unchanged. Geometry is described per object (a hash and its bounds):
    when objects change, only the answers near their old and new bounds are dropped."""

    objects: dict = field(default_factory=dict)  # name -> (hash, lo (3,), hi (3,))
    table: dict = field(default_factory=dict)  # fine key (ix, iy, heading bin) -> (ok, z)
    # (from fine cell, to fine key) -> (ground, clear, the way leaves the ground)
    between: dict = field(default_factory=dict)
    margin: float = 0.6  # m around a changed object whose answers are dropped
    cell: float = FINE_CELL  # m: the fine grid of the keys (the planner's ``fine_cell``)
    # what the distance field's cells were built to -> the cells (``Planner.field_cells``):
    # they hold for any goal, so the plans of one bake (its legs, its tries with and
    # without a turn in place) and its re-plans build them once; all dropped at any change
    fields: dict = field(default_factory=dict, repr=False)

    #: cells kept for this many builds' keys at most (the latest)
    MAX_FIELDS = 4

    def field_cells(self, key, build):
        """The distance field's cells for ``key`` (what they are built to), ``build()``
        the first time."""
        cells = self.fields.pop(key, None)
        if cells is None:
            cells = build()
        self.fields[key] = cells  # (the latest last)
        while len(self.fields) > self.MAX_FIELDS:
            del self.fields[next(iter(self.fields))]
        return cells

    def update(self, objects: dict) -> int:
        """Bring the cache to ``objects`` (name -> (hash, lo, hi)); returns how many
        answers were dropped."""
        changed = []
        for name in set(self.objects) | set(objects):
            old, new = self.objects.get(name), objects.get(name)
            if old is None or new is None or old[0] != new[0]:
                changed += [b for b in (old, new) if b is not None]
        self.objects = dict(objects)
        if changed:
            self.fields.clear()
        if not changed or not self.table:
            return 0
        # a step's answer goes with either end's region (a step is shorter than 2 m), and
        # one over void with the ground's islands (a change anywhere may join or part them)
        for k in [k for k, v in self.between.items()
                  if v[2:3] == (True,)
                  or any(lo[0] - self.margin - 2 <= k[0][0] * self.cell <= hi[0] + self.margin + 2
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
