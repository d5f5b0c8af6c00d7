"""Turning on the spot (issue 14): pivot steps instead of a walking loop. Pure numpy.

When the way ahead at the start lies behind or beside the character, the goal's
heading far from the way the walk arrives, or the way turns back on a hairpin bend
mid-path (``hairpin``), a person turns on the spot: the foot on the
turning side opens (turns out and steps), the other closes beside it, and so on until
both stand side by side facing the new way. ``pivot_footprints`` makes those steps;
``plan`` decides where a path turns in place and plans the walk from the turned feet;
``synthesize`` plays each turn as a leg of its own, from standing to standing, joined with
the walk (``directed.join``) as a pause is.

A path that turns in place carries the turns in its footprints: the pivot steps are
labelled ``PIVOT``. A turn at the start is the start footprint the walk does not leave
from, then the pivot steps, the last of which is the footprint the walk leaves from; a
turn at the end is the foot set down beside the walk's last footprint, then the pivot
steps (``split`` takes such a path apart); a turn at a hairpin is an end turn's
footprints between two walks, the next leaving from its last pivot step (``hairpins``).

Conventions: headings are yaws (rad) from ``forward`` (the world direction of heading
0), positive turning left; feet 0 left, 1 right; metres.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace

import numpy as np

from ..footprint import PIVOT, STAND_LABEL, STAND_HALF_WIDTH, Leg, PathFootprint, beside_position
from ..plan.navgraph import PlanError, PlanResult, Planner
from ..plan.surface import FootShape
from .directed import join
from ..base.angles import wrap, yaw

#: A pivot step is played this much quicker than the walk's step (its clip's time over
#: it): a turn on the spot takes short, quick steps.
PIVOT_PACE = 1.5
#: rad: how far a closing (outside) foot may turn past the opening one (toes in).
TOE_IN = np.radians(20.0)
#: m: the least room left between the two feet's rectangles.
GAP = 0.01
#: m: how far the feet of a pivot pair may be set apart, or one ahead of the other, beyond
#: what keeps them clear, to keep their middle over the spot the turn began on.
SLACK = 0.1
#: rad: a turn this small is no turn.
NO_TURN = 1e-6


def beside(planner: Planner, fp: PathFootprint) -> PathFootprint:
    """The other foot standing beside ``fp``, side by side (STAND_HALF_WIDTH from the middle),
    on the ground under it."""
    p = beside_position(fp, 1 - fp.foot, planner.forward, 2 * planner.settings.length(STAND_HALF_WIDTH))
    hit = planner.ground.ray_down(np.array([[p[0], p[1], p[2] + 0.5]]), 3.0)
    if hit.hit[0]:
        p[2] = hit.z[0]
    return PathFootprint(1 - fp.foot, p, fp.heading, fp.time, fp.label, fp.gait)


def _offset(body, heading: float, forward) -> np.ndarray:
    """(3,) the world offset of ``body`` (ahead, left) m in the frame of ``heading``."""
    ahead, left = _axes(heading, forward)
    return body[0] * ahead + body[1] * left


def _axes(heading: float, forward) -> tuple[np.ndarray, np.ndarray]:
    """(ahead, left) world unit vectors (3,) of a heading."""
    a = heading + yaw(forward)
    return np.array([np.cos(a), np.sin(a), 0.0]), np.array([-np.sin(a), np.cos(a), 0.0])


def _corners(pos: np.ndarray, heading: np.ndarray, forward, foot: FootShape) -> np.ndarray:
    """(K, 4, 2) the corners of K footprints' rectangles (positions (K, >=2), headings (K,)),
    in order round them (``FootShape.corners`` less the middle)."""
    return foot.corners(np.asarray(pos, float), np.asarray(heading, float), forward)[..., [0, 1, 3, 2], :]


def _clear(cand: np.ndarray, other: np.ndarray) -> np.ndarray:
    """(K,) the gap (m) along the best of the rectangles' edge normals (a lower bound of
    their distance; negative: they overlap) between rectangles ``cand`` (K, 4, 2) turned
    alike and one rectangle ``other`` (4, 2)."""
    axes = []
    for poly in (cand[0], other):
        for k in (0, 1):
            e = poly[(k + 1) % 4] - poly[k]
            axes.append(np.array([-e[1], e[0]]) / max(np.linalg.norm(e), 1e-12))
    ax = np.stack(axes)  # (4, 2)
    pc = cand @ ax.T  # (K, 4 corners, 4 axes)
    po = other @ ax.T  # (4 corners, 4 axes)
    gap = np.maximum(pc.min(axis=1) - po.max(axis=0), po.min(axis=0) - pc.max(axis=1))  # (K, 4)
    return gap.max(axis=1)


def pivot_footprints(standing: PathFootprint, first: PathFootprint, target: float, forward,
                     step_angle: float, foot: FootShape = FootShape(), width: float | None = None,
                     body=(0.0, 0.0)) -> list[PathFootprint]:
    """The pivot steps that turn the feet ``standing`` and ``first`` (side by side, the
    latter the foot to step first) on the spot to ``target`` (rad), the shorter way
    round: the feet step in turn, the one on the turning side opening up to
    ``step_angle`` past the other (toes out), the other closing beside it (up to TOE_IN
    past it, toes in), no foot turning more than ``step_angle`` in one step; each foot
    set beside the other as near as it may to where it would stand, turned so, in a pair
    ``width`` apart (default the feet's own spacing) round the spot the body stands over
    (``body``: (ahead, left) m from the middle of the standing feet, in their frame;
    over the ankles, not the footprints' middles, so that the body turns on the spot;
    ``pipeline.standing_body``), keeping the feet's
    rectangles (``foot``) GAP apart (``_beside``). The last two stand side by side
    facing ``target``. Returns the steps in order (the last two
    are the turned feet); none when the feet already face ``target``."""
    if not 0 < step_angle <= np.pi / 2:
        raise ValueError(f"a pivot step turns more than 0 and at most 90 degrees, not {np.degrees(step_angle):g}")
    if standing.foot == first.foot:
        raise ValueError("a turn in place needs a left and a right foot")
    pos = {standing.foot: np.asarray(standing.position, float), first.foot: np.asarray(first.position, float)}
    mean = standing.heading + 0.5 * float(wrap(first.heading - standing.heading))
    turn = float(wrap(target - mean))
    if abs(abs(turn) - np.pi) < 1e-9:
        turn = np.pi  # (right behind: turn left)
    goal = mean + turn
    head = {standing.foot: mean + float(wrap(standing.heading - mean)),
            first.foot: mean + float(wrap(first.heading - mean))}
    if abs(turn) < NO_TURN and all(abs(h - goal) < NO_TURN for h in head.values()):
        return []
    if width is None:
        width = float(np.linalg.norm((pos[0] - pos[1])[:2]))
    c = 0.5 * (pos[0] + pos[1]) + _offset(body, mean, forward)  # (under the body)
    sign = 1.0 if turn >= 0 else -1.0
    inside = 0 if sign > 0 else 1  # the foot on the turning side
    out, f = [], first.foot
    for _ in range(64):
        o = 1 - f
        lead = step_angle if f == inside else TOE_IN
        new = head[o] + sign * lead
        new = head[f] + sign * min(sign * (new - head[f]), step_angle)  # (no foot turns past the limit)
        if sign * (new - goal) > -NO_TURN:
            new = goal
        last = abs(new - goal) < NO_TURN and abs(head[o] - goal) < NO_TURN
        pos[f] = _beside(pos[o], head[o], new, f, forward, foot, width, c, body, last)
        head[f] = goal if last else new
        out.append(PathFootprint(f, pos[f].copy(), float(head[f]), 0.0, PIVOT, "walk"))
        if last:
            return out
        f = o
    raise ValueError("a turn in place did not end")  # (never: every step turns on or closes)


#: m: the grid on which a pivot step's place is chosen
PLACE_STEP = 0.005


def _beside(other: np.ndarray, other_heading: float, heading: float, f: int, forward, foot: FootShape,
            width: float, centre: np.ndarray, body=(0.0, 0.0), last: bool = False) -> np.ndarray:
    """Where foot ``f`` turned ``heading`` steps beside the other (at ``other``, turned
    ``other_heading``): as near as it may to where it would stand, turned so, in a pair
    ``width`` apart round ``centre``, the body's spot, ``body`` (ahead, left) m from their
    middle (the ``last``: half way from there to where it puts the pair's middle there),
    keeping GAP from the other foot's rectangle, set across their mean heading at least
    half ``width`` and at most ``width`` + SLACK apart and at most SLACK ahead or
    behind."""
    ahead, left = _axes(0.5 * (heading + other_heading), forward)
    side = left if f == 0 else -left
    own = _axes(heading, forward)[1] * (1.0 if f == 0 else -1.0)
    want = centre - _offset(body, heading, forward) + 0.5 * width * own
    if last:  # (the last step halves what the other foot is off: the pair ends nearer over the centre)
        want = 0.5 * (want + 2.0 * (centre - _offset(body, 0.5 * (heading + other_heading), forward)) - other)
    k = foot.scale  # (GAP, SLACK and PLACE_STEP are a human's)
    d = np.arange(0.5 * width, width + SLACK * k + 1e-9, PLACE_STEP * k)
    a = np.arange(-SLACK * k, SLACK * k + 1e-9, PLACE_STEP * k)
    dd, aa = np.meshgrid(d, a, indexing="ij")
    cand = other[None, :2] + dd.reshape(-1, 1) * side[:2] + aa.reshape(-1, 1) * ahead[:2]
    ok = _clear(_corners(cand, np.full(len(cand), heading), forward, foot),
                _corners(other[None], np.array([other_heading]), forward, foot)[0]) >= GAP * k
    cost = np.linalg.norm(cand - want[:2], axis=1) + np.where(ok, 0.0, np.inf)
    if not np.isfinite(cost).any():  # (a foot too big for the slack: straight out beside it)
        far = other[:2] + (width + SLACK * k) * side[:2] + 2 * max(foot.back, foot.front) * side[:2]
        cand, cost = far[None], np.zeros(1)
    p = other.copy()
    p[:2] = cand[int(np.argmin(cost))]
    return p


# ----------------------------------------------------------------------------- paths

@dataclass
class Turn:
    """Where a path turns in place ("start", "hairpin" or "end"), from which heading to which (rad,
    the turned way, not wrapped), and the footprint indices of its pivot steps in the
    path."""

    where: str
    heading_from: float
    heading_to: float
    first: int
    last: int

    @property
    def degrees(self) -> float:
        return float(np.degrees(self.heading_to - self.heading_from))

    def to_dict(self) -> dict:
        return {"where": self.where, "degrees": round(self.degrees, 1), "steps": self.last - self.first + 1,
                "from_heading": round(float(self.heading_from), 4), "to_heading": round(float(self.heading_to), 4),
                "footprints": [self.first, self.last]}


def turns_of(path: list[PathFootprint]) -> list[Turn]:
    """The turns in place of a path (``split``'s), with the indices of their pivot steps
    (in a planned path; a synthesized one, both standing feet at either end, is read
    from its second footprint on)."""

    if path and path[0].label == STAND_LABEL:
        return [replace(t, first=t.first + 1, last=t.last + 1) for t in turns_of(path[1:])]
    head, walk, tail = split(path)
    out = []
    if head:
        a, b = head[0], head[-1]
        out.append(Turn("start", a.heading, b.heading, 1, len(head) - 1))
    for a, b in hairpins(path):
        out.append(Turn("hairpin", _mean_heading(path[a - 1], path[a]), path[b].heading, a + 1, b))
    if tail:
        n = len(path)
        out.append(Turn("end", _mean_heading(walk[-1], tail[0]), tail[-1].heading, n - len(tail) + 1, n - 1))
    return out


def hairpins(path: list[PathFootprint]) -> list[tuple[int, int]]:
    """(first, last) indices of each run of pivot footprints between two walks (a turn in
    place at a hairpin, ``hairpin_turn``: the foot set down beside the walk's last, the
    pivot steps, the last of which the next walk leaves from); not the start's turn nor
    the end's."""
    piv = np.array([f.label == PIVOT for f in path], bool)
    k = 1
    while k < len(path) and piv[k]:  # (the start's turn)
        k += 1
    out, i = [], k
    while i < len(path):
        if piv[i]:
            j = i
            while j + 1 < len(path) and piv[j + 1]:
                j += 1
            if j + 1 < len(path):
                out.append((i, j))
            i = j + 1
        else:
            i += 1
    return out


def _mean_heading(a: PathFootprint, b: PathFootprint) -> float:
    return a.heading + 0.5 * float(wrap(b.heading - a.heading))


def split(path: list[PathFootprint]) -> tuple[list, list, list]:
    """(start turn, walk, end turn) of a path: the start turn the footprints up to the
    last of the leading pivot steps (the start foot that stays, then the steps; empty
    without one), the walk from that last step on (the footprint it leaves from first),
    the end turn the trailing pivot footprints (the foot set beside the walk's last, then
    the steps; empty without one)."""
    path = list(path)
    k = 0
    while k + 1 < len(path) and path[k + 1].label == PIVOT:
        k += 1
    head = path[:k + 1] if k > 0 else []
    j = len(path)
    while j - 1 > k and path[j - 1].label == PIVOT:
        j -= 1
    tail = path[j:]
    walk = path[k:j]
    if head:
        walk[0] = replace(walk[0], label="start")
    return head, walk, tail


def facing_way(planner: Planner, footprints: list[PathFootprint], goal, field=None) -> float | None:
    """The heading (rad) of the way ahead to ``goal`` from the middle of ``footprints``
    (the walking-distance map's way, a few cells on), or None where the map has none."""
    mid = np.mean([np.asarray(f.position, float) for f in footprints], axis=0)
    field = field if field is not None else planner.distance_field(np.asarray(goal, float))
    _, ahead = field.at_and_ahead(mid[None])
    if not np.isfinite(ahead[0]):
        d = np.asarray(goal, float)[:2] - mid[:2]
        if np.hypot(*d) < planner.settings.goal_radius:
            return None
        return float(np.arctan2(d[1], d[0])) - yaw(planner.forward)
    return float(ahead[0]) - yaw(planner.forward)


def start_turn(planner: Planner, start: list[PathFootprint], goal, body=(0.0, 0.0),
               field=None, first: int | None = None) -> list[PathFootprint]:
    """The start turn's footprints (the start foot that stays, then the pivot steps), when
    the way ahead lies more than ``turn_in_place_angle`` from where the standing feet
    face; else []. The pivot steps must stand (support, obstacles), else no turn. The
    foot on the turning side steps first, or ``first`` (0 left, 1 right).
    ``body``: see ``pivot_footprints``."""
    cfg = planner.settings
    if cfg.turn_in_place_angle <= 0 or len(start) != 2 or start[0].foot == start[1].foot:
        return []
    way = facing_way(planner, start, goal, field)
    if way is None:
        return []
    facing = _mean_heading(start[0], start[1])
    off = float(wrap(way - facing))
    if abs(off) <= cfg.turn_in_place_angle:
        return []
    moves = (0 if off > 0 else 1) if first is None else first  # (the foot on the turning side)
    stays = next(f for f in start if f.foot != moves)
    first = next(f for f in start if f.foot == moves)
    steps = pivot_footprints(stays, first, facing + off, planner.forward, cfg.turn_step_angle, planner.foot,
                             body=body)
    if not steps or not _stand(planner, steps):
        return []
    return [replace(stays, label="start")] + steps


def end_turn(planner: Planner, last: PathFootprint, goal_heading: float, body=(0.0, 0.0)) -> list[PathFootprint]:
    """The end turn's footprints: the other foot set down beside ``last`` (the walk's last
    footprint), then the pivot steps to ``goal_heading`` (``body``: see
    ``pivot_footprints``); [] where they can't stand."""

    other = replace(beside(planner, last), label=PIVOT)
    steps = pivot_footprints(other, last, goal_heading, planner.forward, planner.settings.turn_step_angle,
                             planner.foot, body=body)
    if not steps or not _stand(planner, [other] + steps):
        return []
    return [other] + steps


def _stand(planner: Planner, fps: list[PathFootprint]) -> bool:
    pos = np.array([f.position for f in fps], float)
    head = np.array([f.heading for f in fps], float)
    sup = planner._support(pos, head)
    return bool(sup.ok.all())


#: m of path from the start (and to the goal) in which a walk that turns further than
#: ``turn_in_place_angle`` from the way the character faces (the goal's heading) is taken
#: for a loop, and a turn in place is weighed against it.
LOOP_REACH = 1.5
#: rad: a walk to the goal's heading whose footprints within LOOP_REACH of the goal face
#: further than this (or than ``turn_in_place_angle``) from it looped round to it.
LOOPED = np.radians(120.0)


def plan(planner: Planner, start: list[PathFootprint], goal, goal_heading: float | None = None,
         body=(0.0, 0.0), turns_left: int = 3) -> PlanResult:
    """``Planner.plan`` that turns in place where that beats a walking loop: at the start
    when the way ahead lies more than ``turn_in_place_angle`` from the way the character
    faces (the walk then leaves from the turned feet), and at the end when, with a goal
    heading, the walk arrives further than that from it (it then arrives facing its way
    and the path ends turning on the spot to the goal's heading). Where the map's way in
    (``arrival_way``) arrives further than that from the goal's heading, the walk that
    arrives facing its way is searched first, and the one to the goal's heading only if
    that arrives near enough after all: a search that loops round to the heading can take
    the whole budget (the way in hugs the inside of a bend, so it is only a guess). Without a goal heading
    the walk is planned first and the way ahead weighed only where it turns that far
    within LOOP_REACH of the start, or is refused; with one, the walking-distance map is
    built once more to weigh both. A walk to the goal's heading that still faces further
    than LOOPED from it within LOOP_REACH of the goal is weighed against one arriving
    facing its way. Where the walk's way then turns back (``hairpin``), it stops and turns
    in place there (``hairpin_turn``; at most ``turns_left`` times). The result's
    footprints hold the turns (``split``, ``hairpins``); ``body``: see
    ``pivot_footprints``."""
    cfg = planner.settings
    angle = cfg.turn_in_place_angle
    if angle <= 0:
        return planner.plan(start, goal, goal_heading)
    t0 = time.perf_counter()
    if goal_heading is None:
        res, refused = _try(planner, start, goal, None)
        head = []
        if res is None or _loops(res.footprints, _mean_heading(start[0], start[-1]), angle, cfg.length(LOOP_REACH)):
            head = start_turn(planner, start, goal, body)
            if head:
                res, refused = _try(planner, [head[-1]], goal, None)
    else:
        field = planner.distance_field(np.asarray(goal, float))
        head = start_turn(planner, start, goal, body, field=field)
        origin = [head[-1]] if head else start
        res, refused = None, None
        way = arrival_way(planner, field, origin, goal)
        looping = way is not None and abs(float(wrap(goal_heading - way))) > angle
        if not looping:
            res, refused = _try(planner, origin, goal, goal_heading)
        if looping or res is None or _loops(res.footprints[::-1], goal_heading, max(angle, LOOPED),
                                            cfg.length(LOOP_REACH)):
            free, err = _try(planner, origin, goal, None)
            if free is not None and abs(float(wrap(goal_heading - free.footprints[-1].heading))) > angle:
                tail = end_turn(planner, free.footprints[-1], goal_heading, body)
                if tail:
                    res = replace(free, footprints=list(free.footprints) + tail)
            if res is None and looping:  # (the walk arrives facing near enough after all)
                res, refused = _try(planner, origin, goal, goal_heading)
            refused = refused or err
    if res is None:
        raise refused
    if turns_left > 0:
        res = hairpin_turn(planner, [head[-1]] if head else start, res, goal, goal_heading, body, turns_left)
    if head:
        fps = head[:-1] + [replace(res.footprints[0], label=PIVOT)] + list(res.footprints[1:])
        res = replace(res, footprints=fps)
    return replace(res, seconds=time.perf_counter() - t0)


#: rad and m: a walk whose way (each two footprints' mean heading) turns further than
#: HAIRPIN_TURN on a walking turn of under HAIRPIN_RADIUS (its path over the angle)
#: turns back as on a hairpin bend: a person stops and turns on the spot there (a
#: walking U-turn of 0.45 m radius read as a loop).
HAIRPIN_TURN = np.radians(135.0)
HAIRPIN_RADIUS = 0.9


#: m: how near the hairpin's spot the walk there stops (the turn on the spot needs the
#: room the walking turn found, not the goal radius's slack)
SPOT_RADIUS = 0.15
#: (share of the way across from the way in to the way out, m further along the way in
#: than the hairpin's far end) of each spot tried for the turn, in order
SPOT_TRIES = tuple((share, deeper) for share in (1.0, 0.75, 0.5) for deeper in (0.0, 0.15, 0.3))
#: rad: a hairpin that leaves less than this to turn once the walk stands at its spot is
#: walked round after all
HAIRPIN_LEFT = np.radians(45.0)


def hairpin(fps: list[PathFootprint], scale: float = 1.0) -> tuple[int, int] | None:
    """(i, j): the first stretch of the walk ``fps`` (footprints in walking order) whose
    way turns further than HAIRPIN_TURN on a turn of under HAIRPIN_RADIUS (a human's,
    times the body's ``scale``): its first footprint and its last; None where it never
    turns back so sharply."""
    if len(fps) < 4:
        return None
    pos = np.array([f.position for f in fps], float)[:, :2]
    head = np.unwrap(np.array([f.heading for f in fps], float))
    way = 0.5 * (head[1:] + head[:-1])  # (two footprints' mean: the feet's turn out cancels)
    mid = 0.5 * (pos[1:] + pos[:-1])  # (the way: between the feet)
    along = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(mid, axis=0), axis=1))]
    turned = np.abs(way[None, :] - way[:, None])  # (from each pair of footprints to each later one)
    run = along[None, :] - along[:, None]
    radius = HAIRPIN_RADIUS * scale
    sharp = (run >= 0.0) & (run <= np.pi * radius) & (turned > HAIRPIN_TURN) & (run <= radius * turned)
    rows = np.flatnonzero(sharp.any(axis=1))
    if not len(rows):
        return None
    i = int(rows[0])
    return i, int(np.argmax(sharp[i])) + 1


def hairpin_turn(planner: Planner, origin: list[PathFootprint], res: PlanResult, goal, goal_heading,
                 body=(0.0, 0.0), turns_left: int = 3, walk_on=None) -> PlanResult:
    """``res`` (a walk from ``origin``) with its first hairpin (``hairpin``) turned in
    place: the walk goes to the hairpin's far end (as far along the way in as the middle
    of its two footprints furthest along it, and as far across as the way out: a turn on
    the spot then leaves straight down the way out; failing that, further in and nearer
    the way in, SPOT_TRIES), stopping within SPOT_RADIUS of it, turns on the spot to the
    way on (``facing_way``) and walks on to the goal (``plan``, ``turns_left`` - 1 more
    hairpins; or ``walk_on(turned feet)``, a leg of a route). The pivot footprints go
    between the two walks, as an end turn's (``split``, ``hairpins``). ``res`` unchanged
    where no spot gives both walks and the turn, or the walk arrives with less than
    HAIRPIN_LEFT left to turn."""
    _, walk, _ = split(list(res.footprints))
    found = hairpin(walk, planner.settings.body_scale)
    if found is None:
        return res
    i, j = found
    before = walk[max(0, i - 3):i + 2]  # (the way in, before it turns)
    way_in = float(np.mean([_mean_heading(a, b) for a, b in zip(before[:-1], before[1:])]))
    ang = way_in + yaw(planner.forward)
    ahead = np.array([np.cos(ang), np.sin(ang), 0.0])
    side = np.array([-ahead[1], ahead[0], 0.0])
    loop = np.array([f.position for f in walk[i:j + 1]], float)
    along = loop @ ahead
    k = int(np.argmax(along[:-1] + along[1:]))  # (the two furthest in, one after the other)
    far = 0.5 * (loop[k] + loop[k + 1])
    out = np.array([f.position for f in walk[j:j + 4]], float).mean(axis=0)  # (the way out, beside the way in)
    sides = (loop - far) @ side
    across = float(np.clip((out - far) @ side, sides.min(), sides.max()))
    field = planner.distance_field(np.asarray(goal, float))
    for share, deeper in SPOT_TRIES:  # (where the turn's feet can't stand: nearer the way in, further in)
        spot = far + share * across * side + planner.settings.length(deeper) * ahead
        got = _turned_at(planner, origin, spot, field, goal, goal_heading, body, turns_left, walk_on)
        if got is not None:
            break
    else:
        return res
    first, turn, rest = got
    shift = first.footprints[-1].time
    out = list(first.footprints) + [replace(f, time=shift) for f in turn] + [
        replace(f, time=f.time + shift) for f in rest.footprints[1:]]
    return replace(res, footprints=out, expanded=res.expanded + first.expanded + rest.expanded,
                   generated=res.generated + first.generated + rest.generated, cost=first.cost + rest.cost)


def _turned_at(planner: Planner, origin, spot, field, goal, goal_heading, body, turns_left, walk_on=None):
    """(walk to ``spot``, the turn there, the walk on) of ``hairpin_turn``; None where one
    of them can't be had, or the walk arrives with less than HAIRPIN_LEFT left to turn."""
    cfg = planner.settings
    first, _ = _try(replace(planner, settings=cfg.replace(goal_radius=min(cfg.goal_radius, cfg.length(SPOT_RADIUS)))),
                    origin, spot, None)
    if first is None:
        return None
    last = first.footprints[-1]

    way_on = facing_way(planner, [last, beside(planner, last)], goal, field)
    if way_on is None or abs(float(wrap(way_on - last.heading))) <= HAIRPIN_LEFT:
        return None
    turn = end_turn(planner, last, way_on, body)
    if not turn:
        return None
    try:
        rest = (walk_on([turn[-1]]) if walk_on is not None
                else plan(planner, [turn[-1]], goal, goal_heading, body, turns_left - 1))
    except PlanError:
        return None
    return first, turn, rest


#: m from the goal at which ``arrival_way`` reads the way in
ARRIVAL_REACH = 1.0


def arrival_way(planner: Planner, field, start: list[PathFootprint], goal) -> float | None:
    """The heading (rad) the walk from ``start`` arrives at ``goal`` with, as the
    walking-distance map ``field`` leads there: its way followed from the middle of the
    feet until ARRIVAL_REACH from the goal, then straight on to it; None where the map has
    no way."""
    p = np.mean([np.asarray(f.position, float) for f in start], axis=0)[:2]
    goal = np.asarray(goal, float)
    step = 0.5 * field.cell
    d0, _ = field.at_and_ahead(p[None])
    if not np.isfinite(d0[0]):
        return None
    for _ in range(int(d0[0] / step) * 2 + 20):
        d, ahead = field.at_and_ahead(p[None])
        if np.hypot(*(goal[:2] - p)) <= planner.settings.length(ARRIVAL_REACH) or not np.isfinite(ahead[0]):
            break
        p = p + step * np.array([np.cos(ahead[0]), np.sin(ahead[0])])
    v = goal[:2] - p
    if np.hypot(*v) < 1e-6:
        return None
    return float(np.arctan2(v[1], v[0])) - yaw(planner.forward)


def _try(planner: Planner, start, goal, heading) -> tuple[PlanResult | None, PlanError | None]:
    try:
        return planner.plan(start, goal, heading), None
    except PlanError as ex:
        return None, ex


def _loops(fps: list[PathFootprint], facing: float, angle: float, reach: float = LOOP_REACH) -> bool:
    """Whether the footprints (from the end they are walked from) turn more than ``angle``
    from ``facing`` within ``reach`` m (LOOP_REACH, a human's) of path."""
    pos = np.array([f.position for f in fps], float)[:, :2]
    along = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(pos, axis=0), axis=1))]
    near = along <= reach
    off = np.abs(wrap(np.array([f.heading for f in fps], float)[near] - facing))
    return bool((off > angle).any())


# ----------------------------------------------------------------------------- synthesis

def synthesize(path: list[PathFootprint], synth, leg: Leg, forward, foot: FootShape, step_angle: float,
               body=(0.0, 0.0)):
    """The motion of a path that turns in place (``split``): each turn a leg from standing
    to standing on its pivot steps, the start turn's laid again from the feet it stands on
    (a stop's are eased onto its waypoint), the walk a leg leaving from the feet the start
    turn stood on, the end turn's pivot steps laid from the feet the walk stood on to the
    last one's heading; joined (``directed.join``). ``synth`` makes a leg as
    ``directed.SynthFn`` does: (path, other standing foot, goal, goal heading, lead s,
    hold s, pace) -> Synthesis. ``leg`` (``footprint.Leg``) gives the whole path's ends:
    ``start_other`` the start's other standing foot; ``goal`` and ``goal_heading``;
    ``lead`` and ``hold`` s of standing before the first step and after the last (None:
    the settings'); ``pace`` the walk's, one per step of ``path`` (the pivot steps'
    ignored) or one for all (its ``standing`` is not read: every leg stands). The
    result's ``turns`` say where it turned, by how much and on which frames; its plan
    labels the pivot steps ``PIVOT``. ``body``: see ``pivot_footprints``."""
    other, goal, goal_heading, lead, hold, pace = (leg.start_other, leg.goal, leg.goal_heading, leg.lead, leg.hold,
                                                   leg.pace)
    if path and path[0].label == STAND_LABEL:  # (a synthesized path, both standing feet at either end)
        other, path = path[0], list(path[1:])
        if not any(f.label == PIVOT for f in path[-2:]):
            path = path[:-1]
    runs = hairpins(path)
    if runs:  # (the walk to the first hairpin and its turn, then the rest from the turned feet)
        return _through_hairpin(path, runs[0][1], synth, replace(leg, start_other=other), forward, foot, step_angle,
                                body)
    head, walk_path, tail = split(path)
    if pace is not None and np.ndim(pace):
        k = max(len(head) - 1, 0)
        pace = np.asarray(pace, float)[k:k + len(walk_path) - 1]
    parts, turns = [], []
    if head and other is not None:  # (laid again from the feet it stands on: a stop's are eased onto the waypoint)
        steps = pivot_footprints(head[0], other, head[-1].heading, forward, step_angle, foot, body=body)
        if len(steps) == len(head) - 1:
            head = [head[0]] + [replace(f, time=g.time) for f, g in zip(steps, head[1:])]
    if head:
        turn0 = _turned(synth(head, other, None, None, lead, 0.0, PIVOT_PACE), "start")
        pos, hd = turn0.footprints
        walk_path[0] = replace(walk_path[0], position=pos[-1].copy(), heading=float(hd[-1]))
        other = replace(turn0.plan[-2], position=pos[-2].copy(), heading=float(hd[-2]), label="walk")
        parts.append(turn0)
        turns.append(("start", turn0))
        lead = 0.0
    moving = synth(walk_path, other, goal, None if tail else goal_heading, lead, 0.0 if tail else hold, pace)
    parts.append(moving)
    if tail:
        pos, hd = moving.footprints
        stands = replace(moving.plan[-1], position=pos[-1].copy(), heading=float(hd[-1]), label="start")
        first = replace(moving.plan[-2], position=pos[-2].copy(), heading=float(hd[-2]))
        steps = pivot_footprints(stands, first, tail[-1].heading, forward, step_angle, foot, body=body)
        if steps:
            turn1 = _turned(synth([stands] + steps, first, None, None, 0.0, hold, PIVOT_PACE), "end")
            parts.append(turn1)
            turns.append(("end", turn1))
    out = join(parts)
    out.plan = _labelled(out.plan, parts, turns)
    return out


def _through_hairpin(path: list[PathFootprint], k: int, synth, leg: Leg, forward, foot: FootShape,
                     step_angle: float, body):
    """``synthesize`` of a path with a hairpin turn ending at footprint ``k``: the walk to it
    and its turn (no goal, holding 0 s), then the rest from the turned feet (leading 0 s),
    joined; ``leg.pace`` split between them when given per step."""
    pace1 = pace2 = leg.pace
    if leg.pace is not None and np.ndim(leg.pace):
        pace1, pace2 = np.asarray(leg.pace, float)[:k], np.asarray(leg.pace, float)[k:]
    first = synthesize(path[:k + 1], synth, replace(leg, goal=None, goal_heading=None, hold=0.0, pace=pace1),
                       forward, foot, step_angle, body)
    if first.turns and first.turns[-1]["where"] == "end":  # (its end turn is the hairpin's)
        first.turns[-1]["where"] = "hairpin"
    pos, hd = first.footprints
    stood = replace(first.plan[-2], position=pos[-2].copy(), heading=float(hd[-2]), label="walk")
    rest = [replace(path[k], position=pos[-1].copy(), heading=float(hd[-1]), label="start")] + list(path[k + 1:])
    return join([first, synthesize(rest, synth, replace(leg, start_other=stood, lead=0.0, pace=pace2), forward, foot,
                                   step_angle, body)])


def _turned(leg, where: str):
    """A turn's leg with its ``turns`` row: where, the degrees its body turned, its pivot
    steps, its first and last frame (0 its first; ``directed.join`` shifts them) and its
    seconds."""
    h = leg.body_heading
    leg.turns = [{"where": where, "degrees": round(float(np.degrees(h[-1] - h[0])), 1), "steps": len(leg.plan) - 2,
                  "frames": [0, int(leg.final.schedule.n - 1)], "seconds": round(float(leg.t[-1] - leg.t[0]), 3)}]
    return leg


def _labelled(plan: list, parts, turns) -> list:
    """The joined plan with every turn's pivot steps (and the foot an end turn begins
    beside the walk's last) labelled PIVOT."""
    plan, n = list(plan), 0
    turning = [t for _, t in turns]
    for i, p in enumerate(parts):
        a = 0 if i == 0 else n - 2  # (a leg's first two footprints are the last one's last two)
        b = a + len(p.plan)
        if any(p is t for t in turning):
            lo = a + 2 if i == 0 else a + 1
            plan[lo:b] = [replace(f, label=PIVOT) for f in plan[lo:b]]
        n = b
    return plan


__all__ = ["PIVOT", "Turn", "end_turn", "facing_way", "hairpin", "hairpin_turn", "hairpins", "pivot_footprints",
           "plan", "split", "start_turn", "turns_of"]
