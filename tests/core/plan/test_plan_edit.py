"""Plans as data (PLAN.json) and edited plans made whole (pure core): a plan read back is
the plan written; locked footprints are kept exactly; a footprint that no longer works
is re-planned only between the nearest locks around it."""

import json

import numpy as np
import pytest
from hypothesis import given, settings as hsettings, strategies as st

from footstep_planner.core.footprint import PathFootprint
from footstep_planner.core.plan.navgraph import PlanError, Planner
from footstep_planner.core.plan.plan_edit import edited_path, in_frame, problems_of
from footstep_planner.core.plan.plan_file import PlanFile, PlanFileError, plan_from_dict, read_plan
from footstep_planner.core.base.settings import Settings
from footstep_planner.core.plan.surface import MeshGround, TriMesh, footprint_support
from conftest import box, plane
from test_navgraph import FWD, start, steps

FWD3 = np.array([0.0, -1.0, 0.0])
finite = st.floats(-1e6, 1e6, allow_nan=False)


@hsettings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.lists(finite, min_size=3, max_size=3), st.floats(-10, 10), st.floats(0, 100),
                          st.booleans(), st.booleans(), st.none() | st.floats(0, 1), st.booleans()),
                min_size=2, max_size=12),
       st.sampled_from([0, 1]))
def test_a_plan_read_back_is_the_plan_written(rows, first_foot):
    fps = [PathFootprint((first_foot + i) % 2, np.array(p), h, t, "walk", "walk", j, tread, blend)
           for i, (p, h, t, j, _, blend, tread) in enumerate(rows)]
    plan = PlanFile("Hero", FWD3, fps, np.array([r[4] for r in rows]), np.array([1.0, 2.0, 0.0]), 0.5)
    back = read_plan(json.dumps(plan.to_dict()), "p.json")
    assert back.to_dict() == plan.to_dict()
    for a, b in zip(fps, back.footprints):
        assert a.foot == b.foot and np.array_equal(a.position, b.position) and a.heading == b.heading
        assert a.speed == b.speed and a.tread == b.tread  # (a jog's blend, a tread: kept)
    for a, b in zip(fps, in_frame(back, FWD3)):  # (and through the re-plan's reading of it)
        assert a.speed == b.speed and a.tread == b.tread


def _doc(**change):
    fp = {"foot": "L", "position": [0, 0, 0], "heading": 0.0, "clip": "walk+0", "gait": "walk"}
    doc = {"format": "footstep-plan", "version": 1, "character": "Hero", "forward": [0, -1, 0],
           "footprints": [dict(fp), dict(fp, foot="R")]}
    for k, v in change.items():
        if k.startswith("fp1_"):
            doc["footprints"][1][k[4:]] = v
        else:
            doc[k] = v
    return doc


@pytest.mark.parametrize("change, words", [
    ({"format": "other"}, "not a footstep plan"),
    ({"version": 7}, "version 7"),
    ({"forward": [0, 0, 1]}, "'forward'"),
    ({"footprints": []}, "at least two"),
    ({"fp1_foot": "L"}, "must alternate"),
    ({"fp1_foot": "X"}, "footprint 1: 'foot'"),
    ({"fp1_position": [0, "a", 0]}, "footprint 1: 'position'"),
    ({"fp1_heading": None}, "footprint 1: 'heading'"),
    ({"fp1_locked": "yes"}, "footprint 1: 'locked'"),
    ({"fp1_blend": 1.5}, "footprint 1: 'blend'"),
    ({"goal": [1, 2]}, "'goal'"),
])
def test_a_bad_plan_names_the_footprint_and_the_field(change, words):
    with pytest.raises(PlanFileError, match=words.replace("(", r"\(")):
        plan_from_dict(_doc(**change), "PLAN.json")


# -- editing ----------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def floor():
    """A 14 m floor with a 1 m square hole in the middle of the way."""
    parts = [plane(-2, 14, -3, -0.5, name="s"), plane(-2, 14, 0.5, 3, name="n"),
             plane(-2, 5.5, -0.5, 0.5, name="w"), plane(6.5, 14, -0.5, 0.5, name="e")]
    return MeshGround(TriMesh.concat(parts))


@pytest.fixture(scope="module")
def planner(floor):
    return Planner(floor, None, steps(with_jump=False), FWD, settings=Settings(run_penalty=5.0))


@pytest.fixture(scope="module")
def planned(planner):
    goal = np.array([12.0, 1.2, 0.0])
    res = planner.plan(start(0, 1.2), goal)
    return res, goal


def _plan_file(res, goal, locked=()):
    lk = np.zeros(len(res.footprints), bool)
    lk[list(locked)] = True
    return PlanFile("Hero", FWD3, [PathFootprint(f.foot, f.position.copy(), f.heading, f.time, f.label, f.gait,
                                                 f.jump) for f in res.footprints], lk, goal, None)


def _valid(planner, fps):
    pos = np.array([f.position for f in fps])
    sup = footprint_support(planner.ground, None, pos, np.array([f.heading for f in fps]), FWD, planner.foot)
    assert sup.ok.all(), sup.reason
    assert all(a.foot != b.foot for a, b in zip(fps[:-1], fps[1:]))
    assert not any(problems_of(planner, fps))


def test_an_unedited_plan_is_kept_exactly(planner, planned):
    res, goal = planned
    ed = edited_path(planner, _plan_file(res, goal))
    assert ed.spans == [] and len(ed.result.footprints) == len(res.footprints)
    for a, b in zip(res.footprints, ed.result.footprints):
        assert np.array_equal(a.position, b.position) and a.heading == b.heading and a.label == b.label


def test_a_footprint_moved_into_a_hole_is_replanned_between_its_locks(planner, planned):
    res, goal = planned
    n = len(res.footprints)
    k = n // 2
    locks = (k - 3, k + 3)
    plan = _plan_file(res, goal, locks)
    plan.footprints[k].position[:] = [6.0, 0.0, 0.0]  # the middle of the hole
    ed = edited_path(planner, plan)
    assert "off surface" in ed.problems[k]
    (a, b), = ed.spans
    out = ed.result.footprints
    assert a == k - 3
    for i in range(k - 2):  # before the span: exactly as planned
        assert np.array_equal(out[i].position, res.footprints[i].position)
    tail = n - (k + 3)
    for i in range(1, tail + 1):  # from the lock after the span on: exactly as planned
        assert np.array_equal(out[-i].position, res.footprints[-i].position)
        assert out[-i].heading == res.footprints[-i].heading
    _valid(planner, out[1:])


def test_a_footprint_moved_beyond_every_step_is_replanned(planner, planned):
    res, goal = planned
    k = len(res.footprints) // 2
    plan = _plan_file(res, goal, (k - 2, k + 2))
    plan.footprints[k].position[1] += 1.2  # sideways, out of every step's reach
    ed = edited_path(planner, plan)
    assert "no step of the library reaches it" in ed.problems[k]
    _valid(planner, ed.result.footprints[1:])


def test_a_locked_footprint_that_cannot_be_kept_is_refused(planner, planned):
    res, goal = planned
    k = len(res.footprints) // 2
    plan = _plan_file(res, goal, (k,))
    plan.footprints[k].position[:] = [6.0, 0.0, 0.0]
    with pytest.raises(PlanError, match=f"footprint {k} .* is locked but it is off surface"):
        edited_path(planner, plan)


def test_a_small_move_within_reach_is_kept_as_it_is(planner, planned):
    res, goal = planned
    k = len(res.footprints) // 2
    plan = _plan_file(res, goal, (k,))
    plan.footprints[k].position[0] += 0.05
    ed = edited_path(planner, plan)
    assert ed.spans == []
    assert np.array_equal(ed.result.footprints[k].position, plan.footprints[k].position)


def test_without_a_lock_after_the_edit_the_way_to_the_goal_is_searched_again(planner, planned):
    res, goal = planned
    k = len(res.footprints) // 2
    plan = _plan_file(res, goal, (k - 2,))
    plan.footprints[k].position[:] = [6.0, 0.0, 0.0]
    ed = edited_path(planner, plan)
    (a, b), = ed.spans
    out = ed.result.footprints
    assert a == k - 2 and b == len(out) - 1
    assert np.linalg.norm(out[-1].position[:2] - goal[:2]) <= planner.settings.goal_radius
    _valid(planner, out[1:])


def test_headings_follow_the_plans_own_forward(planner, planned):
    """A plan written with another forward (+X) reads the same in the planner's (-Y)."""
    res, goal = planned
    plan = _plan_file(res, goal)
    turned = PlanFile("Hero", np.array([1.0, 0.0, 0.0]),
                      [PathFootprint(f.foot, f.position, f.heading - np.pi / 2, f.time, f.label, f.gait, f.jump)
                       for f in plan.footprints], plan.locked, goal, None)
    ed = edited_path(planner, turned)
    assert ed.spans == []
    for a, b in zip(res.footprints, ed.result.footprints):
        assert abs((a.heading - b.heading + np.pi) % (2 * np.pi) - np.pi) < 1e-9


# -- waypoints ----------------------------------------------------------------------------------

def test_a_path_through_three_waypoints_visits_them_in_order(planner):
    from footstep_planner.core.perform.waypoints import Waypoint, plan_via

    wps = [Waypoint("A", np.array([3.0, -2.0, 0.0])), Waypoint("B", np.array([9.0, -2.0, 0.0]), heading=np.pi / 2),
           Waypoint("C", np.array([12.0, 2.0, 0.0]))]
    route = plan_via(planner, start(0, 1.2), wps)
    fps = route.result.footprints
    assert route.arrivals == sorted(route.arrivals) and len(set(route.arrivals)) == 3
    r = planner.settings.goal_radius
    for wp, i in zip(wps, route.arrivals):
        assert np.linalg.norm(fps[i].position[:2] - wp.position[:2]) <= r
    b = fps[route.arrivals[1]]
    assert abs((b.heading - np.pi / 2 + np.pi) % (2 * np.pi) - np.pi) <= planner.settings.goal_heading_tolerance
    _valid(planner, fps[1:])
    assert all(t1.time > t0.time for t0, t1 in zip(fps[:-1], fps[1:]))
    # the legs pass each waypoint before heading for the next: A is reached before x = 6
    assert fps[route.arrivals[0]].position[0] < 6


def test_a_leg_that_cannot_be_found_is_named(planner):
    from footstep_planner.core.perform.waypoints import Waypoint, plan_via

    wps = [Waypoint("A", np.array([3.0, -2.0, 0.0])), Waypoint("Lake", np.array([40.0, 0.0, 0.0]))]
    with pytest.raises(PlanError, match="no way from waypoint 'A' to waypoint 'Lake'"):
        plan_via(planner, start(0, 1.2), wps)


def test_a_moved_footprint_is_kept_and_the_way_around_it_searched_again(planner, planned):
    """Moving footprint k (it was planned elsewhere): k stays exactly where it was put,
    the way is searched again from the lock before it to it and from it to the lock
    after; nothing else changes."""
    res, goal = planned
    n, k = len(res.footprints), len(res.footprints) // 2
    doc = _plan_file(res, goal, (k - 3, k + 3)).to_dict()
    doc["footprints"][k]["position"][1] += 0.25  # a quarter metre sideways: still on the floor
    plan = plan_from_dict(json.loads(json.dumps(doc)))
    assert plan.moved.tolist() == [i == k for i in range(n)] and plan.locked[k]
    ed = edited_path(planner, plan)
    out = ed.result.footprints
    assert len(ed.spans) == 2 and ed.spans[0][0] == k - 3
    moved = [f for f in out if np.array_equal(f.position, plan.footprints[k].position)]
    assert len(moved) == 1
    for i in range(k - 2):
        assert np.array_equal(out[i].position, res.footprints[i].position)
    for i in range(1, n - (k + 3) + 1):
        assert np.array_equal(out[-i].position, res.footprints[-i].position)
    _valid(planner, out[1:])


# -- locks and other characters -------------------------------------------------------------------

def test_a_locked_footprint_out_of_reach_of_one_replanned_is_kept_and_the_way_to_it_found(planner, planned):
    """A footprint moved sideways beyond every step from the footprint before it and locked
    is kept where it was put when the one before is not locked (the re-plan makes that one
    anew); with the one before locked too, the step between them can't change: refused."""
    res, goal = planned
    k = len(res.footprints) // 2
    plan = _moved(res, goal, k, (k,))
    ed = edited_path(planner, plan)
    out = ed.result.footprints
    kept = [i for i, f in enumerate(out) if np.array_equal(f.position, plan.footprints[k].position)]
    assert len(kept) == 1 and out[kept[0]].heading == plan.footprints[k].heading
    assert any(b == kept[0] for _, b in ed.spans) and any(a == kept[0] for a, _ in ed.spans)
    _valid(planner, out[1:])
    with pytest.raises(PlanError, match=f"footprint {k} .* is locked but no step of the library reaches it"):
        edited_path(planner, _moved(res, goal, k, (k - 1, k)))


def _moved(res, goal, k, locks):
    plan = _plan_file(res, goal, locks)
    plan.footprints[k].position[1] += 1.0
    return plan


def test_footprints_that_meet_another_character_in_time_are_replanned_between_the_locks(planner, planned):
    """Round another character standing on the path's middle footprint the whole time, the
    footprints whose steps meet it (``MEETS``) are searched again between the nearest locks,
    clear of it in time; the rest stays exactly as planned. Without it nothing changes."""
    from dataclasses import replace

    from footstep_planner.core.plan.plan_edit import MEETS
    from test_others import _others, _walker

    res, goal = planned
    n = len(res.footprints)
    k = n // 2
    times = np.arange(0.0, 30.0, 1.0 / 30)
    here = np.repeat(res.footprints[k].position[None, :2], len(times), axis=0)
    round_it = replace(planner, others=_others(_walker("Other", times, here), times=times))
    locks = (k - 4, k + 4)
    ed = edited_path(round_it, _plan_file(res, goal, locks))
    assert MEETS in ed.problems[k]
    assert all(p in ("", MEETS) for p in ed.problems)
    (a, b), = ed.spans
    out = ed.result.footprints
    assert a == k - 4
    for i in range(k - 3):
        assert np.array_equal(out[i].position, res.footprints[i].position)
    for i in range(1, n - (k + 4) + 1):
        assert np.array_equal(out[-i].position, res.footprints[-i].position)
    assert round_it.clear_in_time(out)[a + 1:b].all()
    assert edited_path(planner, _plan_file(res, goal, locks)).spans == []


def _same(a, b):
    return np.array_equal(a.position, b.position) and a.heading == b.heading


@pytest.mark.parametrize("shift", [(0.0, 0.0), (0.004, -0.003), (0.0, 1.0), (-1.5, -0.6)])
def test_a_moved_goal_replans_from_the_last_lock_and_keeps_the_rest(planner, planned, shift):
    """The goal given again (a re-plan reads it from its object): where it has not moved
    (within GOAL_MOVED) nothing is searched; moved, only the way past the last lock is,
    every footprint up to that lock kept exactly, and the new way ends at the new goal."""
    res, goal = planned
    k = len(res.footprints) // 2
    plan = _plan_file(res, goal, (k,))
    new_goal = goal + np.array([*shift, 0.0])
    ed = edited_path(planner, plan, new_goal, None)
    out = ed.result.footprints
    if np.hypot(*shift) < 0.01:
        assert ed.spans == [] and all(_same(a, b) for a, b in zip(out, res.footprints))
        return
    assert ed.spans == [(k, len(out) - 1)] and ed.to_goal
    assert all(_same(a, b) for a, b in zip(out[:k + 1], res.footprints[:k + 1]))
    assert np.linalg.norm(out[-1].position[:2] - new_goal[:2]) <= planner.settings.goal_radius
    _valid(planner, out)


def test_a_turned_goal_replans_the_way_to_it(planner, planned):
    """A goal turned (its heading given) re-plans the tail to arrive facing it."""
    res, goal = planned
    plan = _plan_file(res, goal)
    ed = edited_path(planner, plan, goal, np.pi / 2)
    assert ed.spans and ed.spans[-1][1] == len(ed.result.footprints) - 1
    last = ed.result.footprints[-1]
    assert abs((last.heading - np.pi / 2 + np.pi) % (2 * np.pi) - np.pi) <= planner.settings.goal_heading_tolerance


def test_a_moved_start_replans_to_the_first_lock_and_keeps_the_rest(planner, planned):
    """The first footprint given anew (the Start moved): the way from it to the first lock
    is searched again, every footprint from that lock on kept exactly."""
    res, goal = planned
    k = len(res.footprints) // 2
    plan = _plan_file(res, goal, (k,))
    first = res.footprints[0]
    moved = PathFootprint(first.foot, first.position + np.array([0.0, -1.5, 0.0]), first.heading, 0.0,
                          first.label, first.gait)
    ed = edited_path(planner, plan, start=moved)
    out = ed.result.footprints
    assert ed.spans[0][0] == 0 and len(ed.spans) == 1 and not ed.to_goal
    assert np.array_equal(out[0].position, moved.position)
    j = ed.spans[0][1]
    assert _same(out[j], res.footprints[k])
    assert all(_same(a, b) for a, b in zip(out[j:], res.footprints[k:]))
    _valid(planner, out)
    same = edited_path(planner, plan, start=first)
    assert same.spans == []
