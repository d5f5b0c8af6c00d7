"""The characters already in the shot, as the search sees them: where each body is and
where each foot stands, in time (issue 29: characters planned in one space and time,
in turn, each around those planned before it).

Reads: what the other characters play (their hips, their body's radius, their feet's
soles and when each is planted, at the scene's frame rate) on the clock of the plan being
made (seconds from its first frame). Returns: ``Others``, which answers for a batch of the
search's steps whether each comes too near another body at the same time or lands on a
footprint another foot stands on then. Never: reads the scene (``blender.planning`` plays
it and passes the arrays), or changes what the others do.

The search's clock is its own: each footprint lands the sum of its path's step durations
after the start, which the synthesis then shifts (the stand before the first step, the
start clip, the blends, the pace: about a second later on a CMU walk). ``Others.clock``
maps it onto the shot's: a first plan is synthesized, the clock fitted to when its
footprints were struck (``fit_clock``), and the plan made again on it. Then a body is
refused where another comes within the two bodies' radii and
``Settings.character_clearance`` at any time within ``TIME_SLACK`` of it, and a foot where
another foot stands within a foot's length at any time of its stance, widened as much.
Before its first frame and after its last, another character stands as it stood then.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import cached_property
from itertools import chain

import numpy as np
from scipy.ndimage import maximum_filter1d, minimum_filter1d
from scipy.spatial import cKDTree

#: m: a human's half shoulder width, the radius of a body's capsule (times its size).
BODY_RADIUS = 0.2

#: s: the search's times against the played ones (the start clip, blends and pace shift
#: them): another body or foot counts this long before and after the time asked.
TIME_SLACK = 0.5

#: m: two bodies' hips this much apart in height (a human's, times the larger body's size)
#: are on different levels (a bridge over a floor), never in each other's way.
LEVEL_APART = 1.2

#: A step's new footprint is stood on from its landing for this many times the step's
#: duration (until the foot lifts again: about the next step and its double support).
STANCE_STEPS = 1.5


@dataclass(frozen=True, eq=False)
class Others:
    """Other characters over the frames of a shot, on the plan's clock:

    - ``names`` (N,): each character's name, for messages;
    - ``times`` (F,) s: the frames' times (seconds from the plan's first frame, evenly spaced);
    - ``hips`` (N, F, 3): each body's hips; ``radius`` (N,) m its capsule's radius;
    - ``prints`` (M, 3): the footprints the other feet stand on (a sole's middle over one
      planted stretch), ``print_owner`` (M,) whose, ``print_span`` (M, 2) s from and to;
    - ``foot_length`` (N,) m each one's foot;
    - ``clock`` (lead s, rate): the search's time t is the shot's lead + rate t;
    - ``slack`` s: another body or foot counts this long before and after the time asked
      (``TIME_SLACK``; wider where a plan made with it still met another as synthesized)."""

    names: tuple
    times: np.ndarray
    hips: np.ndarray
    radius: np.ndarray
    prints: np.ndarray
    print_owner: np.ndarray
    print_span: np.ndarray
    foot_length: np.ndarray
    clock: tuple = (0.0, 1.0)
    slack: float = TIME_SLACK
    movers: tuple = ()  # the obstacles that move among the bodies (``with_movers``), by name

    def on_clock(self, lead: float, rate: float) -> "Others":
        """These others for a search whose time t is the shot's ``lead`` + ``rate`` t."""
        return replace(self, clock=(float(lead), float(rate)))

    def widened(self, by: float = 2.0) -> "Others":
        """These others with ``by`` times the time slack."""
        return replace(self, slack=self.slack * by)

    def least_gap(self, times: np.ndarray, hips: np.ndarray, radius: float, scale: float = 1.0) -> float:
        """m: the least distance between a body whose hips are at ``hips`` (F, 3) at the
        shot's ``times`` (F,) s (a synthesis's, from the plan's first frame) and any other
        body on its level at the same moment, less both radii (inf where none is on its
        level)."""
        if self.empty or not len(times):
            return np.inf
        other = self.hips[:, np.clip(self._frame(times), 0, len(self.times) - 1)]  # (N, F, 3)
        gap = np.linalg.norm(other[..., :2] - hips[None, :, :2], axis=-1) - (self.radius[:, None] + radius)
        gap = np.where(np.abs(other[..., 2] - hips[None, :, 2]) < LEVEL_APART * scale, gap, np.inf)
        return float(gap.min())

    @property
    def _dt(self) -> float:
        """s between two of the frames (they are evenly spaced)."""
        times = self.times
        return max((times[-1] - times[0]) / (len(times) - 1), 1e-6) if len(times) > 1 else 1.0

    def _frame(self, t) -> np.ndarray:
        """The index of the frame nearest each shot time ``t`` (not clamped)."""
        return np.rint((np.asarray(t, float) - self.times[0]) / self._dt).astype(np.int64)

    def _shot(self, t) -> np.ndarray:
        lead, rate = self.clock
        return lead + rate * np.asarray(t, float)

    @classmethod
    def of(cls, names, times, hips, radius, soles, planted, foot_length) -> "Others":
        """From what each character played at ``times`` (F,) s: ``hips`` (N, F, 3), ``radius``
        (N,), ``soles`` (N, 2, F, 3) each foot's sole middle, ``planted`` (N, 2, F) bool,
        ``foot_length`` (N,)."""
        times = np.asarray(times, float)
        soles, planted = np.asarray(soles, float), np.asarray(planted, bool)
        prints, owner, span = [], [], []
        for n in range(len(names)):
            for k in range(2):
                for a, b in _runs(planted[n, k]):
                    prints.append(soles[n, k, a:b].mean(axis=0))
                    owner.append(n)
                    span.append((times[a], times[b - 1]))
        # (the first stretch stood on since before the first frame, the last until after the last)
        span = np.array(span, float).reshape(-1, 2)
        if len(span):
            span[span[:, 0] <= times[0], 0] = -np.inf
            span[span[:, 1] >= times[-1], 1] = np.inf
        return cls(tuple(names), times, np.asarray(hips, float).reshape(len(names), len(times), 3),
                   np.asarray(radius, float).reshape(-1), np.array(prints, float).reshape(-1, 3),
                   np.array(owner, np.int64), span, np.asarray(foot_length, float).reshape(-1))

    def with_movers(self, names, points, radius: float) -> "Others":
        """These others and obstacles that move: ``points`` (M, F, 3) on each one's outline
        (``outline_points``) at these others' frames, each a body of ``radius`` m named
        after its obstacle (``names`` (M,)), standing on no footprint."""
        points = np.asarray(points, float).reshape(-1, len(self.times), 3)
        if not len(points):
            return self
        return replace(self, names=self.names + tuple(names), hips=np.concatenate([self.hips, points]),
                       radius=np.concatenate([self.radius, np.full(len(points), float(radius))]),
                       foot_length=np.concatenate([self.foot_length, np.zeros(len(points))]),
                       movers=tuple(dict.fromkeys(self.movers + tuple(names))))

    @property
    def empty(self) -> bool:
        return not len(self.names)

    def _hips_near(self, t: np.ndarray) -> np.ndarray:
        """(N, Q, W, 3) each body's hips at the frames within ``slack`` of each time
        ``t`` (Q,) (clamped to the shot: before it and after it, as it stood)."""
        return self.hips[:, self._window(t)]

    def _window(self, t: np.ndarray) -> np.ndarray:
        """(Q, W) the frames within ``slack`` of each time ``t`` (Q,), clamped to the shot."""
        w = int(np.ceil(self.slack / self._dt))
        return np.clip(self._frame(t)[:, None] + np.arange(-w, w + 1)[None, :], 0, len(self.times) - 1)

    @cached_property
    def _bounds(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(lo, hi) (N, F, 3): the box each body's hips keep within over the frames within
        ``slack`` of each frame (as ``_window`` clamps them): a body whose box is further
        than a need from a point is further than it at every one of those frames. Then
        (all_lo, all_hi) (1, F, 3): the box of all of them."""
        size = 2 * int(np.ceil(self.slack / self._dt)) + 1
        lo = minimum_filter1d(self.hips, size, axis=1, mode="nearest")
        hi = maximum_filter1d(self.hips, size, axis=1, mode="nearest")
        return lo, hi, lo.min(axis=0, keepdims=True), hi.max(axis=0, keepdims=True)

    def bodies_apart(self, a: np.ndarray, b: np.ndarray, t0: np.ndarray, t1: np.ndarray, hips_z: np.ndarray,
                     radius: float, clearance: float, scale: float = 1.0) -> np.ndarray:
        """(K,) whether a body whose hips go from ``a`` to ``b`` (K, 2) over the times ``t0`` to
        ``t1`` (K,) s, its hips at height ``hips_z`` (K,), with ``radius`` m, keeps
        ``clearance`` m clear of every other body at points along the way no further apart
        than ``SAMPLE_SPACING`` (at its start, middle and end for a walk's step; a run's
        step or a jump at more: it passes no one between two of them), each against the
        other bodies within ``slack`` of its time, where both are on one level.

        Each point is first held against the box of all the bodies over that time, then
        against each body's (``_bounds``); only a body whose box comes within reach is
        looked at frame by frame: bodies far from the way cost one test a point."""
        k = len(a)
        if self.empty or not k:
            return np.ones(k, bool)
        t0, t1 = self._shot(t0), self._shot(t1)
        d = b - a
        n = np.maximum(np.ceil(np.linalg.norm(d, axis=1) / (SAMPLE_SPACING * scale)).astype(np.int64), 2)
        s = np.minimum(np.arange(int(n.max()) + 1)[None, :] / n[:, None], 1.0)  # (K, S): the last repeated
        m = s.shape[1]
        pos = (a[:, None, :] + d[:, None, :] * s[..., None]).reshape(-1, 2)  # (K*S, 2)
        t = (t0[:, None] + (t1 - t0)[:, None] * s).reshape(-1)
        z = np.repeat(np.asarray(hips_z, float), m)
        need = self.radius + radius + clearance  # (N,)
        level = LEVEL_APART * scale
        lo, hi, all_lo, all_hi = self._bounds
        at = np.clip(self._frame(t), 0, len(self.times) - 1)
        q = np.flatnonzero(_within(all_lo[:, at], all_hi[:, at], need.max(), pos, z, level)[0])  # (near any)
        if not len(q):
            return np.ones(k, bool)
        who, i = np.nonzero(_within(lo[:, at[q]], hi[:, at[q]], need[:, None], pos[q], z[q], level))
        q = q[i]
        if not len(q):
            return np.ones(k, bool)
        near = self.hips[who[:, None], self._window(t[q])]  # (P, W, 3): the bodies within reach, frame by frame
        gap = np.linalg.norm(near[..., :2] - pos[q][:, None, :], axis=-1)
        close = ((np.abs(near[..., 2] - z[q][:, None]) < level) & (gap < need[who][:, None])).any(axis=1)
        hit = np.zeros(len(t), bool)
        hit[q[close]] = True
        return ~hit.reshape(k, m).any(axis=1)

    @cached_property
    def _print_tree(self) -> cKDTree:
        """The footprints' middles across (``prints``), for ``feet_clear``'s nearest."""
        return cKDTree(self.prints[:, :2])

    def feet_clear(self, at: np.ndarray, t0: np.ndarray, t1: np.ndarray, foot_length: float) -> np.ndarray:
        """(K,) whether a foot standing at ``at`` (K, 3) from ``t0`` to ``t1`` (K,) s keeps off
        every footprint another foot stands on at any time of it (within ``slack``):
        their middles a foot's length apart (the longer foot's). Only the footprints
        within the longest foot's length across are looked at (``_print_tree``): a shot's
        thousands of footprints cost a step the few near it."""
        k = len(at)
        if not len(self.prints) or not k:
            return np.ones(k, bool)
        at = np.asarray(at, float)
        t0, t1 = self._shot(t0), self._shot(t1)
        near = self._print_tree.query_ball_point(at[:, :2], r=max(float(self.foot_length.max()), foot_length))
        count = np.fromiter(map(len, near), np.int64, k)
        if not count.sum():
            return np.ones(k, bool)
        q = np.repeat(np.arange(k), count)
        j = np.fromiter(chain.from_iterable(near), np.int64, int(count.sum()))
        span, where = self.print_span[j], self.prints[j]
        meet = (span[:, 0] <= t1[q] + self.slack) & (span[:, 1] >= t0[q] - self.slack)
        reach = np.maximum(self.foot_length[self.print_owner[j]], foot_length)
        d = np.linalg.norm(where[:, :2] - at[q, :2], axis=1)
        on = meet & (np.abs(where[:, 2] - at[q, 2]) < 0.5 * reach) & (d < reach)
        hit = np.zeros(k, bool)
        hit[q[on]] = True
        return ~hit


def _within(lo: np.ndarray, hi: np.ndarray, need: np.ndarray, pos: np.ndarray, z: np.ndarray,
            level: float) -> np.ndarray:
    """(R, Q) whether each box ``lo``..``hi`` (R, Q, 3) comes within ``need`` (broadcast to
    (R, Q)) m of its point ``pos`` (Q, 2) across and within ``level`` m of ``z`` (Q,) in
    height."""
    out = np.maximum(np.maximum(lo[..., :2] - pos[None], pos[None] - hi[..., :2]), 0.0)
    return ((out ** 2).sum(axis=-1) < need ** 2) & (lo[..., 2] < z + level) & (hi[..., 2] > z - level)


#: m: a body's way between two footprints is checked against the others at points no
#: further apart than this (a human's; ``bodies_apart``): a walk's step at its start,
#: middle and end, a run's step or a jump at more.
SAMPLE_SPACING = 0.4

#: The fitted clock's rate is kept within these (a synthesis never plays a path at twice
#: or half the pace the search timed it at).
RATE_RANGE = (0.5, 2.0)


def fit_clock(path, synthesized, planted) -> tuple[float, float] | None:
    """(lead s, rate): the least-squares line from the search's times of ``path``'s stepped
    footprints (``PathFootprint.time``) to when the synthesis struck them (``planted``:
    ``Synthesis.planted``'s (strike, stance, liftoff) per footprint of ``synthesized``, its
    ``plan``), each matched to the synthesized footprint of its foot nearest it in order;
    None with fewer than two matched."""
    pos = np.array([f.position for f in synthesized], float).reshape(-1, 3)
    feet = np.array([f.foot for f in synthesized])
    ts, tp, j0 = [], [], 0
    for f in path:
        if f.time <= 0.0:
            continue
        mine = np.flatnonzero(feet[j0:] == f.foot) + j0
        if not len(mine):
            break
        d = np.linalg.norm(pos[mine, :2] - np.asarray(f.position, float)[:2], axis=1)
        j = int(mine[int(np.argmin(d))])
        if d.min() < 0.5:
            ts.append(f.time)
            tp.append(planted[j][0])
            j0 = j + 1
    if len(ts) < 2:
        return None
    rate, lead = np.polyfit(np.array(ts), np.array(tp), 1)
    rate = float(np.clip(rate, *RATE_RANGE))
    return float(np.mean(np.array(tp) - rate * np.array(ts))), rate


#: m: an obstacle that moves is kept clear of as points this far apart along its outline
#: (each a body of half this radius).
OUTLINE_STEP = 0.1


def outline_points(verts: np.ndarray, tris: np.ndarray, step: float = OUTLINE_STEP) -> np.ndarray:
    """(P, 3) points of a mesh (its own space: ``verts`` (V, 3), ``tris`` (T, 3)) seen from
    above: along every edge at most ``step`` apart, one per half-``step`` cell of the plane
    (a cell a whole step wide let an inner edge's point stand for an outline's, 0.12 m off
    it), at the mesh's middle height (a body is on its level from the ground to a person's
    height)."""
    verts = np.asarray(verts, float)
    if not len(tris):
        return verts[:0]
    e = np.asarray(tris, np.int64)[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    a, b = verts[e[:, 0]], verts[e[:, 1]]
    n = np.maximum(np.ceil(np.linalg.norm((b - a)[:, :2], axis=1) / step).astype(np.int64), 1)
    k = np.repeat(np.arange(len(e)), n + 1)
    t = np.concatenate([np.linspace(0.0, 1.0, m + 1) for m in n.tolist()])
    pts = a[k] + (b - a)[k] * t[:, None]
    _, first = np.unique(np.rint(pts[:, :2] / (0.5 * step)).astype(np.int64), axis=0, return_index=True)
    out = pts[np.sort(first)]
    out[:, 2] = 0.5 * (verts[:, 2].min() + verts[:, 2].max())
    return out


def _runs(flags: np.ndarray) -> list[tuple[int, int]]:
    """[start, stop) of each run of True in ``flags`` (F,)."""
    f = np.concatenate([[False], np.asarray(flags, bool), [False]])
    edges = np.flatnonzero(f[1:] != f[:-1])
    return list(zip(edges[0::2].tolist(), edges[1::2].tolist()))


__all__ = ["BODY_RADIUS", "LEVEL_APART", "OUTLINE_STEP", "Others", "RATE_RANGE", "STANCE_STEPS", "TIME_SLACK",
           "fit_clock", "outline_points"]
