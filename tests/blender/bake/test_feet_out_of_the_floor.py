"""The clips people download, baked: the CC0 Quaternius game character imported from its FBX
as it is (11 one-cycle takes at 24 fps, its feet parented to its root bone, 4.85 m tall,
set to a human's size by its object's scale, as its README says a user does) plans and
bakes the sample scenes from standing to standing with its idle, the Jumps scene's gaps
crossed by its running steps (2 m and more: they span them) or its running jump; and with every library, as Blender plays the bake, no heel, ball or toe tip
goes more than 1 cm into the floor (the toe tip: its toe bone's end, or for a foot with no
toe bone, like the Quaternius one, its skinned mesh's)."""

from importlib import import_module

import numpy as np
import pytest

from conftest import cmu_armature, needs_cmu
from conftest import QUATERNIUS, needs_quaternius

#: m: no heel, ball or toe tip of a played bake goes deeper into the floor than this.
DEEPEST = 0.010


def _scene(fp, name: str):
    import bpy

    bpy.ops.wm.read_homefile(use_empty=True)
    import_module(fp.__name__ + ".blender.sample.sample_scenes").build(name)
    scene = bpy.context.scene
    scene.render.fps = 30
    return scene


def _bake(fp, scene, ob):
    planning = import_module(fp.__name__ + ".blender.planning")
    start = scene.objects["Start"]
    ob.location, ob.rotation_euler.z = start.location, start.rotation_euler.z
    goal, heading = planning.goal_of(scene, "Goal")
    return planning.run(scene, ob, goal, heading, start, name="feet", frame_start=1)


def _gap_crossings(fp, scene, footprints):
    """The footprints of the path whose step from the one before crosses missing ground
    (no traversable surface within 0.5 m under a point a quarter, half or three quarters
    of the way)."""
    import bpy

    surfaces = import_module(fp.__name__ + ".blender.read.surfaces")
    ground, _ = surfaces.scene_surfaces(scene, bpy.context.evaluated_depsgraph_get())
    out = []
    for a, b in zip(footprints[:-1], footprints[1:]):
        pa, pb = np.asarray(a["position"], float), np.asarray(b["position"], float)
        pts = pa + np.array([0.25, 0.5, 0.75])[:, None] * (pb - pa)
        pts[:, 2] = max(pa[2], pb[2]) + 0.25
        if not ground.ray_down(pts, 0.5).hit.all():
            out.append(b)
    return out


def _quaternius(fp, scene):
    clips = import_module(fp.__name__ + ".blender.read.clips")
    scene_mod = import_module(fp.__name__ + ".blender.read.scene")
    body = import_module(fp.__name__ + ".core.clips.body")
    ob, _ = clips.import_clips([QUATERNIUS], name="Quaternius")
    ob.scale = (1.0 / body.body_scale(scene_mod.rig_from_armature(ob)),) * 3
    return ob


def _check(doc, tolerance_mm=(1.0, 1.0)):
    q = doc["quality"]
    assert q["goal"]["distance_m"] < 0.05
    assert q["foot_skate"]["max_mm"] < tolerance_mm[0] and q["footprint_error"]["max_mm"] < tolerance_mm[1]
    pen = q["penetration"]
    assert "tip_max_mm" in pen and pen["lowest_mm"] <= DEEPEST * 1000, pen


@needs_quaternius
@pytest.mark.parametrize("name", ["turns", "jumps", "obstacles"])
def test_the_quaternius_character_as_downloaded_bakes_the_sample_scenes(fp, name):
    scene = _scene(fp, name)
    ob = _quaternius(fp, scene)
    doc = _bake(fp, scene, ob)
    _check(doc)
    clips = doc["synthesis"]["clips"]
    assert "Man_Idle" in clips  # (it stands at either end in its own idle, not its clapping)
    assert not any(c in clips for c in ("Man_Death", "Man_Sitting", "Man_Clapping", "Man_SwordSlash"))
    if name == "jumps":  # (its running steps are 2 m or more: each gap crossed by a run or its jump)
        crossing = _gap_crossings(fp, scene, doc["footprints"])
        assert crossing and all(f["gait"] == "run" or f["jump"] for f in crossing), crossing
        assert not any(f["jump"] for f in doc["footprints"]) or "Man_RunningJump" in clips
    body = np.asarray(doc["synthesis"]["body"]["position"])
    v = np.linalg.norm(np.diff(body[:, :2], axis=0), axis=1) * doc["synthesis"]["fps"]
    assert v[0] < 0.02 and v[-1] < 0.02  # (from standing to standing)


def test_the_sample_character_keeps_its_toes_out_of_the_floor(fp):
    scene = _scene(fp, "stairs")
    ob, _ = import_module(fp.__name__ + ".blender.sample.mannequin").add_to_scene(scene, "Start")
    _check(_bake(fp, scene, ob))


@needs_cmu
def test_the_cmu_library_keeps_its_toes_out_of_the_floor(fp):

    scene = _scene(fp, "obstacles")
    ob = cmu_armature(fp)
    _check(_bake(fp, scene, ob), (1.0, 10.0))
