"""Steps: what a clip does to the feet, as relative transforms from one footprint to the
next (thesis 3.2, after Choi et al. 2003, one footstep at a time).

A step carries a foot from a footprint of one foot to the next footprint of the other:
``fwd``/``left`` metres in the frame of the footprint it starts from (forward = the
footprint's heading, left = 90 degrees counter-clockwise), ``turn`` radians of heading
change, and ``duration`` seconds between their stance times. Turning groups give steps
for blends between their clips too, so radii between the library's clips are reachable,
and *bent* steps beyond them (``bent_step``): the step of the group's outermost clip on
that side, bent along arcs up to ``bend_curvature`` (1/m) either way, so a library of one
straight walk still turns (labelled "group@tau", synthesized with that clip; the IK puts
the feet on the bent footprints). A jump step flies: it may cross a gap, and only a jump
step may.

*Adapted strides* (``stride_steps``): a walking step may also be shortened or lengthened,
its forward length times ``stride`` between ``Settings.stride_min`` and ``stride_max``
(sideways and turn kept, the same clip and duration: the refinement's similarity maps
the clip's footprints onto the shorter ones and the IK puts the feet there), so that
stair treads, kerbs and short gaps between obstacles are stepped on with an ordinary
walk. An adapted step costs more than its time (``Settings.stride_penalty``), so open
ground keeps the clips' own stride.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import cached_property

import numpy as np

from .analysis import ClipAnalysis
from .stances import Footprint
from ..base.errors import FootstepError
from .library import Library
from ..base.settings import Settings

#: 1/m: bent steps are added at curvatures at most this far apart, from the end of a
#: turning group's own range out to the bend limit.
BEND_SPACING = 0.2


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
    stride: np.ndarray | None = None  # (N,) the clip's forward length scaled by (1: its own)
    #: (N,) bool: a walk's turn tighter than any of the library's running steps turns
    #: (``Library.corners``): a run slows into a walk before it (``navgraph.CORNER_STEPS``)
    corner: np.ndarray | None = None

    def __post_init__(self):
        if self.stride is None:
            object.__setattr__(self, "stride", np.ones(len(self.fwd)))
        if self.corner is None:
            object.__setattr__(self, "corner", np.zeros(len(self.fwd), bool))

    def time_cost(self, stride_penalty: float) -> np.ndarray:
        """(N,) s: each step's duration (its cycle's mean, ``cycle_mean``), an adapted
        stride's made dearer by ``stride_penalty`` per unit of |ln stride| (see
        ``Settings.stride_penalty``)."""
        return self.cycle_mean(self.duration) * (1.0 + stride_penalty * np.abs(np.log(self.stride)))

    def cycle_mean(self, x: np.ndarray) -> np.ndarray:
        """(N,) ``x`` (N,) averaged over each step's cycle: the steps of its clip (or blend)
        at its stride, one from each foot (a jump: its own). A step's cost is priced from
        these, so a path cannot take the quicker (or straighter) half of one clip's cycle
        after the quicker half of another's."""
        x = np.asarray(x, float)
        keys = [f"{lab}|{g}|{float(s)!r}|{bool(j)}"
                for lab, g, s, j in zip(self.label, self.gait, self.stride, self.jump)]
        _, inv = np.unique(np.array(keys, dtype=object), return_inverse=True)
        total = np.bincount(inv, weights=x)
        count = np.bincount(inv)
        return np.where(self.jump, x, (total / count)[inv])

    @property
    def n(self) -> int:
        return len(self.fwd)

    @staticmethod
    def concat(sets) -> "StepSet":
        sets = [part for part in sets if part.n]
        if not sets:
            raise StepError("the clip library gives no steps: it needs at least one walk or run clip")
        return StepSet(*(np.concatenate([getattr(part, f) for part in sets]) for f in
                         FIELDS))

    def toe_out(self) -> float:
        """rad, how far each foot of the straightest walk turns out from the way it walks
        (its left foot's heading that much left of it, the right's right): a quarter of
        the difference of its right and left steps' turns, for the walking clip (or
        blend) of the clips' own stride whose strides turn least. 0 without one."""
        return self._straight[0]

    def stance_width(self) -> float:
        """m, how far apart across the way the straightest walk (``toe_out``) puts its
        feet: how far its steps go sideways, from the left foot to the right and back.
        0 without one."""
        return self._straight[1]

    @cached_property
    def _straight(self) -> tuple[float, float]:
        """(toe-out rad, half the straightest walk's stance width m: how far a step goes
        sideways across the way walked, from the left foot to the right and back), read
        once per step set."""
        best, out = np.inf, (0.0, 0.0)
        walk = (self.gait == "walk") & ~self.jump & (self.stride == 1.0)
        for lab in set(self.label[walk]):
            sel = walk & (self.label == lab)
            t0, t1 = self.turn[sel & (self.foot == 0)], self.turn[sel & (self.foot == 1)]
            if len(t0) and len(t1) and abs(t0.mean() + t1.mean()) < best:
                toe = 0.25 * float(t1.mean() - t0.mean())
                side = self._across(toe)
                best = abs(t0.mean() + t1.mean())
                out = (toe, 0.5 * float(side[sel & (self.foot == 1)].mean() - side[sel & (self.foot == 0)].mean()))
        return out

    def _across(self, toe: float) -> np.ndarray:
        """(N,) m each step's sideways move across the way walked (its start foot's frame
        turned back by the foot's toe-out ``toe``)."""
        a = np.where(self.foot == 0, toe, -toe)
        return np.sin(a) * self.fwd + np.cos(a) * self.left

    def sidestep(self) -> np.ndarray:
        """(N,) m each step's sideways move across the way walked beyond the straightest
        walk's (half its stance width, right from the left foot and left from the right):
        steps that crab, which a straight way must not take one after another."""
        toe, half = self._straight
        return self._across(toe) - np.where(self.foot == 0, -half, half)

    def veer(self) -> np.ndarray:
        """(N,) rad, each step's turn beyond the straightest walk's (``toe_out``): the
        heading change of the way walked, not of the foot (a straight walk's steps turn
        each foot out and back, and veer 0)."""
        two = 2.0 * self.toe_out()
        return self.turn - np.where(self.foot == 0, -two, two)

    def take(self, sel) -> "StepSet":
        """The steps ``sel`` (a mask or indices)."""
        return StepSet(*(getattr(self, f)[sel] for f in FIELDS))


#: StepSet's array fields, in order.
FIELDS = ("fwd", "left", "turn", "duration", "foot", "gait", "jump", "label", "stride", "corner")


def relative(a: Footprint, b: Footprint, forward: np.ndarray) -> tuple[float, float, float]:
    """(fwd, left, turn) of footprint b in the frame of footprint a."""
    ang = a.heading + np.arctan2(forward[1], forward[0])
    f = np.array([np.cos(ang), np.sin(ang)])
    left = np.array([-f[1], f[0]])
    d = b.position[:2] - a.position[:2]
    turn = (b.heading - a.heading + np.pi) % (2 * np.pi) - np.pi
    return float(d @ f), float(d @ left), float(turn)


def clip_steps(a: ClipAnalysis, window: tuple[float, float] | None = None, early: float = 0.0) -> list[tuple]:
    """The steps of one clip: consecutive footprints of alternating feet (inside
    ``window`` seconds, default the best cycle widened to hold two steps each foot,
    starting ``early`` cycles before it)."""
    prints = a.footprints()
    fwd = a.motion.rest_forward
    if window is None:
        window = a.best_cycle or (0.0, a.duration)
    out = []
    for p, q in zip(prints[:-1], prints[1:]):
        if p.foot == q.foot or p.strike_part is None and p.time <= 0:
            continue
        if window[0] - early * (a.cycle or 0) - 1e-6 <= p.time \
                and q.time <= window[1] + 0.6 * (a.cycle or 0) + 1e-6:
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


def _sinc_half(x):
    """sin(x/2) / (x/2), 1 at 0: a chord over its arc for an arc turning by x radians."""
    return np.sinc(x / (2 * np.pi))


def bent_step(m: dict, foot: int, curvature: float | None = None, by: float = 0.0) -> np.ndarray:
    """The step of a clip from ``foot`` (its two feet's mean steps ``m``: foot ->
    (fwd, left, turn, duration)) bent along an arc of ``curvature`` (1/m, + left; None:
    the clip's own curvature ``by`` more).

    The two feet straddle the clip's centre line: each foot's heading is the centre
    line's turned by a toe-out (equal and opposite for the two feet, from the difference
    of their steps' turns), and each footprint lies the same distance either side of it.
    The centre line between the step's footprints is an arc (straight for a straight
    clip) of the clip's own heading change per step (the mean of its feet's turns); the
    bent step keeps that arc's length, the footprints' offsets from it, the toe-out and
    the duration, and turns the arc to ``curvature``. At the clip's own curvature the step
    is unchanged. Returns (fwd, left, turn, duration)."""
    theta, da, h, arc = _on_centre_line(m, foot)
    db = -da
    phi = theta + by * arc if curvature is None else curvature * arc
    # the centre line's end along the bent arc, the second footprint +h from it
    ex, ey = arc * _sinc_half(phi) * np.cos(0.5 * phi), arc * _sinc_half(phi) * np.sin(0.5 * phi)
    bx, by_ = ex - h * np.sin(phi), ey + h * np.cos(phi) + h
    c, s = np.cos(-da), np.sin(-da)
    return np.array([c * bx - s * by_, s * bx + c * by_, phi + db - da, float(m[foot][3])])


def _on_centre_line(m: dict, foot: int) -> tuple[float, float, float, float]:
    """The step of a clip from ``foot`` (``bent_step``'s ``m``) in terms of the clip's
    centre line: (theta, its turn per step, rad: the mean of the feet's turns; da, the
    start foot's toe-out from it, rad; h, m: the footprints sit at -h and +h from it; arc,
    m: its length over the step)."""
    f, l = float(m[foot][0]), float(m[foot][1])
    theta = 0.5 * (float(m[0][2]) + float(m[1][2]))  # the centre line's turn per step
    toe = 0.25 * (float(m[1][2]) - float(m[0][2]))  # the left foot's toe-out (the right's: -toe)
    da = toe if foot == 0 else -toe
    # the step in the centre line's frame at the first footprint
    c, s = np.cos(da), np.sin(da)
    qx, qy = c * f - s * l, s * f + c * l
    # the chord turns by theta / 2
    h = 0.5 * (qy - qx * np.tan(0.5 * theta))
    chord = np.hypot(qx + h * np.sin(theta), qy - h * np.cos(theta) - h)
    return theta, da, h, chord / _sinc_half(theta)


def bend_chain(position: np.ndarray, heading: np.ndarray, bends: np.ndarray | None, forward: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray]:
    """Footprints (N, 3) with headings (N,) (rad from ``forward``, feet alternating)
    re-chained with each step j (footprint j to j + 1) bent ``bends[j]`` (1/m) more than
    it turns (``bent_step``, the toe-out from it and its neighbour step): what a clip
    bent as the planner bent it leaves. The first footprint stays; heights are kept
    relative. Unchanged (the same arrays) without bends (None or all 0)."""
    pos, head = np.asarray(position, float), np.asarray(heading, float)
    n = len(pos)
    if bends is None or n < 3 or not np.any(bends):
        return pos, head
    bends = np.asarray(bends, float)
    fa = np.arctan2(forward[1], forward[0])
    ang = head + fa
    d = pos[1:, :2] - pos[:-1, :2]
    c, s = np.cos(ang[:-1]), np.sin(ang[:-1])
    rel = np.c_[c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1], np.diff(head), np.zeros(n - 1)]
    out_p, out_h = pos.copy(), head.copy()
    for j in range(n - 1):
        nb = j + 1 if j + 1 < n - 1 else j - 1  # the other foot's step
        step = rel[j]
        if bends[j] != 0.0:
            step = bent_step({0: rel[j], 1: rel[nb]}, 0, by=bends[j])
        a = out_h[j] + fa
        f_, l_ = np.array([np.cos(a), np.sin(a)]), np.array([-np.sin(a), np.cos(a)])
        out_p[j + 1, :2] = out_p[j, :2] + step[0] * f_ + step[1] * l_
        out_p[j + 1, 2] = out_p[j, 2] + pos[j + 1, 2] - pos[j, 2]
        out_h[j + 1] = out_h[j] + step[2]
    return out_p, out_h


def bend_curvatures(lo: float, hi: float, limit: float, reach: tuple[float, float] | None = None,
                    spacing: float = BEND_SPACING) -> list[float]:
    """Curvatures (1/m) of the bent steps of a turning group whose clips turn from ``lo``
    to ``hi``: from beyond each end of that range out to +-``limit``, at most ``spacing``
    (BEND_SPACING, a human's) apart; none on a side that ``reach`` (the curvatures the
    whole library's clips turn, default the group's own) already covers to ``limit``."""
    rlo, rhi = reach or (lo, hi)
    out = []
    for end, far, covered in ((hi, limit, rhi), (lo, -limit, rlo)):
        span = far - end
        if (far - covered) * np.sign(far) >= 1e-3 and span * np.sign(far) >= 1e-3:  # labels: tau to 1e-3
            n = int(np.ceil(abs(span) / spacing - 1e-6))
            out += [end + span * i / n for i in range(1, n + 1)]
    return out


def library_steps(library: Library, analyses: list[ClipAnalysis], blends_per_interval: int = 3,
                  jump_tolerance: float = 0.1,
                  bend_curvature: float = Settings.bend_curvature,
                  stride: tuple[float, float] = (Settings.stride_min, Settings.stride_max),
                  straighten: bool = Settings().straightens, scale: float = 1.0) -> StepSet:
    """Steps of every cyclic clip of the library's turning groups, of blends between
    neighbouring clips of a group, of its outermost clips bent beyond the group's range
    out to +-``bend_curvature`` on a side where no clip of the library turns that
    tightly (``bent_step``, ``bend_curvatures``; 0: none: a library that turns keeps its
    own turns, and where it turns only walking, runs do not bend), and of the jumps
    (take-off to landing, within ``jump_tolerance`` of their length and 10 degrees of
    their direction: the refinement stage bends the clip that far), and every walking step
    (every running one, in a library without a walk: a jog up a flight) again with adapted strides (``stride_steps``, ``stride``: (least, most) share of the
    clip's forward length; a shortened bent step turns as much in less way: a library of
    wide turns turns on a stair's landing). With ``straighten`` (a search that prices a
    way that is not straight, ``Settings.straightens``: without it nothing prefers them,
    and they only move paths), each group's straightest clip straightened too
    (``_straight_rows``). ``scale``: the body's (``Settings.body_scale``): bent steps'
    curvatures are spaced BEND_SPACING over it. Each walking step that turns tighter than
    any running one is marked a corner (``StepSet.corner``, ``Library.corners``)."""
    by = {a.name: a for a in analyses}
    groups = _group_steps(library, by)
    taus = [tau for *_, per_clip in groups for _, tau, _ in per_clip]
    reach = (min(taus), max(taus)) if taus else (0.0, 0.0)
    rows = []  # foot, fwd, left, turn, duration, gait, jump, label
    for gait, group, per_clip in groups:
        rows += _cyclic_rows(gait, group, per_clip, blends_per_interval)
        if straighten:
            rows += _straight_rows(gait, group, per_clip, rows)
        if bend_curvature > 0:
            rows += _bent_rows(gait, group, per_clip, bend_curvature, reach, BEND_SPACING / scale)
    for sp in library.specials:
        rows += _jump_rows(sp, by.get(sp.clip), jump_tolerance)
    if not rows:
        raise StepError("the clip library gives no steps: it needs walk or run clips "
                        "with at least two steps of each foot")
    cols = list(zip(*rows))
    own = StepSet(fwd=np.array(cols[1], float), left=np.array(cols[2], float),
                  turn=np.array(cols[3], float), duration=np.array(cols[4], float),
                  foot=np.array(cols[0], int), gait=np.array(cols[5], object),
                  jump=np.array(cols[6], bool), label=np.array(cols[7], object))
    own = replace(own, corner=library.corners(own.label, np.where(own.jump, "jump", own.gait), bend_curvature))
    walks = "walk" in own.gait[~own.jump].tolist()
    cyclic = (own.gait == ("walk" if walks else "run")) & ~own.jump
    return StepSet.concat([own, stride_steps(own.take(cyclic), *stride)])


#: Adapted strides are spaced at most this ratio apart (from the clip's own outwards).
STRIDE_RATIO = 1.25


def stride_factors(lo: float, hi: float) -> np.ndarray:
    """The stride factors (not 1) from ``lo`` to ``hi``: both ends and, between them and
    1, factors at most STRIDE_RATIO apart (geometrically spaced); an end within 1 % of 1
    gives none."""
    out = []
    for end in (lo, hi):
        if abs(np.log(end)) < 0.01:
            continue
        n = int(np.ceil(abs(np.log(end)) / np.log(STRIDE_RATIO) - 1e-9))
        out += list(np.exp(np.log(end) * np.arange(1, n + 1) / n))
    return np.array(sorted(out))


def stride_steps(steps: StepSet, lo: float, hi: float) -> StepSet:
    """``steps`` again at each stride factor between ``lo`` and ``hi`` (``stride_factors``):
    forward lengths scaled, the rest kept."""
    k = stride_factors(lo, hi)
    if not steps.n or not len(k):
        return steps.take(np.zeros(0, int))
    idx = np.tile(np.arange(steps.n), len(k))
    out = steps.take(idx)
    f = np.repeat(k, steps.n)
    return replace(out, fwd=out.fwd * f, stride=f)


def _group_steps(library: Library, by: dict) -> list[tuple]:
    """(gait, group, [(clip, tau, {foot: mean step (4,)})]) of each turning group with
    clips giving steps of both feet. A group none of whose clips has steps of both feet
    in its best cycle (a cycle that starts a hair after a stance loses that step: the
    mannequin's walk) takes its clips' steps from a quarter cycle earlier."""
    groups = []
    for gait, group in library.turn_groups.items():
        for early in (0.0, 0.25):
            per_clip = []
            for c in group.clips:
                if c.clip not in by:
                    continue
                m = _mean_by_foot(clip_steps(by[c.clip], early=early))
                if len(m) == 2:
                    per_clip.append((c.clip, c.tau, m))
            if per_clip:
                groups.append((gait, group, per_clip))
                break
    return groups


def _cyclic_rows(gait: str, group, per_clip: list[tuple], blends_per_interval: int) -> list[tuple]:
    """Step rows of a group's clips and of ``blends_per_interval`` blends between each
    two neighbours (labelled ``<group>@<tau>``)."""
    rows = [(foot, *v, gait, False, name) for name, tau, m in per_clip for foot, v in m.items()]
    for (na, ta, ma), (nb, tb, mb) in zip(per_clip[:-1], per_clip[1:]):
        for w in np.linspace(0, 1, blends_per_interval + 2)[1:-1]:
            for foot in (0, 1):
                v = (1 - w) * ma[foot] + w * mb[foot]
                rows.append((foot, *v, gait, False, f"{group.name}@{(1 - w) * ta + w * tb:+.3f}"))
    return rows


#: rad: a clip whose two steps turn the way walked by less than this per stride walks
#: straight as it is (``_straight_rows``).
STRAIGHT_STRIDE_TURN = 1e-3


def _straight_rows(gait: str, group, per_clip: list[tuple], rows: list[tuple]) -> list[tuple]:
    """Step rows of the group's straightest clip (the one whose tau is nearest 0) bent to
    curvature 0 (``bent_step``: the two feet's mean steps' stride turn taken out, their
    toe-out, stance width, arc length and duration kept), labelled ``<group>@+0.000``
    (synthesized with the group's weights at tau 0): a straight way's straight step.

    A captured walk's footprints may lie on a straight line while its steps' turns, read
    from the feet's yaws at a few stances, do not cancel over a stride (CMU's 16_16 walk:
    the foot yaw of one stance is 5 degrees off, and its steps would veer 0.056 1/m right
    where the clip walks straight): its steps chained curve away, and a planner asked for a
    straight way alternates them with turning steps. None when that clip's steps already
    walk straight, or the group has a step of that label."""
    label = f"{group.name}@{0.0:+.3f}"
    if any(r[-1] == label for r in rows):
        return []
    _, _, m = min(per_clip, key=lambda c: abs(c[1]))
    if abs(float(m[0][2]) + float(m[1][2])) < STRAIGHT_STRIDE_TURN:
        return []
    return [(foot, *step, gait, False, label) for foot, step in enumerate(straight_steps(m))]


def straight_steps(m: dict) -> tuple[np.ndarray, np.ndarray]:
    """The steps from the left foot and from the right (fwd, left, turn, duration) of a
    clip (its two feet's mean steps ``m``, as ``bent_step``) straightened: each step's arc
    along the centre line kept as a straight line of that length, the feet's toe-out and
    the durations kept, and both footprints the same distance either side of the line
    (half the clip's mean stance width): a stride of them neither veers nor crabs."""
    line = [_on_centre_line(m, foot) for foot in (0, 1)]
    half = 0.5 * (line[1][2] - line[0][2])  # the left foot's step goes right (h < 0), the right's left
    out = []
    for foot, sign in ((0, -1.0), (1, 1.0)):
        _, da, _, arc = line[foot]
        c, s = np.cos(-da), np.sin(-da)
        bx, by = arc, 2.0 * sign * half
        out.append(np.array([c * bx - s * by, s * bx + c * by, -2.0 * da, float(m[foot][3])]))
    return tuple(out)


def _bent_rows(gait: str, group, per_clip: list[tuple], bend_curvature: float, reach,
               spacing: float = BEND_SPACING) -> list[tuple]:
    """Step rows of the group's outermost clips bent beyond its range (``bent_step``)."""
    rows = []
    for k in bend_curvatures(per_clip[0][1], per_clip[-1][1], bend_curvature, reach, spacing):
        _, _, m = per_clip[-1] if k > per_clip[-1][1] else per_clip[0]
        for foot in (0, 1):
            rows.append((foot, *bent_step(m, foot, k), gait, False, f"{group.name}@{k:+.3f}"))
    return rows


def _jump_rows(sp, a: ClipAnalysis | None, jump_tolerance: float) -> list[tuple]:
    """Step rows of a running jump clip: take-off to landing, a little shorter or longer
    (``jump_tolerance``) and a little turned (10 degrees)."""
    if sp.kind != "jump" or a is None or not a.jump_flights or sp.entry_gait != "run":
        return []
    t0, t1 = a.jump_flights[0]
    prints = a.footprints()
    take = [f for f in prints if f.time < t0]
    land = [f for f in prints if f.time > t1]
    if not (take and land):
        return []
    p, q = take[-1], land[0]
    fwd, left, turn = relative(p, q, a.motion.rest_forward)
    rows = []
    for scale in (1 - jump_tolerance, 1.0, 1 + jump_tolerance):
        for dturn in np.radians([-10.0, 0.0, 10.0]):
            c, sn = np.cos(dturn), np.sin(dturn)
            rows.append((p.foot, scale * (c * fwd - sn * left), scale * (sn * fwd + c * left),
                         turn + dturn, q.time - p.time, "run", True, sp.clip))
    return rows


#: m (a human's): the shortest step a walk is shortened to is at most this long, whatever
#: its clip's stride (one stair tread, 28 cm, a step): ``Settings.stride_min`` of a
#: long-striding game walk (0.9 m a step) would still skip treads.
SHORTEST_STEP = 0.28


def shortest_stride(settings: Settings, library: Library, analyses) -> float:
    """The least share of its clip's stride a walking step may be shortened to:
    ``Settings.stride_min``, or less for a library whose straightest walk steps so far
    that that share is well longer than SHORTEST_STEP (at the character's size: a 0.9 m
    game walk step, not a human's 0.72 m)."""
    if settings.stride_min >= 1.0:  # (the clips' own strides only, as asked)
        return settings.stride_min
    by = {a.name: a for a in analyses}
    walk = library.turn_groups.get("walk") or library.turn_groups.get("run")
    if walk is None or not walk.clips:
        return settings.stride_min
    straight = min(walk.clips, key=lambda c: abs(c.tau))
    a = by.get(straight.clip)
    step = 0.5 * a.stride if a is not None and a.stride else 0.0
    if step <= 0:
        return settings.stride_min
    share = settings.length(SHORTEST_STEP) / step
    return settings.stride_min if share >= 0.8 * settings.stride_min else float(max(share, 0.05))
