"""Clip analysis after Johansen (2008): when and where each foot is planted, and what
the clip does (speed, stride, cycle, curvature, gait, start/stop, jumps).

All times are seconds from the clip's first sample; frames are scene frames. Foot index 0
is the left foot. Curvature tau = 1/r is signed, positive turning left. The clip is first
resampled (cubic) to ``Settings.analysis_rate`` so the figures do not depend on the rate
the clip was sampled at.

Contact events of one stance, in time order (Johansen's names)::

    strike  the foot first touches the ground (heel or toe)
    land    the foot is fully landed (heel and toe down)
    stance  the foot stands most firmly (heel and toe both lowest)
    lift    the foot begins to lift (the first of heel and toe rises)
    liftoff the foot has left the ground

The foot bears weight ("contact") from strike to liftoff.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import NamedTuple

import numpy as np
from scipy.ndimage import gaussian_filter1d

from . import inplace, loops
from .clip import FOOT_NAMES, ClipMotion
from ..base.settings import Settings
from ..base.errors import FootstepError


class AnalysisError(FootstepError):
    """A clip that cannot be analysed; the message names the clip."""


class ShortClipError(AnalysisError):
    """A locomotion clip too short for a gait cycle; ``stances`` are those it has."""

    def __init__(self, message: str, stances: list):
        super().__init__(message)
        self.stances = stances


@dataclass
class Footprint:
    foot: int  # 0 left, 1 right
    time: float  # stance time, s
    position: np.ndarray  # (3,) midpoint of heel and toe on the ground
    heading: float  # yaw of heel -> toe, radians (0 = the rig's rest forward)
    heel: np.ndarray  # (3,)
    toe: np.ndarray  # (3,)
    strike_part: str | None  # "heel" or "toe": which touched first (None: down at clip start)

    def to_dict(self, motion: ClipMotion) -> dict:
        return {
            "foot": FOOT_NAMES[self.foot], "time": _r(self.time),
            "frame": _r(float(motion.frame_of(self.time)), 2),
            "position": [_r(v) for v in self.position], "heading": _r(self.heading),
            "heel": [_r(v) for v in self.heel], "toe": [_r(v) for v in self.toe],
            "strike": self.strike_part,
        }


@dataclass
class Stance:
    foot: int
    stance: float
    strike: float  # equals the clip start when the foot is already down there
    land: float
    lift: float
    liftoff: float  # equals the clip end when the foot is still down there
    open_start: bool  # already down when the clip starts
    open_end: bool  # still down when the clip ends
    footprint: Footprint


@dataclass
class ClipAnalysis:
    name: str
    fps: float
    frames: int
    duration: float
    gait: str  # "walk", "run" or "stand"
    kind: str  # "cycle", "start", "stop", "jump", "idle" or "other" (not locomotion: never in a library)
    starts_at_rest: bool
    ends_at_rest: bool
    entry_gait: str
    exit_gait: str
    speed: float  # m/s over the best cycle (0 for a clip with no cycle)
    stride: float | None  # m, same-foot footprint to footprint
    cycle: float | None  # s, period of the gait cycle
    cadence: float | None  # steps per minute
    tau: float  # 1/m, signed, positive turning left
    best_cycle: tuple[float, float] | None  # (start, end) s
    loop_error: float | None  # mean bone rotation mismatch over the best cycle, radians
    is_loop: bool
    stances: list[Stance]
    flights: list[tuple[float, float]]
    jump_flights: list[tuple[float, float]]
    balance: np.ndarray = field(repr=False)  # (2, N) toe weight per sample of ``motion``
    contact: np.ndarray = field(repr=False)  # (2, N) bool per sample of ``motion``
    motion: ClipMotion = field(repr=False, default=None)
    in_place: bool = False  # an in-place clip: ``motion`` holds its reconstructed root motion
    # a loop read round its seam (``analyze_clip``): the loop; ``motion`` then holds it
    # tiled (``loops.tile``), and every time here is a time of the tiled clip
    loop: loops.Loop | None = None

    @property
    def gait_text(self) -> str:
        """The gait, marked "(in place)" for an in-place clip: "walk (in place)"."""
        return f"{self.gait} (in place)" if self.in_place else self.gait

    def footprints(self) -> list[Footprint]:
        return [st.footprint for st in sorted(self.stances, key=lambda st: st.stance)]

    def contact_intervals(self, foot: int) -> list[tuple[float, float]]:
        return [(st.strike, st.liftoff) for st in self.stances if st.foot == foot]

    def to_dict(self) -> dict:
        """The report: events as scene frames of the clip. A loop read round its seam
        (``loop``) is reported in its own terms: its stances of one period, their frames
        folded into its own range (a contact that crosses the seam starts on a later frame
        than it ends), an interval's end its start plus its length."""
        m = self.motion
        own = (lambda t: t) if self.loop is None else (lambda t: loops.fold(t, self.loop))  # noqa: E731
        fr = lambda t: _r(float(m.frame_of(own(t))), 2)  # noqa: E731
        span = lambda a, b: [fr(a), fr(b) if self.loop is None else  # noqa: E731
                             _r(float(m.frame_of(own(a) + (b - a))), 2)]
        stances = self.reported_stances()
        feet = {}
        for k, foot in enumerate(FOOT_NAMES):
            feet[foot] = {
                "contacts": [[fr(st.strike), fr(st.liftoff)] for st in stances if st.foot == k],
                "events": [{"strike": fr(st.strike), "land": fr(st.land), "stance": fr(st.stance),
                            "lift": fr(st.lift), "liftoff": fr(st.liftoff)}
                           for st in stances if st.foot == k],
                "stance_time": _r(float(np.mean([st.liftoff - st.strike for st in stances
                                                 if st.foot == k and not (st.open_start or st.open_end)]
                                                or [np.nan]))),
            }
        return {
            "name": self.name, "fps": _r(self.fps), "frames": self.frames,
            "duration": _r(self.duration), "source_fps": m.source_fps,
            "kind": self.kind, "gait": self.gait, "in_place": self.in_place, "start": self.starts_at_rest,
            "stop": self.ends_at_rest, "entry_gait": self.entry_gait, "exit_gait": self.exit_gait,
            "speed": _r(self.speed), "stride": _r(self.stride), "cycle": _r(self.cycle),
            "cadence": _r(self.cadence, 1), "tau": _r(self.tau),
            "best_cycle": None if self.best_cycle is None else span(*self.best_cycle),
            "loop_error_deg": None if self.loop_error is None else _r(np.degrees(self.loop_error), 2),
            "is_loop": self.is_loop,
            "loop": None if self.loop is None else self.loop.to_dict(self.fps),
            "flights": [span(a, b) + [_r(b - a)] for a, b in self.reported(self.flights)],
            "jumps": [span(a, b) + [_r(b - a)] for a, b in self.reported(self.jump_flights)],
            "feet": feet,
            "footprints": [st.footprint.to_dict(m) | {"frame": fr(st.footprint.time)}
                           for st in sorted(stances, key=lambda st: st.stance)],
        }

    def reported_stances(self) -> list[Stance]:
        """The stances a report lists: all of them; a loop read round its seam, those of
        one period (``loops.Loop``): its jump's, or those whose stance falls in the
        period the clip's own samples play in the tiled clip (its second)."""
        if self.loop is None or self.kind == "jump":
            return list(self.stances)
        lo, hi = self.loop.period, 2.0 * self.loop.period
        return [st for st in self.stances if lo - 1e-9 <= st.stance < hi - 1e-9]

    def reported(self, intervals) -> list[tuple[float, float]]:
        """``intervals`` (start, end) s as a report lists them: all; a loop's, those that
        start in the period its own samples play in (its second); a jump loop's, all (it
        keeps those of one period about its jump)."""
        if self.loop is None or self.kind == "jump":
            return list(intervals)
        lo, hi = self.loop.period, 2.0 * self.loop.period
        return [(a, b) for a, b in intervals if lo - 1e-9 <= a < hi - 1e-9]


def _r(v, nd=4):
    """``v`` rounded to ``nd`` decimals for a report; None for None or not finite."""
    if v is None:
        return None
    v = float(v)
    return None if not np.isfinite(v) else round(v, nd)


# ----------------------------------------------------------------------------------
# helpers on 1-D signals

def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """(start, stop) index pairs of the True runs of ``mask`` (stop exclusive)."""
    m = np.concatenate([[False], np.asarray(mask, bool), [False]])
    d = np.flatnonzero(np.diff(m.astype(np.int8)))
    return list(zip(d[0::2], d[1::2]))


def _clean_runs(mask: np.ndarray, max_gap: int, min_len: int) -> list[tuple[int, int]]:
    """The True runs of ``mask`` (``_runs``) with gaps of at most ``max_gap`` samples
    closed, then runs shorter than ``min_len`` samples dropped."""
    runs = _runs(mask)
    merged: list[list[int]] = []
    for a, b in runs:
        if merged and a - merged[-1][1] <= max_gap:
            merged[-1][1] = b
        else:
            merged.append([a, b])
    return [(a, b) for a, b in merged if b - a >= min_len]


def _peak(values: np.ndarray, i: int) -> float:
    """Sub-sample position of a peak at index ``i`` (parabola through three samples)."""
    if 0 < i < len(values) - 1:
        a, b, c = values[i - 1], values[i], values[i + 1]
        den = a - 2 * b + c
        if den < 0:
            return i + float(np.clip(0.5 * (a - c) / den, -0.5, 0.5))
    return float(i)


def _rise_index(y: np.ndarray, d1: np.ndarray, d2: np.ndarray, i0: int, i1: int,
                s: Settings) -> float | None:
    """Johansen's rules, searching forward from the stance index ``i0`` (exclusive bound
    ``i1``): the point where the curve starts to rise from the ground. None when the
    curve does not rise above ``min_step_height`` before ``i1``."""
    seg = y[i0:i1]
    if len(seg) < 3:
        return None
    y0 = seg[0]
    top = seg.max()
    if top - y0 < s.min_step_height:
        return None
    reach = np.flatnonzero(seg >= y0 + s.lift_fraction * (top - y0))
    te = int(reach[0]) if len(reach) else len(seg) - 1
    # rules 2-4 inside [i0, i0 + te]: steepest rise of the slope, above the ground
    # (not below the stance height), where the curve is not going down
    idx = np.arange(i0, i0 + te + 1)
    ok = (y[idx] >= min(y0, 0.0)) & (d1[idx] >= 0)
    if not ok.any():
        return float(i0 + te)
    cand = idx[ok]
    best = int(cand[np.argmax(d2[cand])])
    return _peak(d2, best)


def _crossing(y: np.ndarray, i: int, toward: int, thr: float, first: int = 0) -> float:
    """Sub-sample time where ``y`` crosses ``thr`` between sample ``i`` (above) and its
    neighbour ``i + toward`` (below); ``y`` may be a window of a longer signal starting
    at its sample ``first``, which the time is then counted in."""
    j = i + toward
    if not 0 <= j < len(y) or y[i] == y[j]:
        return float(first + i)
    return (first + i) + toward * float(np.clip((y[i] - thr) / (y[i] - y[j]), 0.0, 1.0))


def _flip(x: float | None, n: int) -> float | None:
    """Sample position ``x`` of a signal of ``n`` samples run backward, as a position in
    the forward signal (None stays None)."""
    return None if x is None else (n - 1) - x


# ----------------------------------------------------------------------------------
# the clip

@dataclass
class _Dense:
    """The clip resampled to the analysis rate, and its body's speed."""

    motion: ClipMotion  # the resampled clip: times (n,) s, 0 to (n - 1) * dt
    rate: float  # samples per second: the analysis rate, or the clip's own if higher
    dt: float  # 1 / rate, s
    n: int  # samples
    body_speed: np.ndarray  # (n,) m/s of the root in the ground plane (XY)
    body_speed_s: np.ndarray  # (n,) m/s, the same as a 0.1 s moving average


class _Window(NamedTuple):
    """A gait cycle candidate: two consecutive strikes (or liftoffs) of one foot."""

    foot: int  # 0 left, 1 right
    event: str  # "strike" or "liftoff"
    start: float  # s
    end: float  # s


class _Cycle(NamedTuple):
    """What the clip's best gait cycle says (all None or 0 but ``speed`` without one)."""

    best: tuple[float, float] | None  # (start, end) s of the best window
    cycle: float | None  # s, mean length of all windows
    stride: float | None  # m, same-foot footprint to footprint
    cadence: float | None  # steps per minute
    speed: float  # m/s along the best window's arc (mean body speed without a cycle)
    tau: float  # 1/m, signed curvature over the best window, positive turning left
    loop_error: float | None  # radians, pose mismatch between the window's ends


def analyze_clip(motion: ClipMotion, settings: Settings | None = None) -> ClipAnalysis:
    """Analyse one clip. Raises AnalysisError (naming the clip) when no foot ever touches
    the ground, or a locomotion clip is too short to hold one gait cycle.

    An in-place clip (its hips stay over one spot while its feet step, ``core.inplace``)
    is analysed on its root motion reconstructed from its planted feet; its analysis says
    ``in_place`` and its ``motion`` is the reconstructed clip. AnalysisError when its feet
    are never planted.

    A loop (its last pose matches its first, ``core.loops``) whose own reading holds no
    gait cycle and that moves across its seam (one gait cycle long, each foot stepping
    once; a running jump) is read round its seam (``_analyze_loop``).

    A body of another size than a human's is read with the settings' lengths and speeds
    scaled to its size (``Settings.for_body``, the clip's ``body_scale``)."""
    s = (settings or Settings()).for_body(motion.body_scale)
    _check_analysable(motion)
    loop = loops.find_loop(motion)
    if loop is None:
        return _read(motion, s)
    return _analyze_loop(motion, loop, s)


def _read(motion: ClipMotion, s: Settings, loop: loops.Loop | None = None) -> ClipAnalysis:
    """The analysis of a clip as it is, in place or travelling (``loop``: the loop a
    tiled clip was made of, ``_analyze``)."""
    d = _resample(motion, s)
    if inplace.check_in_place(motion, s, d.motion).in_place:
        return _analyze_in_place(motion, d.motion, s, loop)
    return _analyze(motion, s, d, loop)


#: A loop is read on this many of its periods end to end, its own samples the second's.
LOOP_COPIES = 3
#: A loop of fewer frames a period holds no gait cycle (nor is one tiled).
MIN_LOOP_FRAMES = 8


def _analyze_loop(motion: ClipMotion, loop: loops.Loop, s: Settings) -> ClipAnalysis:
    """The analysis of loop ``motion``: as it is when that holds a gait cycle of each foot
    (a loop of several cycles, ``_steps_twice``) or the loop rests at its seam (at rest at both ends: nothing moves
    across it, an idle, a jump from standing to standing), else read on ``LOOP_COPIES``
    periods tiled (``loops.tile``): a stance
    that crosses the seam is one stance, each foot's step is read across it, an in-place
    loop's root motion comes from its feet planted across it. The figures are the tiled
    clip's, its times the tiled clip's (``ClipAnalysis.loop``); its name, rate, frames and
    duration the loop's own. AnalysisError (one line naming the clip and what it lacks)
    for a loop too short for a gait cycle."""
    try:
        plain = _read(motion, s)
    except AnalysisError as ex:
        plain, failure = None, ex
    if plain is not None and (_steps_twice(plain) or loop.frames < MIN_LOOP_FRAMES
                              or (plain.starts_at_rest and plain.ends_at_rest)):
        return plain
    if loop.frames < MIN_LOOP_FRAMES:
        raise AnalysisError(
            f"loop {motion.name!r} repeats every {loop.frames} frames ({loop.period:.2f} s): too few for "
            f"a gait cycle (at least {MIN_LOOP_FRAMES}); {failure}")
    tiled = loops.tile(motion, loop, LOOP_COPIES)
    try:
        a = _read(tiled, s, loop)
    except ShortClipError as ex:
        raise AnalysisError(_short_loop(motion, loop, ex.stances)) from None
    return _as_loop(a, motion, loop)


def _steps_twice(a: ClipAnalysis) -> bool:
    """Each foot of analysis ``a`` strikes (or lifts off) twice inside the clip (not at its
    ends), with a gait cycle between: the clip holds a gait cycle of each foot."""
    if a.best_cycle is None:
        return False
    for k in range(2):
        mine = [st for st in a.stances if st.foot == k]
        if sum(not st.open_start for st in mine) < 2 and sum(not st.open_end for st in mine) < 2:
            return False
    return True


def _short_loop(motion: ClipMotion, loop: loops.Loop, stances: list[Stance]) -> str:
    """The one-line message for a loop too short for a gait cycle: which foot does not
    step (its stances in the tiled clip: none, never planted; one, never lifting)."""
    count = [sum(st.foot == k for st in stances) for k in range(2)]
    side = ("left", "right")
    lacking = [f"its {side[k]} foot is never planted" if c == 0 else f"its {side[k]} foot never lifts"
               for k, c in enumerate(count) if c < 2]
    what = ("only its " + side[count.index(max(count))] + " foot steps (" + lacking[0] + ")"
            if len(lacking) == 1 else "neither foot steps (" + " and ".join(lacking) + ")" if lacking
            else "its feet do not step one after the other without a pause or a jump")
    return (f"loop {motion.name!r} ({motion.n} frames, repeating every {loop.frames} at "
            f"{motion.fps:g} fps) is too short for a gait cycle: {what}")


def _as_loop(a: ClipAnalysis, motion: ClipMotion, loop: loops.Loop) -> ClipAnalysis:
    """The analysis ``a`` of loop ``motion`` tiled, as the loop's: its name, rate, frames
    and duration, ``is_loop`` and ``loop``; a jump keeps the stances and flights of one
    period about its jump (one jump, as the clip is)."""
    a.name, a.fps, a.frames, a.duration = motion.name, motion.fps, motion.n, motion.duration
    a.is_loop, a.loop = True, loop
    if a.kind == "jump" and a.jump_flights:
        lo = a.jump_flights[0][0] - 0.5 * loop.period
        hi = a.jump_flights[-1][1] + 0.5 * loop.period
        a.stances = [st for st in a.stances if lo <= st.stance <= hi]
        a.flights = [f for f in a.flights if lo <= f[0] and f[1] <= hi]
    return a


def _analyze_in_place(motion: ClipMotion, dense: ClipMotion, s: Settings,
                      loop: loops.Loop | None = None) -> ClipAnalysis:
    """The analysis of an in-place clip (``dense``: at the analysis rate): its root motion
    reconstructed from the feet ``inplace.slide_weights`` finds planted, then again from
    the stances Johansen's rules find on that, and analysed as a travelling clip."""
    moved = inplace.reconstruct(motion, *inplace.slide_weights(dense, s), dense, s)
    if moved is None:
        raise AnalysisError(
            f"clip {motion.name!r} is in place (its hips stay while its feet step) but its feet "
            f"are never planted: no heel or toe stays low while moving steadily backwards under "
            f"the body for {inplace.MIN_PLANT:.2f} s, so its root motion cannot be reconstructed")
    first = _analyze(moved, s, loop=loop)
    moved = inplace.reconstruct(motion, *inplace.stance_weights(dense.times, first.stances), dense, s)
    out = first if moved is None else _analyze(moved, s, loop=loop)
    out.in_place = True
    return out


def _analyze(motion: ClipMotion, s: Settings, d: _Dense | None = None,
             loop: loops.Loop | None = None) -> ClipAnalysis:
    """analyze_clip of a clip whose root travels (or stands): Johansen's analysis (``d``:
    the clip resampled by ``_resample``, if at hand). ``loop``: the clip is that loop
    tiled ``LOOP_COPIES`` times; its jumps are counted per period, and the kind, gaits
    and jumps are those of its second period."""
    d = _resample(motion, s) if d is None else d
    feet = [_foot_stances(d.motion, k, d.body_speed_s, s) for k in range(2)]
    stances = _all_stances(feet, motion.name)
    contact = _contact_mask(d, feet)
    flights, jumps = _flights_and_jumps(stances, d, s)
    if loop is not None:
        jumps = _loop_jumps(flights, loop.period, s)
    mine = jumps if loop is None else [j for j in jumps if loop.period <= j[0] < 2 * loop.period]
    starts_at_rest, ends_at_rest, moving = _rest_at_ends(d, contact, s)
    loco = moving & ~_jump_mask(d, jumps)
    kind = _kind(d, mine, starts_at_rest, ends_at_rest, s)
    gait, entry_gait, exit_gait = _gaits(d, loco, stances, flights, jumps, mine,
                                         starts_at_rest, ends_at_rest, s)
    kind = _locomotion_kind(kind, gait, d.motion, contact.any(axis=0))
    windows = _cycle_windows(stances, loco, d.dt)
    cyc = _cycle_figures(motion, d, stances, windows, loco, kind)
    idx = _clip_samples(motion, d)
    return ClipAnalysis(
        name=motion.name, fps=motion.fps, frames=motion.n, duration=motion.duration,
        gait=gait, kind=kind, starts_at_rest=starts_at_rest, ends_at_rest=ends_at_rest,
        entry_gait=entry_gait, exit_gait=exit_gait, speed=cyc.speed, stride=cyc.stride,
        cycle=cyc.cycle, cadence=cyc.cadence, tau=cyc.tau, best_cycle=cyc.best,
        loop_error=cyc.loop_error, is_loop=_is_loop(motion, d, windows), stances=stances,
        flights=flights, jump_flights=mine,
        balance=np.stack([f.balance for f in feet])[:, idx], contact=contact[:, idx],
        motion=motion)


def _check_analysable(motion: ClipMotion) -> None:
    """AnalysisError for a clip of fewer than 4 samples or no duration."""
    if motion.n < 4 or motion.duration <= 0:
        raise AnalysisError(f"clip {motion.name!r} is too short to analyse ({motion.n} frames)")


def _resample(motion: ClipMotion, s: Settings) -> _Dense:
    """The clip at ``s.analysis_rate`` samples per second (cubic; kept as it is when its
    own rate is that or higher), with its root's horizontal speed, raw and smoothed."""
    rate = max(float(s.analysis_rate), motion.fps)
    dense = motion if abs(rate - motion.fps) < 1e-9 else motion.resample(rate)
    dt = 1.0 / rate
    root_v = np.gradient(dense.root_pos[:, :2], dt, axis=0)
    body_speed = np.linalg.norm(root_v, axis=1)
    return _Dense(dense, rate, dt, len(dense.times), body_speed,
                  _smooth(body_speed, int(round(0.1 / dt))))


def _all_stances(feet: list[_Foot], name: str) -> list[Stance]:
    """Both feet's stances by stance time (left before right at equal times);
    AnalysisError naming clip ``name`` when there are none."""
    stances = feet[0].stances + feet[1].stances
    if not stances:
        raise AnalysisError(
            f"clip {name!r}: no foot ever touches the ground (the lowest heel or toe is "
            f"{min(f.lowest for f in feet):.3f} m above the clip's ground at z = 0, or never "
            f"stands still)")
    stances.sort(key=lambda st: st.stance)
    return stances


def _contact_mask(d: _Dense, feet: list[_Foot]) -> np.ndarray:
    """(2, n) bool per dense sample: the foot bears weight (strike to liftoff, both
    inclusive within 1e-9 s)."""
    t = d.motion.times
    contact = np.zeros((2, d.n), bool)
    for k, foot in enumerate(feet):
        for st in foot.stances:
            contact[k] |= (t >= st.strike - 1e-9) & (t <= st.liftoff + 1e-9)
    return contact


def _flights_and_jumps(stances: list[Stance], d: _Dense, s: Settings
                       ) -> tuple[list[tuple[float, float]], list[tuple[float, float]]]:
    """(flights, jumps) as (start, end) s. A flight: inside the clip, neither foot bears
    weight, for 0.02 s or more. A jump: a flight of ``s.jump_min_flight`` or more that
    lasts twice the median flight (or any such flight when there are at most two)."""
    flights = _gaps([(st.strike, st.liftoff) for st in stances], 0.0, (d.n - 1) * d.dt)
    flights = [f for f in flights if f[1] - f[0] >= 0.02]
    durations = np.array([b - a for a, b in flights])
    typical = float(np.median(durations)) if len(durations) else 0.0
    jumps = [f for f in flights
             if f[1] - f[0] >= s.jump_min_flight and (f[1] - f[0] >= 2.0 * typical or len(flights) <= 2)]
    return flights, jumps


def _loop_jumps(flights: list[tuple[float, float]], period: float, s: Settings) -> list[tuple[float, float]]:
    """The jumps of a loop tiled period after period (``period`` s), its ``flights`` (start,
    end) s: a flight of ``s.jump_min_flight`` or more that lasts twice the median of the
    other flights of its period (any such flight when it is its period's only one: a run's
    cycle has two alike, a running jump's cycle a jump and a run's flights), the second
    period's read, the others' by their repeats."""
    own = [f for f in flights if period <= f[0] < 2 * period]
    jump_starts = []
    for f in own:
        others = [g[1] - g[0] for g in own if g is not f]
        if f[1] - f[0] >= s.jump_min_flight and (not others or f[1] - f[0] >= 2.0 * float(np.median(others))):
            jump_starts.append(f[0] - period)
    tol = 0.25 * min((b - a for a, b in flights), default=0.0) + 1e-6
    return [f for f in flights if any(abs(np.mod(f[0] - t + 0.5 * period, period) - 0.5 * period) <= tol
                                      for t in jump_starts)]


def _rest_at_ends(d: _Dense, contact: np.ndarray, s: Settings) -> tuple[bool, bool, np.ndarray]:
    """(starts_at_rest, ends_at_rest, moving): at rest is the body slower than
    ``s.rest_speed`` with both feet down, for ``s.rest_time`` at the clip's start or end;
    ``moving`` (n,) bool is every sample but the runs of rest touching either end."""
    rest_n = max(1, int(round(s.rest_time / d.dt)))
    both = contact[0] & contact[1]
    at_rest = (d.body_speed_s < s.rest_speed) & both
    starts_at_rest = bool(d.n > rest_n and at_rest[:rest_n].all())
    ends_at_rest = bool(d.n > rest_n and at_rest[-rest_n:].all())
    moving = ~(at_rest & _edge_runs(at_rest))
    return starts_at_rest, ends_at_rest, moving


def _jump_mask(d: _Dense, jumps: list[tuple[float, float]]) -> np.ndarray:
    """(n,) bool: the dense samples inside a jump's flight (ends rounded, included)."""
    in_jump = np.zeros(d.n, bool)
    for a, b in jumps:
        in_jump[int(round(a / d.dt)):int(round(b / d.dt)) + 1] = True
    return in_jump


def _kind(d: _Dense, jumps: list, starts_at_rest: bool, ends_at_rest: bool, s: Settings) -> str:
    """"jump" with a jump; "idle" at rest at both ends travelling under 0.5 m (a human's),
    else "start" / "stop" at rest at the start / end; "cycle" otherwise."""
    if jumps:
        return "jump"
    if starts_at_rest and ends_at_rest:
        pos = d.motion.root_pos
        travel = float(np.linalg.norm(pos[-1, :2] - pos[0, :2]))
        return "idle" if travel < s.length(0.5) else "start"
    if starts_at_rest:
        return "start"
    if ends_at_rest:
        return "stop"
    return "cycle"


#: m/s (a human's): locomotion whose steps have flights is still a walk while its body
#: goes slower than this (its 90th percentile): a game character's walk whose feet hover
#: a little over the ground between its steps; the slowest runs and jogs go faster.
WALK_TOP_SPEED = 2.0

#: The body stands at a clip's end while its hips are at least this share of their
#: standing height (the rig's, as it stands at rest; or the highest they are in the clip
#: with a foot on the ground, if lower) there, over END_POSTURE s.
STANDING_HIPS = 0.7
END_POSTURE = 0.2


def _locomotion_kind(kind: str, gait: str, m: ClipMotion, down: np.ndarray) -> str:
    """``kind``, or "other" for a clip (``m`` at the analysis rate, a foot ``down`` (n,)
    bool) that is not locomotion: its body does not stand at its start or its end (its
    hips below STANDING_HIPS of their standing height there: lying down, sitting, getting
    up), or a start or stop that neither walks nor runs (a lunge, a stagger that ends at
    rest). Such clips are never put in the library."""
    h = m.hips_in_root[:, 2, 3]
    top = float(h[down].max()) if down.any() else float(np.median(h))
    if m.stand_height is not None and m.stand_height > 0:
        top = min(top, m.stand_height)
    n = max(1, int(round(END_POSTURE * m.fps)))
    if top > 0 and min(float(np.mean(h[:n])), float(np.mean(h[-n:]))) < STANDING_HIPS * top:
        return "other"
    if kind in ("start", "stop") and gait not in ("walk", "run"):
        return "other"
    return kind


def _gait_of(d: _Dense, mask: np.ndarray, stances: list[Stance], flights: list,
             jumps: list, s: Settings) -> str | None:
    """The gait of the dense samples in ``mask`` (n,) bool: None under 0.15 s; "stand"
    when the body is slow or no foot lifts or lands in it; "walk" when a foot is always down, "run" when the steps have
    flight phases: decided by the share of the steps inside ``mask`` followed by a
    flight that is not a jump."""
    dt, n = d.dt, d.n
    if mask.sum() * dt < 0.15:
        return None
    if np.mean(d.body_speed_s[mask]) < 2 * s.rest_speed:
        return "stand"
    inside = lambda t_: mask[min(int(round(t_ / dt)), n - 1)]  # noqa: E731
    if not any(inside(t_) for st in stances for t_, cut in ((st.strike, st.open_start), (st.liftoff, st.open_end))
               if not cut):
        return "stand"  # no foot lifts or lands: the feet stay down (a jump on the spot's run-up)
    steps = sum(1 for st in stances if inside(st.stance))
    air = sum(1 for a, b in flights if inside(0.5 * (a + b)) and (a, b) not in jumps)
    runs = air > 0 if steps < 2 else air >= s.run_flight_share * (steps - 1)
    if runs and float(np.percentile(d.body_speed_s[mask], 90)) < s.length(WALK_TOP_SPEED):
        return "walk"  # (a game's walk whose feet hover between its steps: at a walk's speed, a walk)
    return "run" if runs else "walk"


def _gaits(d: _Dense, loco: np.ndarray, stances: list[Stance], flights: list, jumps: list,
           mine: list, starts_at_rest: bool, ends_at_rest: bool, s: Settings) -> tuple[str, str, str]:
    """(gait, entry_gait, exit_gait). The gait is that of the locomotion ``loco`` (n,)
    bool ("stand" when too short to tell); the clip is entered and left in it, or in the
    gaits before the first and after the last of the jumps ``mine`` (of all ``jumps``: the
    locomotion from the jump before them, to the jump after them), or "stand" from and to
    rest."""
    gait = _gait_of(d, loco, stances, flights, jumps, s) or "stand"
    if not mine:
        return (gait, "stand" if starts_at_rest else gait,
                "stand" if ends_at_rest else gait)
    ja, jb = int(round(mine[0][0] / d.dt)), int(round(mine[-1][1] / d.dt))
    before = [b for a, b in jumps if b <= mine[0][0]]
    after = [a for a, b in jumps if a >= mine[-1][1]]
    pre = loco.copy()
    pre[ja:] = False
    if before:
        pre[:int(round(max(before) / d.dt)) + 1] = False
    post = loco.copy()
    post[:jb + 1] = False
    if after:
        post[int(round(min(after) / d.dt)):] = False
    entry_gait = "stand" if starts_at_rest else (_gait_of(d, pre, stances, flights, jumps, s) or gait)
    exit_gait = "stand" if ends_at_rest else (_gait_of(d, post, stances, flights, jumps, s) or gait)
    return gait, entry_gait, exit_gait


def _cycle_windows(stances: list[Stance], loco: np.ndarray, dt: float) -> list[_Window]:
    """Every pair of consecutive strikes (or liftoffs) of one foot, both real (not the
    clip's ends), with the locomotion ``loco`` (n,) bool all the way between them; left
    foot first, strikes before liftoffs, in time order."""
    windows = []
    for k in range(2):
        mine = [st for st in stances if st.foot == k]
        for key in ("strike", "liftoff"):
            ev = [getattr(st, key) for st in mine
                  if not (st.open_start if key == "strike" else st.open_end)]
            for a, b in zip(ev[:-1], ev[1:]):
                ia, ib = int(round(a / dt)), int(round(b / dt))
                if loco[ia:ib + 1].all():
                    windows.append(_Window(k, key, a, b))
    return windows


def _cycle_figures(motion: ClipMotion, d: _Dense, stances: list[Stance],
                   windows: list[_Window], loco: np.ndarray, kind: str) -> _Cycle:
    """Speed, stride, cycle, cadence and curvature from the best cycle window. Without
    a window: the mean body speed over the locomotion, AnalysisError for a "cycle"."""
    if not windows:
        if kind == "cycle":
            raise ShortClipError(
                f"clip {motion.name!r} is too short for a gait cycle: no foot steps twice in "
                f"its {motion.duration:.2f} s", stances)
        speed = float(np.mean(d.body_speed[loco])) if loco.any() else 0.0
        return _Cycle(None, None, None, None, speed, 0.0, None)
    cycle = float(np.mean([b - a for _, _, a, b in windows]))
    bi, turn, loop_error = _best_window(motion, d.motion, windows, loco)
    _, _, a, b = windows[bi]
    speed, tau = _arc_speed_and_tau(d.motion, a, b, turn)
    stride = _median_stride(stances, loco, d.dt)
    return _Cycle((a, b), cycle, speed * cycle if stride is None else stride, 120.0 / cycle,
                  speed, tau, loop_error)


def _best_window(motion: ClipMotion, dense: ClipMotion, windows: list[_Window],
                 loco: np.ndarray) -> tuple[int, float, float]:
    """(index into ``windows``, its heading change (radians, positive left), its pose
    error (radians)): the window whose end pose best matches its start pose; when the
    locomotion turns more than 20 degrees, among the windows turning at least 0.6 times
    the most any turns."""
    total_turn = abs(dense.root_heading[loco][-1] - dense.root_heading[loco][0]) if loco.any() else 0.0
    turns = np.array([_heading_at(dense, b) - _heading_at(dense, a) for _, _, a, b in windows])
    errs = np.array([_pose_error(motion, a, b) for _, _, a, b in windows])
    cand = np.arange(len(windows))
    if total_turn > np.radians(20):
        cand = cand[np.abs(turns) >= 0.6 * np.abs(turns).max()]
    bi = int(cand[np.argmin(errs[cand])])
    return bi, turns[bi], float(errs[bi])


def _arc_speed_and_tau(dense: ClipMotion, a: float, b: float, dpsi: float) -> tuple[float, float]:
    """(speed m/s, tau 1/m) of the root from time ``a`` to ``b`` s, taken as a circular
    arc turning ``dpsi`` radians through its end points (a straight line below 1e-6)."""
    chord = float(np.linalg.norm(_pos_at(dense, b) - _pos_at(dense, a)))
    arc = chord if abs(dpsi) < 1e-6 else chord * (0.5 * dpsi) / np.sin(0.5 * dpsi)
    speed = arc / (b - a)
    tau = 0.0 if chord < 1e-6 else float(2.0 * np.sin(0.5 * dpsi) / chord)
    return speed, tau


def _median_stride(stances: list[Stance], loco: np.ndarray, dt: float) -> float | None:
    """Median ground distance (m) between consecutive footprints of one foot with the
    locomotion ``loco`` (n,) bool all the way between them; None without any."""
    strides = []
    for k in range(2):
        prints = [st.footprint for st in stances if st.foot == k]
        for f0, f1 in zip(prints[:-1], prints[1:]):
            ia, ib = int(round(f0.time / dt)), int(round(f1.time / dt))
            if loco[ia:ib + 1].all():
                strides.append(np.linalg.norm(f1.position[:2] - f0.position[:2]))
    return float(np.median(strides)) if strides else None


def _is_loop(motion: ClipMotion, d: _Dense, windows: list[_Window]) -> bool:
    """A clip with a cycle loops when its last pose is within 4 degrees of its first and
    its turning rate at the end within 0.2 rad/s of that at the start."""
    return bool(bool(windows) and _pose_error(motion, 0.0, motion.duration) < np.radians(4) and
                abs(_heading_rate_gap(d.motion)) < 0.2)


def _clip_samples(motion: ClipMotion, d: _Dense) -> np.ndarray:
    """(N,) index of the dense sample nearest each of the clip's own samples."""
    return np.clip(np.rint(motion.times * d.rate).astype(int), 0, d.n - 1)


# ----------------------------------------------------------------------------------
# one foot

@dataclass
class _Foot:
    """What the analysis of one foot gives."""

    stances: list[Stance]
    balance: np.ndarray  # (N,) toe weight
    lowest: float  # lowest of heel and toe, m


@dataclass
class _FootSignals:
    """One foot's curves on the dense clip: N samples ``dt`` s apart, metres, m/s."""

    heel: np.ndarray  # (N, 3) heel point
    toe: np.ndarray  # (N, 3) toe (ball) point
    heel_z: np.ndarray  # (N,) heel height
    toe_z: np.ndarray  # (N,) toe height
    balance: np.ndarray  # (N,) toe weight in [0, 1]: 0.5 + (heel_z - toe_z) / balance band
    lower_z: np.ndarray  # (N,) the lower of heel and toe
    upper_z: np.ndarray  # (N,) the higher of heel and toe: low only with both down
    velocity: np.ndarray  # (N, 2) horizontal velocity of the part that is down
    speed: np.ndarray  # (N,) its norm
    sigma: float  # derivative smoothing, samples
    dt: float  # s between samples


@dataclass
class _Events:
    """One stance's contact events, in dense samples (fractional but ``stance``)."""

    stance: int  # the foot stands most firmly
    strike: float  # first touch (0 with open_start)
    land: float  # fully landed
    lift: float  # begins to lift
    liftoff: float  # has left the ground (N - 1 with open_end)
    open_start: bool  # no strike found: already down when the clip starts
    open_end: bool  # no liftoff found: still down when the clip ends


def _foot_stances(dense: ClipMotion, k: int, body_speed: np.ndarray, s: Settings) -> _Foot:
    """The stances of foot ``k`` on the densely resampled clip (Johansen's rules);
    ``body_speed`` (N,) m/s is the smoothed body speed."""
    sig = _foot_signals(dense, k, s)
    out = _Foot([], sig.balance, float(sig.lower_z.min()))
    runs = _seed_runs(sig, s)
    if not runs:
        return out
    firm, ts = _firm_parts(sig, runs, s)
    heights = _height_curves(sig)
    events = [_stance_events(sig, heights, firm, j, i0, body_speed, s) for j, i0 in enumerate(ts)]
    for ev in _merge_standing(events):
        out.stances.append(_stance_of(dense, k, sig, ev))
    return out


def _foot_signals(dense: ClipMotion, k: int, s: Settings) -> _FootSignals:
    """Heights, balance and the planted part's velocity of foot ``k``."""
    t = dense.times
    dt = t[1] - t[0]
    heel, toe = dense.heel[k], dense.toe[k]
    hh, ht = heel[:, 2], toe[:, 2]
    # Johansen's balance: the toe's weight grows as the heel rises above the toe
    b = np.clip(0.5 + (hh - ht) / s.balance_band, 0.0, 1.0)
    # velocity of the part that is down: the heel's and toe's velocities blended by the
    # balance (differentiating the blended point would add the roll-off itself)
    sigma = s.derivative_smoothing / dt
    v_heel = gaussian_filter1d(heel[:, :2], sigma, axis=0, order=1, mode="nearest") / dt
    v_toe = gaussian_filter1d(toe[:, :2], sigma, axis=0, order=1, mode="nearest") / dt
    vc = v_heel + b[:, None] * (v_toe - v_heel)
    return _FootSignals(heel, toe, hh, ht, b, np.minimum(hh, ht), np.maximum(hh, ht), vc,
                        np.linalg.norm(vc, axis=1), sigma, dt)


def _seed_runs(sig: _FootSignals, s: Settings) -> list[tuple[int, int]]:
    """(start, stop) sample runs where the foot is near the clip's ground (or the foot's
    lowest level, for feet that sink below it) and slow: gaps up to 0.06 s closed, runs
    under 0.04 s (2 samples) dropped."""
    dt = sig.dt
    ground = min(float(np.percentile(sig.lower_z, 2)), 0.0)
    down = (sig.lower_z < ground + s.contact_height) & (sig.speed < s.contact_speed)
    return _clean_runs(down, int(round(0.06 / dt)), max(2, int(round(0.04 / dt))))


def _firm_parts(sig: _FootSignals, runs: list[tuple[int, int]], s: Settings
                ) -> tuple[list[tuple[int, int]], list[int]]:
    """(firm, ts) per seed run: ``firm`` the (first, last) sample (inclusive) of the
    firm part of the stance (heel and toe both near their lowest, the foot slow), ``ts``
    the stance sample inside it. Johansen's searches start from the firm part's edges,
    so a heel wobbling while the foot pivots on its ball (sharp turns) does not end the
    stance."""
    low = sig.upper_z
    firm, ts = [], []
    for a, e in runs:
        i0 = a + int(np.argmin(low[a:e]))
        ok = (low[a:e] <= low[i0] + s.firm_height) & (sig.speed[a:e] < s.firm_speed)
        idx = np.flatnonzero(ok) + a
        if len(idx):
            firm.append((int(idx[0]), int(idx[-1])))
            i0 = int(idx[np.argmin(low[idx])])
        else:
            firm.append((i0, i0))
        ts.append(i0)
    return firm, ts


def _height_curves(sig: _FootSignals) -> tuple[list, list]:
    """(forward, backward): for the heel and the toe height, (y, dy, d2y) per sample
    (Gaussian derivatives, ``sig.sigma``), and the same curves run backward in time."""
    curves = [(y, gaussian_filter1d(y, sig.sigma, order=1, mode="nearest"),
               gaussian_filter1d(y, sig.sigma, order=2, mode="nearest"))
              for y in (sig.heel_z, sig.toe_z)]
    reverse = [(y[::-1], -d[::-1], dd[::-1]) for y, d, dd in curves]
    return curves, reverse


def _stance_events(sig: _FootSignals, heights: tuple[list, list], firm: list[tuple[int, int]],
                   j: int, i0: int, body_speed: np.ndarray, s: Settings) -> _Events:
    """The events of the ``j``-th stance (stance sample ``i0``): Johansen's vertical
    rules searched from its firm part's edges up to the neighbouring firm parts, cut
    short where the foot slips (``_slips``)."""
    n = len(sig.heel_z)
    fa, fb = firm[j]
    nxt = firm[j + 1][0] if j + 1 < len(firm) else n
    prv = firm[j - 1][1] if j > 0 else -1
    forward, backward = heights
    slip_b, slip_f = _slips(sig, body_speed[i0], fa, fb, prv, nxt, s)
    lift, liftoff = _leaving(forward, fb, nxt, slip_f, s)
    strike, land = _arriving(backward, fa, prv, n, slip_b, s)
    return _Events(i0, 0.0 if strike is None else strike, 0.0 if land is None else land,
                   float(n - 1) if lift is None else lift,
                   float(n - 1) if liftoff is None else liftoff, strike is None, liftoff is None)


def _slips(sig: _FootSignals, body_speed: float, fa: int, fb: int, prv: int, nxt: int,
           s: Settings) -> tuple[float | None, float | None]:
    """(before, after): Johansen's horizontal check. The foot has not yet reached
    (``before``, searched back from ``fa`` to ``prv``) or has left (``after``, from
    ``fb`` to ``nxt``) the ground where its velocity departs from its median velocity
    over the firm part [fa, fb] by more than ``s.slip_tolerance`` times the body speed
    (m/s), at least ``s.slip_min_speed``. Fractional samples; None: no such point."""
    vc = sig.velocity
    thr = max(s.slip_tolerance * body_speed, s.slip_min_speed)
    lo, hi = max(prv, 0), min(nxt + 1, len(vc))  # (the search, and the samples beside it)
    dev = np.linalg.norm(vc[lo:hi] - np.median(vc[fa:fb + 1], axis=0), axis=1)
    fwd = np.flatnonzero(dev[fb - lo:nxt - lo] > thr)
    bwd = np.flatnonzero(dev[prv + 1 - lo:fa + 1 - lo] > thr)
    slip_f = _crossing(dev, fb - lo + fwd[0], -1, thr, lo) if len(fwd) else None
    slip_b = _crossing(dev, prv + 1 - lo + bwd[-1], +1, thr, lo) if len(bwd) else None
    return slip_b, slip_f


def _leaving(curves: list, fb: int, nxt: int, slip: float | None, s: Settings
             ) -> tuple[float | None, float | None]:
    """(lift, liftoff) in fractional samples: the first and last of heel and toe to rise
    after ``fb`` (before ``nxt``), liftoff no later than ``slip``. None: the foot does
    not leave."""
    rises = [x for x in (_rise_index(*c, fb, nxt, s) for c in curves) if x is not None]
    lift, liftoff = (min(rises), max(rises)) if rises else (None, None)
    if slip is not None and (liftoff is None or slip < liftoff):
        liftoff = slip
        lift = slip if lift is None else min(lift, slip)
    return lift, liftoff


def _arriving(reverse: list, fa: int, prv: int, n: int, slip: float | None, s: Settings
              ) -> tuple[float | None, float | None]:
    """(strike, land) in fractional samples: the first and last of heel and toe to come
    down before ``fa`` (after ``prv``; the rise rules run backward in time), strike no
    earlier than ``slip``. None: the foot was down all along."""
    touches = [x for x in (_flip(_rise_index(*c, n - 1 - fa, n - 1 - prv, s), n)
                           for c in reverse) if x is not None]
    strike, land = (min(touches), max(touches)) if touches else (None, None)
    if slip is not None and (strike is None or slip > strike):
        strike = slip
        land = slip if land is None else max(land, slip)
    return strike, land


def _merge_standing(events: list[_Events]) -> list[_Events]:
    """A foot that never left the ground between two stances stood all along: such
    stances become one (the first's stance, strike and land; the last's lift and
    liftoff). Modifies the merged records in place."""
    merged: list[_Events] = []
    for ev in events:
        if merged and (merged[-1].open_end or ev.strike <= merged[-1].liftoff):
            merged[-1].lift, merged[-1].liftoff, merged[-1].open_end = ev.lift, ev.liftoff, ev.open_end
        else:
            merged.append(ev)
    return merged


def _stance_of(dense: ClipMotion, k: int, sig: _FootSignals, ev: _Events) -> Stance:
    """The Stance of foot ``k`` with events ``ev`` (samples converted to seconds) and its
    footprint: heel and toe at their medians from landing (or the stance, if earlier)
    to lifting (or the stance, if later)."""
    t = dense.times
    n = len(t)
    lo, hi = int(np.ceil(min(ev.land, ev.stance))), int(np.floor(max(ev.lift, ev.stance)))
    heel_p = np.median(sig.heel[lo:hi + 1], axis=0)
    toe_p = np.median(sig.toe[lo:hi + 1], axis=0)
    d = toe_p - heel_p
    fwd_angle = np.arctan2(dense.rest_forward[1], dense.rest_forward[0])
    heading = float((np.arctan2(d[1], d[0]) - fwd_angle + np.pi) % (2 * np.pi) - np.pi)
    si = int(np.clip(round(ev.strike), 0, n - 1))
    part = None if ev.open_start else ("heel" if sig.heel_z[si] <= sig.toe_z[si] else "toe")
    fp = Footprint(k, float(t[ev.stance]), 0.5 * (heel_p + toe_p), heading, heel_p, toe_p, part)
    dt = sig.dt
    return Stance(k, float(t[ev.stance]), ev.strike * dt, ev.land * dt, ev.lift * dt,
                  ev.liftoff * dt, ev.open_start, ev.open_end, fp)


def _gaps(intervals, lo, hi):
    """Interior gaps (a, b) of the union of closed intervals within [lo, hi]."""
    out, end = [], None
    for a, b in sorted(intervals):
        if end is not None and a > end:
            out.append((end, a))
        end = b if end is None else max(end, b)
    return [(a, b) for a, b in out if a > lo and b < hi]


def _smooth(x: np.ndarray, width: int) -> np.ndarray:
    """Moving average of ``x`` (N,) over ``width`` samples, edges padded by repetition;
    ``x`` itself for a width of 1 or less."""
    if width <= 1:
        return x
    k = np.ones(width) / width
    return np.convolve(np.pad(x, (width // 2, width - 1 - width // 2), mode="edge"), k, "valid")


def _edge_runs(mask: np.ndarray) -> np.ndarray:
    """Only the runs of ``mask`` touching either end of the clip."""
    out = np.zeros_like(mask)
    for a, b in _runs(mask):
        if a == 0 or b == len(mask):
            out[a:b] = True
    return out


def _heading_at(m: ClipMotion, t: float) -> float:
    """The root's unwrapped heading (radians) at time ``t`` s, linearly interpolated."""
    return float(np.interp(t, m.times, m.root_heading))


def _pos_at(m: ClipMotion, t: float) -> np.ndarray:
    """(2,) the root's ground position (x, y) m at time ``t`` s, linearly interpolated."""
    return np.array([np.interp(t, m.times, m.root_pos[:, i]) for i in range(2)])


def _pose_error(m: ClipMotion, a: float, b: float) -> float:
    """Mean rotation angle between the bone poses at times a and b (root motion removed)."""
    ia = int(np.clip(round(a * m.fps), 0, m.n - 1))
    ib = int(np.clip(round(b * m.fps), 0, m.n - 1))
    trace = np.einsum("bij,bij->b", m.local_rot[ia], m.local_rot[ib])  # trace(Ra^T Rb)
    ang = np.arccos(np.clip((trace - 1) / 2, -1, 1))
    # the hips' rotation relative to the root replaces its own (heading-carrying) rotation
    ha, hb = m.hips_in_root[ia, :3, :3], m.hips_in_root[ib, :3, :3]
    ang[m.hips_index] = np.arccos(np.clip((np.trace(ha.T @ hb) - 1) / 2, -1, 1))
    return float(ang.mean())


def _heading_rate_gap(m: ClipMotion) -> float:
    """Turning rate (rad/s) at the clip's last sample minus that at its first."""
    v = np.gradient(m.root_heading, m.times)
    return float(v[-1] - v[0])
