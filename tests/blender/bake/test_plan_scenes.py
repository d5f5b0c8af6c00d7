"""Planning on the sample scenes with the real CMU library (subject 16 and its leap)."""

import json
import math
from importlib import import_module

import numpy as np
import pytest

from conftest import needs_cmu, plan_sample as _plan, scene_with_cmu as _scene_with_character

pytestmark = needs_cmu

def _check(fp, result, setup, goal):
    core = import_module(fp.__name__ + ".core.plan.surface")
    pl = setup.planner
    fs = result.footprints
    assert np.linalg.norm(fs[-1].position[:2] - goal[:2]) <= pl.settings.goal_radius
    sup = core.footprint_support(pl.ground, pl.obstacles, np.array([f.position for f in fs]),
                                 np.array([f.heading for f in fs]), setup.forward, pl.foot,
                                 core.SupportLimits(clearance=pl.clearance))
    assert sup.ok.all(), list(zip(sup.reason, [f.position for f in fs]))
    assert [f.foot for f in fs[1:]] == [1 - f.foot for f in fs[:-1]]


@pytest.mark.parametrize("name", ["jumps", "turns", "obstacles"])
def test_every_sample_scene_reaches_its_goal(fp, name):
    scene, result, setup, goal = _plan(fp, name)
    _check(fp, result, setup, goal)
    labels = set(f.label for f in result.footprints)
    assert labels - {"start"}  # carried by the library's clips and blends


def test_jumps_jumps_both_gaps_and_only_them(fp):
    scene, result, setup, goal = _plan(fp, "jumps")
    jumps = [(a, b) for a, b in zip(result.footprints[:-1], result.footprints[1:]) if b.jump]
    assert len(jumps) == 2
    # (the leap or its mirror: a jump takes off from either foot)
    assert all(b.label in ("cmu_49_05_run_leap_run", "cmu_49_05_run_leap_run~mirror") and a.gait == "run"
               for a, b in jumps)
    (a1, b1), (a2, b2) = jumps
    assert a1.position[1] < 8.0 < 9.0 < b1.position[1]  # across the first gap, northwards
    assert a2.position[0] < 15.0 < 16.0 < b2.position[0]  # across the second, eastwards


def test_obstacles_passes_the_doorway_and_climbs_the_step(fp):
    scene, result, setup, goal = _plan(fp, "obstacles")
    fs = result.footprints
    through = [(a.position, b.position) for a, b in zip(fs[:-1], fs[1:])
               if a.position[0] < 6.15 <= b.position[0]]
    assert len(through) == 1
    a, b = through[0]
    y = a[1] + (6.15 - a[0]) / (b[0] - a[0]) * (b[1] - a[1])
    assert 4.0 < y < 5.0  # through the doorway
    assert fs[-1].position[2] == pytest.approx(0.15, abs=1e-3)  # up on the step


def test_a_gap_wider_than_any_jump_is_refused(fp):
    import bpy

    scene, ob = _scene_with_character(fp, "jumps")
    p3 = scene.objects["Platform3"]
    p3.location.x += 1.5  # the second gap becomes 2.5 m
    goal = scene.objects["Goal"]
    goal.location.x += 1.5
    planning = import_module(fp.__name__ + ".blender.planning")
    errors = import_module(fp.__name__ + ".core.plan.navgraph")
    with pytest.raises(errors.PlanError, match="cannot be reached.*nearest reachable point is \\(1[45]\\."):
        planning.plan(scene, ob, np.array(goal.location), start_marker=scene.objects["Start"])
    del bpy


def test_plan_from_the_characters_own_feet(fp):
    scene, ob = _scene_with_character(fp, "obstacles")
    ob.animation_data.action = next(a for a in __import__("bpy").data.actions if a.name == "cmu_16_16_walk")
    ob.animation_data.action_slot = ob.animation_data.action.slots[0]
    ob.location = (-3.0, -3.0, 0.0)
    ob.rotation_euler.z = 0.5
    scene.frame_set(1)
    planning = import_module(fp.__name__ + ".blender.planning")
    result, setup = planning.plan(scene, ob, np.array([2.0, -6.0, 0.0]))
    _check(fp, result, setup, np.array([2.0, -6.0, 0.0]))
    ob.scale = (2, 1, 2)  # (an even scale is taken as Blender shows it; an uneven one refused)
    with pytest.raises(Exception, match="'CMU' is scaled 2, 1, 2 on X, Y, Z"):
        planning.plan(scene, ob, np.array([2.0, -6.0, 0.0]))


def test_plan_verb(fp, capsys, tmp_path):
    import bpy

    scene, ob = _scene_with_character(fp, "turns")
    path = str(tmp_path / "turns.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path)
    cli = import_module(fp.__name__ + ".blender.command.cli").cli_main
    capsys.readouterr()
    assert cli(["plan", path, "--character", "CMU", "--goal", "Goal", "--start", "Start", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["character"] == "CMU" and len(doc["footprints"]) > 20
    fp0 = doc["footprints"][-1]
    assert {"foot", "position", "heading", "time", "clip"} <= set(fp0)
    assert {"expanded", "generated", "seconds"} <= set(doc["search"])
    assert cli(["plan", path, "--character", "CMU", "--goal", "Goal", "--start", "Start"]) == 0
    out = capsys.readouterr().out
    assert "footprints expanded" in out and "blend groups" in out
    assert {"synthesis", "stages"} <= set(doc)
    assert len(doc["synthesis"]["curves"]["tau"]) == doc["stages"]["frames"]
    # bad input: an object that isn't there, a goal off every surface, no traversable mesh
    assert cli(["plan", path, "--character", "CMU", "--goal", "Nowhere", "--start", "Start"]) == 2
    assert "'Nowhere'" in capsys.readouterr().err
    bpy.ops.wm.open_mainfile(filepath=path)
    bpy.context.scene.cursor.location = (40, 40, 0)
    assert cli(["plan", "--character", "CMU", "--start", "Start"]) == 2
    assert "off every traversable surface" in capsys.readouterr().err
    bpy.data.collections["Traversable"].footstep.surface = "NONE"
    assert cli(["plan", "--character", "CMU", "--goal", "Goal", "--start", "Start"]) == 2
    assert "no traversable mesh" in capsys.readouterr().err
    assert cli(["plan", "--character", "CMU", "--goal", "Goal", "--start", "Start",
                "--traversable", "Path,CurvedPlatform"]) == 0


def test_replanning_after_moving_one_obstacle_keeps_the_other_answers(fp):
    scene, ob = _scene_with_character(fp, "obstacles")
    planning = import_module(fp.__name__ + ".blender.planning")
    goal = np.array(scene.objects["Goal"].location)
    _, s = planning.plan(scene, ob, goal, start_marker=scene.objects["Start"])
    cache = s.planner.cache
    before = len(cache.table)
    scene.objects["Pillar4"].location.x += 1.0  # (0, -3) -> (1, -3)
    result, s2 = planning.plan(scene, ob, goal, start_marker=scene.objects["Start"])
    assert s2.planner.cache is cache
    kept = [k for k in cache.table if abs(k[0] * 0.02 - 0.5) > 1.5 or abs(k[1] * 0.02 + 3) > 1.5]
    assert 0 < len(kept) and before > 0
    _check(fp, result, s2, goal)  # and the new plan respects the moved pillar


def test_the_support_caches_keep_the_latest_scenes_only(fp):
    """A session that plans in many scenes keeps the answers of the CACHED_SCENES it used
    last (the one used again moves to the end), and a worker can drop them all."""
    planning = import_module(fp.__name__ + ".blender.planning")
    planning.forget_support_caches()
    keys = [(f"scene {i}", None, True) for i in range(planning.CACHED_SCENES + 2)]
    first = planning._support_cache(keys[0], 0.6)
    for k in keys[1:planning.CACHED_SCENES]:
        planning._support_cache(k, 0.6)
    assert planning._support_cache(keys[0], 0.6) is first  # (kept, and now the latest)
    for k in keys[planning.CACHED_SCENES:]:
        planning._support_cache(k, 0.6)
    assert len(planning._CACHES) == planning.CACHED_SCENES
    assert keys[0] in planning._CACHES and keys[1] not in planning._CACHES and keys[2] not in planning._CACHES
    planning.forget_support_caches()
    assert not planning._CACHES


def test_plan_operator_and_panel(fp):
    import bpy

    from conftest import draw_tab

    scene, ob = _scene_with_character(fp, "turns")
    scene.footstep.character = ob
    scene.footstep.goal = scene.objects["Goal"]
    scene.footstep.start = scene.objects["Start"]
    assert bpy.ops.footstep.plan() == {"FINISHED"}
    doc = json.loads(scene.footstep.plan_json)
    assert len(doc["footprints"]) > 20 and "footprints" in scene.footstep.last_report
    log = draw_tab(fp, bpy.context)  # (the tab and its sub-panels)
    assert any(a and a[0] == "footstep.plan" for name, a, _ in log if name == "operator")
    scene.footstep.goal = None
    scene.cursor.location = (60, 60, 0)  # off every surface: a clear report, nothing changed
    with pytest.raises(RuntimeError, match="off every traversable surface"):
        bpy.ops.footstep.plan()  # the operator reports the error (scripts get it raised)
    assert json.loads(scene.footstep.plan_json) == doc  # and changed nothing


def test_the_wall_is_stepped_around(fp):
    """Wall1 runs from x = -6 to -2 at y = 2; straight through it is the short way."""
    scene, ob = _scene_with_character(fp, "obstacles")
    scene.objects["Start"].location = (-4.0, 0.0, 0.0)
    planning = import_module(fp.__name__ + ".blender.planning")
    goal = np.array([-4.0, 4.5, 0.0])
    result, s = planning.plan(scene, ob, goal, start_marker=scene.objects["Start"])
    _check(fp, result, s, goal)
    for a, b in zip(result.footprints[:-1], result.footprints[1:]):
        if (a.position[1] - 2.15) * (b.position[1] - 2.15) <= 0:  # a step across the wall's line
            x = a.position[0] + (2.15 - a.position[1]) / (b.position[1] - a.position[1]) * (b.position[0] - a.position[0])
            assert x < -6.2 or x > -1.8


def test_up_the_ramp_to_its_landing(fp):
    scene, ob = _scene_with_character(fp, "obstacles")
    scene.objects["Start"].location = (-3.0, -8.0, 0.0)
    scene.objects["Start"].rotation_euler.z = math.pi / 2  # facing +X, towards the ramp
    planning = import_module(fp.__name__ + ".blender.planning")
    run = 0.8 / math.tan(math.radians(15))
    goal = np.array([run + 1.2, -8.0, 0.8])
    result, s = planning.plan(scene, ob, goal, start_marker=scene.objects["Start"])
    _check(fp, result, s, goal)
    on_ramp = [f for f in result.footprints if 0.2 < f.position[0] < run - 0.2]
    assert on_ramp and all(0.0 < f.position[2] < 0.8 for f in on_ramp)
    assert result.footprints[-1].position[2] == pytest.approx(0.8, abs=1e-3)


@pytest.mark.parametrize("turn", [0.0, 0.5 * math.pi, -0.5 * math.pi])
def test_the_goal_empty_faces_the_way_to_arrive(fp, turn):
    """The Goal empty's facing (its -Y axis, as Blender's characters face) is the heading
    the path arrives with; the command line's --goal-heading overrides it."""
    import bpy

    scene, ob = _scene_with_character(fp, "obstacles")
    planning = import_module(fp.__name__ + ".blender.planning")
    goal_ob = scene.objects["Goal"]
    goal_ob.rotation_euler.z = math.pi / 2 + turn
    bpy.context.view_layer.update()
    goal, heading = planning.goal_of(scene, "Goal")
    assert abs(math.remainder(heading - (math.pi / 2 + turn), 2 * math.pi)) < 1e-6
    result, setup = planning.plan(scene, ob, goal, heading, scene.objects["Start"])
    want = np.array([np.cos(heading - math.pi / 2), np.sin(heading - math.pi / 2)])  # -Y turned by heading
    fwd = setup.forward
    for f in result.footprints[-1:]:
        a = f.heading + math.atan2(fwd[1], fwd[0])
        got = np.array([math.cos(a), math.sin(a)])
        assert math.degrees(math.acos(np.clip(got @ want, -1, 1))) <= math.degrees(
            setup.planner.settings.goal_heading_tolerance) + 1e-6
    assert planning.goal_of(scene, None)[1] is None  # the 3D cursor has no heading


def test_the_overlay_draws_the_way_start_and_goal_face(fp):
    """The overlay's arrows for Start and Goal point along each empty's -Y axis turned by
    its rotation: the headings the path starts and arrives with."""
    scene = import_module(fp.__name__ + ".blender.sample.sample_scenes").build("obstacles")
    overlay = import_module(fp.__name__ + ".blender.ui.overlay")
    fs = scene.footstep
    fs.start, fs.goal = scene.objects["Start"], scene.objects["Goal"]
    seg = overlay._facing_arrows(scene, fs)
    assert seg.shape == (12, 3)
    for ob, arrow in zip((fs.start, fs.goal), (seg[:6], seg[6:])):
        shaft = arrow[1] - arrow[0]
        want = np.array(ob.matrix_world.to_3x3().col[1])[:2] * -1  # its -Y axis
        np.testing.assert_allclose(shaft[:2] / np.linalg.norm(shaft[:2]), want / np.linalg.norm(want), atol=1e-6)
