"""A directed performance: a path through waypoints that stops and stands at some of them
(a pause) and reaches some on a given frame (an arrival). Pure numpy.

The path is synthesized leg by leg between its stops, each leg a whole performance from
standing to standing (``pipeline.synthesize``), the next leaving from the feet the last
one stood on; the legs are joined into one ``Synthesis`` (``join``) that the IK and the
bake take as they take any other.

Arrival frames are met by the pace of the walking steps before them (the clips' time
warped between ``Settings.pace_min`` and ``pace_max``); when even the fastest pace is
late, by a jog (``_jog``: the walk and the run blended at the speed needed, the walking
stretches of the way laid again at that blend's stride, ``stride``); when even the
slowest pace is early, by standing longer at the last stop before (the start, or a
pause). A frame even the fastest jog can't meet is refused naming the earliest frame
it can (the caller may then plan the way again, running).

When is a waypoint reached (``arrival_times``): where the path stops there, on the frame
the body comes within ARRIVE_BAND of where it then stands; where it passes through, on
the frame the body goes past it (crosses the line through it across its way). The same
measure reads the played scene.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Callable

import numpy as np

from ..synth.blending import Playback
from ..base.errors import FootstepError
from ..synth.ends import STAND_LEAD
from ..synth.passes import Pass
from ..synth.pipeline import Synthesis
from ..synth.schedule import Schedule
from ..synth.standing import STAND_SETTLE
from ..synth.refinement import Refined
from ..synth.smoothing import Smoothed


class TimingError(FootstepError):
    """An arrival frame that can't be met: names the waypoint and the earliest frame.
    ``kind`` is "soon" (too soon for the fastest pace: ``earliest`` the frame it can) or
    "early" (early at the slowest pace with no stop since ``anchor`` to wait at);
    ``mark`` and ``anchor`` are the waypoints' names."""

    def __init__(self, message: str, kind: str = "", mark: str = "", anchor: str | None = None,
                 earliest: int | None = None):
        super().__init__(message)
        self.kind, self.mark, self.anchor, self.earliest = kind, mark, anchor, earliest


#: m: a stopping body has arrived when it is this near where it comes to stand.
ARRIVE_BAND = 0.05
#: frames: an arrival this near its frame is met (the pace search aims within it)...
ARRIVE_TOLERANCE = 0.5
#: ... and this near, where the pace can go no further that way (the issue's "within one
#: frame": rather than run, or wait, for under a frame)
MET = 1.0
#: syntheses tried per arrival frame before giving up (the pace search).
MAX_TRIES = 8
#: speeds from the walk's to the run's a stretch that can't be laid for a jog's tries, down
JOG_SPEEDS = 25
#: s: the longest a character pauses or waits at one place (a bake's frames are held in
#: memory: ten minutes at 30 fps is 18,000 frames)
MAX_STAND = 600.0


@dataclass
class Mark:
    """A waypoint on the path: its name, the index of the footprint of the path that
    reaches it, where it is, the heading to arrive with there (the planner's, rad) or None,
    whether the path stops there, the seconds to stand there, and the time (s from the
    first frame) to arrive on, or None."""

    name: str
    index: int
    position: np.ndarray
    heading: float | None = None
    stop: bool = False
    pause: float = 0.0
    arrive: float | None = None


#: (path, start_other, goal (3,), goal heading, lead s, hold s, pace (steps,)) -> Synthesis
SynthFn = Callable[..., Synthesis]


@dataclass
class Performance:
    """The joined synthesis, and per mark: when it is reached (s), the pace of the steps
    before it, the seconds waited at the stop before it, the frames (from the first) of
    the window its arrival is looked for in, and the jog the way to it was laid at."""

    synthesis: Synthesis
    marks: list[Mark]
    times: np.ndarray  # (M,) s
    pace: np.ndarray  # (M,) the pace of the steps leading to each mark
    waited: np.ndarray  # (M,) s stood at the stop before it beyond its pause
    windows: list[tuple[int, int]]  # frames, per mark
    jogged: np.ndarray | None = None  # (M,) m/s of the jog the way to it was laid at (0: none)
    blend: np.ndarray | None = None  # (M,) that jog's walk/run blend (0 the walk, 1 the run)


# ----------------------------------------------------------------------------- the legs

def _legs(marks: list[Mark], n: int) -> list[tuple[int, int]]:
    """(first, last) footprint indices of the path (n footprints) of each leg between
    stops: a stop's leg ends on the footprint that reaches it, the next begins on the one
    beside it."""
    out, a = [], 0
    for m in marks[:-1]:
        if m.stop:
            out.append((a, m.index))
            a = m.index + 1
    out.append((a, n - 1))
    return out


def _stand_times(pause: float) -> tuple[float, float]:
    """(hold after the stop, lead before the next step) s that make ``pause`` s of
    standing (the feet settle for STAND_SETTLE s between)."""
    lead = float(np.clip(pause - STAND_SETTLE, 0.0, STAND_LEAD))
    return max(pause - STAND_SETTLE - lead, 0.0), lead


@dataclass
class _Plan:
    """What the legs are synthesized from: the path, its marks and legs, the step paces,
    the seconds waited before each leg, and the stretches between marks a jog laid again.

    The path as planned is kept (``planned``); a stretch between two marks (``way``) is
    walked as planned at its pace, or laid again at a jog's speed (``jog``): the marks'
    footprints stay, the footprints between are new, and each mark's ``index`` follows
    (``_lay_out``)."""

    path: list
    marks: list[Mark]
    goal: np.ndarray
    goal_heading: float | None
    hold: float | None  # at the goal (None: the settings')
    jogger: object = None  # ``stride.Jog``, or None: no jog (the library has no walk and run to blend)

    def __post_init__(self):
        self.planned = list(self.path)
        self.bounds = [0] + [m.index for m in self.marks]  # (stretch j: planned footprints bounds[j] to bounds[j + 1])
        self.stretch_pace = np.ones(len(self.marks))
        self.speed: list = [None] * len(self.marks)  # per stretch: the jog's speed m/s, or None
        self._laid: dict = {}
        self.wait = np.zeros(len(_legs(self.marks, len(self.path))))
        self._cache: dict = {}
        self._lay_out()

    def way(self, anchor: Mark | None, m: Mark) -> list[int]:
        """The stretches from ``anchor`` (None: the start) to ``m``."""
        at = {id(x): k for k, x in enumerate(self.marks)}
        return list(range(0 if anchor is None else at[id(anchor)] + 1, at[id(m)] + 1))

    def stretch(self, j: int) -> list:
        return self.planned[self.bounds[j]:self.bounds[j + 1] + 1]

    def laid(self, j: int, v: float):
        """The stretch ``j`` jogged at speed ``v``: (its footprints, their pace, the speed m/s
        they are laid for), or None where it can't be laid for a jog. Where its footprints
        can't be laid for ``v`` (a bend too sharp for the blend's steps, a narrow place) it
        jogs at the fastest speed below that they can be (of JOG_SPEEDS from the walk's to
        the run's): the narrow place slows it, and a way's stretches keep near one speed."""
        key = (j, round(float(v), 6))
        if key not in self._laid:
            fps, got = self.stretch(j), None
            ease_in = j == 0 or self.marks[j - 1].stop  # (leaves from standing)
            ease_out = self.marks[j].stop or j + 1 == len(self.marks)  # (stops to standing)
            if self.jogger.can_lay(fps):
                grid = np.linspace(self.jogger.strides.speed(0.0), self.jogger.strides.speed(1.0), JOG_SPEEDS)
                for u in [v] + [g for g in grid[:0:-1] if g < v]:
                    got = self.jogger.lay(fps, float(u), ease_in, ease_out)
                    if got is not None:
                        got = (*got, float(u))
                        break
            self._laid[key] = got
        return self._laid[key]

    def set_pace(self, way: list[int], pace: float) -> None:
        self.stretch_pace[way] = pace
        self._lay_out()

    def set_jog(self, way: list[int], v: float | None, q: float = 1.0, lo: float = 0.0, hi: float = np.inf) -> None:
        """Jog the stretches ``way`` at ``v`` m/s (None: walk them as planned), their steps'
        pace the jog's times ``q`` (within ``lo`` and ``hi``)."""
        for j in way:
            got = None if v is None else self.laid(j, v)
            self.speed[j] = None if got is None else float(v)
            if got is not None:
                self.stretch_pace[j] = float(np.clip(got[1] * q, lo, hi))
        self._lay_out()

    def _lay_out(self) -> None:
        path, pace = [self.planned[0]], []
        for j in range(len(self.marks)):
            fps = self.stretch(j) if self.speed[j] is None else self.laid(j, self.speed[j])[0]
            path += fps[1:]
            pace += [self.stretch_pace[j]] * (len(fps) - 1)
            self.marks[j].index = len(path) - 1
        path += self.planned[self.bounds[-1] + 1:]
        self.path = path
        self.pace = np.r_[np.asarray(pace, float), np.ones(len(path) - 1 - len(pace))]
        self.legs = _legs(self.marks, len(self.path))

    def leg_of(self, index: int) -> int:
        return next(k for k, (a, b) in enumerate(self.legs) if a <= index <= b)

    def synthesize(self, synth: SynthFn) -> tuple[Synthesis, list[Synthesis]]:
        parts, before = [], None
        for k, (a, b) in enumerate(self.legs):
            stop = next((m for m in self.marks if m.stop and m.index == b), None)
            last = k + 1 == len(self.legs)
            hold = self.hold if last else _stand_times(stop.pause)[0]
            lead = None if k == 0 else _stand_times(self._stop_before(k).pause)[1]
            if self.wait[k] > 0:
                lead = (STAND_LEAD if lead is None else lead) + float(self.wait[k])
            path = list(self.path[a:b + 1])
            other = None
            if before is not None:  # leave from the feet the last leg stood on
                pos, head = before.footprints
                path[0] = replace(path[0], position=pos[-1].copy(), heading=float(head[-1]))
                other = replace(before.plan[-2], position=pos[-2].copy(), heading=float(head[-2]))
            goal = self.goal if last else stop.position
            heading = self.goal_heading if last else stop.heading
            key = (k, a, b, tuple(self.speed), np.round(self.pace[a:b], 9).tobytes(), lead, hold,
                   None if before is None else np.round(before.footprints[0][-2:], 9).tobytes())
            part = self._cache.get(key)
            if part is None:
                part = self._cache[key] = synth(path, other, goal, heading, lead, hold, self.pace[a:b])
            parts.append(part)
            before = part
        return join(parts), parts

    def _stop_before(self, k: int) -> Mark:
        return next(m for m in self.marks if m.stop and m.index == self.legs[k - 1][1])


def perform(path, marks: list[Mark], synth: SynthFn, goal, goal_heading=None, hold: float | None = None,
            pace_range: tuple[float, float] = (0.8, 1.25), frame_start: float = 1.0, body=None,
            wait: float = 0.0, jog=None) -> Performance:
    """The performance of ``path`` through its ``marks`` (in order, the last the goal):
    stopping where a mark stops, each arrival frame met (``Mark.arrive``). ``synth`` makes
    one leg (see ``SynthFn``); ``hold`` s of standing at the goal. Raises TimingError for
    an arrival that can't be met (too soon for ``pace_range``'s fastest, or too late with
    no stop before it to wait at), naming the waypoint and, when too soon, the earliest
    frame (``frame_start`` is the first frame's number). ``body(synthesis)`` gives the body
    positions (F, 3) the arrivals are read on (default the synthesis's; the bake's, after
    the IK, is what the scene plays). ``wait`` s more are stood at the start before the
    first step (a stand the search made there, to let another character pass).

    A frame too soon for the walk's fastest pace is met by a jog where ``jog`` (a
    ``stride.Jog``) can lay one: the walk and the run blended, the stride following the
    speed (``_jog``); the marks' ``index`` then follow the footprints laid again. The
    caller runs (a ``TimingError`` "soon") only where even the fastest jog is late."""
    body = body or (lambda s: s.body_position)
    plan = _Plan(list(path), marks, np.asarray(goal, float), goal_heading, hold, jog)
    plan.wait[0] = max(float(wait), 0.0)
    syn, parts = plan.synthesize(synth)
    fps = syn.final.schedule.fps
    lo, hi = pace_range
    paced = [(m, anchor) for m, anchor in zip(marks, _anchors(marks)) if m.arrive is not None]
    for _ in range(ROUNDS):  # (a later leg's pace moves an earlier arrival a little: go round again)
        changed = False
        for m, anchor in paced:
            got = _meet(plan, synth, body, marks, m, anchor, fps, (lo, hi), frame_start)
            if got is not None:
                syn, parts = got
                changed = True
        if not changed:
            break
    times, windows = arrival_times(syn, parts, marks, body(syn))
    pace = np.array([plan.pace[max(m.index - 1, 0)] if m.index > 0 else 1.0 for m in marks])
    waited = np.array([plan.wait[plan.leg_of(m.index)] for m in marks])
    jogged = np.array([_way_jog(plan, m, anchor) for m, anchor in zip(marks, _anchors(marks))])
    blend = np.array([jog.strides.blend_for(v) if v else 0.0 for v in jogged])
    return Performance(syn, marks, times, pace, waited, windows, jogged, blend)


def _anchors(marks: list[Mark]) -> list[Mark | None]:
    """Per mark, the mark before it with an arrival frame of its own (None: the start)."""
    out, last = [], None
    for m in marks:
        out.append(last)
        last = m if m.arrive is not None else last
    return out


def _way_jog(plan: _Plan, m: Mark, anchor: Mark | None) -> float:
    """m/s of the fastest jog on the way to ``m`` (from ``anchor`` where ``m`` has a frame
    to meet, else its own stretch), 0 where it walks as planned."""
    way = plan.way(anchor, m) if m.arrive is not None else plan.way(None, m)[-1:]
    return max([plan.laid(j, plan.speed[j])[2] for j in way if plan.speed[j] is not None] or [0.0])


#: rounds over the arrival frames (each met in turn) until none moves
ROUNDS = 3


def _meet(plan: _Plan, synth: SynthFn, body, marks: list[Mark], m: Mark, anchor: Mark | None, fps: float,
          pace_range: tuple[float, float], frame_start: float):
    """Meet ``m``'s arrival frame by the pace of the steps since ``anchor`` (the mark
    before with a frame of its own, or the start), then a jog there (``_jog``), and the
    wait at its leg's start: (synthesis, legs) when they changed, None when it was met
    already."""
    lo, hi = pace_range
    way = plan.way(anchor, m)
    t_anchor = 0.0 if anchor is None else float(anchor.arrive)
    k = _wait_leg(plan, m, anchor)
    if any(plan.speed[j] is not None for j in way):  # (jogging there already: the jog's speed first)
        got = _jog(plan, synth, body, marks, m, anchor, fps, pace_range)
        if not isinstance(got, float):
            return None if got == "met" else got
        plan.set_jog(way, None)
    tried = []  # (pace, arrival)
    pace = float(plan.stretch_pace[way[0]]) if m.index > (0 if anchor is None else anchor.index) else 1.0
    got, best = None, (np.inf, pace, 0.0)
    for _ in range(MAX_TRIES):
        plan.set_pace(way, pace)
        s, p = plan.synthesize(synth)
        t = float(arrival_times(s, p, marks, body(s))[0][marks.index(m)])
        tried.append((pace, t))
        err = t - m.arrive
        at_bound = (pace >= hi - 1e-9 and err > 0) or (pace <= lo + 1e-9 and err < 0)
        if abs(err) * fps <= (MET if at_bound else ARRIVE_TOLERANCE):  # (at its fastest or slowest, a frame will do)
            break
        got = (s, p)
        if abs(err) < best[0]:
            best = (abs(err), pace, 0.0 if k is None else float(plan.wait[k]))
        if err > 0 and k is not None and plan.wait[k] > 0:  # late after waiting: wait less
            plan.wait[k] = max(plan.wait[k] - err, 0.0)
            tried = []
            continue
        if pace >= hi - 1e-9 and err > 0:  # (too soon for the walk: a jog, or refused naming the earliest)
            jogged = _jog(plan, synth, body, marks, m, anchor, fps, pace_range, (pace, err))
            if not isinstance(jogged, float):
                return None if jogged == "met" else jogged
            plan.set_jog(way, None)
            plan.set_pace(way, pace)
            raise _too_soon(m, anchor, min(t, jogged), jogged < t, fps, frame_start, hi)
        if pace <= lo + 1e-9 and err < 0:  # (early at the slowest pace: wait longer at the stop before)
            _wait_longer(plan, k, m, anchor, err, t, fps, frame_start, lo)
            tried = []
            continue
        pace = _next_pace(tried, m.arrive, t_anchor, lo, hi)
    else:  # (the arrival moves by steps where a footprint finds another place: the nearest try, within a frame)
        if best[0] * fps > 1.0:
            raise TimingError(f"waypoint {m.name!r}: no pace found to arrive on frame "
                              f"{_frame(m.arrive, fps, frame_start)} within a frame (the nearest, "
                              f"{best[0] * fps:.1f} frames off)")
        plan.set_pace(way, best[1])
        if k is not None:
            plan.wait[k] = best[2]
    return None if got is None else plan.synthesize(synth)


def _wait_longer(plan: _Plan, k: int | None, m: Mark, anchor: Mark | None, err: float, t: float, fps: float,
                 frame_start: float, lo: float) -> None:
    """Stand ``-err`` s longer at the start of leg ``k`` to arrive at ``m`` (early at the
    slowest pace ``lo``, at ``t`` s), or the TimingError where there is no stop to wait
    at (``k`` None) or the wait would be longer than MAX_STAND."""
    if k is None:
        raise TimingError(f"waypoint {m.name!r} is reached at frame {_frame(t, fps, frame_start)} at the "
                          f"slowest pace ({lo:g}), before frame {_frame(m.arrive, fps, frame_start)}, and "
                          f"the path does not stop between {anchor.name!r} and it to wait: give "
                          f"{anchor.name!r} a pause", "early", m.name, anchor.name)
    plan.wait[k] += -err
    if plan.wait[k] > MAX_STAND:
        raise TimingError(f"waypoint {m.name!r} on frame {_frame(m.arrive, fps, frame_start)}: the character "
                          f"would wait {plan.wait[k]:.0f} s for it, more than {MAX_STAND:.0f} s: give an "
                          "earlier frame", "far", m.name)


def _too_soon(m: Mark, anchor: Mark | None, t: float, jogging: bool, fps: float, frame_start: float,
              hi: float) -> TimingError:
    """The refusal of ``m``'s frame, too soon for the walk's fastest pace ``hi`` and for
    any jog: the earliest frame, reached at ``t`` s (by the fastest jog where ``jogging``)."""
    how = "jogging as fast as the way can be laid" if jogging else f"at the fastest pace, {hi:g} times the clips'"
    earliest = int(np.ceil(frame_start + t * fps - 1e-6))
    return TimingError(f"waypoint {m.name!r} can't be reached by frame {_frame(m.arrive, fps, frame_start)}:"
                       f" the earliest is frame {earliest} ({how})",
                       "soon", m.name, None if anchor is None else anchor.name, earliest)


def _jog(plan: _Plan, synth: SynthFn, body, marks: list[Mark], m: Mark, anchor: Mark | None, fps: float,
         pace_range: tuple[float, float], walked: tuple[float, float] | None = None):
    """Meet ``m``'s arrival frame, too soon for the walk's fastest pace (``walked``: that
    pace and how late it arrived, s), by a jog on the way from ``anchor``: each stretch
    that can be laid again (``stride.Jog``) at the stride of a speed between the walk's
    and the fastest the way can be laid for, its steps the walk and the run blended at
    that speed (``_jog_speed``), then, where the arrival jumps past the frame as a
    stretch takes a step fewer, the jog's pace within ``pace_range`` (``_jog_pace``).
    (synthesis, legs) when met, "met" when it was already, or where no jog meets it the
    soonest it arrives jogging (s; inf where nothing on the way can be laid again)."""
    jog = plan.jogger
    if jog is None:
        return np.inf
    lo, hi = pace_range
    way = plan.way(anchor, m)
    v_walk, v_top = jog.strides.speed(0.0), jog.strides.speed(1.0)
    if not any(plan.laid(j, v_top) is not None for j in way):  # (each stretch as fast as it can be laid)
        return np.inf
    at = {id(x): n for n, x in enumerate(marks)}[id(m)]

    def arrive(v: float, q: float = 1.0):
        plan.set_jog(way, v, q, lo, hi)
        s, p = plan.synthesize(synth)
        return (s, p), float(arrival_times(s, p, marks, body(s))[0][at]) - m.arrive

    now = next((plan.speed[j] for j in way if plan.speed[j] is not None), None)
    if now is not None and abs(arrive(now)[1]) * fps <= ARRIVE_TOLERANCE:
        return "met"
    got, e_top = arrive(v_top)
    if e_top * fps > MET:
        return float(m.arrive + e_top)  # (late even at the fastest jog: run)
    if abs(e_top) * fps <= ARRIVE_TOLERANCE:
        return got
    low = (walked[0] * v_walk, walked[1]) if walked is not None else (v_walk, np.inf)
    got, v = _jog_speed(arrive, low, (v_top, e_top), fps)
    if got is None:
        got = _jog_pace(arrive, v, fps, m.arrive)
    return got if got is not None else float(m.arrive + e_top)


def _jog_speed(arrive, low: tuple[float, float], high: tuple[float, float], fps: float):
    """(synthesis and legs, speed) of the jog whose arrival (``arrive(v)``: (result, s
    late)) is within ARRIVE_TOLERANCE, found between ``low`` (speed, s late: the walk at
    its fastest) and ``high`` (the fastest jog, early) by regula falsi (Illinois); or
    (None, the nearest speed tried) where the arrival jumps past the frame."""
    (a, ea), (b, eb) = low, high
    best, side = (abs(eb), b), 0
    for _ in range(MAX_TRIES):
        v = 0.5 * (a + b) if not np.isfinite(ea) else b - eb * (b - a) / (eb - ea)
        v = float(np.clip(v, a + 0.02 * (b - a), b - 0.02 * (b - a)))
        got, err = arrive(v)
        if abs(err) < best[0]:
            best = (abs(err), v)
        if abs(err) * fps <= ARRIVE_TOLERANCE:
            return got, v
        if err > 0:
            a, ea, eb = v, err, eb * (0.5 if side == 1 else 1.0)
            side = 1
        else:
            b, eb, ea = v, err, ea * (0.5 if side == -1 else 1.0)
            side = -1
        if b - a < 1e-3 * high[0]:
            break
    return None, best[1]


def _jog_pace(arrive, v: float, fps: float, target: float):
    """The jog at speed ``v`` (its footprints kept) with its pace tuned by the secant
    (within 0.85 to 1.15 of the jog's) until it arrives within ARRIVE_TOLERANCE: its
    synthesis and legs, the last try's within MET, or None."""
    tried, q = [], 1.0
    for _ in range(MAX_TRIES):
        got, err = arrive(v, q)
        if abs(err) * fps <= ARRIVE_TOLERANCE:
            return got
        tried.append((q, err))
        if len(tried) >= 2 and abs(tried[-1][1] - tried[-2][1]) > 1e-9:
            (q0, e0), (q1, e1) = tried[-2:]
            q = q1 - e1 * (q1 - q0) / (e1 - e0)
        else:
            q *= 1.0 + 0.5 * err / max(target, 1e-3)
        q = float(np.clip(q, 0.85, 1.15))
    return got if abs(err) * fps <= MET else None


def _frame(t: float, fps: float, frame_start: float) -> str:
    return f"{frame_start + t * fps:.0f}"


def _next_pace(tried: list, target: float, t_anchor: float, lo: float, hi: float) -> float:
    """The next pace to try: the secant through the last two tries, or (after one) the
    pace that scales the time since the anchor to the target's."""
    (p1, t1) = tried[-1]
    if len(tried) >= 2:
        p0, t0 = tried[-2]
        if abs(t1 - t0) > 1e-9 and abs(p1 - p0) > 1e-9:
            return float(np.clip(p1 + (target - t1) * (p1 - p0) / (t1 - t0), lo, hi))
    span = max(target - t_anchor, 1e-3)
    return float(np.clip(p1 * (t1 - t_anchor) / span, lo, hi))


def _wait_leg(plan: _Plan, m: Mark, anchor: Mark | None) -> int | None:
    """The leg whose start the character may wait at to arrive at ``m`` later (its own:
    the last stop before it), or None when that stop comes before ``anchor`` (the mark
    before with an arrival frame of its own, which the wait would make late)."""
    k = plan.leg_of(m.index)
    return k if anchor is None or k > plan.leg_of(anchor.index) else None


# ----------------------------------------------------------------------------- arrivals

def arrival_times(syn: Synthesis, parts: list[Synthesis], marks: list[Mark], body=None) -> tuple[np.ndarray, list]:
    """((M,) s at which each mark is reached, [(first, last) frame of the window it is
    looked for in]) on the joined synthesis ``syn`` of the legs ``parts``, by its body
    positions or ``body`` (F, 3)."""
    windows = mark_windows(syn, parts, marks)
    t = syn.final.schedule.t
    frames = arrival_frames(syn.body_position if body is None else body, marks, windows,
                            syn.settings.length(ARRIVE_BAND))
    return np.interp(frames, np.arange(len(t)), t), windows


def mark_windows(syn: Synthesis, parts: list[Synthesis], marks: list[Mark]) -> list[tuple[int, int]]:
    """Per mark, the frames its arrival is looked for in: for a stop, its leg's frames;
    for a mark passed through, from the stance two footprints before the one reaching it
    to two after."""
    S = syn.final.schedule
    ends = np.cumsum([p.final.schedule.n - 1 for p in parts])  # the last frame of each leg
    starts = np.r_[0, ends[:-1]]
    legs = _legs(marks, len(syn.plan) - 2)  # (on the path as planned: the joined one has a foot more at each end)
    T, fps = S.footprint_times, S.fps
    out = []
    for m in marks:
        leg = next(k for k, (a, b) in enumerate(legs) if a <= m.index <= b)
        if m.stop or m is marks[-1]:
            out.append((int(starts[leg]), int(ends[leg])))
        else:
            i = m.index + 1  # (the joined path begins with the other standing foot)
            a = int(np.floor(T[max(i - 2, 0)] * fps))
            b = int(np.ceil(T[min(i + 2, len(T) - 1)] * fps))
            out.append((max(a, int(starts[leg])), min(b, int(ends[leg]))))
    return out


def arrival_frames(body, marks: list[Mark], windows: list[tuple[int, int]], band: float = ARRIVE_BAND) -> np.ndarray:
    """(M,) the frame (from the first, fractional) at which the body (F, 3) reaches each
    mark within its window: a stop's when it comes within ``band`` m (ARRIVE_BAND, a
    human's) of where it stands at the window's end, a mark passed through when it goes
    past it (``_passing``)."""
    xy = np.asarray(body, float)[:, :2]
    out = np.zeros(len(marks))
    for k, (m, (a, b)) in enumerate(zip(marks, windows)):
        seg = xy[a:b + 1]
        if m.stop or k + 1 == len(marks):
            d = np.linalg.norm(seg - seg[-1], axis=1)
            far = np.flatnonzero(d > band)
            if not len(far):
                out[k] = a
                continue
            j = int(far[-1])  # the last frame still further: it crosses the band after it
            f = (d[j] - band) / max(d[j] - d[j + 1], 1e-12)
            out[k] = a + j + float(np.clip(f, 0.0, 1.0))
        else:
            out[k] = a + _passing(seg, np.asarray(m.position, float)[:2])
    return out


#: frames either side of the nearest one that give the way the body goes past a mark
PASS_SPAN = 6


def _passing(xy: np.ndarray, p: np.ndarray) -> float:
    """The frame (fractional, from the first of ``xy`` (F, 2)) at which the body passes
    ``p`` (2,): where it crosses the line through ``p`` across its way (the way from
    PASS_SPAN frames before its nearest frame to as many after, over the sway of its
    steps). The nearest frame itself where it never crosses."""
    d = np.linalg.norm(xy - p, axis=1)
    j = int(np.argmin(d))
    way = xy[min(j + PASS_SPAN, len(xy) - 1)] - xy[max(j - PASS_SPAN, 0)]
    n = np.linalg.norm(way)
    if n < 1e-9:
        return float(j)
    ahead = (xy - p) @ (way / n)  # (F,) rises through 0 as the body goes past
    cross = np.flatnonzero((ahead[:-1] < 0) & (ahead[1:] >= 0))
    if not len(cross):
        return float(j)
    c = int(cross[np.argmin(np.abs(cross - j))])
    return c + float(-ahead[c] / max(ahead[c + 1] - ahead[c], 1e-12))


# ----------------------------------------------------------------------------- joining

def join(parts: list[Synthesis]) -> Synthesis:
    """One synthesis of legs each synthesized from standing to standing, the next leaving
    from where the last one stood: its first two footprints are the last one's last two,
    its first frame the last one's last (both standing still in the same pose). The
    frames follow on, the clips' columns are their union (the standing clip last)."""
    if len(parts) == 1:
        return parts[0]
    out = parts[0]
    for p in parts[1:]:
        out = _join2(out, p)
    return out


def _columns(a: list[str], b: list[str]) -> list[str]:
    """The union of two schedules' columns, the standing clip (the last of each) last."""
    stand = a[-1]
    body = list(a[:-1]) + [c for c in b[:-1] if c not in a[:-1] and c != stand]
    return body + [stand]


def _spread(S: Schedule, cols: list[str], arr: np.ndarray) -> np.ndarray:
    out = np.zeros((len(arr), len(cols)))
    out[:, [cols.index(c) for c in S.clips]] = arr
    return out


def _join_schedules(A: Schedule, B: Schedule, shift: float, du: float) -> Schedule:
    cols = _columns(A.clips, B.clips)
    cat = lambda a, b: np.concatenate([a, b[1:]])  # noqa: E731
    wa = A.walk_t
    wshift = wa[-1] - B.walk_t[0]
    return Schedule(
        t=cat(A.t, B.t + shift), u=cat(A.u, B.u + du), clips=cols,
        weights=cat(_spread(A, cols, A.weights), _spread(B, cols, B.weights)),
        clip_time=cat(_spread(A, cols, A.clip_time), _spread(B, cols, B.clip_time)),
        clip_rate=cat(_spread(A, cols, A.clip_rate), _spread(B, cols, B.clip_rate)),
        footprint_times=np.concatenate([A.footprint_times, B.footprint_times[2:] + shift]),
        feet=np.concatenate([A.feet, B.feet[2:]]), fps=A.fps,
        walk_time=cat(wa, B.walk_t + wshift),
        walk_footprint_times=np.concatenate([A.walk_times, B.walk_times[2:] + wshift]))


def _turns_on(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``b`` (headings) moved by whole turns to follow on from ``a``'s last."""
    return b + 2 * np.pi * np.round((a[-1] - b[0]) / (2 * np.pi))


def _join_playback(A: Playback, B: Playback, shift: float) -> Playback:
    cat = lambda a, b, ax=0: np.concatenate([a, np.take(b, np.arange(1, b.shape[ax]), axis=ax)], axis=ax)  # noqa
    return Playback(t=cat(A.t, B.t + shift), root=cat(A.root, B.root), heading=cat(A.heading, _turns_on(A.heading, B.heading)),
                    heel=cat(A.heel, B.heel, 1), toe=cat(A.toe, B.toe, 1),
                    contact_point=cat(A.contact_point, B.contact_point, 1), contact=cat(A.contact, B.contact, 1),
                    blend_alpha=cat(A.blend_alpha, B.blend_alpha), correction=cat(A.correction, B.correction),
                    footprints=np.concatenate([A.footprints, B.footprints[2:]]),
                    footprint_heading=np.concatenate([A.footprint_heading,
                                                      _turns_on(A.footprint_heading, B.footprint_heading)[2:]]))


def _join_refined(A: Refined, B: Refined) -> Refined:
    n = max(len(A.mismatch), len(B.mismatch))
    pad = lambda m: np.pad(m, (0, n - len(m)), mode="edge") if len(m) else np.zeros(n)  # noqa: E731
    return Refined(np.concatenate([A.position, B.position[2:]]),
                   np.concatenate([A.heading, _turns_on(A.heading, B.heading)[2:]]),
                   np.maximum(pad(A.mismatch), pad(B.mismatch)), np.concatenate([A.rejected, B.rejected[2:]]))


def _join_pass(A: Pass, B: Pass, shift: float, du: float) -> Pass:
    cat = lambda a, b: np.concatenate([a, b[1:]])  # noqa: E731
    return Pass(_join_schedules(A.schedule, B.schedule, shift, du), _join_playback(A.played, B.played, shift),
                _join_refined(A.refined, B.refined), cat(A.body_pos, B.body_pos),
                cat(A.body_heading, _turns_on(A.body_heading, B.body_heading)))


@dataclass
class Joined(Synthesis):
    """Legs joined (``join``): their planted ranges joined too (the feet the character
    stops on stay planted until it leaves them)."""

    joined_planted: list = field(default_factory=list)

    def planted(self) -> list[tuple[float, float, float]]:
        return list(self.joined_planted)


def _join2(A: Synthesis, B: Synthesis) -> Synthesis:
    shift = float(A.final.schedule.t[-1])
    du = float(len(A.plan) - 2)
    shift1 = float(A.first.schedule.t[-1])
    final = _join_pass(A.final, B.final, shift, du)
    first = _join_pass(A.first, B.first, shift1, du)
    pa, pb = A.planted(), B.planted()
    planted = pa[:-2] + [(a0, m0, b1 + shift) for (a0, m0, _), (_, _, b1) in zip(pa[-2:], pb[:2])] \
        + [(a + shift, m + shift, b + shift) for a, m, b in pb[2:]]
    cat = lambda a, b: np.concatenate([a, b[1:]])  # noqa: E731
    seconds = {k: A.seconds.get(k, 0.0) + B.seconds.get(k, 0.0) for k in set(A.seconds) | set(B.seconds)}
    sm = Smoothed(np.concatenate([A.smoothed.position, B.smoothed.position[2:]]),
                  np.concatenate([A.smoothed.heading, _turns_on(A.smoothed.heading, B.smoothed.heading)[2:]]),
                  A.smoothed.iterations, np.concatenate([A.smoothed.rejected, B.smoothed.rejected[2:]]))
    return Joined(plan=list(A.plan) + list(B.plan[2:]), settings=A.settings, clips=final.schedule.clips,
                  smoothed=sm, first=first, tau_plan=cat(A.tau_plan, B.tau_plan), tau_raw=cat(A.tau_raw, B.tau_raw),
                  tau=cat(A.tau, B.tau), final=final, tau_final=cat(A.tau_final, B.tau_final),
                  s_final=cat(A.s_final, B.s_final),
                  speed_pins=list(A.speed_pins) + [(u + du, s) for u, s in B.speed_pins],
                  seconds=seconds, tracks={**A.tracks, **B.tracks}, standing=A.standing,
                  turns=list(A.turns) + [_shifted(t, A.final.schedule.n - 1) for t in B.turns],
                  flat=None if A.flat is None and B.flat is None else cat(_flat(A), _flat(B)),
                  joined_planted=planted)


def _flat(s: Synthesis) -> np.ndarray:
    return np.zeros(s.final.schedule.n) if s.flat is None else s.flat


def _shifted(turn: dict, frames: int) -> dict:
    """A turn in place (``Synthesis.turns``) of a leg that begins ``frames`` later: one at
    the start of a leg after the first is at a "waypoint" (where the path stopped)."""
    where = "waypoint" if turn["where"] == "start" and frames > 0 else turn["where"]
    return dict(turn, where=where, frames=[f + frames for f in turn["frames"]])


__all__ = ["ARRIVE_BAND", "Joined", "Mark", "Performance", "TimingError", "arrival_frames", "arrival_times", "join",
           "mark_windows", "perform"]
