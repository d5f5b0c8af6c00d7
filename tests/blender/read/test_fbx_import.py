"""Importing FBX clips as Mixamo delivers them: Y up, centimetres, ``mixamorig:`` names.

The files are made here, from the project's own sample character: the Footstep Mannequin
and its generated clips, its bones renamed to Mixamo's, the armature turned and scaled the
way Mixamo files come into Blender (90 degrees about X, scale 0.01, bones and location keys
in centimetres), and written one clip per file by Blender's FBX exporter.
"""

import json
import os
from importlib import import_module

import numpy as np
import pytest

from benchmarks import mixamo_like
from benchmarks.mixamo_like import MIXAMO, PREFIX

FRAMES = (1, 6, 13, 20, 27, 34, 41)  # where bone positions are compared
CLIPS = ("walk", "run")


def _mixamo_skeleton():
    """Mixamo's full skeleton (no prefix): (names, parent indices)."""
    tree = [("Hips", None), ("Spine", "Hips"), ("Spine1", "Spine"), ("Spine2", "Spine1"),
            ("Neck", "Spine2"), ("Head", "Neck"), ("HeadTop_End", "Head")]
    for side in ("Left", "Right"):
        tree += [(f"{side}Shoulder", "Spine2"), (f"{side}Arm", f"{side}Shoulder"),
                 (f"{side}ForeArm", f"{side}Arm"), (f"{side}Hand", f"{side}ForeArm")]
        for finger in ("Thumb", "Index", "Middle", "Ring", "Pinky"):
            tree += [(f"{side}Hand{finger}{i}", f"{side}Hand{finger}{i - 1}" if i > 1 else f"{side}Hand")
                     for i in range(1, 5)]
        tree += [(f"{side}UpLeg", "Hips"), (f"{side}Leg", f"{side}UpLeg"), (f"{side}Foot", f"{side}Leg"),
                 (f"{side}ToeBase", f"{side}Foot"), (f"{side}Toe_End", f"{side}ToeBase")]
    names = [n for n, _ in tree]
    return names, [names.index(p) if p else -1 for _, p in tree]


@pytest.mark.parametrize("prefix", ["mixamorig:", "mixamorig1:", "mixamorig12:", ""])
def test_mixamo_names_map_to_roles_with_or_without_the_prefix(prefix):
    from footstep_planner.core.clips.roles import map_roles

    names, parents = _mixamo_skeleton()
    roles = map_roles([prefix + n for n in names], parents)
    assert roles.ok and set(roles.how.values()) == {"name"}
    want = {"hips": "Hips", "spine": "Spine", "thigh_l": "LeftUpLeg", "shin_l": "LeftLeg",
            "foot_l": "LeftFoot", "toe_l": "LeftToeBase", "thigh_r": "RightUpLeg", "shin_r": "RightLeg",
            "foot_r": "RightFoot", "toe_r": "RightToeBase"}
    assert roles.roles == {k: prefix + v for k, v in want.items()}


# -- the files --------------------------------------------------------------------------


def _heads(ob, frames, names=None):
    """World heads {bone: (F, 3)} of ``ob``'s bones through the depsgraph at ``frames``
    (whole or fractional)."""
    import bpy

    scene = bpy.context.scene
    names = names or [pb.name for pb in ob.pose.bones]
    out = {n: [] for n in names}
    for f in frames:
        scene.frame_set(int(np.floor(f)), subframe=float(f - np.floor(f)))
        mw = np.array(ob.matrix_world)
        for n in names:
            out[n].append((mw @ np.append(ob.pose.bones[n].head, 1.0))[:3])
    return {n: np.array(v) for n, v in out.items()}


def _vertices(ob):
    """World positions (V, 3) of mesh object ``ob``'s vertices as evaluated (deformed)."""
    import bpy

    ev = ob.evaluated_get(bpy.context.evaluated_depsgraph_get())
    co = np.empty(3 * len(ev.data.vertices))
    ev.data.vertices.foreach_get("co", co)
    mw = np.array(ev.matrix_world)
    return co.reshape(-1, 3) @ mw[:3, :3].T + mw[:3, 3]






@pytest.fixture(scope="module")
def mixamo(fp, tmp_path_factory):
    """Mixamo-like FBX files of the mannequin's walk (with its skinned body), run and
    in-place walk, and what the originals give: {"files", "heads", "analysis"}."""
    import bpy

    mannequin = import_module(fp.__name__ + ".blender.sample.mannequin")
    character = import_module(fp.__name__ + ".blender.read.character")
    bpy.ops.wm.read_homefile(use_empty=True)
    scene = bpy.context.scene
    scene.render.fps, scene.render.fps_base = 24, 1.0
    ob, body = mannequin.build()
    acts = {a.name: a for a in mannequin.generate_clips(ob, names=list(CLIPS))}
    analysis = {a.name: (a.speed, a.stride, a.gait) for a in character.analyze_character(ob).analyses}
    acts["walk_in_place"] = mixamo_like.in_place(ob, acts["walk"], "spine")
    names = list(MIXAMO)
    heads = {}
    for name, act in acts.items():
        mixamo_like.play(ob, act)
        h = _heads(ob, FRAMES, names)
        heads[name] = {PREFIX + MIXAMO[n]: v for n, v in h.items()}
    mixamo_like.play(ob, acts["walk"])
    bpy.context.scene.frame_set(20)
    deformed = _vertices(body)
    mixamo_like.mixamoize(ob, body)
    mixamo_like.play(ob, acts["walk"])
    assert max(np.abs(v - heads["walk"][n]).max() for n, v in _heads(ob, FRAMES).items()) < 1e-4
    out = tmp_path_factory.mktemp("mixamo")
    files = {}
    for name, act in acts.items():
        objects = [ob, body] if name == "walk" else [ob]
        files[name] = mixamo_like.export(str(out / f"{name}.fbx"), objects, act, (1, int(act.frame_range[1])))
    files["no_armature"] = mixamo_like.export(str(out / "no_armature.fbx"), [body], None, (1, 2))
    twin, _ = mannequin.build(name="Twin")
    files["two_armatures"] = mixamo_like.export(str(out / "two_armatures.fbx"), [ob, twin], acts["run"], (1, 10))
    # a skeleton with no legs: a snake, four bones in a row
    snake = bpy.data.objects.new("Snake", bpy.data.armatures.new("Snake"))
    scene.collection.objects.link(snake)
    view = bpy.context.view_layer
    view.objects.active = snake
    bpy.ops.object.mode_set(mode="EDIT")
    parent = None
    for i in range(4):
        eb = snake.data.edit_bones.new(f"mixamorig:Spine{i}")
        eb.head, eb.tail, eb.parent = (0, -0.3 * i, 0.1), (0, -0.3 * (i + 1), 0.1), parent
        parent = eb
    bpy.ops.object.mode_set(mode="OBJECT")
    legless = bpy.data.actions.new("legless")
    slot = legless.slots.new(id_type="OBJECT", name=snake.name)
    cb = legless.layers.new("L").strips.new(type="KEYFRAME").channelbag(slot, ensure=True)
    fc = cb.fcurves.new('pose.bones["mixamorig:Spine1"].rotation_quaternion', index=3)
    fc.keyframe_points.insert(1, 0.0)
    fc.keyframe_points.insert(10, 0.2)
    scene.render.fps = 30  # (a file at another rate)
    files["legless"] = mixamo_like.export(str(out / "legless.fbx"), [snake], legless, (1, 10))
    scene.render.fps = 24
    with open(files["walk"], "rb") as fh:
        head = fh.read(3000)
    files["truncated"] = str(out / "truncated.fbx")
    with open(files["truncated"], "wb") as fh:
        fh.write(head)
    files["junk"] = str(out / "junk.fbx")
    with open(files["junk"], "w") as fh:
        fh.write("this is a text file with an .fbx name\n")
    files["ascii"] = str(out / "ascii.fbx")
    with open(files["ascii"], "w") as fh:
        fh.write("; FBX 7.4.0 project file\nFBXHeaderExtension:  {\n}\n")
    bpy.ops.wm.read_homefile(use_empty=True)
    return {"files": files, "heads": heads, "analysis": analysis, "body_at_20": deformed}


def _clips(fp):
    return import_module(fp.__name__ + ".blender.read.clips")


def _data():
    """Names of every data-block an import could add to or change."""
    import bpy

    return {attr: sorted(i.name for i in getattr(bpy.data, attr))
            for attr in ("objects", "armatures", "meshes", "actions", "materials", "images", "cameras",
                         "lights", "collections")}


def _users_things(scene):
    """An empty (selected, active) and an armature with the user's own action."""
    import bpy

    empty = bpy.data.objects.new("UserEmpty", None)
    scene.collection.objects.link(empty)
    arm = bpy.data.objects.new("Hero", bpy.data.armatures.new("Armature"))  # the importer's name
    scene.collection.objects.link(arm)
    bpy.context.view_layer.update()  # (an armature never evaluated crashes on assignment)
    mine = bpy.data.actions.new("walk")  # the name the first file's clip wants
    slot = mine.slots.new(id_type="OBJECT", name=arm.name)
    fc = mine.layers.new("L").strips.new(type="KEYFRAME").channelbag(slot, ensure=True).fcurves.new(
        "location", index=2)
    fc.keyframe_points.insert(1, 0.5)
    fc.keyframe_points.insert(10, 0.7)
    arm.animation_data_create()
    arm.animation_data.action = mine
    arm.animation_data.action_slot = slot
    bpy.context.view_layer.objects.active = empty
    empty.select_set(True)
    return empty, arm, mine


# -- the tests ----------------------------------------------------------------------------

def test_the_files_come_into_blender_as_mixamo_files_do(fp, empty_scene, mixamo):
    """Blender's own importer: the armature turned 90 degrees about X, scale 0.01, the
    bones and the hips' keys in centimetres."""
    import bpy

    bpy.ops.import_scene.fbx(filepath=mixamo["files"]["walk"])
    (ob,) = [o for o in bpy.data.objects if o.type == "ARMATURE"]
    assert np.degrees(ob.rotation_euler[:]) == pytest.approx([90, 0, 0], abs=1e-3)
    assert ob.scale[:] == pytest.approx([0.01] * 3)
    assert 90 < ob.data.bones[PREFIX + "Hips"].head_local[1] < 100  # cm, Y up
    assert bpy.context.scene.render.fps == 24
    hips = [fc for fc in mixamo_like.curves(ob.animation_data.action)
            if fc.data_path == f'pose.bones["{PREFIX}Hips"].location']
    assert max(abs(k.co[1]) for fc in hips for k in fc.keyframe_points) > 20  # cm of travel


def test_import_gives_one_armature_in_metres_z_up_and_leaves_the_users_data(fp, empty_scene, mixamo):
    import bpy

    clips = _clips(fp)
    scene_mod = import_module(fp.__name__ + ".blender.read.scene")
    empty, arm, mine = _users_things(empty_scene)
    before = _data()
    files = mixamo["files"]
    ob, acts = clips.import_clips([files["walk"], files["run"], files["walk_in_place"]], name="Mixamo")
    after = _data()
    # one armature (its data renamed after it), its body, one action per file; nothing else
    assert ob.name == "Mixamo" and ob.data.name == "Mixamo"
    assert [a.name for a in acts] == ["walk.001", "run", "walk_in_place"]
    assert set(after["objects"]) - set(before["objects"]) == {"Mixamo", "Footstep Mannequin Body"}
    assert set(after["armatures"]) - set(before["armatures"]) == {"Mixamo"}
    assert set(after["actions"]) - set(before["actions"]) == {"walk.001", "run", "walk_in_place"}
    assert len(after["meshes"]) == len(before["meshes"]) + 1
    for attr in ("materials", "images", "cameras", "lights", "collections"):
        assert len(after[attr]) - len(before[attr]) <= (attr == "materials"), attr
    # the user's things as they were
    assert bpy.context.view_layer.objects.active == empty and empty.select_get()
    assert not ob.select_get() and arm.animation_data.action == mine
    assert [tuple(k.co) for k in next(iter(mixamo_like.curves(mine))).keyframe_points] == [(1, 0.5), (10, pytest.approx(0.7))]
    assert empty_scene.render.fps == 24 and empty_scene.render.fps_base == 1.0
    # identity transform, metres, Z up, feet near the ground
    assert np.allclose(np.array(ob.matrix_world), np.eye(4), atol=1e-6)
    rig = scene_mod.rig_from_armature(ob)
    assert rig.rest[rig.role_index("hips"), 2, 3] == pytest.approx(0.95, abs=1e-4)
    assert rig.rest[rig.role_index("foot_l"), :3, 3] == pytest.approx([0.09, 0.01, 0.08], abs=1e-4)
    for act in acts:
        assert act.use_fake_user and act["footstep_source_fps"] == pytest.approx(24)
        assert act["footstep_armature"] == "Mixamo" and act["footstep_source_file"] == act.name.split(".")[0] + ".fbx"
        assert act.frame_range[0] == pytest.approx(1)
    # the motion, bone by bone through the depsgraph: within 1 cm of the original clips
    errors = {}
    for act in acts:
        ob.animation_data.action = act
        ob.animation_data.action_slot = act.slots[0]
        want = mixamo["heads"][act.name.split(".")[0]]
        got = _heads(ob, FRAMES, list(want))
        errors[act.name] = max(np.abs(got[n] - want[n]).max() for n in want)
    print("largest bone position error (m):", errors)
    assert max(errors.values()) < 0.01
    # the body: parented to the armature at the identity, skinned, in place around the bones
    body = bpy.data.objects["Footstep Mannequin Body"]
    assert body.parent == ob and [m.object for m in body.modifiers if m.type == "ARMATURE"] == [ob]
    assert np.allclose(np.array(body.matrix_world), np.eye(4), atol=1e-6)
    z = np.array([v.co.z for v in body.data.vertices])
    assert -0.05 < z.min() < 0.05 and 1.7 < z.max() < 1.8
    # ... and deformed by the walk as the original body was
    mixamo_like.play(ob, acts[0])
    empty_scene.frame_set(20)
    assert np.abs(_vertices(body) - mixamo["body_at_20"]).max() < 0.01


def test_the_walk_analyses_as_the_original_does(fp, empty_scene, mixamo):
    clips = _clips(fp)
    character = import_module(fp.__name__ + ".blender.read.character")
    files = mixamo["files"]
    ob, _ = clips.import_clips([files[n] for n in CLIPS])
    result = character.analyze_character(ob)
    got = {a.name: (a.speed, a.stride, a.gait) for a in result.analyses}
    print("imported:", got, "original:", mixamo["analysis"])
    assert set(got) == set(CLIPS) and not result.errors
    for name in CLIPS:
        (speed, stride, gait), (speed0, stride0, gait0) = got[name], mixamo["analysis"][name]
        assert gait == gait0
        assert speed == pytest.approx(speed0, rel=0.02) and stride == pytest.approx(stride0, rel=0.02)


def test_a_scene_at_another_rate_keys_the_clip_at_its_rate(fp, empty_scene, mixamo):
    """A 24 fps file in a 30 fps scene: keys 1.25 frames apart, the motion in time."""
    clips = _clips(fp)
    empty_scene.render.fps = 30
    ob, (act,) = clips.import_clips([mixamo["files"]["walk_in_place"]])
    assert empty_scene.render.fps == 30 and act["footstep_source_fps"] == pytest.approx(24)
    xs = np.array([k.co[0] for k in next(iter(mixamo_like.curves(act))).keyframe_points])
    assert xs[0] == pytest.approx(1) and np.diff(xs) == pytest.approx(1.25, abs=1e-4)
    want = mixamo["heads"]["walk_in_place"]
    got = _heads(ob, [1 + (f - 1) * 1.25 for f in FRAMES], list(want))
    assert max(np.abs(got[n] - want[n]).max() for n in want) < 0.01
    # in place: the hips never travel
    hips = got[PREFIX + "Hips"]
    assert np.abs(hips[:, :2] - hips[0, :2]).max() < 1e-3


def test_import_clips_and_analyze_from_the_command_line(fp, empty_scene, mixamo, tmp_path, capsys):
    cli = import_module(fp.__name__ + ".blender.command.cli").cli_main
    files = mixamo["files"]
    lib = str(tmp_path / "lib.blend")
    assert cli(["import-clips", "--out", lib, "--name", "Mixamo", files["walk"], files["run"]]) == 0
    assert "imported 2 clip(s) into armature 'Mixamo': walk, run" in capsys.readouterr().out
    assert cli(["analyze", lib, "--json"]) == 0
    (char,) = json.loads(capsys.readouterr().out)["characters"]
    walk = {c["name"]: c for c in char["clips"]}["walk"]
    assert walk["fps"] == 24 and walk["speed"] == pytest.approx(mixamo["analysis"]["walk"][0], rel=0.02)
    # an FBX straight into analyze
    assert cli(["analyze", files["walk"], "--json"]) == 0
    (walk,) = json.loads(capsys.readouterr().out)["clips"]
    assert walk["name"] == "walk" and walk["gait"] == mixamo["analysis"]["walk"][2]
    # a bad file: one line naming it, no traceback, nothing saved
    bad = str(tmp_path / "bad.blend")
    assert cli(["import-clips", "--out", bad, files["junk"]]) == 2
    err = capsys.readouterr().err
    assert err.strip().splitlines() == [f"footstep: error: {files['junk']}: not a valid FBX file (no binary FBX header)"]
    assert not os.path.exists(bad)


def test_the_frame_rate_of_a_clip_file(fp, mixamo):
    clips = _clips(fp)
    files = mixamo["files"]
    assert clips.clip_fps(files["walk"]) == 24 and clips.clip_fps(files["legless"]) == 30
    with pytest.raises(clips.ClipImportError, match="ascii.fbx: an ASCII FBX"):
        clips.clip_fps(files["ascii"])


def test_the_import_operator_reads_fbx(fp, empty_scene, mixamo):
    import bpy

    d = os.path.dirname(mixamo["files"]["walk"])
    assert bpy.ops.footstep.import_clips(directory=d, files=[{"name": "walk.fbx"}, {"name": "run.fbx"}],
                                         target="NEW") == {"FINISHED"}
    ob = empty_scene.footstep.character
    assert ob.name == "walk" and ob.type == "ARMATURE"
    assert sorted(c.name for c in ob.data.footstep.clips) == ["run", "walk"]


@pytest.mark.parametrize("case, message", [
    ("no_armature", r"no_armature\.fbx: no armature in the file \(it holds mesh"),
    ("two_armatures", r"two_armatures\.fbx: 2 armatures in the file"),
    ("legless", r"legless\.fbx: skeleton has no usable legs"),
    ("truncated", r"truncated\.fbx: Blender's FBX importer cannot read it"),
    ("junk", r"junk\.fbx: not a valid FBX file"),
    ("ascii", r"ascii\.fbx: an ASCII FBX file"),
    ("other", r"walk\.fbx: joints mixamorig:Hips.* are not bones of armature 'Footstep Mannequin'"),
])
def test_bad_input_is_one_clear_message_and_changes_nothing(fp, empty_scene, mixamo, case, message):
    import bpy

    clips = _clips(fp)
    empty, arm, mine = _users_things(empty_scene)
    target = None
    if case == "other":  # a file of another skeleton, into the user's character
        target, _ = import_module(fp.__name__ + ".blender.sample.mannequin").build()
        paths = [mixamo["files"]["walk"]]
    else:  # a bad file after a good one: the good one's import is undone too
        paths = [mixamo["files"]["run"], mixamo["files"][case]]
    empty_scene.render.fps = 30
    before = _data()
    with pytest.raises(clips.ClipImportError, match=message) as err:
        clips.import_clips(paths, target=target)
    print(err.value)
    assert _data() == before
    assert bpy.context.view_layer.objects.active == empty and empty.select_get()
    assert arm.animation_data.action == mine and empty_scene.render.fps == 30


def test_bvh_and_fbx_of_one_skeleton_mix(fp, empty_scene, mixamo, tmp_path):
    """A BVH written from the imported character goes onto an armature made from an FBX."""
    import bpy

    clips = _clips(fp)
    ob, (_, run) = clips.import_clips([mixamo["files"]["walk"], mixamo["files"]["run"]])
    mixamo_like.play(ob, run)
    bvh = str(tmp_path / "run_bvh.bvh")
    bpy.context.view_layer.objects.active = ob
    from mathutils import Matrix

    ob.data.transform(Matrix.Rotation(-np.pi / 2, 4, "X"))  # Blender writes armature axes: make them Y up
    bpy.ops.export_anim.bvh(filepath=bvh, frame_start=1, frame_end=int(run.frame_range[1]), global_scale=100.0)
    bpy.ops.wm.read_homefile(use_empty=True)
    bpy.context.scene.render.fps = 24
    ob, acts = clips.import_clips([mixamo["files"]["walk"], bvh])
    assert [a.name for a in acts] == ["walk", "run_bvh"]
    mixamo_like.play(ob, acts[1])
    want = mixamo["heads"]["run"]
    got = _heads(ob, FRAMES, list(want))
    assert max(np.abs(got[n] - want[n]).max() for n in want) < 0.01


def test_a_mixamo_character_with_in_place_clips_bakes_from_the_command_line(fp, tmp_path, capsys):
    """Mixamo-style in-place walk, run and turn clips, imported with import-clips into a
    scene, analysed as in place, planned and baked by the bake verb on Turns: the report
    (the scene as played) shows planted feet and the goal reached."""
    import bpy

    files = mixamo_like.write_character(str(tmp_path))
    import_module(fp.__name__ + ".blender.sample.sample_scenes").build("turns")
    bpy.context.scene.render.fps = 30
    scene_path = str(tmp_path / "turns.blend")
    bpy.ops.wm.save_as_mainfile(filepath=scene_path)
    cli = import_module(fp.__name__ + ".blender.command.cli").cli_main
    with_clips, baked, report = (str(tmp_path / n) for n in ("with_clips.blend", "baked.blend", "r.json"))
    assert cli(["import-clips", "--blend", scene_path, "--name", "Mixamo", "--out", with_clips, *files]) == 0
    capsys.readouterr()
    assert cli(["analyze", with_clips, "--character", "Mixamo", "--json"]) == 0
    out = capsys.readouterr().out
    doc = json.loads(out[out.index("{"):])  # (after Blender's own "Read blend" line)
    clips = [c for c in _walk_dicts(doc) if "in_place" in c]
    assert len(clips) == 4 and all(c["in_place"] for c in clips)
    assert {c["gait"] for c in clips} == {"walk", "run"}
    assert cli(["bake", with_clips, "--character", "Mixamo", "--goal", "Goal", "--start", "Start",
                "--out", baked, "--report", report]) == 0
    with open(report) as fh:
        q = json.load(fh)["quality"]
    assert q["foot_skate"]["max_mm"] < 5.0 and q["footprint_error"]["max_mm"] < 5.0
    assert q["goal"]["distance_m"] < 0.05
    bpy.ops.wm.read_homefile(use_empty=True)


def _walk_dicts(x):
    """Every dict inside a JSON document."""
    if isinstance(x, dict):
        yield x
        for v in x.values():
            yield from _walk_dicts(v)
    elif isinstance(x, list):
        for v in x:
            yield from _walk_dicts(v)
