"""The sample scenes: built by code, tagged, and holding the features they promise."""

import math
import os
import subprocess
import sys
from importlib import import_module

import numpy as np
import pytest

from stairs_checks import square_and_straight
from conftest import HANG_SECONDS, ROOT, needs_cmu

FWD = np.array([0.0, -1.0])


def _scene(fp, name):
    import bpy

    import_module(fp.__name__ + ".blender.sample.sample_scenes").build(name)
    surf = import_module(fp.__name__ + ".blender.read.surfaces")
    ground, obstacles = surf.scene_surfaces(bpy.context.scene, bpy.context.evaluated_depsgraph_get())
    return bpy.context.scene, ground, obstacles, import_module(fp.__name__ + ".core.plan.surface")


def _heading_xy(ob):
    a = ob.rotation_euler.z + math.atan2(FWD[1], FWD[0])
    return np.array([math.cos(a), math.sin(a)])


def _on_ground(ground, xy, z=0.0):
    pts = np.c_[np.atleast_2d(xy), np.full(len(np.atleast_2d(xy)), z + 0.5)]
    return ground.ray_down(pts, 1.0)


@pytest.mark.parametrize("name", ["jumps", "turns", "obstacles", "stairs"])
def test_start_and_goal_stand_on_the_ground(fp, name):
    scene, ground, obstacles, core = _scene(fp, name)
    for marker in ("Start", "Goal"):
        ob = scene.objects[marker]
        s = core.footprint_support(ground, obstacles, np.array([ob.location[:]]),
                                   np.array([ob.rotation_euler.z]), FWD, core.FootShape())
        assert s.ok[0], f"{name}: {marker} is {s.reason[0]}"


def test_jumps_has_two_one_metre_gaps_on_the_way(fp):
    scene, ground, obstacles, core = _scene(fp, "jumps")
    assert obstacles.mesh.n == 0
    # along the run-up (x = 8, northwards) and the last straight (y = 12, eastwards)
    for start, step in (((8.0, 7.0), (0.0, 0.01)), ((14.0, 12.0), (0.01, 0.0))):
        pts = np.asarray(start) + np.outer(np.arange(300), step)
        hit = _on_ground(ground, pts).hit
        holes = np.flatnonzero(~hit)
        assert len(holes) and hit[0] and hit[-1]
        width = (holes[-1] - holes[0] + 1) * 0.01
        assert width == pytest.approx(1.0, abs=0.02)


def test_stairs_are_real_stairs_and_the_only_way_up(fp):
    """Stairs: five 17 cm risers with 28 cm treads up to a landing and five down, the
    ground under a foot on each tread its tread's height (not the underside of the box
    below it), and walls all round: the stairs are the way from one floor to the other."""
    scene, ground, obstacles, core = _scene(fp, "stairs")
    sc = import_module(fp.__name__ + ".blender.sample.sample_scenes")
    x = 3.0 + (np.arange(4) + 0.5) * sc.TREAD  # the middle of each tread of the flight up
    hit = ground.ray_down(np.c_[x, np.zeros(4), np.full(4, 0.3)], 2.0)  # (inside the higher treads' boxes)
    top = (np.arange(4) + 1) * sc.RISER
    below = top > 0.3
    assert np.all(~hit.hit[below] | (hit.z[below] > 0.3 - 1e-9))  # never the underside of a box
    hit = ground.ray_down(np.c_[x, np.zeros(4), top + 0.05], 0.1)
    np.testing.assert_allclose(hit.z, top, atol=1e-6)
    assert obstacles.mesh.n and sc.RISER * sc.FLIGHT == pytest.approx(0.85)


def test_turns_path_is_one_connected_walk(fp):
    scene, ground, obstacles, core = _scene(fp, "turns")
    pts = np.array([(0, 0), (6, 0), (9, 4), (7, 9), (12, 12), (15.5, 10), (17, 10)], float)
    line = np.concatenate([a + np.outer(np.linspace(0, 1, 60), b - a) for a, b in zip(pts[:-1], pts[1:])])
    assert _on_ground(ground, line).hit.all()
    # and on round the curved platform, to the goal
    ang = np.linspace(-math.pi / 2, math.radians(55), 40)
    arc = np.c_[17 + 4 * np.cos(ang), 14 + 4 * np.sin(ang)]
    assert _on_ground(ground, arc).hit.all()


def test_obstacles_scene_features(fp):
    scene, ground, obstacles, core = _scene(fp, "obstacles")
    foot = core.FootShape()
    sup = lambda xy, head, z=0.0: core.footprint_support(  # noqa: E731
        ground, obstacles, np.array([[xy[0], xy[1], z]]), np.array([head]), FWD, foot)
    # the doorway lets a body through its middle, not near its jambs
    assert sup((6.15, 4.5), math.pi / 2).ok[0]
    assert sup((6.15, 3.9), math.pi / 2).reason[0] == "obstacle"
    assert sup((5.0, 0.0), math.pi / 2).ok[0]
    # the corridor is 1.2 m wide: its middle is clear, the walls are not
    assert sup((-8.6, 5.0), math.pi).ok[0]
    assert sup((-9.0, 5.0), math.pi).reason[0] == "obstacle"
    # a 15 cm step and a 15-degree ramp
    assert _on_ground(ground, [(8.5, 4.5)], 0.15).z[0] == pytest.approx(0.15)
    ramp = _on_ground(ground, [(1.5, -8.0)], 0.5)
    assert math.degrees(math.acos(ramp.normal[0, 2])) == pytest.approx(15, abs=0.01)
    assert sup((1.5, -8.0), math.pi / 2, z=ramp.z[0]).ok[0]
    # the pillars block
    assert sup((3.0, 3.0), 0.0).reason[0] == "obstacle"


def test_the_script_saves_the_scenes(tmp_path):
    env = dict(os.environ, BLENDER_USER_RESOURCES=str(tmp_path / "res"))
    script = os.path.join(ROOT, "sample_scenes", "build.py")
    r = subprocess.run([sys.executable, script, "jumps", "turns", "--mannequin", "--out", str(tmp_path)],
                       capture_output=True, text=True, timeout=HANG_SECONDS, env=env)
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "jumps.blend").stat().st_size > 1000 and (tmp_path / "turns.blend").exists()
    check = ("import bpy; bpy.ops.wm.open_mainfile(filepath=%r); ob = bpy.data.objects['Footstep Mannequin'];"
             "st = bpy.data.objects['Start']; print((ob.location - st.location).length < 1e-6, ob.type)"
             % str(tmp_path / "jumps.blend"))
    r = subprocess.run([sys.executable, "-c", check], capture_output=True, text=True, timeout=HANG_SECONDS, env=env)
    assert "True ARMATURE" in r.stdout, r.stderr
    bad = subprocess.run([sys.executable, script, "moon"], capture_output=True, text=True, timeout=HANG_SECONDS, env=env)
    assert bad.returncode == 2 and "unknown scene 'moon'" in bad.stderr


def _climbs_the_stairs(fp, scene, ob):
    """Bake ``ob`` up and down the Stairs (Start to Goal, with the goal's heading) and
    check what the user gets: the feet square to the treads and the body straight along
    each flight (``square_and_straight``), every planned stance on one top (a tread, the landing, a
    floor: the front half of the foot, toes and middle, over the same height; the heel
    there or hanging over the nosing below; the toe tip, and TIP_ROOM ahead of it, in no
    riser), no heel, ball or toe tip inside the steps on any frame, as played through the depsgraph
    (the report's ``penetration``), the body rising and falling smoothly, the goal
    reached."""
    import bpy

    planning = import_module(fp.__name__ + ".blender.planning")
    bpy.context.view_layer.update()
    goal, heading = planning.goal_of(scene, "Goal")
    doc = planning.run(scene, ob, goal, heading)
    q = doc["quality"]
    setup = planning.plan_setup(scene, ob)
    pos = np.array([f["position"] for f in doc["footprints"]])
    head = np.array([f["heading"] for f in doc["footprints"]])
    probes = setup.planner.foot.probes(pos, head, setup.forward)  # (N, 8, 2)
    pts = np.c_[probes.reshape(-1, 2), np.repeat(pos[:, 2], 8) + 0.3]
    hit = setup.planner.ground.ray_down(pts, 0.6)
    z = np.where(hit.hit, hit.z, -np.inf).reshape(-1, 8) - pos[:, 2, None]
    np.testing.assert_allclose(z[:, 2:7], 0.0, atol=0.01)  # the front half (toes, middle) on its tread
    assert z[:, :2].max() < 0.01 and z[:, 7].max() < 0.01  # heel and toe tip (with room) in no riser
    assert pos[:, 2].max() > 0.8  # up on the landing (0.85 m) ...
    assert sorted(set(np.round(pos[:, 2] / 0.17).astype(int))) == [0, 1, 2, 3, 4, 5]  # ... tread by tread
    assert q["penetration"]["frames_over_tolerance"] == 0 and q["penetration"]["max_mm"] < 5.0, q["penetration"]
    assert q["foot_skate"]["max_mm"] < 5.0
    assert q["goal"]["distance_m"] < 0.05 and q["goal"]["heading_deg"] < 5.0
    rig = setup.rig
    world, body, _, _ = import_module(fp.__name__ + ".blender.write.bake").evaluate_played(
        scene, ob, rig, doc["frame_start"], doc["frame_end"] - doc["frame_start"] + 1)
    for side in "lr":  # the toe tips (the toe bones' tails), as played: in no riser, through no tread
        toe = rig.foot_chain(side)[1]
        tip = (world[:, toe] @ (np.linalg.inv(rig.rest[toe]) @ np.append(rig.tails[toe], 1.0)))[:, :3]
        below = setup.planner.ground.ray_down(tip + [0.0, 0.0, 0.5], 1.0)
        inside = below.hit & (below.z > tip[:, 2])  # under a top: its depth is the way out
        _, depth = setup.planner.ground.nearest(tip[inside], max_dist=0.5)
        assert depth.max(initial=0.0) < 0.01, (side, depth.max(initial=0.0))
    vz = np.diff(body[:, 2]) * scene.render.fps
    assert np.abs(np.diff(vz)).max() * scene.render.fps < 12.0  # m/s^2: no jolt (over 1.2 g) up or down a step
    square_and_straight(setup.planner, pos, head, body[:, :2])
    return doc


def test_the_sample_character_climbs_the_stairs_tread_by_tread(fp):
    """Adapted strides (``Settings.stride_min``): one walk stride fits no run of 28 cm
    treads; shortened steps of the same clips do."""
    scene = import_module(fp.__name__ + ".blender.sample.sample_scenes").build("stairs")
    ob, _ = import_module(fp.__name__ + ".blender.sample.mannequin").add_to_scene(scene, "Start")
    _climbs_the_stairs(fp, scene, ob)


@needs_cmu
def test_cmu_climbs_the_stairs_tread_by_tread(fp):
    """Real capture (CMU subject 16, flat-ground walks only) climbs the Stairs too."""
    from conftest import scene_with_cmu

    scene, ob = scene_with_cmu(fp, "stairs")
    ob.location = scene.objects["Start"].location
    ob.rotation_euler = scene.objects["Start"].rotation_euler
    _climbs_the_stairs(fp, scene, ob)


def test_a_mixamo_style_character_with_long_toes_climbs_the_stairs(fp, tmp_path):
    """FBX clips from Blender's exporter with Mixamo's names, axes and units, whose toe
    bones reach 15 cm past the ball (a foot 29 cm long on 28 cm treads): the footprints
    keep the toe tips out of the risers, the heels hanging over the nosings going up."""
    from benchmarks import mixamo_like

    files = mixamo_like.write_character(str(tmp_path))
    scene = import_module(fp.__name__ + ".blender.sample.sample_scenes").build("stairs")
    ob, _ = import_module(fp.__name__ + ".blender.read.clips").import_clips(files, name="Mixamo")
    ob.location = scene.objects["Start"].location
    ob.rotation_euler = scene.objects["Start"].rotation_euler
    setup = import_module(fp.__name__ + ".blender.planning").plan_setup(scene, ob)
    assert setup.planner.foot.tip > setup.planner.foot.front + 0.05
    _climbs_the_stairs(fp, scene, ob)


def test_without_adapted_strides_the_stairs_are_refused_from_one(fp):
    """With ``stride_min`` 1 (the clips' own strides only) the plan is refused from a
    place on the stairs, saying what blocks it, never found under them."""
    import bpy

    scene = import_module(fp.__name__ + ".blender.sample.sample_scenes").build("stairs")
    ob, _ = import_module(fp.__name__ + ".blender.sample.mannequin").add_to_scene(scene, "Start")
    planning = import_module(fp.__name__ + ".blender.planning")
    navgraph = import_module(fp.__name__ + ".core.plan.navgraph")
    settings = import_module(fp.__name__ + ".core.base.settings").Settings(stride_min=1.0)
    bpy.context.view_layer.update()
    goal, heading = planning.goal_of(scene, "Goal")
    with pytest.raises(navgraph.PlanError) as err:
        planning.plan(scene, ob, goal, heading, scene.objects["Start"], settings)
    import re

    m = re.search(r"nearest reachable point is \(([-\d.]+), ([-\d.]+), ([-\d.]+)\)", str(err.value))
    assert m and "what blocks it" in str(err.value), str(err.value)
    assert float(m.group(3)) >= 0.0  # (on the flight or the floor, not under it)
