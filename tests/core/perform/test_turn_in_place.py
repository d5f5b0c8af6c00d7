"""Turning in place (issue 14): the pivot steps' geometry (properties, with hypothesis),
the planner's choice to turn at the start and at the end, and the turn as Blender plays
it (``test_turn_in_place_played``)."""

import math

import numpy as np
import pytest
from hypothesis import given, settings as hsettings, strategies as st

from footstep_planner.core.perform import turn_in_place as tip
from footstep_planner.core.footprint import PathFootprint
from footstep_planner.core.plan.surface import FootShape

from conftest import needs_cmu

FORWARD = np.array([1.0, 0.0])
FOOT = FootShape(back=0.165, front=0.195, half_width=0.05)  # the planner's, for a 25 cm foot


def _standing(x, y, heading, width=0.2):
    ang = heading
    left = np.array([-np.sin(ang), np.cos(ang), 0.0])
    p = np.array([x, y, 0.0])
    return (PathFootprint(0, p + 0.5 * width * left, heading, 0.0, "start", "walk"),
            PathFootprint(1, p - 0.5 * width * left, heading, 0.0, "start", "walk"))


def _rect(fp: PathFootprint, foot: FootShape) -> np.ndarray:
    """(4, 2) corners of a footprint's rectangle."""
    a = fp.heading + math.atan2(FORWARD[1], FORWARD[0])
    f, l = np.array([math.cos(a), math.sin(a)]), np.array([-math.sin(a), math.cos(a)])
    p = np.asarray(fp.position, float)[:2]
    return np.array([p + s * foot.front * f + w * foot.half_width * l if s > 0 else
                     p - foot.back * f + w * foot.half_width * l for s in (1, -1) for w in (1, -1)])


def _gap(a: np.ndarray, b: np.ndarray) -> float:
    """The distance between two convex rectangles' outlines (corners as ``_rect`` gives
    them), negative when they overlap (a separating axis among their edges' normals)."""
    def edges(poly):
        hull = poly[[0, 1, 3, 2]]
        return [(hull[k], hull[(k + 1) % 4]) for k in range(4)]

    for poly in (a, b):
        for p0, p1 in edges(poly):
            n = np.array([-(p1 - p0)[1], (p1 - p0)[0]])
            pa, pb = a @ n, b @ n
            if pb.min() > pa.max() or pa.min() > pb.max():
                break
        else:
            continue
        break
    else:
        return -1.0

    def seg(p, p0, p1):
        e = p1 - p0
        t = np.clip((p - p0) @ e / (e @ e), 0.0, 1.0)
        return np.linalg.norm(p - (p0 + t * e))

    return min(min(seg(p, *e) for p in b for e in edges(a)), min(seg(p, *e) for p in a for e in edges(b)))


def _pairs(start, steps):
    """The two feet standing after each step: [(left, right)]."""
    feet = {f.foot: f for f in start}
    out = []
    for s in steps:
        feet[s.foot] = s
        out.append((feet[0], feet[1]))
    return out


angles = st.floats(-math.pi, math.pi, allow_nan=False)


@hsettings(max_examples=300, deadline=None, database=None)
@given(h0=angles, target=angles, step=st.floats(math.radians(20), math.radians(75)),
       x=st.floats(-50, 50), y=st.floats(-50, 50), first_left=st.booleans())
def test_pivot_steps_turn_on_the_spot(h0, target, step, x, y, first_left):
    left, right = _standing(x, y, h0)
    first, stays = (left, right) if first_left else (right, left)
    steps = tip.pivot_footprints(stays, first, target, FORWARD, step, FOOT)
    turn = (target - h0 + math.pi) % (2 * math.pi) - math.pi
    if abs(turn) < 1e-6:
        assert steps == []
        return
    if abs(abs(turn) - math.pi) < 1e-9:
        turn = math.pi
    # the feet alternate, the first one first; the last two side by side facing the target
    assert [s.foot for s in steps] == [(first.foot + k) % 2 for k in range(len(steps))]
    assert all(s.label == tip.PIVOT for s in steps)
    a, b = steps[-2:] if len(steps) > 1 else (stays, steps[-1])
    for s in (a, b):
        assert abs((s.heading - target + math.pi) % (2 * math.pi) - math.pi) < 1e-9
    assert abs(steps[-1].heading - (h0 + turn)) < 1e-9  # the shorter way round (left when right behind)
    # each foot turns monotonically toward the target, at most a step's angle at a time
    last = {0: h0, 1: h0}
    for s in steps:
        d = s.heading - last[s.foot]
        assert d * np.sign(turn) >= -1e-9
        assert abs(d) <= step + 1e-6  # (a turn within a micro-radian of the target ends on it)
        last[s.foot] = s.heading
    # no more steps than turning a foot by the step's angle each time needs (and two to close)
    assert len(steps) <= 2 * math.ceil(abs(turn) / min(step, math.pi)) + 2
    # the feet never overlap, nor open more than the step's angle
    for l, r in _pairs((left, right), steps):
        assert _gap(_rect(l, FOOT), _rect(r, FOOT)) >= tip.GAP - 1e-6
        assert abs(l.heading - r.heading) <= step + 1e-6
    # the middle of the feet stays over the spot: within 13 cm, and the turned pair within 6 cm
    # (with steps of up to 60 degrees: 10 and 3 cm, ``test_pivot_steps_of_60_degrees_stay_nearer``)
    c = np.array([x, y])
    mids = [0.5 * (np.asarray(l.position)[:2] + np.asarray(r.position)[:2]) for l, r in _pairs((left, right), steps)]
    assert max(np.linalg.norm(m - c) for m in mids) < 0.13
    assert np.linalg.norm(mids[-1] - c) < 0.06


@pytest.mark.parametrize("first_left", [True, False])
def test_pivot_steps_of_60_degrees_stay_nearer(first_left):
    for target in np.radians(np.arange(-180, 181, 5)):
        left, right = _standing(1.0, -2.0, 0.3)
        first, stays = (left, right) if first_left else (right, left)
        steps = tip.pivot_footprints(stays, first, 0.3 + target, FORWARD, math.radians(60), FOOT)
        mids = [0.5 * (np.asarray(a.position)[:2] + np.asarray(b.position)[:2]) for a, b in _pairs((left, right), steps)]
        assert all(np.linalg.norm(m - [1.0, -2.0]) < 0.1 for m in mids)
        assert not mids or np.linalg.norm(mids[-1] - [1.0, -2.0]) < 0.03


def test_pivot_steps_behind_take_a_few_steps_and_stay_put():
    left, right = _standing(0, 0, 0.0)
    steps = tip.pivot_footprints(left, right, math.pi * 0.95, FORWARD, math.radians(60), FOOT)
    # turning left: the left foot opens first ... but here the right was asked first: it closes in
    assert steps[0].foot == 1 and 0 < steps[0].heading <= tip.TOE_IN + 1e-9
    assert 4 <= len(steps) <= 7
    steps = tip.pivot_footprints(right, left, math.pi * 0.95, FORWARD, math.radians(60), FOOT)
    assert steps[0].foot == 0 and abs(steps[0].heading - math.radians(60)) < 1e-9
    ends = np.array([s.position for s in steps[-2:]])
    assert 0.2 - 1e-6 <= np.linalg.norm(ends[0, :2] - ends[1, :2]) <= 0.3
    assert np.linalg.norm(ends[:, :2].mean(axis=0)) < 0.03


def test_pivot_steps_refuse_bad_input():
    left, right = _standing(0, 0, 0.0)
    with pytest.raises(ValueError, match="90 degrees"):
        tip.pivot_footprints(left, right, 1.0, FORWARD, math.radians(120))
    with pytest.raises(ValueError, match="left and a right"):
        tip.pivot_footprints(left, left, 1.0, FORWARD, 1.0)


def test_split_takes_a_turning_path_apart():
    left, right = _standing(0, 0, 0.0)
    steps = tip.pivot_footprints(left, right, math.pi, FORWARD, math.radians(60), FOOT)
    walk = [PathFootprint(1 - steps[-1].foot, np.array([0.7 * k, 0.0, 0.0]), math.pi, 0.5 * k, "walk", "walk")
            for k in range(1, 4)]
    path = [left] + steps + walk
    head, middle, tail = tip.split(path)
    assert head == [left] + steps and tail == []
    assert middle[0].label == "start" and middle[1:] == walk
    turns = tip.turns_of(path)
    assert len(turns) == 1 and turns[0].where == "start" and turns[0].degrees == pytest.approx(180.0)
    assert (turns[0].first, turns[0].last) == (1, len(steps))


@needs_cmu
def test_a_start_facing_a_narrow_corridors_wall_turns_to_walk_along_it(bench_character):
    """The planner benchmark's corridor1.2_across: 1.2 m wide, the character facing a wall.
    A walking turn barely fits (with the clips' own strides none does: refused); a quarter
    turn in place first, then a straight walk."""
    from benchmarks.bench_planner import loops
    from benchmarks.scene_generator import benchmark_scenes, make_planner
    from footstep_planner.core.plan.navgraph import PlanError

    scene = next(s for s in benchmark_scenes() if s.name == "corridor1.2_across")
    pl, start, goal = make_planner(scene, bench_character)
    try:  # (without turning in place: refused, or a walk that turns round within its first 1.5 m)
        walked = pl.plan(start, goal)
        assert tip._loops(walked.footprints, start[0].heading, pl.settings.turn_in_place_angle)
    except PlanError:
        pass
    res = tip.plan(pl, start, goal)
    turns = tip.turns_of(res.footprints)
    assert [t.where for t in turns] == ["start"] and abs(abs(turns[0].degrees) - 90) < 15
    head, walk, tail = tip.split(res.footprints)
    assert tail == [] and loops(walk) == 0
    assert [f.foot for f in res.footprints[1:]] == [1 - f.foot for f in res.footprints[:-1]]
    assert np.linalg.norm(res.footprints[-1].position[:2] - goal[:2]) <= pl.settings.goal_radius


def _walk_round(radius: float, turn: float = math.pi, step: float = 0.6):
    """Footprints ``step`` m apart along a way that goes 3 m east, round a left turn of
    ``turn`` rad on ``radius`` m, and 3 m on: feet 0.1 m either side of the way, turned
    along it."""
    arc = radius * turn
    out = []
    for i, s in enumerate(np.arange(0.0, 6.0 + arc, step)):
        if s <= 3.0:
            p, h = np.array([s, 0.0]), 0.0
        elif s <= 3.0 + arc:
            h = (s - 3.0) / radius
            p = np.array([3.0 + radius * np.sin(h), radius * (1 - np.cos(h))])
        else:
            h = turn
            p = np.array([3.0 + radius * np.sin(h), radius * (1 - np.cos(h))]) + (s - 3.0 - arc) * np.array(
                [np.cos(h), np.sin(h)])
        q = p + (0.1 if i % 2 == 0 else -0.1) * np.array([-np.sin(h), np.cos(h)])
        out.append(PathFootprint(i % 2, np.array([q[0], q[1], 0.0]), float(h), 0.0, "walk", "walk"))
    return out


@pytest.mark.parametrize("radius, turn, found", [(0.45, math.pi, True), (0.8, math.pi, True),
                                                 (1.5, math.pi, False), (0.45, math.radians(90), False),
                                                 (0.6, math.radians(150), True)])
def test_a_hairpin_is_a_sharp_turn_back(radius, turn, found):
    """``hairpin``: a walk that turns back further than 135 degrees on a turn of under
    0.9 m radius is a hairpin (stop and turn on the spot there); a wide U-turn or a
    sharp right angle is walked."""
    got = tip.hairpin(_walk_round(radius, turn))
    assert (got is not None) == found, got
    if got:
        i, j = got
        assert 3 <= i and j > i


@needs_cmu
@pytest.mark.parametrize("back", [(1.5, 0.0), (3.0, 2.5)])
def test_a_stop_where_the_way_turns_back_arrives_as_it_comes_and_turns_there(bench_character, back):
    """A pause at waypoint A with the next one behind (or well beside) the way there: the
    leg to A is not asked to arrive facing the next one (a loop round A to face back, which
    flooded a quarter of the expansion budget first), it arrives as it comes and turns on
    the spot at A; a pause with the next one ahead still passes facing it."""
    from footstep_planner.core.perform.waypoints import Waypoint, plan_via
    from footstep_planner.core.plan.navgraph import Planner
    from footstep_planner.core.plan.surface import MeshGround
    from conftest import plane, standing

    forward = bench_character.forward
    pl = Planner(MeshGround(plane(-4, 12, -6, 6)), None, bench_character.steps, forward, foot=bench_character.foot)
    north = -float(np.arctan2(forward[1], forward[0]))  # (the start facing +x)
    start = standing(0.0, 0.0, north, forward)
    for ahead, nxt in ((False, back), (True, (9.0, 0.0))):
        wps = [Waypoint("A", np.array([5.0, 0.0, 0.0]), pause=0.5), Waypoint("B", np.array([*nxt, 0.0]))]
        route = plan_via(pl, start, wps)
        fs, a = route.result.footprints, route.arrivals[0]
        assert route.result.expanded < 1000  # (was 5,026 for the way back: a quarter of the budget, then the path)
        assert np.hypot(*(fs[a].position[:2] - [5.0, 0.0])) <= pl.settings.goal_radius
        assert all(f.position[0] < 5.0 + pl.settings.goal_radius for f in fs[:a + 1])  # (no loop past A)
        turns = tip.turns_of(fs)
        if ahead:
            assert turns == []
        else:  # (on the spot at A, as far round as the way on: 150 and 101 degrees)
            assert len(turns) == 1 and abs(turns[0].degrees) >= 90 and a < turns[0].first <= a + 4
            at = fs[turns[0].first:turns[0].last + 1]
            assert max(np.hypot(*(f.position[:2] - fs[a].position[:2])) for f in at) < 0.5
