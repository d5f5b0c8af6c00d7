"""A jog: the walk and the run blended, the stride following the speed (issue 30). Pure numpy.

The library relates stride to speed through its straightest walking and running clips
(``Strides``): blended by s (0 the walk, 1 the run), a step is (1 - s) of the walk's and s
of the run's, in length and in duration alike (the blend groups weigh the clips' step
durations so, ``passes._blend_group_schedule``), and so goes at their ratio. A speed
between the walk's and the run's is that blend's (``Strides.blend_for``).

A stretch of walking steps between two footprints that stay (``relay``) is laid again at
a blend's stride: the same way (the line between the feet), its ends kept, as many steps
as that stride fits (the feet alternating onto the same last foot), each footprint
turned as the way turns there, dropped onto the surface and tested for standing there;
each carries the blend it is played at (``PathFootprint.speed``), which the synthesis
pins (``passes.speed_pins``). Where a footprint would not stand (a gap, an obstacle),
or the stretch climbs, jumps or turns in place, it is not laid again.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Callable

import numpy as np

from ..clips.steps import StepSet
from ..footprint import PIVOT, START_LABEL, STAND_LABEL, PathFootprint

#: (pos (N, 3), heading (N,)) -> (ok (N,), z (N,)): whether a foot stands at each footprint, and the surface's height
StandFn = Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]

#: m (a human's): a stretch whose footprints rise or fall more than this from one to the next climbs (kept as laid)
LEVEL_STEP = 0.06
#: (along, across) shares of a step a footprint that would not stand is slid by, in turn, until it stands
NUDGES = ((0.1, 0.0), (-0.1, 0.0), (0.0, 0.1), (0.0, -0.1), (0.2, 0.0), (-0.2, 0.0), (0.1, 0.1), (0.1, -0.1),
          (-0.1, 0.1), (-0.1, -0.1), (0.0, 0.2), (0.0, -0.2), (0.3, 0.0), (-0.3, 0.0))
#: steps over which a jog's stride and blend grow from the walk's, leaving standing (and shrink, stopping)
EASE_STEPS = 2
#: steps: a stretch shorter than this is kept as laid (too short to take another stride)
MIN_STEPS = 3


@dataclass(frozen=True)
class Strides:
    """The library's step (length along the way m, duration s) of its straightest walk and
    of its straightest run, at the clips' own stride, and the sharpest turn (rad, from one
    footprint's heading to the next) a walking step of the library takes."""

    walk: tuple[float, float]
    run: tuple[float, float]
    sharpest: float = np.pi

    @classmethod
    def of(cls, steps: StepSet, straight: dict | None = None) -> "Strides | None":
        """The walk's and the run's steps of ``steps``: of the clip ``straight`` names for
        each gait (the turning group's straightest, the one a blend plays on a straight
        way: ``straight_clips``), else the one whose steps turn least; None without both
        (or where the run is no quicker than the walk: nothing to blend between)."""
        got = {}
        turn = np.abs((steps.turn + np.pi) % (2 * np.pi) - np.pi)
        for gait in ("walk", "run"):
            rows = (steps.gait == gait) & ~steps.jump & np.isclose(steps.stride, 1.0) & (steps.fwd > 0)
            if not rows.any():
                return None
            labels = steps.label[rows]
            straight_clip = (straight or {}).get(gait)
            straight_clip = straight_clip if straight_clip in set(labels.tolist()) else \
                min(set(labels.tolist()), key=lambda lab: float(turn[rows][labels == lab].mean()))
            m = rows & (steps.label == straight_clip)
            got[gait] = (float(steps.fwd[m].mean()), float(steps.duration[m].mean()))
        out = cls(got["walk"], got["run"], float(turn[(steps.gait == "walk") & ~steps.jump].max()))
        return out if out.speed(1.0) > out.speed(0.0) * 1.05 else None

    def at(self, s: float) -> tuple[float, float]:
        """(length m, duration s) of a step blended ``s`` of the way from the walk to the run."""
        (lw, dw), (lr, dr) = self.walk, self.run
        return (1.0 - s) * lw + s * lr, (1.0 - s) * dw + s * dr

    def speed(self, s: float) -> float:
        length, duration = self.at(s)
        return length / duration

    def blend_for(self, v: float) -> float:
        """The blend s in [0, 1] whose step goes at ``v`` m/s (0 below the walk's speed, 1
        above the run's): v ((1 - s) dw + s dr) = (1 - s) lw + s lr, solved for s."""
        if v <= self.speed(0.0):
            return 0.0
        if v >= self.speed(1.0):
            return 1.0
        (lw, dw), (lr, dr) = self.walk, self.run
        den = v * (dr - dw) - (lr - lw)  # (not 0 between the two speeds: the speed is monotonic in s)
        return float(np.clip((lw - v * dw) / den, 0.0, 1.0))


def straight_clips(turn_groups: dict) -> dict:
    """{gait: the clip of its turning group that turns least} for "walk" and "run"."""
    return {g: min(turn_groups[g].clips, key=lambda c: abs(c.tau)).clip
            for g in ("walk", "run") if g in turn_groups and turn_groups[g].clips}


def blend_cap(tau_of: Callable[[str], float | None], walk: tuple[float, float],
              run: tuple[float, float]) -> Callable[[list], np.ndarray]:
    """The most blend s a jog may have on the step to each footprint of a stretch, for
    its turn: a step's curvature (``tau_of(label)``, 1/m) beyond the run's range (``run``:
    least, most; the library's ``run_reach``) is turned by the walk's clips, out to the
    edge of ``walk``'s range, so a blend may take only the share of the run that still
    turns that tightly, linear between the two edges (0 at the walk's edge and beyond):
    a corner slows a jog as it slows a run."""
    (wlo, whi), (rlo, rhi) = walk, run

    def one(tau: float | None) -> float:
        if tau is None or rlo <= tau <= rhi:
            return 1.0
        if tau > rhi:
            return (whi - tau) / (whi - rhi) if whi > rhi else 0.0
        return (tau - wlo) / (rlo - wlo) if rlo > wlo else 0.0

    return lambda fps: np.clip([1.0] + [one(tau_of(f.label)) for f in fps[1:]], 0.0, 1.0)


def layable(fps: list[PathFootprint], specials=(), body_scale: float = 1.0) -> bool:
    """Whether the stretch of footprints ``fps`` (its ends included) may be laid again:
    walking steps only (no run, jump, special clip or turn in place), level from one
    footprint to the next (LEVEL_STEP), no footprint set on a tread or stone by the
    search, long enough (MIN_STEPS)."""
    if len(fps) < MIN_STEPS + 1:
        return False
    inner = fps[1:]
    if any(f.gait != "walk" or f.jump or f.tread or f.label in (PIVOT, START_LABEL, STAND_LABEL)
           or f.label in specials for f in inner) or fps[0].tread:
        return False
    z = np.array([f.position[2] for f in fps], float)
    return bool(np.abs(np.diff(z)).max() <= LEVEL_STEP * body_scale)


def _left(ang: np.ndarray) -> np.ndarray:
    return np.stack([-np.sin(ang), np.cos(ang)], axis=-1)


def way_of(fps: list[PathFootprint], forward) -> tuple[np.ndarray, np.ndarray, float, float]:
    """(the way's points (N, 2) under each footprint, the way's heading there (N,,
    unwrapped: the footprints' with the feet's turn out averaged away), the half-width m
    the feet stand either side of it, the angle (rad) each foot turns out from it, the
    left foot left and the right foot right) of the footprints ``fps``."""
    pos = np.array([f.position for f in fps], float)[:, :2]
    head = np.unwrap(np.array([f.heading for f in fps], float))
    side = np.array([1.0 if f.foot == 0 else -1.0 for f in fps])
    way_head = head.copy()
    if len(head) >= 3:  # (a [1 2 1] filter: the feet alternate, so their turn out cancels)
        way_head[1:-1] = 0.25 * head[:-2] + 0.5 * head[1:-1] + 0.25 * head[2:]
        toe = float(np.median(side[1:-1] * (head[1:-1] - way_head[1:-1])))
        way_head[[0, -1]] = head[[0, -1]] - side[[0, -1]] * toe
    else:
        toe = 0.0
    ang = way_head + np.arctan2(forward[1], forward[0])
    mid = 0.5 * (ang[1:] + ang[:-1])
    across = np.einsum("ij,ij->i", pos[:-1] - pos[1:], _left(mid)) * side[:-1]  # (the step's width, left foot to right)
    half = float(np.clip(0.5 * np.median(across), 0.0, 0.5)) if len(across) else 0.0
    return pos - half * side[:, None] * _left(ang), way_head, half, toe


def _steps_along(arc: np.ndarray, n_old: int, strides: Strides, s: float, caps: np.ndarray, ease_in: bool,
                 ease_out: bool) -> tuple[np.ndarray, np.ndarray]:
    """(blend (n,), length (n,) m) of the steps that lay a way whose planned footprints
    stand ``arc`` (N,) m along it: each step at blend ``s`` or less where the planned
    footprints it passes allow less (``caps`` (N,), ``blend_cap``), the blend changing by
    at most s / (EASE_STEPS + 1) a step (so it slows before a corner and picks up after
    it), from the walk's where it leaves standing (``ease_in``) and to it where it stops
    (``ease_out``); each step as long as its blend's (``Strides.at``), all scaled to fit
    the way; as many as fit, nearest, with the parity of ``n_old`` (the same last foot)."""
    total, rise = float(arc[-1]), s / (EASE_STEPS + 1)

    def blends(size):  # (the steps' blends where steps of these lengths land)
        land = np.cumsum(size) * total / size.sum()
        start = np.r_[0.0, land[:-1]]
        margin = 0.25 * (land - start)  # (a step that lands a little on either side still passes the corner)
        cap = _caps_between(arc, caps, start - margin, land + margin)
        return _ramped(np.minimum(s, cap), rise, ease_in, ease_out)

    def laid(n):  # (n steps: their blends and lengths, settled where they land)
        size = np.full(n, strides.at(s)[0])
        for _ in range(3):
            size = np.array([strides.at(b)[0] for b in blends(size)])
        blend = blends(size)
        for _ in range(2 * n):  # (each blend only lowered, to its cap where its step lands)
            size = np.array([strides.at(b)[0] for b in blend])
            land = np.cumsum(size) * total / size.sum()
            lower = _ramped(np.minimum(blend, _caps_between(arc, caps, np.r_[0.0, land[:-1]], land)), rise,
                            ease_in, ease_out)
            if np.allclose(lower, blend, atol=1e-12):
                break
            blend = lower
        size = np.array([strides.at(b)[0] for b in blend])
        return blend, size

    # the count (in twos, the same last foot) whose steps fit the way nearest their blends' own strides
    n0 = _count(total / strides.at(s)[0], n_old)
    least = 2 if n_old % 2 == 0 else 1
    tries = [laid(n) for n in range(max(n0 - 4, least), n0 + 5, 2)]
    blend, size = min(tries, key=lambda t: abs(np.log(total / t[1].sum())))
    return blend, size * total / size.sum()


def _count(want: float, n_old: int) -> int:
    """The whole number of steps nearest ``want`` with ``n_old``'s parity (at least 1 or 2)."""
    n = max(int(round(want)), 2)
    if (n - n_old) % 2:  # (the same last foot: steps in twos)
        n += 1 if want > n else -1
    return max(n, 2 if n_old % 2 == 0 else 1)


def _caps_between(arc: np.ndarray, caps: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(K,) the least of ``caps`` (N,) of the planned footprints at ``arc`` (N,) from each
    step's start ``a`` to its end ``b`` (K,), or of the nearest one to its end."""
    out = np.empty(len(a))
    for k, (lo, hi) in enumerate(zip(a, b)):
        within = (arc >= lo - 1e-9) & (arc <= hi + 1e-9)
        out[k] = caps[within].min() if within.any() else caps[np.argmin(np.abs(arc - hi))]
    return out


def _ramped(blend: np.ndarray, rise: float, ease_in: bool, ease_out: bool) -> np.ndarray:
    """``blend`` (n,) lowered so that it changes by at most ``rise`` a step, from 0 before
    the first step with ``ease_in`` and to 0 after the last with ``ease_out``."""
    out = blend.copy()
    prev = 0.0 if ease_in else np.inf
    for k in range(len(out)):
        out[k] = prev = min(out[k], prev + rise)
    nxt = 0.0 if ease_out else np.inf
    for k in range(len(out) - 1, -1, -1):
        out[k] = nxt = min(out[k], nxt + rise)
    return out


def relay(fps: list[PathFootprint], strides: Strides, s: float, forward, stands: StandFn,
          ease_in: bool = False, ease_out: bool = False, caps: np.ndarray | None = None,
          max_turn: float = np.pi) -> list[PathFootprint] | None:
    """The stretch ``fps`` laid again along its way at the stride of blend ``s`` (the
    library's ``strides``): its first and last footprints kept, the others new, each
    with its blend (``speed``); or None where one would not stand (``stands``) or a step
    would turn more than ``max_turn`` rad (from one footprint's heading to the next).
    Each step's blend and stride follow ``_steps_along``: lower where the planned
    footprints it passes allow less of the run for their turns (``caps`` (len(fps),),
    ``blend_cap``; None: 1), growing from the walk's over EASE_STEPS leaving standing
    (``ease_in``) and shrinking back into standing (``ease_out``): the stride follows
    the speed. The number of steps is the nearest that fits and ends on the same foot."""
    way, head, half, toe = way_of(fps, forward)
    seg = np.linalg.norm(np.diff(way, axis=0), axis=1)
    arc = np.r_[0.0, np.cumsum(seg)]
    total = float(arc[-1])
    caps = np.ones(len(fps)) if caps is None else np.asarray(caps, float)
    blend, size = _steps_along(arc, len(fps) - 1, strides, s, caps, ease_in, ease_out)
    n = len(blend)
    even = np.cumsum(size)[:-1]
    feet = [(fps[0].foot + k) % 2 for k in range(1, n)]
    side = np.array([1.0 if f == 0 else -1.0 for f in feet])

    def place(at, side, across=0.0):  # (footprints at ``at`` m along the way, turned out from it as the plan's)
        ang = np.interp(at, arc, head) + np.arctan2(forward[1], forward[0])
        xy = np.stack([np.interp(at, arc, way[:, 0]), np.interp(at, arc, way[:, 1])], axis=1) \
            + (half * side + across)[:, None] * _left(ang)
        return np.c_[xy, np.interp(at, arc, [f.position[2] for f in fps])], np.interp(at, arc, head) + side * toe

    # each footprint where it would not stand is slid along the way and across it (NUDGES) until it does
    at, pos, h = even.copy(), *place(even, side)
    ok, z = stands(pos, h)
    step = total / n
    for along, across in NUDGES:
        if ok.all():
            break
        bad = ~ok
        at[bad] = even[bad] + along * step
        p2, h2 = place(at[bad], side[bad], across * step)
        ok2, z2 = stands(p2, h2)
        pos[bad], h[bad], z[bad], ok[bad] = p2, h2, z2, ok2
    if not ok.all() or np.any(np.diff(np.r_[0.0, at, total]) < 0.5 * step):
        return None
    turns = np.diff(np.r_[fps[0].heading, h, fps[-1].heading])
    if np.abs((turns + np.pi) % (2 * np.pi) - np.pi).max() > max_turn + 1e-9:
        return None
    xy = pos[:, :2]
    t = np.interp(at, arc, [f.time for f in fps])
    near = [int(np.argmin(np.abs(arc - a) + 1e3 * np.array([f.foot != foot for f in fps]))) for a, foot in zip(at, feet)]
    out = [fps[0]]
    for k in range(n - 1):
        src = fps[near[k]]
        out.append(PathFootprint(feet[k], np.array([xy[k, 0], xy[k, 1], z[k]]), float(h[k]), float(t[k]),
                                 src.label if src.label not in (START_LABEL, STAND_LABEL) else fps[1].label,
                                 "walk", speed=float(blend[k])))
    return out + [replace(fps[-1], speed=float(blend[-1]))]


@dataclass(frozen=True)
class Jog:
    """What laying a jog needs: the library's ``strides``, the world direction of heading 0
    (``forward``), where a foot stands (``stands``), the special clips' names (a stretch
    through one is kept as laid), the character's size over a human's and the most blend
    a stretch's steps' turns allow (``caps``, ``blend_cap``: a corner slows a jog as it
    slows a run)."""

    strides: Strides
    forward: np.ndarray
    stands: StandFn
    specials: frozenset = frozenset()
    body_scale: float = 1.0
    #: (len(fps),) the most blend (0 to 1) a stretch's steps' turns allow (``blend_cap``); None: 1
    caps: Callable[[list], np.ndarray] | None = None

    def can_lay(self, fps: list[PathFootprint]) -> bool:
        return layable(fps, self.specials, self.body_scale)

    def lay(self, fps: list[PathFootprint], v: float, ease_in: bool = False, ease_out: bool = False
            ) -> tuple[list[PathFootprint], float] | None:
        """(the stretch ``fps`` laid again for a jog at speed ``v``, leaving standing with
        ``ease_in`` and stopping with ``ease_out`` (``relay``), the pace that plays its
        steps at the blend's speed ``v`` where they reach it: the blend's step duration
        over its step length as laid, times ``v``), or None where it can't be laid."""
        s = self.strides.blend_for(v)
        caps = None if self.caps is None else self.caps(fps)
        laid = relay(fps, self.strides, s, self.forward, self.stands, ease_in, ease_out, caps, self.strides.sharpest)
        if laid is None:
            return None
        way = way_of(laid, self.forward)[0]
        step = np.linalg.norm(np.diff(way, axis=0), axis=1)
        own = np.array([self.strides.at(f.speed)[0] for f in laid[1:]])
        scale = float(np.mean(step / own))  # (the laid steps over their blends' own: the way's fit)
        length, duration = self.strides.at(s)
        return laid, duration * v / (length * scale)


__all__ = ["Jog", "StandFn", "Strides", "blend_cap", "straight_clips", "layable", "relay", "way_of"]
