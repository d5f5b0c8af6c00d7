"""A* over footprints (pure core, numpy ground, hand-made steps)."""

from dataclasses import replace

import numpy as np
import pytest

from footstep_planner.core.plan.navgraph import PlanError, Planner
from footstep_planner.core.base.settings import Settings
from footstep_planner.core.clips.steps import StepSet
from footstep_planner.core.plan.surface import FootShape, MeshGround, SupportLimits, TriMesh, footprint_support
from conftest import box, plane, standing

FWD = np.array([0.0, -1.0])
EAST = np.pi / 2
#: The search on its own: the fastest path (no running penalty).
FASTEST = Settings(run_penalty=0.0)


def steps(with_jump=True, jump_len=1.7):
    """A small library: straight, gentle and sharp turns each way, walk and run, and a
    running jump from the right foot."""
    rows = []
    for gait, fwd, dt in (("walk", 0.6, 0.6), ("run", 1.1, 0.38)):
        for turn in np.radians([-30, -15, 0, 15, 30]):
            for foot, side in ((0, -0.15), (1, 0.15)):
                rows.append((foot, fwd, side, turn, dt, gait, False, f"{gait}{np.degrees(turn):+.0f}"))
    if with_jump:
        rows.append((1, jump_len, -0.1, 0.0, 0.65, "run", True, "leap"))
    c = list(zip(*rows))
    return StepSet(np.array(c[1]), np.array(c[2]), np.array(c[3]), np.array(c[4]), np.array(c[0]),
                   np.array(c[5], object), np.array(c[6], bool), np.array(c[7], object))


def start(x, y, heading=EAST):
    return standing(x, y, heading, FWD)


def check_path(planner, result, goal):
    fs = result.footprints
    assert np.linalg.norm(fs[-1].position[:2] - goal[:2]) <= planner.settings.goal_radius
    pos = np.array([f.position for f in fs[1:]])
    sup = footprint_support(planner.ground, planner.obstacles, pos, np.array([f.heading for f in fs[1:]]),
                            FWD, planner.foot, SupportLimits(clearance=planner.clearance))
    assert sup.ok.all(), sup.reason
    assert [f.foot for f in fs[1:]] == [1 - f.foot for f in fs[:-1]]  # feet alternate
    assert all(b.time > a.time for a, b in zip(fs[:-1], fs[1:]))


def test_open_floor_reaches_the_goal_and_weighting_is_bounded():
    g = MeshGround(plane(-2, 12, -6, 6))
    goal = np.array([10.0, 3.0, 0.0])
    w1 = Planner(g, None, steps(), FWD, settings=FASTEST.replace(heuristic_weight=1.0)).plan(start(0, 0), goal)
    p2 = Planner(g, None, steps(), FWD, settings=FASTEST.replace(heuristic_weight=2.0))
    w2 = p2.plan(start(0, 0), goal)
    check_path(p2, w2, goal)
    assert w1.cost <= w2.cost + 1e-9 <= 2.0 * w1.cost + 1e-9
    assert w2.expanded <= w1.expanded
    assert not any(f.jump for f in w1.footprints + w2.footprints)  # jumps are for gaps only


def test_a_wall_is_walked_around():
    g = MeshGround(plane(-2, 12, -6, 6))
    wall = MeshGround(box((4, -6, 0), (4.3, 2, 2.5), "wall"))
    pl = Planner(g, wall, steps(), FWD, settings=FASTEST)
    goal = np.array([9.0, 0.0, 0.0])
    r = pl.plan(start(0, 0), goal)
    check_path(pl, r, goal)
    # every step that crosses the wall's line does so beyond the wall's end (y > 2)
    xs = [(a.position, b.position) for a, b in zip(r.footprints[:-1], r.footprints[1:])
          if (a.position[0] - 4.15) * (b.position[0] - 4.15) <= 0]
    assert xs
    for a, b in xs:
        t = (4.15 - a[0]) / (b[0] - a[0]) if b[0] != a[0] else 0.5
        assert a[1] + t * (b[1] - a[1]) > 2.0


@pytest.mark.parametrize("gap,jumps", [(1.0, True), (2.5, False)])
def test_gaps_are_jumped_only_where_a_jump_reaches(gap, jumps):
    g = MeshGround(TriMesh.concat([plane(-2, 5, -1, 1, name="A"), plane(5 + gap, 12, -1, 1, name="B")]))
    pl = Planner(g, None, steps(), FWD, settings=FASTEST)
    goal = np.array([10.0, 0.0, 0.0])
    if not jumps:
        # refused before any search: the walking-distance map already shows no way
        with pytest.raises(PlanError, match="no walkable way, nor a gap.*nearest reachable point is \\(4\\.[5-9]") as err:
            pl.plan(start(0, 0), goal)
        assert err.value.expanded == 0 and err.value.explored == []
        return
    r = pl.plan(start(0, 0), goal)
    check_path(pl, r, goal)
    crossing = [(a, b) for a, b in zip(r.footprints[:-1], r.footprints[1:])
                if a.position[0] < 5 < 5 + gap < b.position[0]]
    assert len(crossing) == 1 and crossing[0][1].jump and crossing[0][0].gait == "run"


def test_a_jump_never_flies_through_a_thick_wall():
    """A 1.2 m thick wall over a 1 m gap, a jump that reaches 3 m: without the wall the
    gap is jumped; with it, every way across goes through the wall (the jump's three
    midway points can all miss the wall's faces by more than the clearance), and there
    is none. (The take-off floor is 3 m by 1: room for the run-up, and little to search
    before the search knows there is no way.)"""
    g = MeshGround(TriMesh.concat([plane(2, 5, -0.5, 0.5, name="A"), plane(6, 12, -1, 1, name="B")]))
    goal = np.array([10.0, 0.0, 0.0])
    r = Planner(g, None, steps(jump_len=3.0), FWD, settings=FASTEST).plan(start(2.5, 0), goal)
    assert any(f.jump for f in r.footprints)
    wall = MeshGround(box((4.9, -1.5, 0.0), (6.1, 1.5, 2.5), name="wall"))
    with pytest.raises(PlanError, match="cannot be reached"):
        Planner(g, wall, steps(jump_len=3.0), FWD, settings=FASTEST).plan(start(2.5, 0), goal)


def test_without_a_jump_clip_a_gap_no_step_spans_is_never_crossed():
    """1 m: the run's 1.1 m step less the foot's 0.26 m spans 0.85 m (a narrower gap is
    stepped across: tests/test_gaps.py). The two floors' islands lie too far apart for
    a step, and the library has no jump: refused before any search, naming the step's
    span and the missing jump, with no footprint expanded (the search used to flood floor
    A before it refused)."""
    g = MeshGround(TriMesh.concat([plane(-2, 5, -1, 1, name="A"), plane(6.0, 12, -1, 1, name="B")]))
    with pytest.raises(PlanError, match=r"cannot be reached: it stands on ground apart from the start's by gaps "
                                        r"wider than 0\.8\d m \(the widest gap its longest step spans is 0\.8\d m; "
                                        r"the library has no jump clip\)") as err:
        Planner(g, None, steps(with_jump=False), FWD, settings=FASTEST).plan(start(0, 0),
                                                                                    np.array([10.0, 0, 0]))
    assert err.value.expanded == 0
    # a gap the steps span is crossed (the islands linked): no refusal of the kind
    near = MeshGround(TriMesh.concat([plane(-2, 5, -1, 1, name="A"), plane(5.5, 12, -1, 1, name="B")]))
    r = Planner(near, None, steps(with_jump=False), FWD, settings=FASTEST).plan(start(0, 0), np.array([10.0, 0, 0]))
    assert not any(f.jump for f in r.footprints)


def test_goal_off_every_surface():
    g = MeshGround(plane(-2, 5, -1, 1))
    with pytest.raises(PlanError, match="off every traversable surface"):
        Planner(g, None, steps(), FWD, settings=FASTEST).plan(start(0, 0), np.array([20.0, 20.0, 0.0]))


def test_arrival_heading():
    g = MeshGround(plane(-2, 12, -6, 6))
    pl = Planner(g, None, steps(), FWD, settings=FASTEST)
    goal = np.array([8.0, 0.0, 0.0])
    r = pl.plan(start(0, 0), goal, goal_heading=0.0)  # arrive facing -Y
    assert abs(np.angle(np.exp(1j * r.footprints[-1].heading))) <= pl.settings.goal_heading_tolerance


def test_the_support_cache_serves_the_next_plan():
    g = MeshGround(plane(-2, 12, -6, 6))
    pl = Planner(g, None, steps(), FWD, settings=FASTEST)
    pl.cache.update({"floor": ("v1", np.array([-2, -6, 0.0]), np.array([12, 6, 0.0]))})
    goal = np.array([10.0, 3.0, 0.0])
    a = pl.plan(start(0, 0), goal)
    n = len(pl.cache.table)
    b = pl.plan(start(0, 0), goal)
    assert len(pl.cache.table) == n and [f.label for f in a.footprints] == [f.label for f in b.footprints]
    # the geometry changed: answers are dropped
    pl.cache.update({"floor": ("v2", np.array([-2, -6, 0.0]), np.array([12, 6, 0.0]))})
    left = np.array([k[:2] for k in pl.cache.table], dtype=float).reshape(-1, 2) * 0.02
    assert len(left) < n and not pl.cache.between  # nothing kept on or near the changed floor
    assert np.all((left[:, 0] > 12.6) | (left[:, 0] < -2.6) | (left[:, 1] > 6.6) | (left[:, 1] < -6.6))
    pl.plan(start(0, 0), goal)
    assert pl.cache.objects["floor"][0] == "v2"


def test_the_distance_fields_cells_serve_every_plan_on_the_same_geometry(monkeypatch):
    """The field's cells hold for any goal: a second plan (another goal, a planner with other
    penalties sharing the cache) builds none and finds what a planner of its own finds;
    other limits (plain A*'s map) build their own; a changed object drops them all."""
    from footstep_planner.core.plan import distance_field

    built = []
    build = distance_field.FieldCells.build
    monkeypatch.setattr(distance_field.FieldCells, "build",
                        staticmethod(lambda *a, **k: built.append(1) or build(*a, **k)))
    g = MeshGround(TriMesh.concat([plane(-2, 12, -6, 6), box((4, -1, 0), (5, 1, 1), "crate")]))
    pl = Planner(g, MeshGround(box((4, -1, 0), (5, 1, 1), "crate")), steps(), FWD, settings=FASTEST)
    pl.cache.update({"floor": ("v1", np.array([-2, -6, 0.0]), np.array([12, 6, 0.0]))})
    pl.plan(start(0, 0), np.array([10.0, 0.0, 0.0]))
    assert len(built) == 1
    other_goal = pl.plan(start(0, 0), np.array([9.0, 3.0, 0.0]))
    turning_dearer = replace(pl, settings=FASTEST.replace(turn_penalty=0.5))  # (replace: the cache is shared)
    penalised = turning_dearer.plan(start(0, 0), np.array([9.0, 3.0, 0.0]))
    assert len(built) == 1
    fresh = Planner(g, pl.obstacles, steps(), FWD, settings=FASTEST)
    alone = fresh.plan(start(0, 0), np.array([9.0, 3.0, 0.0]))
    assert [f.position.tolist() for f in other_goal.footprints] == [f.position.tolist() for f in alone.footprints]
    assert penalised.cost >= other_goal.cost  # (the path's cost: its steps' time plus the turn penalty)
    replace(pl, settings=FASTEST.replace(heuristic_weight=1.0)).distance_field(np.array([9.0, 3.0, 0.0]))
    assert len(built) == 3  # (the fresh planner's, and plain A*'s map: a lower bound, built to its own limits)
    pl.cache.update({"floor": ("v2", np.array([-2, -6, 0.0]), np.array([12, 6, 0.0]))})
    assert not pl.cache.fields
    pl.plan(start(0, 0), np.array([10.0, 0.0, 0.0]))
    assert len(built) == 4


def test_a_changed_object_drops_only_the_answers_near_it():
    from footstep_planner.core.plan.navgraph import FootprintCache

    c = FootprintCache()
    c.update({"floor": ("a", np.array([0, 0, 0.0]), np.array([20, 20, 0.0])),
              "box": ("b", np.array([5, 5, 0.0]), np.array([6, 6, 1.0]))})
    for x in range(0, 1000, 10):  # answers along y = 1 m and y = 5.5 m
        c.table[(x, 50, 0)] = (True, 0.0)
        c.table[(x, 275, 0)] = (True, 0.0)
    n = len(c.table)
    assert c.update(dict(c.objects)) == 0 and len(c.table) == n  # nothing changed
    # the box moves from x 5-6 to x 8-9: answers near either place go, the rest stay
    dropped = c.update({"floor": c.objects["floor"], "box": ("b2", np.array([8, 5, 0.0]), np.array([9, 6, 1.0]))})
    assert dropped > 0 and len(c.table) == n - dropped
    assert (250, 275, 0) not in c.table and (420, 275, 0) not in c.table  # x = 5 m and 8.4 m
    assert (700, 275, 0) in c.table and (250, 50, 0) in c.table  # far along, or on y = 1 m


def test_a_search_that_cannot_finish_stops_at_its_budget():
    """Bounded, never a hang: with the goal reachable only by a route the budget can't
    cover, the search stops after max_expansions and says where it got to."""
    g = MeshGround(plane(-2, 40, -6, 6))
    pl = Planner(g, None, steps(), FWD, settings=FASTEST.replace(max_expansions=5))
    with pytest.raises(PlanError, match="ran out of its budget, 6 footprints expanded.*nearest reachable point"):
        pl.plan(start(0, 0), np.array([38.0, 0.0, 0.0]))


def test_a_floor_under_a_platform_is_a_level_of_its_own():
    """The distance map has a level per surface over a cell: a platform 1.5 m over the
    floor, with no way up, is refused before any search (not flooded from below), and
    the floor under it stays walkable."""
    g = MeshGround(TriMesh.concat([plane(-2, 12, -6, 6), plane(2, 8, -1, 1, z=1.5, name="deck")]))
    pl = Planner(g, None, steps(), FWD, settings=FASTEST)
    with pytest.raises(PlanError, match="no walkable way") as err:
        pl.plan(start(0, 0), np.array([5.0, 0.0, 1.5]))
    assert err.value.expanded == 0
    goal = np.array([10.0, 0.0, 0.0])  # under the deck and beyond
    check_path(pl, pl.plan(start(0, 0), goal), goal)


def test_a_goal_reached_but_never_facing_its_heading_says_so():
    """The search gets to the goal's place but the library can't arrive facing the way
    asked: the message says that, not 'the nearest reachable point is the goal'."""
    g = MeshGround(plane(-2, 4, -0.6, 0.6))
    pl = Planner(g, None, steps(with_jump=False), FWD, settings=FASTEST.replace(max_expansions=400))
    with pytest.raises(PlanError, match="reached the goal's place .* but never facing the goal's heading"):
        pl.plan(start(0, 0), np.array([2.5, 0.0, 0.0]), goal_heading=-EAST)  # facing back, on a narrow strip


def _long_and_short():
    """A straight walk of 0.6 m steps and a straight stride of 0.9 m in the same time (the
    search's cheapest on the level)."""
    rows = []
    for lab, fwd in (("walk", 0.6), ("long", 0.9)):
        for foot, side in ((0, -0.2), (1, 0.2)):
            rows.append((foot, fwd, side, 0.0, 0.6, "walk", False, lab))
    c = list(zip(*rows))
    return StepSet(np.array(c[1]), np.array(c[2]), np.array(c[3]), np.array(c[4]), np.array(c[0]),
                   np.array(c[5], object), np.array(c[6], bool), np.array(c[7], object))


@pytest.mark.parametrize("rise", [0.12, -0.12])
def test_a_step_up_or_down_goes_no_further_than_the_walks_straight_step(rise, monkeypatch):
    """Onto a platform 12 cm up (or off one, down): on the level the search strides 0.9 m,
    but the step that climbs (descends) goes no further over the ground than the straight
    walk's step (``climb_reach``: a running stride up a flight leaps its treads, and the
    legs snap straight landing). Without the limit the search takes the long stride there
    too."""
    from dataclasses import replace

    from footstep_planner.core.plan import step_rules
    lo, hi = (0.0, rise) if rise > 0 else (-rise, 0.0)
    g = MeshGround(TriMesh.concat([plane(-2, 4.0, -3, 3, z=lo, name="near"),
                                   plane(4.0, 10, -3, 3, z=hi, name="far")]))
    steps = _long_and_short()
    reach = step_rules.climb_reach(steps)
    assert np.allclose(reach, np.hypot(0.6, 0.2))  # (the walk's: 0.6 m on, 0.2 m across)
    feet = [replace(f, position=f.position + [0.0, 0.0, lo]) for f in start(0, 0)]

    def climb(limit: bool) -> float:
        if not limit:
            monkeypatch.setattr(step_rules, "CLIMB_DZ", np.inf)
        pl = Planner(g, None, steps, FWD, settings=FASTEST.replace(stride_min=1.0, stride_max=1.0))
        p = np.array([f.position for f in pl.plan(feet, np.array([8.0, 0.0, hi])).footprints])
        d = np.diff(p, axis=0)
        up = np.abs(d[:, 2]) > 0.03
        assert up.sum() == 1
        return float(np.hypot(*d[up][0, :2]))

    assert climb(True) <= reach[0] + 1e-9
    assert climb(False) > reach[0]


def test_a_step_edge_is_explained_with_its_height():
    """The "uneven" refusal (a step edge under the foot) says where and how high the
    edge is (it named a helper that did not exist: the message raised NameError)."""
    from footstep_planner.core.plan.refusals import _explain

    g = MeshGround(TriMesh.concat([plane(-2, 4.0, -3, 3, name="near"), plane(4.0, 10, -3, 3, z=0.15, name="far")]))
    pl = Planner(g, None, steps(), FWD)
    words = _explain(pl, "uneven", np.array([4.0, 0.0, 0.0]), np.array([3.0, 0.0, 0.0]), np.array([8.0, 0.0, 0.15]))
    assert "(4.00, 0.00), 0.15 m high" in words, words


def test_a_search_that_runs_dry_tries_again_without_the_weave_penalty(monkeypatch):
    """Where every way on ran dry with the weave penalty (it orders the search, and the
    footprint reached first closes its merge key), the search is tried once more without
    it: the straight-walk preference never refuses a path a plain search finds."""
    g = MeshGround(plane(-2, 12, -6, 6))
    goal = np.array([6.0, 0.0, 0.0])
    expand = Planner._expand
    monkeypatch.setattr(Planner, "_expand", lambda self, search, idx: (
        expand(self, search, idx) if self.settings.weave_penalty == 0 else None))  # (weaving: runs dry)
    res = Planner(g, None, steps(), FWD, settings=FASTEST).plan(start(0, 0), goal)
    assert np.linalg.norm(res.footprints[-1].position[:2] - goal[:2]) <= FASTEST.goal_radius
    monkeypatch.setattr(Planner, "_expand", lambda self, search, idx: None)  # (dry either way: refused)
    with pytest.raises(PlanError):
        Planner(g, None, steps(), FWD, settings=FASTEST).plan(start(0, 0), goal)


def test_from_standing_the_first_step_walks():
    """A standing start (or a turn's last pivot step) walks off: the first step is a
    walk's even where running is free (``run_penalty`` 0); a footprint a run reached (a
    waypoint passed through running) may run on at once."""
    from dataclasses import replace

    g = MeshGround(plane(-2, 20, -6, 6))
    goal = np.array([15.0, 0.0, 0.0])
    pl = Planner(g, None, steps(with_jump=False), FWD, settings=FASTEST)
    fs = pl.plan(start(0, 0), goal).footprints
    assert fs[1].gait == "walk" and any(f.gait == "run" for f in fs[2:])  # (then runs: it is free)
    running = [replace(f, label="run+0", gait="run") for f in start(0, 0)][:1]
    assert pl.plan(running, goal).footprints[1].gait == "run"


def _cornering_steps():
    """Walks and runs straight or turning 15 degrees a step either way, and a walk turning
    45 degrees a step either way, marked as a corner (``StepSet.corner``: tighter than any
    run of the set turns)."""
    rows = []
    for gait, fwd, dt, turns in (("walk", 0.6, 0.6, [-15, 0, 15]), ("run", 1.1, 0.38, [-15, 0, 15]),
                                 ("walk", 0.5, 0.6, [-45, 45])):
        for turn in np.radians(turns):
            for foot, side in ((0, -0.15), (1, 0.15)):
                rows.append((foot, fwd, side, turn, dt, gait, False, f"{gait}{np.degrees(turn):+.0f}"))
    c = list(zip(*rows))
    labels = np.array(c[7], object)
    return StepSet(np.array(c[1]), np.array(c[2]), np.array(c[3]), np.array(c[4]), np.array(c[0]),
                   np.array(c[5], object), np.array(c[6], bool), labels,
                   corner=np.isin(labels, ["walk-45", "walk+45"]))


@pytest.mark.parametrize("marked", [True, False])
def test_a_run_walks_into_a_corner_tighter_than_it_turns_and_out_of_it(marked):
    """Running free along an L-shaped corridor 0.9 m wide: the way turns its corner with
    the sharp walk (the runs turn 15 degrees a step at most). With the sharp steps marked
    as corners, no run comes within ``CORNER_STEPS`` steps of one (a run slows into a walk
    before the corner and speeds up after it), and it runs before and after the corner;
    unmarked, the search runs straight into the sharp step (what the blend played as a
    run taking the corner at full speed)."""
    from footstep_planner.core.plan.navgraph import CORNER_STEPS
    from footstep_planner.core.plan.surface import TriMesh

    g = MeshGround(TriMesh.concat([plane(-1, 8.9, -0.45, 0.45), plane(8.0, 8.9, -0.45, 8.0, name="up")]))
    st = _cornering_steps()
    if not marked:
        st = replace(st, corner=np.zeros(st.n, bool))
    goal = np.array([8.45, 7.0, 0.0])
    pl = Planner(g, None, st, FWD, settings=FASTEST)
    result = pl.plan(start(0, 0), goal)
    check_path(pl, result, goal)
    fs = result.footprints[1:]
    gaits = [f.gait for f in fs]
    sharp = [i for i, f in enumerate(fs) if f.label in ("walk-45", "walk+45")]
    assert sharp and "run" in gaits[:min(sharp)] and "run" in gaits[max(sharp):]
    near = [gaits[j] for i in sharp for j in range(max(0, i - CORNER_STEPS), min(len(fs), i + CORNER_STEPS + 1))]
    assert ("run" not in near) == marked, (gaits, sharp)
