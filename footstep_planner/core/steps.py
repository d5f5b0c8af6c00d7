"""Steps: what a clip does to the feet, as relative transforms from one footprint to the
next (thesis 3.2, after Choi et al. 2003, one footstep at a time).

A step carries a foot from a footprint of one foot to the next footprint of the other:
``fwd``/``left`` metres in the frame of the footprint it starts from (forward = the
footprint's heading, left = 90 degrees counter-clockwise), ``turn`` radians of heading
change, and ``duration`` seconds between their stance times. Turning groups give steps
for blends between their clips too, so radii between the library's clips are reachable.
A jump step flies: it may cross a gap, and only a jump step may.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .analysis import ClipAnalysis, Footprint
from .errors import FootstepError
from .library import Library


class StepError(FootstepError):
    pass


@dataclass(frozen=True)
class StepSet:
    """N steps as arrays. ``foot`` is the foot the step starts from (0 left, 1 right)."""

    fwd: np.ndarray
    left: np.ndarray
    turn: np.ndarray
    duration: np.ndarray
    foot: np.ndarray
    gait: np.ndarray  # (N,) object: "walk" / "run" (the gait stepped in)
    jump: np.ndarray  # (N,) bool
    label: np.ndarray  # (N,) object: clip name, or "group@param" for a blend

    @property
    def n(self) -> int:
        return len(self.fwd)

    @staticmethod
    def concat(sets) -> "StepSet":
        sets = [part for part in sets if part.n]
        if not sets:
            raise StepError("the clip library gives no steps: it needs at least one walk or run clip")
        return StepSet(*(np.concatenate([getattr(part, f) for part in sets]) for f in
                         ("fwd", "left", "turn", "duration", "foot", "gait", "jump", "label")))


def relative(a: Footprint, b: Footprint, forward: np.ndarray) -> tuple[float, float, float]:
    """(fwd, left, turn) of footprint b in the frame of footprint a."""
    ang = a.heading + np.arctan2(forward[1], forward[0])
    f = np.array([np.cos(ang), np.sin(ang)])
    left = np.array([-f[1], f[0]])
    d = b.position[:2] - a.position[:2]
    turn = (b.heading - a.heading + np.pi) % (2 * np.pi) - np.pi
    return float(d @ f), float(d @ left), float(turn)


def clip_steps(a: ClipAnalysis, window: tuple[float, float] | None = None) -> list[tuple]:
    """The steps of one clip: consecutive footprints of alternating feet (inside
    ``window`` seconds, default the best cycle widened to hold two steps each foot)."""
    prints = a.footprints()
    fwd = a.motion.rest_forward
    if window is None:
        window = a.best_cycle or (0.0, a.duration)
    out = []
    for p, q in zip(prints[:-1], prints[1:]):
        if p.foot == q.foot or p.strike_part is None and p.time <= 0:
            continue
        if window[0] - 1e-6 <= p.time and q.time <= window[1] + 0.6 * (a.cycle or 0) + 1e-6:
            out.append((p.foot, *relative(p, q, fwd), q.time - p.time))
    return out


def _mean_by_foot(steps):
    """One step per starting foot: the mean of the clip's steps from that foot."""
    out = {}
    for foot in (0, 1):
        mine = np.array([step[1:] for step in steps if step[0] == foot])
        if len(mine):
            out[foot] = mine.mean(axis=0)
    return out


def library_steps(library: Library, analyses: list[ClipAnalysis], blends_per_interval: int = 3,
                  jump_tolerance: float = 0.1) -> StepSet:
    """Steps of every cyclic clip of the library's turning groups, of blends between
    neighbouring clips of a group, and of the jumps (take-off to landing, within
    ``jump_tolerance`` of their length and 10 degrees of their direction: the
    refinement stage bends the clip that far)."""
    by = {a.name: a for a in analyses}
    rows = []  # foot, fwd, left, turn, duration, gait, jump, label
    for gait, group in library.turn_groups.items():
        per_clip = []
        for c in group.clips:
            if c.clip not in by:
                continue
            m = _mean_by_foot(clip_steps(by[c.clip]))
            if len(m) == 2:
                per_clip.append((c.clip, c.tau, m))
        for name, tau, m in per_clip:
            for foot, v in m.items():
                rows.append((foot, *v, gait, False, name))
        for (na, ta, ma), (nb, tb, mb) in zip(per_clip[:-1], per_clip[1:]):
            for w in np.linspace(0, 1, blends_per_interval + 2)[1:-1]:
                for foot in (0, 1):
                    v = (1 - w) * ma[foot] + w * mb[foot]
                    rows.append((foot, *v, gait, False, f"{group.name}@{(1 - w) * ta + w * tb:+.3f}"))
    for sp in library.specials:
        a = by.get(sp.clip)
        if sp.kind != "jump" or a is None or not a.jump_flights:
            continue
        t0, t1 = a.jump_flights[0]
        prints = a.footprints()
        take = [f for f in prints if f.time < t0]
        land = [f for f in prints if f.time > t1]
        if take and land and sp.entry_gait == "run":
            p, q = take[-1], land[0]
            fwd, left, turn = relative(p, q, a.motion.rest_forward)
            # the jump within its tolerance: a little shorter or longer, a little turned
            for scale in (1 - jump_tolerance, 1.0, 1 + jump_tolerance):
                for dturn in np.radians([-10.0, 0.0, 10.0]):
                    c, sn = np.cos(dturn), np.sin(dturn)
                    rows.append((p.foot, scale * (c * fwd - sn * left), scale * (sn * fwd + c * left),
                                 turn + dturn, q.time - p.time, "run", True, sp.clip))
    if not rows:
        raise StepError("the clip library gives no steps: it needs walk or run clips "
                        "with at least two steps of each foot")
    cols = list(zip(*rows))
    return StepSet(fwd=np.array(cols[1], float), left=np.array(cols[2], float),
                   turn=np.array(cols[3], float), duration=np.array(cols[4], float),
                   foot=np.array(cols[0], int), gait=np.array(cols[5], object),
                   jump=np.array(cols[6], bool), label=np.array(cols[7], object))
