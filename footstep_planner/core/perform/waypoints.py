"""A path through waypoints, in order: one search per leg, each leg leaving from the
footprint the last one arrived on, spliced into one path. Pure numpy.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace

import numpy as np

from ..base.angles import wrap, yaw
from ..footprint import PathFootprint
from ..plan.navgraph import PlanError, PlanResult, Planner
from .turn_in_place import beside, hairpin_turn, start_turn


@dataclass
class Waypoint:
    """A place the path passes through: its name (for messages), position (3,), the
    heading to pass it with (rad, from the planner's forward) or None, seconds to stand
    there, and a scene frame to arrive on (or None)."""

    name: str
    position: np.ndarray
    heading: float | None = None
    pause: float = 0.0
    arrive: float | None = None
    stop: bool = False  # stand there (also with a pause), even for no time
    hurry: bool = False  # the way there the fastest, running where that is quicker

    @property
    def stops(self) -> bool:
        return self.stop or self.pause > 0


@dataclass
class Route:
    """The whole path and, per waypoint, the index of the footprint that reaches it."""

    result: PlanResult
    arrivals: list[int]


def plan_via(planner: Planner, start: list[PathFootprint], waypoints: list[Waypoint], body=(0.0, 0.0)) -> Route:
    """The footprints from ``start`` through every waypoint in order (each reached within
    the goal radius, and heading tolerance when it has a heading). Where the path stops
    at a waypoint and the way on lies behind or beside it, it turns in place there
    (``turn_in_place.start_turn``; ``body``: see ``turn_in_place.pivot_footprints``), and
    at a hairpin on a leg (``turn_in_place.hairpin_turn``). A leg that can't be found
    raises PlanError naming the leg. Round other characters (``Planner.others``) a leg
    goes round or ahead of them; it does not stand to let one pass (``stands``: not on a
    route yet)."""

    if not waypoints:
        raise PlanError("no waypoint to go to")
    t0 = time.perf_counter()
    path: list[PathFootprint] = []
    arrivals, counts, cost = [], [0, 0], 0.0
    origin, here = start, "the start"
    for i, wp in enumerate(waypoints):
        heading = _passing_heading(planner, waypoints, i, origin)
        try:
            leg = _leg(planner, origin, wp, heading)
        except PlanError as ex:
            raise PlanError(f"no way from {here} to waypoint {wp.name!r}: {ex}", ex.expanded, ex.explored) from None
        if planner.settings.turn_in_place_angle > 0:  # (a hairpin on the way there: turned on the spot)
            leg = hairpin_turn(planner, origin, leg, np.asarray(wp.position, float), heading, body,
                               walk_on=lambda feet, wp=wp, heading=heading: _leg(planner, feet, wp, heading))
        shift = path[-1].time if path else 0.0
        fresh = leg.footprints if not path else leg.footprints[1:]
        path += [PathFootprint(f.foot, f.position, f.heading, f.time + shift, f.label, f.gait, f.jump) for f in fresh]
        arrivals.append(len(path) - 1)
        counts = [counts[0] + leg.expanded, counts[1] + leg.generated]
        cost += leg.cost
        origin, here = [path[-1]], f"waypoint {wp.name!r}"
        if wp.stops and i + 1 < len(waypoints):  # stand there: the next leg leaves from the other foot beside it
            path.append(beside(planner, path[-1]))
            origin = [path[-1]]
            turn = start_turn(planner, path[-2:], waypoints[i + 1].position, body, first=path[-2].foot)
            if turn:  # (the way on lies behind: turn on the spot first, the foot that arrived stepping first)
                path += [replace(f, time=path[-1].time) for f in turn[1:]]
                origin = [path[-1]]
    return Route(PlanResult(path, counts[0], counts[1], time.perf_counter() - t0, cost), arrivals)


#: rad: failing that, a waypoint without a heading of its own is passed facing within
#: this of the next one
PASSING_TOLERANCE = np.pi / 2
#: of the expansion budget: what each stricter try at a passing heading may spend
TRY_SHARE = 0.25


def _leg(planner: Planner, origin, wp: Waypoint, heading) -> PlanResult:
    """One leg: to the waypoint with its own heading (the planner's tolerance), or passing
    it facing the next one (the planner's tolerance, then ``PASSING_TOLERANCE``), or with
    any heading when the library can't turn that way in time."""
    goal = np.asarray(wp.position, float)
    if wp.hurry and planner.settings.run_penalty > 0:
        planner = replace(planner, settings=planner.settings.replace(run_penalty=0.0))
    if heading is None or wp.heading is not None:
        return planner.plan(origin, goal, heading)
    cfg = planner.settings
    budget = max(1, int(cfg.max_expansions * TRY_SHARE))
    for tol in (cfg.goal_heading_tolerance, max(cfg.goal_heading_tolerance, PASSING_TOLERANCE)):
        trial = replace(planner, settings=cfg.replace(goal_heading_tolerance=tol, max_expansions=budget))
        try:
            return trial.plan(origin, goal, heading)
        except PlanError:
            continue
    return planner.plan(origin, goal, None)


def _passing_heading(planner: Planner, waypoints: list[Waypoint], i: int, origin) -> float | None:
    """The heading to pass waypoint ``i`` with: its own, else (but at the last) facing the
    next waypoint, as a person on the way there would; None at the last without one, and
    at a waypoint the path stops at whose way on turns from the way there (from ``origin``,
    the footprints the leg leaves from) by more than turning in place takes: the path
    arrives as it comes and turns on the spot there (``plan_via``), where a heading to
    arrive with would have the leg walk a loop round the waypoint to face back."""
    wp = waypoints[i]
    if wp.heading is not None or i + 1 == len(waypoints):
        return wp.heading
    here = np.asarray(wp.position, float)[:2]
    d = np.asarray(waypoints[i + 1].position, float)[:2] - here
    if np.hypot(*d) < 1e-6:
        return None
    turn_angle = planner.settings.turn_in_place_angle
    if wp.stops and turn_angle > 0:
        came = here - np.mean([f.position[:2] for f in origin], axis=0)
        if np.hypot(*came) > 1e-6 and abs(wrap(yaw(d) - yaw(came))) > turn_angle:
            return None
    return yaw(d) - yaw(planner.forward)


__all__ = ["Route", "Waypoint", "plan_via"]
