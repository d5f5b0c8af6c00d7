"""Start from standing and stop to standing (issue 14), measured on the scene as Blender
plays it: the baked character stands still on both feet at its first frame, speeds up
from rest without a jerk, and ends standing still at the goal, facing the goal's way,
for ``stand_hold`` seconds. With the sample character (its idle clip) and with the CMU
library (no idle, start or stop clip: the standing pose is made from its walk)."""

from importlib import import_module

import numpy as np
import pytest

from conftest import needs_cmu, scene_with_cmu

FPS = 30


def _sample_scene(fp, name):
    import bpy

    bpy.ops.wm.read_homefile(use_empty=True)
    scene = import_module(fp.__name__ + ".blender.sample.sample_scenes").build(name)
    scene.render.fps = FPS
    ob, _ = import_module(fp.__name__ + ".blender.sample.mannequin").add_to_scene(scene, "Start")
    return scene, ob


def _bake(fp, scene, ob, settings=None):
    planning = import_module(fp.__name__ + ".blender.planning")
    goal, heading = planning.goal_of(scene, "Goal")
    doc = planning.run(scene, ob, goal, heading, scene.objects["Start"], settings=settings, name="stand",
                       frame_start=1)
    return doc, heading


def _played(fp, scene, ob, doc):
    """(foot points (4, F, 3): left heel, right heel, left ball, right ball; their heights
    over the ground (4, F); body positions (F, 3); body yaw (F,)) as Blender plays it."""
    planning = import_module(fp.__name__ + ".blender.planning")
    bake = import_module(fp.__name__ + ".blender.write.bake")
    report = import_module(fp.__name__ + ".core.report.document")
    setup = planning.plan_setup(scene, ob)
    n = doc["frame_end"] - doc["frame_start"] + 1
    world, body, yaw, _ = bake.evaluate_played(scene, ob, setup.rig, doc["frame_start"], n)
    feet = doc["feet"]
    bones = [setup.rig.names.index(b) for b in feet["bones"]]
    pts = np.stack([(world[:, bones[k]] @ np.array(feet[key][k]))[:, :3]
                    for key in ("heel_local", "toe_local") for k in range(2)])
    height = pts[..., 2] - np.stack([report.ground_under(setup.planner.ground, p) for p in pts])
    return pts, height, body, yaw


def _check_standing(fp, scene, ob, doc, goal_heading, hold=1.0):
    pts, height, body, yaw = _played(fp, scene, ob, doc)
    speed = np.linalg.norm(np.diff(pts, axis=1), axis=-1) * FPS  # (4, F-1) m/s
    body_v = np.linalg.norm(np.diff(body[:, :2], axis=0), axis=-1) * FPS
    body_a = np.abs(np.diff(body_v)) * FPS
    first, last = int(round(0.3 * FPS)), int(round(hold * FPS))
    # the first frame: both feet flat on the ground (heels and balls within 1 cm), still
    assert np.abs(height[:, 0]).max() < 0.01
    assert speed[:, :first].max() < 0.02
    assert body_v[0] < 0.02
    # speeding up from rest and slowing down to it: no jerk beyond what the walk itself
    # has between them (its frame-to-frame changes of speed, m/s^2)
    walking = body_a[4 * FPS:-5 * FPS].max()
    assert body_a[:3 * FPS].max() <= 1.5 * walking
    assert body_a[-4 * FPS:].max() <= 1.5 * walking
    # the end: both feet planted and the body still for the hold
    assert np.abs(height[:, -last:]).max() < 0.01
    assert speed[:, -last:].max() < 0.01 and body_v[-last:].max() < 0.01
    q = doc["quality"]
    assert q["goal"]["distance_m"] < 0.05
    if goal_heading is not None:
        assert q["goal"]["heading_deg"] < 5.0
    assert q["foot_skate"]["max_mm"] < 1.0
    return body_v


@pytest.fixture(scope="module")
def sample_turns(fp):
    scene, ob = _sample_scene(fp, "turns")
    doc, heading = _bake(fp, scene, ob)
    return scene, ob, doc, heading


def test_the_sample_character_starts_and_stops_standing_on_turns(fp, sample_turns):
    scene, ob, doc, heading = sample_turns
    assert heading is not None  # (the Goal empty's facing: the heading to arrive with)
    body_v = _check_standing(fp, scene, ob, doc, heading)
    assert doc["quality"]["pops"]["introduced"]["max_excess_deg"] < 5.0
    assert body_v.max() > 1.0  # (and it does walk)
    syn = doc["synthesis"]
    assert "idle" in syn["clips"]  # its own idle clip stands
    fps_ = doc["footprints"]
    # the path holds both standing feet at either end: side by side, the last two facing the goal
    assert fps_[0]["foot"] != fps_[1]["foot"] and fps_[-1]["foot"] != fps_[-2]["foot"]
    for a, b in ((fps_[0], fps_[1]), (fps_[-2], fps_[-1])):
        d = np.subtract(a["position"][:2], b["position"][:2])
        assert 0.1 < np.linalg.norm(d) < 0.4
    assert fps_[0]["planted_frames"][0] == fps_[1]["planted_frames"][0] == doc["frame_start"]
    assert fps_[-1]["planted_frames"][1] == fps_[-2]["planted_frames"][1] == doc["frame_end"]


def _standing_frames(doc) -> int:
    """Frames at the end where the walk stands still (its normalized time no longer moves)."""
    u = np.asarray(doc["synthesis"]["curves"]["u"])
    return int(len(u) - np.flatnonzero(u < u[-1] - 1e-9)[-1] - 1)


def test_the_hold_at_the_goal_is_a_setting(fp, sample_turns):
    settings = import_module(fp.__name__ + ".core.base.settings")
    scene, ob, doc, heading = sample_turns
    longer, _ = _bake(fp, scene, ob, settings.Settings(stand_hold=2.0))
    assert _standing_frames(longer) - _standing_frames(doc) == pytest.approx(FPS, abs=1)
    assert _standing_frames(doc) >= FPS  # (at least the hold, after the feet settle)
    _check_standing(fp, scene, ob, longer, heading, hold=2.0)


@needs_cmu
def test_the_cmu_library_starts_and_stops_standing_on_turns(fp):
    """No idle, start or stop clip: the standing pose is its walk's, held where one foot
    swings past the other, the feet laid flat; speeding up and slowing down time-warp the
    walk from and to rest."""
    scene, ob = scene_with_cmu(fp, "turns", FPS)
    doc, heading = _bake(fp, scene, ob)
    _check_standing(fp, scene, ob, doc, heading)
    assert any(c.endswith("~stand") for c in doc["synthesis"]["clips"])
