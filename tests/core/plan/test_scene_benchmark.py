"""A handful of the planner benchmark's generated scenes (benchmarks/scene_generator.py)
with the CMU subject-16 library: paths without loops where the goal is reachable, and
where it is not, a quick refusal that names what blocks the way (issue 15)."""

import re

import numpy as np
import pytest

from benchmarks.bench_planner import loops
from benchmarks.scene_generator import benchmark_scenes, corridor, make_planner, plan_scene, stairs
from conftest import needs_cmu
from footstep_planner.core.plan.navgraph import PlanError
from footstep_planner.core.base.settings import Settings, SettingsError

pytestmark = needs_cmu

SCENES = {s.name: s for s in benchmark_scenes()}


def check_path(pl, result, scene):
    fs = result.footprints
    assert np.linalg.norm(fs[-1].position[:2] - np.asarray(scene.goal)[:2]) <= pl.settings.goal_radius
    assert [f.foot for f in fs[1:]] == [1 - f.foot for f in fs[:-1]]
    assert loops(fs) == 0


@pytest.mark.parametrize("name", ["zigzag1", "bridge_down", "clutter10"])
def test_reachable_scenes_find_a_path_without_loops(bench_character, name):
    scene = SCENES[name]
    pl, result = plan_scene(scene, bench_character)
    check_path(pl, result, scene)
    if name == "zigzag1":  # the 0.73 m gap, which a running step spans: crossed by one, not jumped
        across = [(a, b) for a, b in zip(result.footprints[:-1], result.footprints[1:])
                  if a.position[0] < 13.18 and b.position[0] > 13.91 and abs(a.position[1] - 6.5) < 1.0]
        assert len(across) == 1 and across[0][1].gait == "run" and not across[0][1].jump
        assert not any(f.jump for f in result.footprints)
    if name == "bridge_down":  # down from the bridge by the ramp, not through it
        assert result.footprints[-1].position[2] == pytest.approx(0.0, abs=0.01)
        assert max(f.position[1] for f in result.footprints) > 12.5


def test_an_island_is_refused_quickly_saying_why(bench_character):
    scene = SCENES["island_far"]
    pl, start, goal = make_planner(scene, bench_character)
    with pytest.raises(PlanError, match="no walkable way, nor a gap a step or a jump clip can clear.*nearest "
                                        r"reachable point is \(1[34]\.") as err:
        pl.plan(start, goal)
    assert err.value.expanded == 0  # refused before any search (its speed: benchmarks/bench_planner.py)
    # the gap against the longest step (the run's) and against the jump
    assert re.search(r"the gap beyond is 3\.0\d m wide; the library's longest running step spans a gap of "
                     r"0\.9\d m \(1\.1\d m from footprint to footprint, less the foot's 0\.2\d m\), "
                     r"and its jump reaches 1\.8\d m", str(err.value)), err.value


@pytest.mark.parametrize("width", [1.2, 2.0, 3.0])
def test_a_corridor_start_facing_along_it_walks_along_it(bench_character, width):
    scene = corridor(np.random.default_rng(7), "c", width, "along")
    pl, result = plan_scene(scene, bench_character)
    check_path(pl, result, scene)
    assert all(abs(f.position[1]) < width / 2 for f in result.footprints)


@pytest.mark.parametrize("width", [2.0, 3.0])
def test_a_corridor_start_facing_across_turns_where_the_turns_fit(bench_character, width):
    scene = corridor(np.random.default_rng(7), "c", width, "across")
    pl, result = plan_scene(scene, bench_character)
    check_path(pl, result, scene)


def test_a_corridor_too_narrow_for_the_clips_strides_is_turned_in_with_shorter_ones(bench_character):
    """1.2 m across: no step of the clips' own stride fits before the wall 0.6 m ahead;
    shortened strides (``Settings.stride_min``) turn into the corridor."""
    scene = corridor(np.random.default_rng(7), "c", 1.2, "across")
    pl, result = plan_scene(scene, bench_character)
    check_path(pl, result, scene)
    st = bench_character.steps
    own = (st.stride == 1.0) & ~st.jump & (st.gait == "walk")
    shortest = float(np.hypot(st.fwd[own], st.left[own]).min())
    p = np.array([f.position for f in result.footprints])
    assert (np.linalg.norm(np.diff(p[:, :2], axis=0), axis=1) < 0.9 * shortest).any()  # a shortened step


def test_a_corridor_too_narrow_to_turn_in_names_the_wall(bench_character):
    """1.2 m across with the clips' own strides only: the wall is 0.6 m ahead, and the
    shortest step with the body's clearance does not fit before it."""
    from conftest import own_strides

    scene = corridor(np.random.default_rng(7), "c", 1.2, "across")
    pl, start, goal = make_planner(scene, own_strides(bench_character))
    with pytest.raises(PlanError) as err:
        pl.plan(start, goal)
    msg = str(err.value)
    assert "the start itself: no step of the library leaves it towards the goal" in msg
    assert re.search(r"an obstacle \(a wall or an object\) at \([\d.-]+, -0\.60\)", msg), msg
    assert "clearance (0.25 m)" in msg and "the shortest goes 0.38 m" in msg


def test_steps_with_treads_shorter_than_the_foot_say_so(bench_character):
    """Three 12 cm steps with 8 cm treads: refused at once, at the foot of the steps (not
    "the start"), saying that no footprint fits on a tread."""
    scene = stairs(np.random.default_rng(3), "s", 0.12, 0.08, 3)
    pl, start, goal = make_planner(scene, bench_character)
    with pytest.raises(PlanError) as err:
        pl.plan(start, goal)
    assert err.value.expanded == 0  # refused before any search
    msg = str(err.value)
    m = re.search(r"nearest reachable point is \(([\d.-]+), ([\d.-]+)\)", msg)
    assert m and 5.0 < float(m.group(1)) < 6.1, msg  # at the foot of the steps, 4 m from the start
    assert "steps ahead, rising 0.12 m with treads 0.08 m deep" in msg and "on one tread" in msg, msg
    assert "start" not in msg.split("nearest reachable point")[1]


def test_a_negative_goal_radius_is_refused_before_any_search():
    with pytest.raises(SettingsError, match="goal_radius"):
        Settings(goal_radius=-1.0)


@needs_cmu
def test_without_cross_gaps_the_gap_is_jumped_from_a_run(bench_character):
    """zigzag1's 0.73 m gap with ``Settings.cross_gaps`` off: steps keep to the ground, and
    the gap is jumped (from a run)."""
    pl, result = plan_scene(SCENES["zigzag1"], bench_character, cross_gaps=False)
    check_path(pl, result, SCENES["zigzag1"])
    jumps = [(a, b) for a, b in zip(result.footprints[:-1], result.footprints[1:]) if b.jump]
    assert len(jumps) == 1 and jumps[0][0].gait == "run"
