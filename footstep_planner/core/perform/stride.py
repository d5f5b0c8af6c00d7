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
#: rad: a stretch laid again turns no more than this at a step, or than its sharpest step as planned
MAX_STEP_TURN = np.radians(35.0)
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
    of its straightest run, at the clips' own stride."""

    walk: tuple[float, float]
    run: tuple[float, float]

    @classmethod
    def of(cls, steps: StepSet) -> "Strides | None":
        """The walk's and the run's steps of ``steps``, or None without both (or where
        the run is no quicker than the walk: nothing to blend between)."""
        got = {}
        for gait in ("walk", "run"):
            rows = (steps.gait == gait) & ~steps.jump & np.isclose(steps.stride, 1.0) & (steps.fwd > 0)
            if not rows.any():
                return None
            turn = np.abs((steps.turn + np.pi) % (2 * np.pi) - np.pi)
            labels = steps.label[rows]
            straight = min(set(labels.tolist()), key=lambda lab: float(turn[rows][labels == lab].mean()))
            m = rows & (steps.label == straight)
            got[gait] = (float(steps.fwd[m].mean()), float(steps.duration[m].mean()))
        out = cls(got["walk"], got["run"])
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


def way_of(fps: list[PathFootprint], forward) -> tuple[np.ndarray, np.ndarray, float]:
    """(the way's points (N, 2) under each footprint, their headings (N,) unwrapped, the
    half-width m the feet stand either side of it) of the footprints ``fps``."""
    pos = np.array([f.position for f in fps], float)[:, :2]
    head = np.unwrap(np.array([f.heading for f in fps], float))
    ang = head + np.arctan2(forward[1], forward[0])
    side = np.array([1.0 if f.foot == 0 else -1.0 for f in fps])
    mid = 0.5 * (ang[1:] + ang[:-1])
    across = np.einsum("ij,ij->i", pos[:-1] - pos[1:], _left(mid)) * side[:-1]  # (the step's width, left foot to right)
    half = float(np.clip(0.5 * np.median(across), 0.0, 0.5)) if len(across) else 0.0
    return pos - half * side[:, None] * _left(ang), head, half


def _steps_along(total: float, n_old: int, length: float, s: float, ease_in: float | None,
                 ease_out: float | None) -> tuple[int, np.ndarray, np.ndarray]:
    """(n, blend (n,), relative length (n,)) of the steps that lay a way ``total`` m long
    at ``length`` m a step, blend ``s``, eased from and to the walk's step length
    (``ease_in``, ``ease_out``, or None) over EASE_STEPS: as many steps as that takes,
    nearest, with the parity of ``n_old`` (the same last foot)."""
    frac = np.arange(1, EASE_STEPS + 1) / (EASE_STEPS + 1)  # (of the way from the walk to the jog, per eased step)
    deficit = sum(EASE_STEPS * length - float(np.sum(e + (length - e) * frac)) for e in (ease_in, ease_out)
                  if e is not None)
    want = (total + deficit) / max(length, 1e-6)
    n = max(int(round(want)), 2)
    if (n - n_old) % 2:  # (the same last foot: steps in twos)
        n += 1 if want > n else -1
    n = max(n, 2 if n_old % 2 == 0 else 1)
    blend, size = np.full(n, float(s)), np.full(n, float(length))
    for e, k in ((ease_in, slice(0, EASE_STEPS)), (ease_out, slice(n - 1, n - 1 - EASE_STEPS, -1))):
        if e is not None and n >= 2 * EASE_STEPS + 1:
            blend[k], size[k] = s * frac, e + (length - e) * frac
    return n, blend, size


def relay(fps: list[PathFootprint], length: float, s: float, forward, stands: StandFn,
          ease_in: float | None = None, ease_out: float | None = None) -> list[PathFootprint] | None:
    """The stretch ``fps`` laid again at steps of ``length`` m along its way, blend ``s``:
    its first and last footprints kept, the others new (each with its ``speed``), or None
    where one would not stand (``stands``) or a step would turn more than MAX_STEP_TURN.
    The number of steps is the nearest to what the way's length takes that ends on the
    same foot (at least two). From standing (``ease_in``: the walk's step length) the
    first EASE_STEPS steps grow from the walk's stride and blend to the jog's, and into
    standing (``ease_out``) the last ones shrink back: the stride follows the speed."""
    way, head, half = way_of(fps, forward)
    seg = np.linalg.norm(np.diff(way, axis=0), axis=1)
    arc = np.r_[0.0, np.cumsum(seg)]
    total = float(arc[-1])
    n, blend, size = _steps_along(total, len(fps) - 1, length, s, ease_in, ease_out)
    even = np.cumsum(size)[:-1] * total / size.sum()
    feet = [(fps[0].foot + k) % 2 for k in range(1, n)]
    side = np.array([1.0 if f == 0 else -1.0 for f in feet])
    sharpest = max(MAX_STEP_TURN, float(np.abs(np.diff(head)).max()))  # (no sharper than the planner's own steps)

    def place(at, side, across=0.0):
        h = np.interp(at, arc, head)
        ang = h + np.arctan2(forward[1], forward[0])
        xy = np.stack([np.interp(at, arc, way[:, 0]), np.interp(at, arc, way[:, 1])], axis=1) \
            + (half * side + across)[:, None] * _left(ang)
        return np.c_[xy, np.interp(at, arc, [f.position[2] for f in fps])], h

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
    if np.abs(np.diff(np.r_[head[0], h, head[-1]])).max() > sharpest + 1e-9:
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
    through one is kept as laid) and the character's size over a human's."""

    strides: Strides
    forward: np.ndarray
    stands: StandFn
    specials: frozenset = frozenset()
    body_scale: float = 1.0

    def can_lay(self, fps: list[PathFootprint]) -> bool:
        return layable(fps, self.specials, self.body_scale)

    def lay(self, fps: list[PathFootprint], v: float, ease_in: bool = False, ease_out: bool = False
            ) -> tuple[list[PathFootprint], float] | None:
        """(the stretch ``fps`` laid again at the stride of speed ``v``, leaving standing
        with ``ease_in`` and stopping with ``ease_out`` (``relay``), the pace that plays its
        steps at ``v``: the blend's step duration over the laid step's at ``v``), or None
        where it can't be."""
        s = self.strides.blend_for(v)
        length, duration = self.strides.at(s)
        walk = self.strides.walk[0]
        laid = relay(fps, length, s, self.forward, self.stands, walk if ease_in else None, walk if ease_out else None)
        if laid is None:
            return None
        pos = np.array([f.position for f in laid], float)[:, :2]
        steady = [k for k, f in enumerate(laid[1:]) if f.speed is not None and abs(f.speed - s) < 1e-9]
        way, _, _ = way_of(laid, self.forward)
        step = np.linalg.norm(np.diff(way, axis=0), axis=1)
        laid_length = float(np.mean(step[steady])) if steady else float(np.mean(step)) if len(pos) > 1 else length
        return laid, duration * v / max(laid_length, 1e-9)


__all__ = ["Jog", "StandFn", "Strides", "layable", "relay", "way_of"]
