"""A plan performed: its synthesis leg by leg (turns in place, stops and arrival frames
through waypoints), ready for the solve stage. The core's side of a bake between the
search and the IK; the Blender layer reads the scene into a ``PlanSetup`` and calls
``perform_plan``.

Reads: a ``PlanResult`` and its ``PlanSetup``, ``Settings``, the scene's frame rate, the goal,
and optionally a route through waypoints (``MarkedRoute``). Returns: ``Planned`` (the path
with both standing feet at either end, its ``Synthesis``, when each waypoint is reached).
Never: reads the scene, writes keys, or imports bpy.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Protocol, runtime_checkable

import numpy as np

from ..base.memo import freeze
from ..base.settings import Settings
from ..base.timing import collection_paused
from ..footprint import PIVOT, Leg
from ..plan.navgraph import PlanResult
from ..plan.setup import PlanSetup
from ..plan.surface import footprint_support
from ..solve.frames import Solved, solve
from ..synth.labels import clip_tracks
from ..synth.pipeline import Synthesis, standing_body, surface_snap
from ..synth.pipeline import synthesize as synthesize_leg
from . import turn_in_place
from .stride import Jog, Strides, blend_cap, straight_clips
from .directed import Mark, Performance, SynthFn, TimingError, arrival_frames, arrival_times, perform


@runtime_checkable
class StartedRoute(Protocol):
    """A route that leaves from footprints of its own (an edited plan,
    ``blender/ui/directing.EditedRoute``: its first footprint, where its bake left from):
    ``standing(setup)`` the feet it starts standing on."""

    def standing(self, setup: PlanSetup) -> list: ...


@runtime_checkable
class MarkedRoute(Protocol):
    """A route through waypoints (``blender/ui/directing.ViaRoute``): called as
    ``route(setup, start, heading)`` for its path; ``marks(fps, first frame)`` its waypoints'
    marks; ``directed`` when some stop or have arrival frames; ``retime(error, can_run)``
    changes it after a ``TimingError`` (False: it can't); ``laid(marks)`` tells it the
    footprint reaching each waypoint once performed (a jog lays the way again)."""

    directed: bool

    def __call__(self, setup: PlanSetup, start, heading) -> PlanResult: ...

    def marks(self, fps: float, first: float) -> list: ...

    def retime(self, error: TimingError, can_run: bool) -> bool: ...

    def laid(self, marks: list) -> None: ...


def legs(setup: PlanSetup, settings: Settings, fps: float) -> SynthFn:
    """``directed.SynthFn`` of this plan at ``fps`` frames a second: a leg from standing to
    standing (a path that turns in place: its turns and walk, ``turn_in_place.synthesize``)."""
    pl = setup.planner
    settings = settings.for_body(pl.settings.body_scale)  # (a human's lengths, for this character)
    snap = surface_snap(pl.ground, pl.obstacles, setup.forward, pl.foot, clearance=pl.clearance,
                        step_height=pl.max_step_height)
    body = standing_body(setup.library, setup.analyses)

    def leg(path, other, goal, heading, lead, hold, pace):
        if other is None:
            other = next((f for f in setup.start or () if f.foot != path[0].foot), None)
        ends = Leg(goal=goal, goal_heading=heading, standing=True, start_other=other, pace=pace, lead=lead, hold=hold)
        if setup.tracks is None:  # (every clip's track, made at the first leg for them all, kept on the setup:
            tracks = clip_tracks(setup.library, setup.analyses)  # a turn's tries, waypoints' legs, a re-plan's)
            freeze(tracks)  # (shared by every leg: read only)
            setup.tracks = tracks
        return synthesize_leg(path, setup.library, setup.tracks, ends, settings, fps=fps, forward=setup.forward,
                              snap=snap)

    def turning(path, other, goal, heading, lead, hold, pace):
        if any(f.label == PIVOT for f in path):
            ends = Leg(goal=goal, goal_heading=heading, start_other=other, pace=pace, lead=lead, hold=hold)
            return turn_in_place.synthesize(path, leg, ends, setup.forward, pl.foot, settings.turn_step_angle, body)
        return leg(path, other, goal, heading, lead, hold, pace)

    return turning


@dataclass
class Planned:
    """A plan and its synthesized motion."""

    result: PlanResult
    setup: PlanSetup
    synthesis: Synthesis
    goal_heading: float | None  # the planner's heading to arrive with (rad), if any
    performance: Performance | None = None  # through waypoints: when each is reached
    solved: Solved | None = None  # the IK of ``synthesis``, when timing it needed one already


@collection_paused()
def synthesize_plan(result: PlanResult, setup: PlanSetup, settings: Settings, fps: float, goal=None,
                    goal_heading: float | None = None) -> Synthesis:
    """Thesis 3.3 to 3.7 on a planned path: the body trajectory and every clip's weight
    and time per frame, footprints kept on the surfaces. The character starts from
    standing on its start footprints and stops to standing at the goal, turned to
    ``goal_heading`` (the planner's heading, rad) when given; the synthesis's path
    (``Synthesis.plan``) holds both standing feet at either end. A path that turns in
    place plays each turn as a leg of its own."""
    path = result.footprints
    other = next((f for f in setup.start or () if f.foot != path[0].foot), None)
    return legs(setup, settings, fps)(path, other, goal, goal_heading, None, None, None)


@collection_paused()
def perform_plan(result: PlanResult, setup: PlanSetup, settings: Settings, fps: float, goal, heading=None,
                 route=None, first: float = 0.0) -> Planned:
    """The plan synthesized: along its path, or with a route through waypoints that
    stops at some or has arrival frames (scene frames from ``first``), leg by leg
    (``directed.perform``: the pace, a jog, a wait); a frame too soon even for a jog runs
    on the way to it, or the route is retimed and planned again (a frame no way meets is
    refused naming the earliest any way tried reaches it)."""
    performance, ik = None, LastSolve(setup, heading, settings)
    if isinstance(route, MarkedRoute):
        marks = route.marks(fps, first)
        if route.directed:
            can_run = bool(setup.library.turn_groups.get("run"))
            soonest: dict = {}  # mark -> the "soon" error naming its earliest frame of any way tried
            while True:  # (a frame too soon: run on the way to it; early with nowhere to wait: stop before)
                try:
                    performance = _perform(result, setup, settings, fps, marks, goal, heading, first, ik.body)
                    break
                except TimingError as ex:
                    if ex.kind == "soon":
                        was = soonest.get(ex.mark)
                        soonest[ex.mark] = ex if was is None or ex.earliest < was.earliest else was
                    if not route.retime(ex, can_run):
                        raise soonest.get(ex.mark, ex) if ex.kind == "soon" else ex
                    result = route(setup, setup.start, heading)
                    marks = route.marks(fps, first)
            route.laid(performance.marks)
            syn = performance.synthesis
        else:
            syn = synthesize_plan(result, setup, settings, fps, goal, heading)
            times, windows = arrival_times(syn, [syn], marks, ik.body(syn))
            performance = Performance(syn, marks, times, np.ones(len(marks)), np.zeros(len(marks)), windows)
    elif result.waits:  # (the search stood to let another character pass: a stop there)
        marks, wait = stand_marks(result, goal, heading)
        performance = _perform(result, setup, settings, fps, marks, goal, heading, first, ik.body, wait)
        syn = performance.synthesis
    else:
        syn = synthesize_plan(result, setup, settings, fps, goal, heading)
    result = replace(result, footprints=list(syn.plan))  # with both standing feet at either end
    return Planned(result, setup, syn, heading, performance, ik.of(syn))


def stand_marks(result: PlanResult, goal, heading=None) -> tuple[list[Mark], float]:
    """The stops of a path whose search stood to let other characters pass (``PlanResult.waits``):
    a mark that stops and pauses at each stand (on the footprint arrived on, the other foot
    beside it next), the goal last; and the seconds stood at the start before the first step."""
    fs, marks, wait = result.footprints, [], 0.0
    for i, w in result.waits:
        if i == 0:
            wait += w
            continue
        marks.append(Mark(f"stand {len(marks) + 1}", i, 0.5 * (fs[i].position + fs[i + 1].position), None,
                          stop=True, pause=float(w)))
    marks.append(Mark("goal", len(fs) - 1, np.asarray(goal, float), heading, stop=True))
    return marks, wait


class LastSolve:
    """The IK of syntheses whose arrival frames are read on the baked body (``body``),
    the last one kept for the bake (``of``)."""

    def __init__(self, setup: PlanSetup, heading, settings: Settings):
        self.setup, self.heading, self.settings, self.last = setup, heading, settings, None

    def body(self, syn: Synthesis) -> np.ndarray:
        solved = solve(syn, self.setup, self.settings)
        self.last = (syn, solved)
        return solved.ik.body_pos

    def of(self, syn: Synthesis) -> "Solved | None":
        return self.last[1] if self.last is not None and self.last[0] is syn else None


def _perform(result: PlanResult, setup: PlanSetup, settings: Settings, fps: float, marks, goal, heading,
             frame_start: float, body, wait: float = 0.0) -> Performance:
    """The path through its marks leg by leg, stopping where they stop, their frames met
    (read on ``body(synthesis)``: the body the bake will have, after the IK), ``wait`` s
    stood at the start."""
    return perform(result.footprints, marks, legs(setup, settings, fps), goal, heading,
                   pace_range=(settings.pace_min, settings.pace_max), frame_start=frame_start, body=body, wait=wait,
                   jog=jog_of(setup) if settings.jog_to_arrive else None)


def jog_of(setup: PlanSetup) -> Jog | None:
    """What a jog is laid with on this plan's surfaces (``stride.Jog``): None where the
    library has no walk and quicker run to blend. Its turns cap its blend as the run's
    turning clips reach (``stride.blend_cap``, ``Library.run_reach``)."""
    pl, lib = setup.planner, setup.library
    strides = Strides.of(pl.steps, straight_clips(lib.turn_groups))
    reach = lib.run_reach(pl.settings.bend_curvature)
    if strides is None or reach is None or "walk" not in lib.turn_groups:
        return None
    caps = blend_cap(lib.label_tau, lib.turn_groups["walk"].tau_range(), reach)

    def stands(pos, heading):
        sup = footprint_support(pl.ground, pl.obstacles, pos, heading, pl.forward, pl.foot, pl.support_limits)
        return sup.ok, sup.z

    return Jog(strides, np.asarray(pl.forward, float), stands, frozenset(sp.clip for sp in lib.specials),
               pl.settings.body_scale, caps)


def waypoint_rows(planned: Planned, frame_start: int, fps: float, played_body=None) -> list[dict]:
    """Per waypoint (the goal last): the frame asked for, the frame the plan reaches it on
    and, with the played body positions (F, 3), the frame the played scene does; the
    pause, the pace of the walk to it, the jog's speed and walk/run blend where the way
    to it was laid again for one, the seconds waited before, and what met its frame
    (``met_by``)."""
    perf = planned.performance
    if perf is None:
        return []
    played = None if played_body is None else arrival_frames(played_body, perf.marks, perf.windows)
    gaits = [f.gait for f in planned.synthesis.plan[1:]]  # (the synthesis's path begins with the other standing foot)
    rows, since = [], 0
    for k, m in enumerate(perf.marks):
        jogged = 0.0 if perf.jogged is None else float(perf.jogged[k])
        ran = "run" in gaits[since + 1:m.index + 1]  # (on its way: since the mark before with a frame of its own)
        rows.append({"name": m.name, "arrive": None if m.arrive is None else round(frame_start + m.arrive * fps, 2),
                     "planned": round(float(frame_start + perf.times[k] * fps), 2),
                     "achieved": None if played is None else round(float(frame_start + played[k]), 2),
                     "stops": bool(m.stop), "pause": round(float(m.pause), 3), "pace": round(float(perf.pace[k]), 4),
                     "jog_speed": round(jogged, 3) if jogged else None,
                     "blend": round(float(perf.blend[k]), 3) if jogged else None,
                     "waited": round(float(perf.waited[k]), 3),
                     "met_by": None if m.arrive is None else _met_by(perf.waited[k], jogged, ran, perf.pace[k])})
        since = m.index if m.arrive is not None else since
    return rows


def _met_by(waited: float, jogged: float, ran: bool, pace: float) -> str:
    """What met an arrival frame: "wait" (stood longer before), "jog" (the walk and the run
    blended, the way laid again at its stride), "run" (the way planned again, running),
    "pace" (the walk's time warped) or "clips" (the clips' own pace met it)."""
    if waited > 1e-6:
        return "wait"
    if jogged:
        return "jog"
    if ran:
        return "run"
    return "pace" if abs(pace - 1.0) > 1e-3 else "clips"


__all__ = ["LastSolve", "MarkedRoute", "Planned", "StartedRoute", "legs", "perform_plan", "stand_marks", "synthesize_plan",
           "waypoint_rows"]
