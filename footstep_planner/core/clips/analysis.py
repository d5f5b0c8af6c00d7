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

Here: the analysis (``ClipAnalysis``, ``analyze_clip``; a loop read round its seam, an
in-place clip on its reconstructed root motion) and its gait cycle figures (speed, stride,
cycle, cadence, tau, loop error). Each foot's stances are found in ``stances``; the
flights, jumps, rest, kind and gaits they make in ``gaits``.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field, fields, replace
from typing import NamedTuple

import numpy as np

from . import inplace, loops
from .clip import FOOT_NAMES, ClipMotion
from .gaits import _flights_and_jumps, _gaits, _jump_mask, _kind, _locomotion_kind, _loop_jumps, _rest_at_ends
from .stances import Footprint, Stance, _Dense, _Foot, _foot_stances, _r, _resample
from ..base.memo import Memo
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


# ----------------------------------------------------------------------------------
# the clip

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
    key = (motion_digest(motion), s)
    kept = _ANALYSED.get(key)
    if kept is None or (isinstance(kept[0], AnalysisError) and kept[2] != motion.name):
        try:  # (a refusal names its clip: another name's is made again)
            made = _analyze_clip(motion, s)
        except AnalysisError as ex:
            made = ex
        # (a travelling clip's analysis holds the very motion it was given: each caller's own)
        own = isinstance(made, ClipAnalysis) and made.motion is motion
        kept = _ANALYSED.put(key, (replace(made, motion=None) if own else made, own, motion.name))
    made, own, name = kept
    if isinstance(made, AnalysisError):
        raise AnalysisError(str(made))
    if own:
        return replace(made, name=motion.name, motion=motion)
    if name == motion.name:
        return made
    return replace(made, name=motion.name, motion=replace(made.motion, name=motion.name))  # (an in-place clip's own)


#: Clips analysed in this process, by their samples (``motion_digest``) and the settings:
#: a re-plan, a re-bake or the next job of a batch of one character (or of another with
#: the same clips under other names: each named as its clip) is given the same analyses
#: (their arrays read only; a travelling clip's with the caller's own motion) or the same
#: refusal. At most this many, and this many bytes of their arrays (a 1,000-sample clip of
#: a 30-bone rig is about 2.5 MB).
_ANALYSED = Memo(kept=128, max_bytes=512 << 20)


def forget_analyses() -> None:
    """Forget every analysis kept (``analyze_clip`` then analyses each clip afresh): for a
    benchmark that times the analysis itself."""
    _ANALYSED.clear()


def motion_digest(motion: ClipMotion) -> str:
    """A digest of everything of ``motion`` that its analysis reads but its name (a label:
    a clip of another name is the same clip): its rates and sizes, and every array's
    values, shape and type."""
    h = hashlib.sha1()
    for f in fields(motion):
        if f.name == "name":
            continue
        v = getattr(motion, f.name)
        if isinstance(v, np.ndarray):
            h.update(repr((f.name, v.shape, v.dtype.str)).encode())
            h.update(np.ascontiguousarray(v).tobytes())
        else:
            h.update(repr((f.name, v)).encode())
    return h.hexdigest()


def _analyze_clip(motion: ClipMotion, s: Settings) -> ClipAnalysis:
    """``analyze_clip``'s work, on settings already made for the body."""
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
