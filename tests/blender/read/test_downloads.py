"""Clips as they are downloaded: one gait cycle per file, in place, 30 fps, Mixamo's bone
names and axes (Y up, centimetres), each written by Blender's FBX exporter from the
project's sample character (``benchmarks/mixamo_like.write_character(one_cycle=True)``:
the walk cut to its 32 frames, its last frame the pose of its first, as a Mixamo walk
download is). Imported with ``import-clips``' code, they plan and bake as well as the same
clips cut long (several cycles each). Measured on the scene as Blender plays it."""

from importlib import import_module

import numpy as np
import pytest

from benchmarks import mixamo_like

CLIPS = ("walk", "run", "walk_turn_left_wide", "walk_turn_right_wide", "walk_turn_left_sharp",
         "walk_turn_right_sharp", "idle")


@pytest.fixture(scope="module")
def libraries(fp, tmp_path_factory):
    out = {}
    for cut in ("long", "one_cycle"):
        d = tmp_path_factory.mktemp(cut)
        out[cut] = mixamo_like.write_character(str(d), clips=CLIPS, one_cycle=cut == "one_cycle", fps=30)
    return out


def _bake(fp, files, scene_name: str):
    import bpy

    bpy.ops.wm.read_homefile(use_empty=True)
    import_module(fp.__name__ + ".blender.sample.sample_scenes").build(scene_name)
    scene = bpy.context.scene
    scene.render.fps = 30
    ob, _ = import_module(fp.__name__ + ".blender.read.clips").import_clips(files, name="Mixamo")
    clips = import_module(fp.__name__ + ".blender.read.character").analyze_character(ob)
    planning = import_module(fp.__name__ + ".blender.planning")
    goal, heading = planning.goal_of(scene, "Goal")
    doc = planning.run(scene, ob, goal, heading, scene.objects["Start"], name="dl", frame_start=1)
    return clips, doc


def test_one_cycle_downloads_are_read_as_loops_of_both_feet(fp, libraries):
    import bpy

    bpy.ops.wm.read_homefile(use_empty=True)
    bpy.context.scene.render.fps = 30
    ob, acts = import_module(fp.__name__ + ".blender.read.clips").import_clips(libraries["one_cycle"], name="Mixamo")
    walk = next(a for a in acts if a.name.startswith("walk_in_place"))
    assert walk.frame_range[1] - walk.frame_range[0] == 32  # (33 frames: the first pose again at the end)
    clips = import_module(fp.__name__ + ".blender.read.character").analyze_character(ob)
    assert not clips.errors, clips.errors
    by = {a.name.removesuffix("_in_place"): a for a in clips.analyses}
    for name in CLIPS[:-1]:
        a = by[name]
        assert a.kind == "cycle" and a.in_place and a.loop is not None, (name, a.kind, a.loop)
        assert {st.foot for st in a.reported_stances()} == {0, 1}
    assert by["walk"].gait == "walk" and by["run"].gait == "run" and by["idle"].kind == "idle"


@pytest.mark.parametrize("scene_name", ["turns", "obstacles"])
def test_one_cycle_downloads_plan_and_bake_as_well_as_long_clips(fp, libraries, scene_name):
    _, long_doc = _bake(fp, libraries["long"], scene_name)
    clips, doc = _bake(fp, libraries["one_cycle"], scene_name)
    q, ql = doc["quality"], long_doc["quality"]
    assert q["goal"]["distance_m"] < 0.05 and q["goal"]["distance_m"] <= ql["goal"]["distance_m"] + 0.02
    assert q["foot_skate"]["max_mm"] <= max(2 * ql["foot_skate"]["max_mm"], 0.5)
    assert q["footprint_error"]["max_mm"] <= max(2 * ql["footprint_error"]["max_mm"], 1.0)
    assert q["penetration"]["max_mm"] <= max(ql["penetration"]["max_mm"] + 2.0, 5.0)
    assert q["pops"]["introduced"]["max_excess_deg"] <= max(ql["pops"]["introduced"]["max_excess_deg"] + 1.0, 3.0)
    n, nl = len(doc["footprints"]), len(long_doc["footprints"])
    assert abs(n - nl) <= max(3, 0.15 * nl)
