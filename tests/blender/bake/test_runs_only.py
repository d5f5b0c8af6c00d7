"""A library that runs and never walks (CMU subject 16's jogs, straight, veering and
turning, and its run to a sudden stop; no walk clip): it plans from standing to standing,
starting from its standing pose (made from its straightest run) and stopping with its own
run-to-stop clip where the way ends straight. Measured on the scene as Blender plays it."""

from importlib import import_module

import numpy as np
import pytest

from conftest import CMU, needs_cmu
from test_start_stop import _bake_straight, _check_standing, _straight_scene

RUNS = ["16_35", "16_37", "16_39", "16_41", "16_43"]
STOP = "16_57"


def _runs_only(fp, scene, names):
    from benchmarks.library import cmu_files

    ob, _ = import_module(fp.__name__ + ".blender.read.clips").import_clips(cmu_files(CMU, names), name="CMU")
    start = scene.objects["Start"]
    ob.location, ob.rotation_euler.z = start.location, start.rotation_euler.z
    return ob


@needs_cmu
def test_a_runs_only_library_runs_from_standing_to_standing_with_its_own_stop(fp):
    scene = _straight_scene()
    ob = _runs_only(fp, scene, RUNS + [STOP])
    doc, heading = _bake_straight(fp, ob, scene)
    syn = doc["synthesis"]
    assert all(f["gait"] == "run" for f in doc["footprints"][1:-1] if not f.get("jump")), \
        [f["gait"] for f in doc["footprints"]]
    stop = [c for c in syn["clips"] if c.startswith("cmu_16_57")]
    assert stop, syn["clips"]  # (the straight way ends with its run to a stop)
    _check_standing(fp, scene, ob, doc, heading)
    body = np.asarray(syn["body"]["position"])
    speed = np.linalg.norm(np.diff(body[:, :2], axis=0), axis=1) * syn["fps"]
    assert speed.max() > 2.0  # (it runs: the jogs go 2.2 to 2.8 m/s)


@needs_cmu
@pytest.mark.parametrize("name", ["turns", "obstacles"])
def test_a_runs_only_library_bakes_the_sample_scenes(fp, name):
    """Without a stop clip (the jogs alone): the start and the stop are both made from its
    standing pose; the goal is met and no planted foot slides."""
    import bpy

    bpy.ops.wm.read_homefile(use_empty=True)
    import_module(fp.__name__ + ".blender.sample.sample_scenes").build(name)
    scene = bpy.context.scene
    scene.render.fps = 30
    ob = _runs_only(fp, scene, RUNS)
    planning = import_module(fp.__name__ + ".blender.planning")
    goal, heading = planning.goal_of(scene, "Goal")
    doc = planning.run(scene, ob, goal, heading, scene.objects["Start"], name="runs", frame_start=1)
    q = doc["quality"]
    assert q["goal"]["distance_m"] < 0.06 and q["foot_skate"]["max_mm"] < 1.0
    body = np.asarray(doc["synthesis"]["body"]["position"])
    v = np.linalg.norm(np.diff(body[:, :2], axis=0), axis=1) * doc["synthesis"]["fps"]
    assert v[0] < 0.02 and v[-1] < 0.02 and v.max() > 2.0
