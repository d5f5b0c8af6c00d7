"""An edited plan made whole: the footprints a user (or a pipeline) locked or moved are
kept exactly; the way is searched again only between the nearest locked footprints
around what changed: around each moved footprint, and around a footprint that no longer
works (off every surface, in an obstacle, beyond the reach of every step of the library
from the footprint before it, or, round other characters (``Planner.others``), a step
onto it that meets one of them in time: ``Planner.clear_in_time``). The first footprint,
where the character stands, always counts as locked; past the last lock the way to the
goal is searched again. Everything outside those spans stays exactly as it was.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace

import numpy as np

from ..footprint import PIVOT, PathFootprint
from .navgraph import PlanError, PlanResult, Planner
from .plan_file import PlanFile
from .surface import footprint_support
from ..base.angles import yaw

#: m and rad: a step further than this from every step of the library is out of reach
REACH_SLACK = 0.3
TURN_SLACK = np.radians(35)
#: m and rad: feet placed side by side (standing, starting, stopping) need no clip's step
SIDE_FWD, SIDE_WIDTH, SIDE_TURN = 0.15, 0.5, np.radians(20)


@dataclass
class Edited:
    """The whole path, the spans re-planned (index ranges [a, b] of the new path, both
    kept ends included) and, per footprint of the file, why it had to go ('' if kept)."""

    result: PlanResult
    spans: list[tuple[int, int]]
    problems: list[str]
    to_goal: bool = False  # the last span runs to the goal (no kept footprint after it)


def in_frame(plan: PlanFile, forward) -> list[PathFootprint]:
    """The plan's footprints with headings measured from ``forward`` instead of the
    plan's own."""
    delta = yaw(plan.forward) - yaw(forward)
    return [replace(f, position=np.asarray(f.position, float), heading=float(f.heading + delta))
            for f in plan.footprints]


def step_offsets(fps: list[PathFootprint], forward) -> np.ndarray:
    """(N - 1, 3) each footprint's (forward, left, turn) from the one before it, in that
    footprint's frame: the step the search would need to take."""
    pos = np.array([f.position for f in fps], float)
    head = np.array([f.heading for f in fps], float) + yaw(forward)
    d = pos[1:, :2] - pos[:-1, :2]
    c, s = np.cos(head[:-1]), np.sin(head[:-1])
    turn = (np.diff(head) + np.pi) % (2 * np.pi) - np.pi
    return np.c_[d[:, 0] * c + d[:, 1] * s, -d[:, 0] * s + d[:, 1] * c, turn]


def problems_of(planner: Planner, fps: list[PathFootprint]) -> list[str]:
    """Per footprint: why it can't be stepped on ('' when it can): off the surface, in an
    obstacle, or no step of the library reaches it from the footprint before (a turn in
    place's pivot step needs none)."""
    stand, reach = _problems(planner, fps)
    return [s or r for s, r in zip(stand, reach)]


def _problems(planner: Planner, fps: list[PathFootprint]) -> tuple[list[str], list[str]]:
    """(per footprint, why a foot can't stand on it; why no step of the library reaches
    it from the footprint before), '' where it can (``problems_of``)."""
    pos = np.array([f.position for f in fps], float)
    head = np.array([f.heading for f in fps], float)
    sup = footprint_support(planner.ground, planner.obstacles, pos, head, planner.forward, planner.foot,
                            planner.support_limits)
    stand = [f"it is {r}" if not ok else "" for ok, r in zip(sup.ok, sup.reason)]
    reach = [""] * len(fps)
    st = planner.steps
    for i, (fwd, left, turn) in enumerate(step_offsets(fps, planner.forward), 1):
        side = planner.settings.length
        if abs(fwd) <= side(SIDE_FWD) and abs(left) <= side(SIDE_WIDTH) and abs(turn) <= SIDE_TURN and not fps[i].jump:
            continue  # (the feet side by side)
        if fps[i].label == PIVOT:
            continue  # (a turn in place's pivot step: no clip's)
        rows = (st.foot == fps[i - 1].foot) & (st.jump == fps[i].jump)
        if not rows.any():
            reach[i] = f"the library has no {'jump' if fps[i].jump else 'step'} from the {'LR'[fps[i - 1].foot]} foot"
            continue
        gap = np.hypot(st.fwd[rows] - fwd, st.left[rows] - left)
        dturn = np.abs((st.turn[rows] - turn + np.pi) % (2 * np.pi) - np.pi)
        if not ((gap <= planner.settings.length(REACH_SLACK)) & (dturn <= TURN_SLACK)).any():
            reach[i] = (f"no step of the library reaches it from footprint {i - 1} "
                        f"({np.hypot(fwd, left):.2f} m, turning {np.degrees(turn):.0f}°; the nearest "
                        f"step is {gap.min():.2f} m off)")
    return stand, reach


def _spans(bad: np.ndarray, locked: np.ndarray, moved: np.ndarray, start_moved: bool = False,
           goal_moved: bool = False) -> list[tuple[int, int | None]]:
    """Index ranges (a, b) to re-plan, in order: for each bad footprint, the nearest lock
    before it and the nearest after it (None: to the goal); for each moved one (a lock
    itself), the ranges from the lock before it to it and from it to the lock after; with
    ``start_moved``, from the first footprint to the lock after it; with ``goal_moved``,
    from the last lock to the goal."""
    lock_idx = np.flatnonzero(locked)
    spans = set()
    if start_moved:
        after = lock_idx[lock_idx > 0]
        spans.add((0, int(after.min()) if len(after) else None))
    if goal_moved:
        spans.add((int(lock_idx.max()), None))
    for i in np.flatnonzero(bad | moved):
        before = int(lock_idx[lock_idx < i].max())
        after = lock_idx[lock_idx > i]
        nxt = int(after.min()) if len(after) else None
        if moved[i]:
            spans |= {(before, int(i)), (int(i), nxt)} if i + 1 < len(bad) or nxt is not None else {(before, int(i))}
        else:
            spans.add((before, nxt))
    return sorted(spans, key=lambda s: (s[0], np.inf if s[1] is None else s[1]))


def nearest_steps(planner: Planner, fps: list[PathFootprint]) -> np.ndarray:
    """(N - 1,) the library step (a ``StepSet`` row) nearest each footprint's step from
    the one before it, among the steps from that foot (jumps for a jump)."""
    st = planner.steps
    out = np.zeros(len(fps) - 1, np.int64)
    for i, (fwd, left, turn) in enumerate(step_offsets(fps, planner.forward), 1):
        rows = np.flatnonzero((st.foot == fps[i - 1].foot) & (st.jump == fps[i].jump))
        rows = rows if len(rows) else np.flatnonzero(st.foot == fps[i - 1].foot)
        rows = rows if len(rows) else np.arange(st.n)
        dturn = np.abs((st.turn[rows] - turn + np.pi) % (2 * np.pi) - np.pi)
        out[i - 1] = rows[np.argmin(np.hypot(st.fwd[rows] - fwd, st.left[rows] - left) + 0.3 * dturn)]
    return out


def relabel(planner: Planner, fps: list[PathFootprint], which, retime_from: int | None = None
            ) -> list[PathFootprint]:
    """The footprints with those at indices ``which`` (and any whose clip the library
    doesn't have, but a turn in place's pivot steps) carried by the library's nearest step, and, from ``retime_from`` (or
    the first of those) on, times that add up the steps' durations."""
    st = planner.steps
    known = set(st.label.tolist())
    which = set(int(i) for i in which) | {i for i, f in enumerate(fps) if i and f.label not in known | {PIVOT}}
    if not which and retime_from is None:
        return fps
    rows = nearest_steps(planner, fps)
    start = min(which | ({retime_from} if retime_from is not None else set()))
    out = list(fps[:1])
    for i in range(1, len(fps)):
        f = fps[i]
        t = out[-1].time + float(st.duration[rows[i - 1]]) if i >= start else f.time
        if i in which:  # (carried by a library step: its clip, its gait, played as it is)
            out.append(replace(f, time=t, label=str(st.label[rows[i - 1]]), gait=str(st.gait[rows[i - 1]]),
                               speed=None))
        else:
            out.append(replace(f, time=t))
    return out


def _search(planner: Planner, origin: PathFootprint, goal, heading, end_foot: int | None) -> PlanResult:
    """The search from ``origin`` (standing) to ``goal``; with ``end_foot`` the path ends on
    the other foot (the footprint after it is ``end_foot``'s)."""
    res = planner.plan([origin], np.asarray(goal, float), heading)
    fps = res.footprints
    if end_foot is not None and fps[-1].foot == end_foot:
        fps = fps[:-1]
    res.footprints = fps
    return res


#: m and rad: a goal (or a start) moved less than this, and turned less, stays where the
#: plan went (a re-plan reads them from their objects: a float's round trip is no move)
GOAL_MOVED, GOAL_TURNED = 0.01, np.radians(1.0)


def _moved(a, b, ha, hb) -> bool:
    """Whether a goal (a footprint) at ``b`` facing ``hb`` is not the one at ``a`` facing
    ``ha`` (positions (3,) or None, headings rad or None)."""
    if a is None or b is None:
        return (a is None) != (b is None)
    if np.linalg.norm(np.asarray(a, float)[:2] - np.asarray(b, float)[:2]) > GOAL_MOVED:
        return True
    if (ha is None) != (hb is None):
        return True
    return ha is not None and abs((ha - hb + np.pi) % (2 * np.pi) - np.pi) > GOAL_TURNED


def first_footprint(first: PathFootprint, start: PathFootprint | None) -> PathFootprint:
    """The footprint an edited plan leaves from: its first, ``first``, or where ``start`` (a
    footprint of the same foot: the Start's) moved or turned from it (``GOAL_MOVED``,
    ``GOAL_TURNED``), that one, at ``first``'s time and with its label."""
    if start is None or not _moved(first.position, start.position, first.heading, start.heading):
        return first
    return PathFootprint(first.foot, np.asarray(start.position, float), float(start.heading), first.time,
                         first.label, first.gait)


def edited_path(planner: Planner, plan: PlanFile, goal=None, goal_heading=None,
                start: PathFootprint | None = None) -> Edited:
    """The plan made whole (see the module's doc). ``goal``/``goal_heading`` (heading from
    the planner's forward) override the plan's: where they differ from it (the user moved
    or turned the goal), the way from the last lock to the goal is searched again.
    ``start`` (a footprint of the plan's first foot, heading from the planner's forward)
    overrides its first footprint: where it moved, the way from it to the first lock is
    searched again. Raises PlanError naming a locked footprint that can't be stepped on."""
    t0 = time.perf_counter()
    fps = in_frame(plan, planner.forward)
    first = first_footprint(fps[0], start)
    start_moved = first is not fps[0]
    fps[0] = first
    moved = np.asarray(plan.moved, bool).copy()
    moved[0] = False
    locked = np.asarray(plan.locked, bool) | moved
    locked[0] = True
    stand, reach = _problems(planner, fps)
    problems = [a or b for a, b in zip(stand, reach)]
    again = moved.copy()  # (the kept footprints the way to and from is searched again)
    for i in np.flatnonzero(locked[1:]) + 1:
        if stand[i] or (reach[i] and locked[i - 1]):  # (a step between two kept footprints can't change)
            err = PlanError(f"footprint {i} ({'LR'[fps[i].foot]}) is locked but {problems[i]}: unlock it "
                            "or move it")
            err.footprint = int(i)  # (for the overlay to show which)
            raise err
        if reach[i]:  # (no clip's step from the footprint before, which the re-plan makes anew)
            problems[i], again[i] = "", True
    _in_time(planner, fps, locked, problems)
    bad = np.array([bool(p) for p in problems])
    planned = None if plan.goal_heading is None else plan.goal_heading + yaw(plan.forward) - yaw(planner.forward)
    goal_moved = goal is not None and _moved(plan.goal, goal, planned, goal_heading)
    if goal is None and plan.goal is not None:
        goal, goal_heading = plan.goal, planned
    return _rebuild(planner, fps, _spans(bad, locked, again, start_moved, goal_moved), goal, goal_heading, problems,
                    t0)


#: Why a footprint must go when the step onto it meets another character in time.
MEETS = "the step onto it meets another character then"


def _in_time(planner: Planner, fps: list[PathFootprint], locked: np.ndarray, problems: list[str]) -> None:
    """Round other characters (``planner.others``), each footprint not locked whose step
    meets one of them in time (``Planner.clear_in_time``: the body on its way there, the
    foot on it over its stance, the last one standing there after) given that problem
    (``MEETS``) in ``problems``, in place. A locked one stays: it is the user's."""
    others = planner.others
    if others is None or others.empty or len(fps) < 2:
        return
    for i in np.flatnonzero(~planner.clear_in_time(fps) & ~locked).tolist():
        problems[i] = problems[i] or MEETS


def _rebuild(planner: Planner, fps: list[PathFootprint], spans, goal, goal_heading, problems, t0) -> Edited:
    """Search each span again and splice the results between the kept footprints."""
    out, new_spans, joints, counts, kept_to = [], [], [], [0, 0], 0
    for a, b in spans:
        out += fps[kept_to:a + 1]
        target = fps[b] if b is not None else None
        if target is None and goal is None:
            raise PlanError(f"footprint {a + 1} can't be kept ({problems[a + 1]}) and the plan has no goal to "
                            "re-plan towards: lock a footprint after it")
        res = _search(planner, fps[a], target.position if target else goal,
                      target.heading if target else goal_heading, target.foot if target else None)
        counts = [counts[0] + res.expanded, counts[1] + res.generated]
        first = len(out)
        out += res.footprints[1:]
        joints.append(len(out))  # (the kept footprint after the span: its step is new)
        new_spans.append((first - 1, len(out) if b is not None else len(out) - 1))
        kept_to = b if b is not None else len(fps)
    out += fps[kept_to:]
    changed = [j for j in joints if j < len(out)]
    out = relabel(planner, out, changed, new_spans[0][0] + 1 if new_spans else None)
    return Edited(PlanResult(out, counts[0], counts[1], time.perf_counter() - t0, float("nan")), new_spans,
                  problems, bool(spans) and spans[-1][1] is None)


__all__ = ["GOAL_MOVED", "GOAL_TURNED", "MEETS", "Edited", "edited_path", "first_footprint", "in_frame",
           "nearest_steps", "problems_of", "relabel", "step_offsets"]
