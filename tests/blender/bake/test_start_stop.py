"""The library's own start and stop clips (issue 14): where the library has a start clip
(a stop clip) and the path's first (last) steps walk straight on, the clip plays over
them, keyed to the planned footprints as a jump is, from the standing feet and to them;
elsewhere, and for a library without such clips, the start and stop are synthesized from
the walk. Measured on the scene as Blender plays it."""

import math
from importlib import import_module

import numpy as np
import pytest

from conftest import CMU, cmu_armature, needs_cmu
from test_standing import FPS, _played

from footstep_planner.core.sample import gait, mannequin
from footstep_planner.core.clips.analysis import analyze_clip
from footstep_planner.core.synth.tracks import make_track
from footstep_planner.core.clips.clip import clip_motion
from footstep_planner.core.clips.mirror import Mirror, lead_foot
from footstep_planner.core.synth.ends import end_windows


@pytest.fixture(scope="module")
def sample_ends():
    """The sample character's start and stop clips analysed (core only)."""
    rig = mannequin.rig()
    specs = {s.name: s for s in gait.library_specs()}
    out = {}
    for name in ("walk_start", "walk_stop"):
        c = gait.generate(rig, specs[name], FPS)
        out[name] = analyze_clip(clip_motion(rig, name, c.basis, FPS))
    return rig, out


@pytest.mark.parametrize("name", ["walk_start", "walk_stop"])
def test_a_start_or_stop_clip_leads_with_one_foot_and_its_mirror_with_the_other(sample_ends, name):
    rig, clips = sample_ends
    a = clips[name]
    mirror = Mirror(rig).analysis(a)
    for clip in (a, mirror):
        foot, win = end_windows(make_track(clip))
        assert foot == lead_foot(clip)
        assert len(win) >= 3  # (its steps and the one it ramps over)
        assert all(b > a_ for a_, b in win) and all(w0[1] == w1[0] for w0, w1 in zip(win[:-1], win[1:]))
    assert lead_foot(mirror) == 1 - lead_foot(a)
    # the first step off standing lifts the foot clear: the analysis sees each foot's first step
    if name == "walk_start":
        assert sum(st.open_start for st in a.stances) == 2
        assert sorted(st.foot for st in a.stances[:4] if not st.open_start)[:2] == [0, 1]


def _check_standing(fp, scene, ob, doc, goal_heading, hold=1.0):
    """Standing still on both feet at the first frame and for ``hold`` s at the last, at
    the goal facing its way; no foot skate (``test_standing._check_standing`` without its
    jerk bound: on a straight walk the walk's own speed hardly changes)."""
    pts, height, body, _ = _played(fp, scene, ob, doc)
    speed = np.linalg.norm(np.diff(pts, axis=1), axis=-1) * FPS
    body_v = np.linalg.norm(np.diff(body[:, :2], axis=0), axis=-1) * FPS
    first, last = int(round(0.3 * FPS)), int(round(hold * FPS))
    assert np.abs(height[:, 0]).max() < 0.01
    assert speed[:, :first].max() < 0.02 and body_v[0] < 0.02
    assert np.abs(height[:, -last:]).max() < 0.01
    assert speed[:, -last:].max() < 0.01 and body_v[-last:].max() < 0.01
    q = doc["quality"]
    assert q["goal"]["distance_m"] < 0.05 and q["goal"]["heading_deg"] < 5.0
    assert q["foot_skate"]["max_mm"] < 1.0 and body_v.max() > 0.8


def _straight_scene(length=14.0):
    """An open floor, a Start empty at the origin facing -Y and a Goal ``length`` m ahead,
    facing the same way."""
    import bpy

    from footstep_planner.blender.sample import sample_scenes as ss
    bpy.ops.wm.read_homefile(use_empty=True)
    scene = bpy.context.scene
    scene.render.fps = FPS
    t = ss._collection(scene, "Traversable", "TRAVERSABLE")
    ss._prism(t, "Floor", ss._rect(-3.0, 3.0, -length - 3.0, 3.0), 0.0, -0.2)
    ss._marker(scene, "Start", (0.0, 0.0, 0.0), 0.0)
    ss._marker(scene, "Goal", (0.0, -length, 0.0), 0.0)
    return scene


def _bake_straight(fp, ob, scene):
    planning = import_module(fp.__name__ + ".blender.planning")
    goal, heading = planning.goal_of(scene, "Goal")
    doc = planning.run(scene, ob, goal, heading, scene.objects["Start"], name="ends", frame_start=1)
    return doc, heading


def _check_own_ends(fp, scene, ob, doc, heading, start: str, stop: str):
    """The clips ``start`` and ``stop`` (or their mirror images) play over the first and
    the last steps; the feet stand on the standing footprints from frame 1 and the first
    footprint leaves from them; the standing ends, goal and pops as ``_check_standing``."""
    syn = doc["synthesis"]
    names = {c.split("~")[0]: c for c in syn["clips"]}
    assert start in names and stop in names, syn["clips"]
    w = {k: np.asarray(syn["weights"][names[k]]) for k in (start, stop)}
    fps_ = doc["footprints"]
    f0 = doc["frame_start"]
    # the start clip is all there is of the motion from the first frame the standing clip
    # leaves to the first footprint's landing; the stop clip from the last step's lift on
    lift = fps_[0]["planted_frames"][1] - f0
    land = fps_[2]["planted_frames"][0] - f0
    assert w[start][0] == 0.0 and (w[start][lift:land + 1] > 0.99).all()
    last_lift = fps_[-1]["planted_frames"][0] - f0 - 8
    assert (w[stop][last_lift:fps_[-1]["planted_frames"][0] - f0] > 0.99).all()
    # both feet stand on the standing footprints at frame 1 (heel/toe middle within 1 cm)
    pts, _, _, _ = _played(fp, scene, ob, doc)
    mid = 0.5 * (pts[:2] + pts[2:])  # (2 feet, F, 3)
    for fp_ in fps_[:2]:
        k = "LR".index(fp_["foot"])
        assert np.linalg.norm(mid[k, 0] - fp_["position"]) < 0.01
        assert fp_["planted_frames"][0] == f0
    # the first footprint to leave is fp0's foot: it lands on the footprint after the other
    assert fps_[0]["foot"] == fps_[2]["foot"] != fps_[1]["foot"]
    assert fps_[0]["planted_frames"][1] < fps_[1]["planted_frames"][1]
    assert fps_[0]["planted_frames"][1] <= fps_[2]["planted_frames"][0]
    _check_standing(fp, scene, ob, doc, heading)
    assert doc["quality"]["pops"]["introduced"]["max_excess_deg"] < 1.0  # (a toe-off at most, by a hair)
    assert doc["quality"]["goal"]["distance_m"] < 0.05


def test_the_sample_character_starts_and_stops_with_its_own_clips(fp):
    scene = _straight_scene()
    ob, _ = import_module(fp.__name__ + ".blender.sample.mannequin").add_to_scene(scene, "Start")
    doc, heading = _bake_straight(fp, ob, scene)
    _check_own_ends(fp, scene, ob, doc, heading, "walk_start", "walk_stop")
    assert "idle" in doc["synthesis"]["clips"]  # (and its idle stands at either end)


@needs_cmu
def test_the_cmu_library_starts_and_stops_with_its_own_clips(fp):
    """Subject 16's walk library with its start from standing (16_31) and walk to a stop
    (16_33): no idle clip (the standing pose is its walk's), its own start and stop."""
    import os

    from benchmarks.library import ENDS, LIBRARY, cmu_files

    scene = _straight_scene()
    ob = cmu_armature(fp, tuple(LIBRARY + ENDS))
    start = scene.objects["Start"]
    ob.location, ob.rotation_euler.z = start.location, start.rotation_euler.z
    doc, heading = _bake_straight(fp, ob, scene)
    names = [os.path.basename(f)[:-4] for f in cmu_files(CMU, ENDS)]
    _check_own_ends(fp, scene, ob, doc, heading, *names)


def test_a_library_without_start_and_stop_clips_synthesizes_them(fp):
    """The sample character with its walk and idle clips only: the start speeds the walk up
    from the idle pose, the stop slows it down to it, as before."""
    scene = _straight_scene()
    mod = import_module(fp.__name__ + ".blender.sample.mannequin")
    ob, _ = mod.add_to_scene(scene, "Start", clips=False)
    mod.generate_clips(ob, names=["walk", "idle"])
    import_module(fp.__name__ + ".blender.read.character").analyze_and_propose(ob)
    doc, heading = _bake_straight(fp, ob, scene)
    clips = doc["synthesis"]["clips"]
    assert not any(c.startswith(("walk_start", "walk_stop")) for c in clips) and "idle" in clips
    _check_standing(fp, scene, ob, doc, heading)


def test_a_start_that_turns_at_once_is_synthesized(fp):
    """The Start turned a quarter turn off the way (short of a turn in place): the first
    steps turn, which the straight start clip cannot; its start is synthesized, its stop
    is its own."""
    scene = _straight_scene()
    scene.objects["Start"].rotation_euler.z = math.radians(60.0)
    ob, _ = import_module(fp.__name__ + ".blender.sample.mannequin").add_to_scene(scene, "Start")
    doc, heading = _bake_straight(fp, ob, scene)
    clips = doc["synthesis"]["clips"]
    assert not any(c.startswith("walk_start") for c in clips)
    assert any(c.startswith("walk_stop") for c in clips)
    _check_standing(fp, scene, ob, doc, heading)
