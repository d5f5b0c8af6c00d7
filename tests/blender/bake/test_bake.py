"""The whole tool on the sample scenes with the real CMU library: plan, synthesize, IK,
bake into NLA, and the report measured on the baked armature; the user's animation is
never touched; the operators, the CLI bake verb (with jobs) and bad input."""

import json
from importlib import import_module

import numpy as np
import pytest

from conftest import HANG_SECONDS, needs_cmu, scene_with_cmu
from fingerprint import _keys as keys

pytestmark = needs_cmu


def _scene(fp, name, fps=30):
    return scene_with_cmu(fp, name, fps)


def _run(fp, scene, ob, **kw):
    planning = import_module(fp.__name__ + ".blender.planning")
    return planning.run(scene, ob, np.array(scene.objects["Goal"].location), start_marker=scene.objects["Start"],
                        **kw)


def _user_animation(ob, scene):
    """Give the character animation of the user's own: an extra action with keys, an NLA
    track with a strip, and a marker; return a snapshot to compare with later."""
    import bpy

    ob["transform_before"] = _transform(ob)
    act = bpy.data.actions.new("UserWave")
    act.use_fake_user = True
    slot = act.slots.new(id_type="OBJECT", name=ob.name)
    cb = act.layers.new("L").strips.new(type="KEYFRAME").channelbag(slot, ensure=True)
    fc = cb.fcurves.new('pose.bones["LeftArm"].rotation_quaternion', index=1)
    fc.keyframe_points.add(2)
    fc.keyframe_points.foreach_set("co", [1.0, 0.0, 20.0, 0.5])
    ad = ob.animation_data_create()
    tr = ad.nla_tracks.new()
    tr.name = "User layer"
    st = tr.strips.new("wave", 1, act)
    st.action_slot = slot
    scene.timeline_markers.new("user mark", frame=7)
    return _snapshot(ob, scene)


def _snapshot(ob, scene):
    """The user's animation as the planner must leave it (and give it back on Clear): the
    user's actions and keys, their NLA tracks, the active action (or the one a bake
    stashed, with its stash track left out) and markers."""
    import bpy

    ad = ob.animation_data
    ours = [st.action for t in ad.nla_tracks if t.name.startswith("Footstep: ") for st in t.strips] if ad else []
    stash = {a.get("footstep_stash_track") for a in ours} - {None}
    stashed = next((a.get("footstep_stashed_action") for a in ours if a.get("footstep_stashed_action")), None)
    return {
        "actions": sorted((a.name, tuple(v for c in _curves(a) for v in keys(c)[1::2]))
                          for a in bpy.data.actions if a.get("footstep_bake") is None),
        "tracks": [(t.name, t.mute, [(s.name, s.action.name, s.frame_start, s.frame_end) for s in t.strips])
                   for t in ad.nla_tracks if not t.name.startswith("Footstep: ") and t.name not in stash] if ad else [],
        "active": (ad.action.name if ad.action else stashed) if ad else None,
        "markers": sorted((m.name, m.frame) for m in scene.timeline_markers if not m.name.startswith("FP ")),
    }


def _transform(ob):
    """The object's own transform (the bake animates it; clear puts it back)."""
    return np.round(np.array(ob.matrix_basis), 5).tolist()


def _curves(act):
    return [c for layer in act.layers for strip in layer.strips for cb in strip.channelbags for c in cb.fcurves]


@pytest.fixture(scope="module")
def jumps_baked(fp):
    scene, ob = _scene(fp, "jumps")
    before = _user_animation(ob, scene)
    doc = _run(fp, scene, ob, name="leap", frame_start=10, markers=True)
    return scene, ob, before, doc


def test_jumps_baked_with_feet_on_the_footprints(fp, jumps_baked):
    scene, ob, before, doc = jumps_baked
    q = doc["quality"]
    assert q["foot_skate"]["mean_mm"] < 2.0 and q["foot_skate"]["max_mm"] < 10.0
    assert q["footprint_error"]["max_mm"] < 10.0  # planted foot within 1 cm of its footprint
    assert q["penetration"]["max_mm"] < 5.0
    assert q["floating"]["max_mm"] < 5.0
    assert q["goal"]["distance_m"] < 0.05
    assert q["pops"]["introduced"]["max_excess_deg"] < 10.0
    st = doc["stages"]
    assert st["frames"] == doc["frame_end"] - doc["frame_start"] + 1 and doc["frame_start"] == 10
    # every stage of Table 4.1 is reported (their times are the benchmarks' business)
    assert {"search_ms", "smoothing_ms", "refinement_ms", "body_trajectory_ms", "blend_groups_ms", "ik_ms",
            "bake_ms"} <= set(st)
    assert json.loads(json.dumps(doc)) == doc  # JSON as it is


def test_the_bake_is_an_nla_track_of_the_planners_own(fp, jumps_baked):
    scene, ob, before, doc = jumps_baked
    tracks = [t for t in ob.animation_data.nla_tracks if t.name == "Footstep: leap"]
    assert len(tracks) == 1 and len(tracks[0].strips) == 1
    strip = tracks[0].strips[0]
    assert strip.frame_start == 10 and strip.action.get("footstep_bake") == "CMU"
    assert strip.action_slot is not None and strip.action_slot.identifier == "OBCMU"
    assert len([m for m in scene.timeline_markers if m.name.startswith("FP ")]) == len(doc["footprints"])
    assert _snapshot(ob, scene) == before  # the user's animation, untouched


def test_the_baked_character_walks_the_path_when_played(fp, jumps_baked):
    """Evaluated by Blender's own depsgraph as the scene stands after the bake (the user's
    active action stashed, their own track still playing its arm wave): the armature
    object follows the body and each planted foot stands on its footprint."""
    import bpy

    scene, ob, before, doc = jumps_baked
    ad = ob.animation_data
    assert ad.action is None  # stashed: it would play over the bake
    stash = [t for t in ad.nla_tracks if t.name == "[Action Stash]"]
    assert len(stash) == 1 and stash[0].mute and stash[0].strips[0].action.name == before["active"]
    assert scene.frame_start <= doc["frame_start"] and scene.frame_end >= doc["frame_end"]  # plays to its end
    for fp_ in doc["footprints"][1::7]:
        scene.frame_set(int(fp_["frame"]))
        foot = ob.evaluated_get(bpy.context.evaluated_depsgraph_get()).pose.bones[
            "LeftFoot" if fp_["foot"] == "L" else "RightFoot"]
        ankle = np.array(ob.matrix_world @ foot.head)
        assert np.linalg.norm(ankle[:2] - np.array(fp_["position"][:2])) < 0.2
        assert ankle[2] < 0.2  # on the ground, not in the air


_PLAYED = """
import sys, json
import numpy as np
import bpy
bpy.ops.wm.open_mainfile(filepath=sys.argv[1])
scene = bpy.context.scene
ob = scene.objects["CMU"]
first, n = int(sys.argv[2]), int(sys.argv[3])
out = []
for f in range(first, first + n):
    scene.frame_set(f)
    ev = ob.evaluated_get(bpy.context.evaluated_depsgraph_get())
    out.append([list(ev.matrix_world @ pb.head) for pb in ev.pose.bones])
np.save(sys.argv[4], np.array(out))
"""


def test_the_report_measures_the_saved_scene_as_blender_plays_it(fp, jumps_baked, tmp_path):
    """The report's evaluation (bake.evaluate_played) and Blender's own, in a fresh
    process on the saved file, agree within 0.1 mm on every bone at every baked frame,
    with the user's active action still on the character (stashed) and their track."""
    import subprocess
    import sys

    import bpy

    scene, ob, before, doc = jumps_baked
    bake = import_module(fp.__name__ + ".blender.write.bake")
    rig = import_module(fp.__name__ + ".blender.read.scene").rig_from_armature(ob)
    n = doc["frame_end"] - doc["frame_start"] + 1
    world = bake.evaluate_played(scene, ob, rig, doc["frame_start"], n)[0]
    path, heads = tmp_path / "baked.blend", tmp_path / "heads.npy"
    bpy.ops.wm.save_as_mainfile(filepath=str(path), copy=True)
    subprocess.run([sys.executable, "-c", _PLAYED, str(path), str(doc["frame_start"]), str(n), str(heads)],
                   check=True, capture_output=True, timeout=HANG_SECONDS)
    played = np.load(heads)
    assert played.shape == world[..., :3, 3].shape
    assert np.abs(played - world[..., :3, 3]).max() < 1e-4


def test_rebake_replaces_only_the_planners_own_and_clear_removes_it(fp, jumps_baked):
    import bpy

    scene, ob, before, doc = jumps_baked
    character = import_module(fp.__name__ + ".blender.read.character")
    clips = character.analyze_character(ob)
    assert not [a for a in clips.analyses if a.name.startswith("Footstep ")]  # a bake is never a clip
    n_actions = len(bpy.data.actions)
    scene.frame_set(200)  # the bake has turned and moved the object here: the plan must not care
    again = _run(fp, scene, ob, name="leap", frame_start=1)  # (a bake replaces the planner's bake of its name)
    assert again["quality"]["goal"]["distance_m"] < 0.05
    assert len(again["footprints"]) == len(doc["footprints"])
    ours = [t.name for t in ob.animation_data.nla_tracks if t.name.startswith("Footstep: ")]
    assert ours == ["Footstep: leap"]
    assert len(bpy.data.actions) == n_actions  # the old bake's action went with its track
    assert _snapshot(ob, scene) == before
    bake = import_module(fp.__name__ + ".blender.write.bake")
    assert bake.clear(ob, scene) == 1
    assert not bake.owned_tracks(ob) and _snapshot(ob, scene) == before
    assert _transform(ob) == [list(r) for r in ob["transform_before"]]  # its own place again
    assert (scene.frame_start, scene.frame_end) == (1, 250)  # the frame range it had
    assert not [a for a in bpy.data.actions if a.get("footstep_bake") is not None]


def test_bake_operator_clear_operator_undo_and_panel(fp):
    import bpy

    from conftest import draw_tab

    scene, ob = _scene(fp, "obstacles")
    scene.footstep.character = ob
    scene.footstep.goal = scene.objects["Goal"]
    scene.footstep.start = scene.objects["Start"]
    assert bpy.ops.footstep.build_graph() == {"FINISHED"}
    assert "footsteps" in scene.footstep.last_report
    bpy.ops.ed.undo_push(message="before bake")
    assert bpy.ops.footstep.bake() == {"FINISHED"}
    bpy.ops.ed.undo_push(message="Bake")  # (the UI pushes after an UNDO operator; scripts do it)
    doc = json.loads(scene.footstep.plan_json)
    assert doc["quality"]["foot_skate"]["max_mm"] < 10.0
    ob = bpy.data.objects["CMU"]
    assert [t.name for t in ob.animation_data.nla_tracks if t.name.startswith("Footstep: ")]
    log = draw_tab(fp, bpy.context)  # (the tab and its sub-panels)
    ops = {a[0] for name, a, _ in log if name == "operator" and a}
    assert {"footstep.build_graph", "footstep.plan", "footstep.bake", "footstep.clear"} <= ops
    labels = [kw.get("text", "") for name, a, kw in log if name == "label"]
    assert any("skate" in t for t in labels) and any("refinement" in t for t in labels)
    bpy.ops.ed.undo()  # undo restores the scene before the bake
    ob = bpy.data.objects["CMU"]
    assert not [t for t in (ob.animation_data.nla_tracks if ob.animation_data else [])
                if t.name.startswith("Footstep: ")]
    assert bpy.ops.footstep.bake() == {"FINISHED"}
    assert bpy.ops.footstep.clear() == {"FINISHED"}
    ob = bpy.data.objects["CMU"]
    assert not [t for t in ob.animation_data.nla_tracks if t.name.startswith("Footstep: ")]


def test_bad_input_is_refused_with_a_clear_message_and_nothing_changed(fp):
    import bpy

    scene, ob = _scene(fp, "jumps")
    before = _user_animation(ob, scene)
    n_actions = len(bpy.data.actions)
    planning = import_module(fp.__name__ + ".blender.planning")
    errors = import_module(fp.__name__ + ".core.base.errors")
    goal = np.array(scene.objects["Goal"].location)
    start = scene.objects["Start"]
    cases = []
    # a goal off every surface
    cases.append((lambda: planning.run(scene, ob, np.array([60.0, 60.0, 0.0]), start_marker=start),
                  "off every traversable surface"))
    # an unreachable goal (across a gap wider than any jump)
    cases.append((lambda: planning.run(scene, ob, goal + [30.0, 0, 0], start_marker=start), "off every|reached"))
    # the character scaled unevenly in object mode (an even scale is taken as Blender shows it)
    def scaled():
        ob.scale = (2, 2, 1)
        try:
            planning.run(scene, ob, goal, start_marker=start)
        finally:
            ob.scale = (1, 1, 1)
    cases.append((scaled, "'CMU' is scaled"))
    # no traversable mesh
    def untagged():
        bpy.data.collections["Traversable"].footstep.surface = "NONE"
        try:
            planning.run(scene, ob, goal, start_marker=start)
        finally:
            bpy.data.collections["Traversable"].footstep.surface = "TRAVERSABLE"
    cases.append((untagged, "no traversable mesh"))
    for fn, msg in cases:
        with pytest.raises(errors.FootstepError, match=msg):
            fn()
        assert len(bpy.data.actions) == n_actions and _snapshot(ob, scene) == before
        assert not [t for t in ob.animation_data.nla_tracks if t.name.startswith("Footstep: ")]


def test_cli_bake_verb_with_jobs(fp, tmp_path, capsys):
    import bpy

    scene, ob = _scene(fp, "turns")
    path = str(tmp_path / "turns.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path)
    jobs = tmp_path / "jobs.json"
    jobs.write_text(json.dumps([
        {"character": "CMU", "goal": "Goal", "start": "Start", "name": "to goal", "report": str(tmp_path / "a.json")},
        {"character": "Nobody", "goal": "Goal"},  # fails: no such character; the others still run
        {"character": "CMU", "goal": "Start", "start": "Goal", "name": "back", "frame_start": 3000,
         "report": str(tmp_path / "c.json")},
    ]))
    cli = import_module(fp.__name__ + ".blender.command.cli").cli_main
    capsys.readouterr()
    out_blend = str(tmp_path / "baked.blend")
    assert cli(["bake", path, "--job", str(jobs), "--out", out_blend]) == 1  # one job failed
    captured = capsys.readouterr()
    assert "job 2 (Nobody to Goal)" in captured.err and "'Nobody'" in captured.err
    assert "2 of 3 jobs baked, 1 failed" in captured.out and " invalid " in captured.out
    a, c = (json.loads((tmp_path / n).read_text()) for n in ("a.json", "c.json"))
    assert a["quality"]["goal"]["distance_m"] < 0.05 and c["frame_start"] == 3000
    bpy.ops.wm.open_mainfile(filepath=out_blend)
    names = [t.name for t in bpy.data.objects["CMU"].animation_data.nla_tracks]
    assert names.count("Footstep: back") == 1 and names.count("Footstep: to goal") == 1  # each bake its own track
    assert cli(["bake", path, "--character", "CMU", "--goal", "Goal", "--start", "Start",
                "--report", str(tmp_path / "one.json")]) == 0
    assert json.loads((tmp_path / "one.json").read_text())["quality"]["foot_skate"]["max_mm"] < 10.0


def test_body_on_the_root_bone(fp):
    """A rig with a root bone above the hips: the body's motion is keyed on the root bone
    and the armature object stays where it is; without a root bone, a clear refusal."""
    import bpy

    scene, ob = _scene(fp, "obstacles")
    bake = import_module(fp.__name__ + ".blender.write.bake")
    errors = import_module(fp.__name__ + ".core.base.errors")
    with pytest.raises(errors.FootstepError, match="no root bone"):
        _run(fp, scene, ob, name="no root", body_on="ROOT")
    assert not bake.owned_tracks(ob)
    # give the rig a root bone at the origin, carrying the hips
    bpy.context.view_layer.objects.active = ob
    bpy.ops.object.mode_set(mode="EDIT")
    eb = ob.data.edit_bones
    root = eb.new("root")
    root.head, root.tail = (0, 0, 0), (0, 0.3, 0)
    eb["Hips"].parent = root
    bpy.ops.object.mode_set(mode="OBJECT")
    ob.location, ob.rotation_euler.z = (-4.0, -7.0, 0.0), 0.4  # away from the origin, turned
    bpy.context.view_layer.update()
    before = np.array(ob.matrix_world)
    doc = _run(fp, scene, ob, name="on root", body_on="ROOT")
    q = doc["quality"]
    assert q["foot_skate"]["max_mm"] < 10.0 and q["goal"]["distance_m"] < 0.05
    act = bake.owned_tracks(ob)[0].strips[0].action
    paths = {c.data_path for c in _curves(act)}
    assert 'pose.bones["root"].location' in paths and "location" not in paths  # the object is not keyed
    scene.frame_set(doc["frame_end"])
    np.testing.assert_allclose(np.array(ob.matrix_world), before)  # it stays put


def test_more_bad_input_legs_library_and_frame_rate(fp):
    """A character without mapped legs and an emptied clip library are refused by name
    with nothing changed; a scene at another frame rate than the clips (24 fps against
    the clips' 120) is not an error: the clips are sampled at the scene's rate."""
    import bpy

    scene, ob = _scene(fp, "obstacles", fps=24)
    planning = import_module(fp.__name__ + ".blender.planning")
    errors = import_module(fp.__name__ + ".core.base.errors")
    goal = np.array(scene.objects["Goal"].location)
    start = scene.objects["Start"]
    n_actions = len(bpy.data.actions)
    # an armature with no legs
    arm = bpy.data.armatures.new("Snake")
    snake = bpy.data.objects.new("Snake", arm)
    scene.collection.objects.link(snake)
    bpy.context.view_layer.objects.active = snake
    bpy.ops.object.mode_set(mode="EDIT")
    b = arm.edit_bones.new("Body")
    b.head, b.tail = (0, 0, 0), (0, 1, 0)
    bpy.ops.object.mode_set(mode="OBJECT")
    with pytest.raises(errors.FootstepError, match="'Snake'"):
        planning.run(scene, snake, goal, start_marker=start)
    # every clip excluded from the library
    character = import_module(fp.__name__ + ".blender.read.character")
    clips = character.analyze_character(ob)
    character.write_library(ob, character.library_for(ob, clips), clips.analyses)
    for item in ob.data.footstep.clips:
        item.usage = "EXCLUDED"
    with pytest.raises(errors.FootstepError, match="library gives no steps"):
        planning.run(scene, ob, goal, start_marker=start)
    assert len(bpy.data.actions) == n_actions
    assert not (ob.animation_data and [t for t in ob.animation_data.nla_tracks if t.name.startswith("Footstep")])
    # back to the proposal: at 24 fps the bake keeps the feet on the footprints
    ob.data.footstep.library_edited = False
    doc = planning.run(scene, ob, goal, start_marker=start)
    q = doc["quality"]
    assert q["foot_skate"]["max_mm"] < 10.0 and q["goal"]["distance_m"] < 0.05
    assert doc["synthesis"]["fps"] == 24.0


def test_without_a_start_the_character_starts_where_it_stands_and_rebakes_the_same(fp):
    """No Start object: the path leaves from under the character's hips, facing its
    forward, whatever its active clip does at the current frame and wherever the
    planner's own bake has moved it; baking again gives the same footprints."""
    import bpy

    scene, ob = _scene(fp, "obstacles")
    start = scene.objects["Start"]
    ob.location = start.location
    ob.rotation_euler.z = start.rotation_euler.z
    assert ob.animation_data.action is not None  # the importer left a clip active
    planning = import_module(fp.__name__ + ".blender.planning")
    goal, heading = planning.goal_of(scene, "Goal")
    scene.frame_set(37)
    first = planning.run(scene, ob, goal, heading, None, name="here", frame_start=1)
    p0 = np.array(first["synthesis"]["footprints"][0]["planned"])  # a standing foot, beside the hips
    lo, hi = import_module(fp.__name__ + ".core.plan.setup").STAND_HALF_WIDTH_RANGE  # (half the walk's stance width)
    assert lo - 0.01 < np.linalg.norm(p0[:2] - np.array(start.location[:2])) < hi + 0.01
    scene.frame_set(first["frame_end"])  # the bake has carried the object to the goal
    again = planning.run(scene, ob, goal, heading, None, name="here", frame_start=1)
    a = np.array([f["position"] for f in first["footprints"]])
    b = np.array([f["position"] for f in again["footprints"]])
    assert a.shape == b.shape and np.abs(a - b).max() < 1e-3  # (the report rounds to 0.1 mm)
    assert again["quality"]["goal"]["distance_m"] < 0.05
    bpy.ops.wm.read_homefile(use_empty=True)


def test_bake_and_clear_give_back_the_whole_scene_with_a_cmu_character(fp):
    """Issue 26: a CMU (BVH) character with animation of the user's own (an active clip,
    an NLA layer, a marker), baked twice with markers and cleared: the whole scene's
    fingerprint as before."""
    from fingerprint import differences, fingerprint

    scene, ob = _scene(fp, "obstacles")
    _user_animation(ob, scene)
    del ob["transform_before"]
    ob.rotation_euler.z += 4 * np.pi  # (typed beyond 360 degrees)
    before = fingerprint()
    first = _run(fp, scene, ob, name="one", frame_start=1, markers=True)
    _run(fp, scene, ob, name="two", frame_start=first["frame_end"] + 1, markers=True)
    scene.frame_set(first["frame_end"])
    scene.frame_current = before["scenes"][scene.name]["current"]
    assert import_module(fp.__name__ + ".blender.write.bake").clear(ob, scene) == 2
    after = fingerprint()
    assert after == before, "\n".join(differences(before, after)[:20])
