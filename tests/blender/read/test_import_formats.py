"""Importing the clip files people download: several takes in one FBX, glTF and GLB, clips that
move the armature object itself (root motion on the object), and every file and clip reported.

The files are made here the way users get them, by Blender's own exporters from the project's
sample character (the Footstep Mannequin and its generated clips): an FBX of several actions
(``bake_anim_use_all_actions``), a GLB and a separate glTF (``export_scene.gltf``), and clips
whose travel and turn are keys on the armature object (a straight walk, a turn and a 180-degree
walking turn), written by the FBX and glTF exporters. The real game character of
``../shared/clips/quaternius_male_casual`` (11 takes in one FBX) is read where it is present.
Files that only look like a format (junk.fbx, a text file named .glb) are made by hand and say so.
"""

import json
import os
import re
from importlib import import_module

import numpy as np
import pytest
from scipy.spatial import cKDTree

from benchmarks import mixamo_like
from conftest import MOD, QUATERNIUS, needs_quaternius

TAKES = ("run", "walk", "walk_turn_left_wide")
ROOT_MOTION = ("Walk_Straight", "Walk_Turn", "Walk_Turn_180")


def _mod(fp, name):
    return import_module(f"{fp.__name__}.blender.{name}")


def _heads(ob, frames):
    """World heads {bone: (F, 3)} of ``ob``'s bones through the depsgraph at ``frames``,
    and the armature object's world matrices (F, 4, 4)."""
    import bpy

    scene = bpy.context.scene
    out, objs = {pb.name: [] for pb in ob.pose.bones}, []
    for f in frames:
        scene.frame_set(int(f))
        mw = np.array(ob.matrix_world)
        objs.append(mw)
        for pb in ob.pose.bones:
            out[pb.name].append((mw @ np.append(pb.head, 1.0))[:3])
    return {n: np.array(v) for n, v in out.items()}, np.array(objs)


def _curves_of(act):
    return [fc for layer in act.layers for strip in layer.strips for cb in strip.channelbags for fc in cb.fcurves]


def _select_only(objects):
    import bpy

    for o in bpy.data.objects:
        o.select_set(o in objects)


def _export_all(folder, objects, stem, kinds=("fbx", "glb", "gltf")):
    """The selected ``objects`` with every action of the armature: one FBX of several takes,
    a GLB and a separate glTF (with its .bin), by Blender's own exporters."""
    import bpy

    _select_only(objects)
    bpy.context.scene.frame_set(1)
    paths = {k: os.path.join(folder, f"{stem}.{k}") for k in kinds}
    bpy.ops.export_scene.fbx(filepath=paths["fbx"], use_selection=True, object_types={o.type for o in objects},
                             add_leaf_bones=False, bake_anim=True, bake_anim_use_all_actions=True,
                             bake_anim_use_nla_strips=False, bake_anim_force_startend_keying=True,
                             bake_anim_simplify_factor=0.0)
    for kind in [k for k in kinds if k != "fbx"]:
        bpy.ops.export_scene.gltf(filepath=paths[kind], export_format="GLB" if kind == "glb" else "GLTF_SEPARATE",
                                  use_selection=True, export_animation_mode="ACTIONS")
    return paths


def _hips_world(ob, act, frames):
    """The world matrices (F, 4, 4) of the root bone "spine" (the mannequin's hips) as
    ``act`` keys it, the armature object at the identity."""
    sample_basis = import_module(MOD + ".blender.read.scene").sample_basis
    rest = np.array(ob.data.bones["spine"].matrix_local)
    return rest @ sample_basis(ob, act, frames)[:, ob.pose.bones.find("spine")]


def _key_object(ob, act, name, world, move_hips):
    """A copy of ``act`` named ``name`` whose keys also move the armature object along
    ``world`` (F, 4, 4; location and XYZ Euler keys at frames 1..F); with ``move_hips``
    the hips' keys are changed so the bones stay where ``act`` put them in the world (the
    clip's travel and turn moved onto the object), else the object's motion is added."""
    import bpy
    from scipy.spatial.transform import Rotation

    write_rotation = import_module(MOD + ".blender.read.clip_keys")._write_rotation
    fill_keys = import_module(MOD + ".blender.write.keys").fill_keys
    new = act.copy()
    new.name = name
    cb = new.layers[0].strips[0].channelbags[0]
    frames = np.arange(1, len(world) + 1, dtype=float)
    for i in range(3):
        fill_keys(cb.fcurves.new("location", index=i), frames, world[:, i, 3])
    euler = np.unwrap(Rotation.from_matrix(world[:, :3, :3]).as_euler("xyz"), axis=0)
    for i in range(3):
        fill_keys(cb.fcurves.new("rotation_euler", index=i), frames, euler[:, i])
    if move_hips:
        rest = np.array(ob.data.bones["spine"].matrix_local)
        basis = np.linalg.inv(rest) @ np.linalg.inv(world) @ _hips_world(ob, act, frames)
        base = 'pose.bones["spine"]'
        for fc in [fc for fc in cb.fcurves if fc.data_path.startswith(base)
                   and not fc.data_path.endswith(".scale")]:
            cb.fcurves.remove(fc)
        write_rotation(cb, base, "spine", "QUATERNION", Rotation.from_matrix(basis[:, :3, :3]), frames)
        for i in range(3):
            fill_keys(cb.fcurves.new(f"{base}.location", index=i), frames, basis[:, i, 3])
    bpy.context.view_layer.update()
    return new


def _travel_and_turn(hips: np.ndarray, turn: bool) -> np.ndarray:
    """The object's world matrices (F, 4, 4) that carry the hips' ground travel (and with
    ``turn`` their heading about Z: the rest's forward, -Y, turned)."""
    world = np.tile(np.eye(4), (len(hips), 1, 1))
    world[:, :2, 3] = hips[:, :2, 3] - hips[0, :2, 3]
    if turn:
        fwd = (hips[:, :3, :3] @ np.linalg.inv(hips[0, :3, :3]) @ np.array([0.0, -1.0, 0.0]))
        yaw = np.unwrap(np.arctan2(fwd[:, 0], -fwd[:, 1]))
        c, s = np.cos(yaw), np.sin(yaw)
        world[:, 0, 0], world[:, 0, 1], world[:, 1, 0], world[:, 1, 1] = c, -s, s, c
    return world


def _semicircle(n: int, radius: float = 1.2) -> np.ndarray:
    """The object's world matrices (n, 4, 4) walking half a circle to the left, turning
    180 degrees with it."""
    ang = np.pi * np.arange(n) / (n - 1)
    world = np.tile(np.eye(4), (n, 1, 1))
    world[:, 0, 3], world[:, 1, 3] = radius * (1 - np.cos(ang)), -radius * np.sin(ang)
    c, s = np.cos(ang), np.sin(ang)
    world[:, 0, 0], world[:, 0, 1], world[:, 1, 0], world[:, 1, 1] = c, -s, s, c
    return world


@pytest.fixture(scope="module")
def made(fp, tmp_path_factory):
    """The files: takes.{fbx,glb,gltf} (walk, run, a turn, with the skinned body),
    root_motion.{fbx,glb,gltf} (three clips moving the object, and a fourth that scales
    it), nan_take.fbx (a take with a key that is not a number), floating.fbx (a walk a
    metre up: no foot touches the ground), junk files; and what the originals play."""
    import bpy

    mannequin = _mod(fp, "sample.mannequin")
    folder = str(tmp_path_factory.mktemp("formats"))
    bpy.ops.wm.read_homefile(use_empty=True)
    scene = bpy.context.scene
    scene.render.fps, scene.render.fps_base = 24, 1.0
    ob, body = mannequin.build()
    acts = mannequin.generate_clips(ob, names=list(TAKES))
    mixamo_like.play(ob, acts[0])
    files = {"takes": _export_all(folder, [ob, body], "takes")}
    want = {}
    for act in acts:
        mixamo_like.play(ob, act)
        want[act.name] = _heads(ob, range(1, int(act.frame_range[1]) + 1))[0]
    body_at = {}
    mixamo_like.play(ob, next(a for a in acts if a.name == "walk"))
    scene.frame_set(20)
    body_at["walk"] = _vertices(body)
    # clips that move the object: the walk's travel, the turn's travel and heading, a semicircle
    by = {a.name: a for a in acts}
    walk, turn = by["walk"], by["walk_turn_left_wide"]
    frames = np.arange(1, int(walk.frame_range[1]) + 1, dtype=float)
    moving = [
        _key_object(ob, walk, "Walk_Straight", _travel_and_turn(_hips_world(ob, walk, frames), False), True),
        _key_object(ob, turn, "Walk_Turn", _travel_and_turn(_hips_world(ob, turn, frames), True), True),
        _key_object(ob, mixamo_like.in_place(ob, walk, "spine"), "Walk_Turn_180", _semicircle(len(frames)), False)]
    grow = walk.copy()
    grow.name = "Grow"  # (the clip scales the object, 1 -> 1.5)
    fill_keys = _mod(fp, "write.keys").fill_keys
    for i in range(3):
        fill_keys(grow.layers[0].strips[0].channelbags[0].fcurves.new("scale", index=i), frames,
                  np.linspace(1.0, 1.5, len(frames)))
    for act in moving:
        mixamo_like.play(ob, act)
        want[act.name], objs = _heads(ob, frames)
        assert np.abs(objs[-1, :3, 3] - objs[0, :3, 3]).max() > 0.5  # (the object travels)
    for act in [*acts, bpy.data.actions["walk_in_place"]]:
        bpy.data.actions.remove(act)
    mixamo_like.play(ob, moving[0])
    files["root_motion"] = _export_all(folder, [ob], "root_motion", ("fbx", "glb"))
    bpy.data.actions.remove(grow)
    # a take with a NaN key among good ones; a walk where no foot touches the ground
    bpy.ops.wm.read_homefile(use_empty=True)
    scene = bpy.context.scene
    scene.render.fps = 24
    ob, _ = mannequin.build()
    acts = mannequin.generate_clips(ob, names=list(TAKES))
    walk = next(a for a in acts if a.name == "walk")
    fc = next(fc for fc in _curves_of(walk) if fc.data_path == 'pose.bones["spine"].location')
    fc.keyframe_points[5].co[1] = float("nan")
    mixamo_like.play(ob, acts[0])
    files["nan_take"] = _export_all(folder, [ob], "nan_take", ("fbx",))["fbx"]
    for act in [a for a in acts if a != walk]:
        bpy.data.actions.remove(act)
    (walk,) = mannequin.generate_clips(ob, names=["walk"])  # (its keys made again: no NaN)
    up = np.array(ob.data.bones["spine"].matrix_local)[:3, :3].T @ [0, 0, 1.0]
    for fc in _curves_of(walk):
        if fc.data_path == 'pose.bones["spine"].location':
            for k in fc.keyframe_points:
                k.co[1] += up[fc.array_index]
    walk.name = "floating"
    files["floating"] = mixamo_like.export(os.path.join(folder, "floating.fbx"), [ob], walk,
                                           (1, int(walk.frame_range[1])))
    # files that only look like the formats (made by hand, on purpose)
    for name, text in (("junk.fbx", "a text file named .fbx\n"), ("junk.glb", "a text file named .glb\n"),
                       ("junk.gltf", "not json\n")):
        files[name] = os.path.join(folder, name)
        with open(files[name], "w") as fh:
            fh.write(text)
    bpy.ops.wm.read_homefile(use_empty=True)
    return {"files": files, "want": want, "body_at": body_at}


def _vertices(ob):
    import bpy

    ev = ob.evaluated_get(bpy.context.evaluated_depsgraph_get())
    co = np.empty(3 * len(ev.data.vertices))
    ev.data.vertices.foreach_get("co", co)
    mw = np.array(ev.matrix_world)
    return co.reshape(-1, 3) @ mw[:3, :3].T + mw[:3, 3]


def _played_error(ob, act, want, frames=None):
    """The largest distance (m) between the bones' world heads as ``act`` plays on ``ob``
    (through the depsgraph) and ``want``; and the object's world matrices meanwhile."""
    mixamo_like.play(ob, act)
    n = len(next(iter(want.values())))
    got, objs = _heads(ob, frames if frames is not None else range(1, n + 1))
    return max(np.abs(got[b] - want[b]).max() for b in want), objs


def _object_keys(act):
    return [fc.data_path for fc in _curves_of(act) if not fc.data_path.startswith("pose.bones[")]


# -- several takes in one file ---------------------------------------------------------------

@pytest.mark.parametrize("kind", ["fbx", "glb", "gltf"])
def test_a_file_of_several_takes_gives_one_clip_per_take(fp, empty_scene, made, kind):
    """Blender's exporters' file of three actions: three clips named after their takes, keyed
    from frame 1 at the scene's rate, tagged, playing as the originals did (within 0.1 mm),
    the skinned body kept; the importer's NLA tracks and scene data not left behind."""
    import bpy

    clips = _mod(fp, "read.clips")
    tracks = lambda: [t.name for t in getattr(empty_scene, "gltf2_animation_tracks", [])]  # noqa: E731
    before = tracks()
    mine = bpy.data.objects.new("UserEmpty", None)
    empty_scene.collection.objects.link(mine)
    bpy.context.view_layer.objects.active = mine
    mine.select_set(True)
    done = clips.import_clip_files([made["files"]["takes"][kind]], name="Mannequin")
    assert bpy.context.view_layer.objects.active == mine and mine.select_get() and not done.armature.select_get()
    bpy.data.objects.remove(mine)
    print("\n".join(done.report()))
    assert not done.refused and done.armature.name == "Mannequin"
    assert [a.name for a in done.actions] == list(TAKES)
    assert [o.take for o in done.outcomes] == list(TAKES) and all(not o.notes for o in done.outcomes)
    assert done.report()[0] == "imported 3 clip(s) into armature 'Mannequin': run, walk, walk_turn_left_wide"
    ob = done.armature
    assert {b.name for b in ob.data.bones} == set(made["want"]["walk"])  # (the importers keep the bones' names)
    assert sorted(o.name for o in bpy.data.objects) == ["Footstep Mannequin Body", "Mannequin"]
    assert sorted(a.name for a in bpy.data.actions) == list(TAKES)
    assert not ob.animation_data.nla_tracks and tracks() == before
    assert np.allclose(np.array(ob.matrix_world), np.eye(4), atol=1e-6) and empty_scene.render.fps == 24
    errors = {}
    for act in done.actions:
        assert act.frame_range[0] == pytest.approx(1) and act["footstep_source_fps"] == pytest.approx(24)
        assert act["footstep_source_file"] == f"takes.{kind}" and act["footstep_armature"] == "Mannequin"
        assert act.use_fake_user and len(act.slots) == 1 and not _object_keys(act)
        errors[act.name], _ = _played_error(ob, act, made["want"][act.name])
    print("largest bone position error (m):", errors)
    assert max(errors.values()) < 1e-4
    body = bpy.data.objects["Footstep Mannequin Body"]
    assert body.parent == ob and [m.object for m in body.modifiers if m.type == "ARMATURE"] == [ob]
    mixamo_like.play(ob, bpy.data.actions["walk"])
    empty_scene.frame_set(20)
    got, want = _vertices(body), made["body_at"]["walk"]  # (glTF splits vertices at seams)
    assert max(cKDTree(want).query(got)[0].max(), cKDTree(got).query(want)[0].max()) < 1e-3


@pytest.mark.parametrize("kind", ["fbx", "glb"])
def test_takes_whose_names_the_armature_has_are_reported(fp, empty_scene, made, kind):
    """The same file imported again into the armature: its clips keep Blender's numbered
    names, each one named in the report, and play as the first ones do."""
    clips = _mod(fp, "read.clips")
    ob, first = clips.import_clips([made["files"]["takes"]["fbx"]], name="Mannequin")
    done = clips.import_clip_files([made["files"]["takes"][kind]], target=ob)
    report = done.report()
    print("\n".join(report))
    assert [a.name for a in done.actions] == [f"{n}.001" for n in TAKES]
    assert report[1:] == [f"  {n}.001 (takes.{kind} take {n!r}): armature 'Mannequin' already has a clip named {n!r}"
                          for n in TAKES]
    for act in done.actions:
        err, _ = _played_error(ob, act, made["want"][act.name[:-4]])
        assert err < 2e-4, (act.name, err)


def test_a_take_that_cannot_be_read_is_refused_and_the_others_imported(fp, empty_scene, made):
    import bpy

    clips = _mod(fp, "read.clips")
    path = made["files"]["nan_take"]
    done = clips.import_clip_files([path])
    assert [a.name for a in done.actions] == ["run", "walk_turn_left_wide"]
    (bad,) = done.refused
    print(bad.error)
    assert bad.label == "nan_take.fbx take 'walk'"
    assert bad.error.startswith(f"{path}: take 'walk': bone '") and "not a finite number" in bad.error
    assert sorted(a.name for a in bpy.data.actions) == ["run", "walk_turn_left_wide"]
    assert done.report()[-1] == "refused 1: nan_take.fbx take 'walk'"
    # all or nothing: the take refuses the file, and nothing is left
    before = sorted(a.name for a in bpy.data.actions), sorted(o.name for o in bpy.data.objects)
    with pytest.raises(clips.ClipImportError, match="nan_take.fbx: take 'walk': bone '.*not a finite number"):
        clips.import_clips([made["files"]["takes"]["fbx"], path], name="Other")
    assert (sorted(a.name for a in bpy.data.actions), sorted(o.name for o in bpy.data.objects)) == before


@needs_quaternius
def test_the_quaternius_character_gives_its_eleven_takes(fp, empty_scene, monkeypatch):
    """The real game character: 11 takes in one FBX, named as the README says, each from
    frame 1 at 24 fps; its armature object is keyed (holding still) in every take, and is
    left unkeyed. Its feet hang from the root bone: until the role mapper maps such legs
    the file is refused for them, so the takes are read here with the legs check set
    aside as well."""
    import bpy

    clips = _mod(fp, "read.clips")
    frames = {"Man_Idle": 101, "Man_Walk": 26, "Man_Run": 22, "Man_Jump": 26, "Man_RunningJump": 31}
    done = clips.import_clip_files([QUATERNIUS])
    if done.refused:  # (the role mapper does not map feet parented to the root)
        (o,) = done.refused
        assert "no usable legs" in o.error and "foot_l, foot_r" in o.error and not done.actions
        assert not bpy.data.actions and not bpy.data.objects
        monkeypatch.setattr(_mod(fp, "read.fbx_gltf_import"), "_check_legs", lambda ob, path: type("Roles", (), {"bone": lambda s, r: "Hips"})())
        done = clips.import_clip_files([QUATERNIUS])
    print("\n".join(done.report()))
    assert not done.refused and len(done.actions) == 11
    names = [a.name for a in done.actions]
    assert set(frames) <= set(names) and all(n.startswith("Man_") and "|" not in n for n in names)
    assert {"Man_Clapping", "Man_Death", "Man_Punch", "Man_Sitting", "Man_Standing", "Man_SwordSlash"} <= set(names)
    for act in done.actions:
        assert act.frame_range[0] == pytest.approx(1) and not _object_keys(act)
        assert act["footstep_source_fps"] == pytest.approx(24) and act["footstep_source_file"] == "Male_Casual.fbx"
        if act.name in frames:
            assert act.frame_range[1] == pytest.approx(frames[act.name]), act.name
    ob = done.armature
    assert ob.name == "Male_Casual" and np.allclose(np.array(ob.matrix_world), np.eye(4), atol=1e-6)
    assert not any(o.notes for o in done.outcomes)  # (the object holds still: nothing moved)
    assert sorted(o.type for o in bpy.data.objects) == ["ARMATURE", "MESH"]


# -- glTF ---------------------------------------------------------------------------------

def test_a_glb_in_a_scene_at_another_rate_keys_its_clips_at_that_rate(fp, empty_scene, made):
    """glTF keys times in seconds: a 24 fps file in a 30 fps scene plays in time."""
    clips = _mod(fp, "read.clips")
    empty_scene.render.fps = 30
    assert clips.clip_fps(made["files"]["takes"]["glb"]) == 24
    ob, acts = clips.import_clips([made["files"]["takes"]["glb"]])
    walk = next(a for a in acts if a.name == "walk")
    assert walk["footstep_source_fps"] == pytest.approx(24) and empty_scene.render.fps == 30
    want = made["want"]["walk"]
    at = np.arange(1, 41)  # 24 fps frames 1..40 are 30 fps frames 1 + (f - 1) * 1.25
    err, _ = _played_error(ob, walk, {b: v[at[::4] - 1] for b, v in want.items()}, 1 + (at[::4] - 1) * 1.25)
    assert err < 2e-3


@pytest.mark.parametrize("name, message", [
    ("junk.glb", r"junk\.glb: not a valid binary glTF"),
    ("junk.gltf", r"junk\.gltf: not a valid glTF file"),
    ("junk.fbx", r"junk\.fbx: not a valid FBX file"),
])
def test_files_that_only_look_like_a_format_are_refused_by_name(fp, empty_scene, made, name, message):
    import bpy

    clips = _mod(fp, "read.clips")
    done = clips.import_clip_files([made["files"][name]])
    (o,) = done.refused
    assert not done.actions and done.armature is None and not bpy.data.objects
    assert re.search(message, o.error), o.error


# -- root motion on the object -------------------------------------------------------------

@pytest.mark.parametrize("kind", ["fbx", "glb"])
def test_the_objects_motion_is_moved_onto_the_hips(fp, empty_scene, made, kind):
    """Clips whose keys move the armature object (a straight walk, a turn, a 180-degree
    walking turn): after import the object is unkeyed and still at the identity, the hips
    carry the travel and turn, and every bone follows the world path the exported
    object and hips gave it, within 1 mm, through the depsgraph; the report says so for
    each clip, and a clip that scales the object is refused."""
    clips = _mod(fp, "read.clips")
    path = made["files"]["root_motion"][kind]
    done = clips.import_clip_files([path], name="Mover")
    report = done.report()
    print("\n".join(report))
    assert [a.name for a in done.actions] == list(ROOT_MOTION)
    assert report[1:4] == ["  Walk_Straight: the armature object's motion (location) was moved onto the hips",
                           "  Walk_Turn: the armature object's motion (location, rotation) was moved onto the hips",
                           "  Walk_Turn_180: the armature object's motion (location, rotation) was moved onto the hips"]
    (grow,) = done.refused
    assert grow.take == "Grow" and "is scaled by the clip's keys" in grow.error and grow.error.startswith(path)
    ob = done.armature
    errors = {}
    for act in done.actions:
        assert not _object_keys(act), act.name
        errors[act.name], objs = _played_error(ob, act, made["want"][act.name])
        assert np.abs(objs - np.eye(4)).max() < 1e-6
    print("largest bone position error (m):", errors)
    assert max(errors.values()) < 1e-3
    # the hips carry the turn: the 180-degree walk ends facing back
    mixamo_like.play(ob, done.actions[2])
    hips, _ = _heads(ob, [1, int(done.actions[2].frame_range[1])])
    assert hips["spine"][1, 0] - hips["spine"][0, 0] == pytest.approx(2.4, abs=0.05)


def test_clips_moving_the_object_added_to_an_armature_play_the_same_path(fp, empty_scene, made):
    """The same files added to an armature made from another file of the rig: the clips,
    folded on the file's own armature, then retargeted bone by bone, play the same path."""
    clips = _mod(fp, "read.clips")
    ob, _ = clips.import_clips([made["files"]["takes"]["glb"]], name="Mannequin")
    done = clips.import_clip_files([made["files"]["root_motion"]["fbx"]], target=ob)
    assert [a.name for a in done.actions] == list(ROOT_MOTION) and len(done.refused) == 1
    errors = {act.name: _played_error(ob, act, made["want"][act.name])[0] for act in done.actions}
    print("largest bone position error (m):", errors)
    assert max(errors.values()) < 1e-3 and not any(_object_keys(a) for a in done.actions)


def test_clips_whose_object_travels_analyse_as_the_path_it_took(fp, empty_scene, made):
    """Folded onto the hips, the object's travel is the clips' root motion: the straight
    walk analyses as the original walk, the turn as the original turn, and the walk on a
    half circle of 1.2 m as a turn of curvature 1/1.2 at its arc's speed."""
    clips = _mod(fp, "read.clips")
    character = _mod(fp, "read.character")
    ob, _ = clips.import_clips([made["files"]["takes"]["fbx"]])
    original = {a.name: a for a in character.analyze_character(ob).analyses}
    done = clips.import_clip_files([made["files"]["root_motion"]["fbx"]], name="Mover")
    res = character.analyze_character(done.armature, actions=done.actions)
    got = {a.name: a for a in res.analyses}
    print({n: (a.gait, a.speed, a.stride, a.tau) for n, a in got.items()}, res.errors)
    assert set(got) == set(ROOT_MOTION) and not res.errors
    for name, was in (("Walk_Straight", "walk"), ("Walk_Turn", "walk_turn_left_wide")):
        a, b = got[name], original[was]
        assert a.gait == "walk" and a.speed == pytest.approx(b.speed, rel=0.01)
        assert a.stride == pytest.approx(b.stride, rel=0.01) and a.tau == pytest.approx(b.tau, abs=0.01)
    half = got["Walk_Turn_180"]
    seconds = (done.actions[2].frame_range[1] - 1) / 24
    assert half.tau == pytest.approx(1 / 1.2, rel=0.03) and half.speed == pytest.approx(np.pi * 1.2 / seconds, rel=0.03)


# -- the command line and the panel --------------------------------------------------------

@pytest.fixture
def cli(fp, empty_scene):
    return _mod(fp, "command.cli").cli_main


def test_import_clips_imports_every_file_it_can_and_counts_the_refused(cli, capsys, made, tmp_path):
    import bpy

    f = made["files"]
    lib = str(tmp_path / "lib.blend")
    assert cli(["import-clips", "--out", lib, "--name", "Hero", f["takes"]["fbx"], f["junk.fbx"],
                f["takes"]["glb"], f["nan_take"]]) == 2
    out, err = capsys.readouterr()
    print(out, err)
    junk, nan = err.splitlines()
    assert junk == f"footstep: error: {f['junk.fbx']}: not a valid FBX file (no binary FBX header)"
    assert nan.startswith(f"footstep: error: {f['nan_take']}: take 'walk': bone '") and "frame 6: the value nan" in nan
    lines = out.splitlines()
    assert lines[0] == ("imported 8 clip(s) into armature 'Hero': run, walk, walk_turn_left_wide, run.001, walk.001, "
                        "walk_turn_left_wide.001, run.002, walk_turn_left_wide.002")
    assert "  walk.001 (takes.glb take 'walk'): armature 'Hero' already has a clip named 'walk'" in lines
    assert "refused 2: junk.fbx, nan_take.fbx take 'walk'" in lines and lines[-1] == f"saved {lib}"
    bpy.ops.wm.open_mainfile(filepath=lib)
    assert sorted(a.name for a in bpy.data.actions if a.get("footstep_armature") == "Hero") == sorted(
        lines[0].split(": ", 1)[1].split(", "))
    # one refused among good ones: status 1; every file refused: 2, nothing saved
    lib2, lib3 = str(tmp_path / "lib2.blend"), str(tmp_path / "lib3.blend")
    assert cli(["import-clips", "--out", lib2, f["takes"]["gltf"], f["junk.glb"]]) == 1
    capsys.readouterr()
    assert cli(["import-clips", "--out", lib3, f["junk.glb"], f["junk.gltf"], str(tmp_path / "missing.fbx")]) == 2
    out, err = capsys.readouterr()
    assert len(err.splitlines()) == 3 and "missing.fbx: no such file" in err and "Traceback" not in err
    assert out.splitlines() == ["imported no clip", "refused 3: junk.glb, junk.gltf, missing.fbx"]
    assert os.path.exists(lib2) and not os.path.exists(lib3)


def test_import_clips_reports_the_objects_motion_moved_onto_the_hips(cli, capsys, made, tmp_path):
    lib = str(tmp_path / "lib.blend")
    assert cli(["import-clips", "--out", lib, made["files"]["root_motion"]["fbx"]]) == 1
    out, err = capsys.readouterr()
    print(out)
    assert out.splitlines()[:5] == [
        "imported 3 clip(s) into armature 'root_motion': Walk_Straight, Walk_Turn, Walk_Turn_180",
        "  Walk_Straight: the armature object's motion (location) was moved onto the hips",
        "  Walk_Turn: the armature object's motion (location, rotation) was moved onto the hips",
        "  Walk_Turn_180: the armature object's motion (location, rotation) was moved onto the hips",
        "refused 1: root_motion.fbx take 'Grow'"]
    assert "take 'Grow': the armature object 'root_motion' is scaled" in err or "take 'Grow'" in err


def test_analyze_prints_a_row_for_every_clip_and_counts_the_refused(cli, capsys, made):
    f = made["files"]
    assert cli(["analyze", f["takes"]["fbx"], f["junk.fbx"]]) == 1
    out, err = capsys.readouterr()
    rows = {line.split()[0]: line for line in out.splitlines()[3:-1]}
    assert set(rows) == {*TAKES, "junk.fbx"}
    assert rows["junk.fbx"].split(None, 1)[1].startswith("refused: ") and "not a valid FBX file" in rows["junk.fbx"]
    assert err.splitlines() == [f"footstep: error: {f['junk.fbx']}: not a valid FBX file (no binary FBX header)"]
    # JSON: every clip an object, the refused with its "error"; a clip no foot touches down in
    assert cli(["analyze", f["takes"]["fbx"], f["floating"], f["junk.fbx"], f["nan_take"], "--json"]) == 3
    out, err = capsys.readouterr()
    doc = json.loads(out)
    names = [c["name"] for c in doc["clips"]]
    assert names == [*TAKES, "floating", "junk.fbx", "run", "walk_turn_left_wide", "walk"]
    errors = {c["name"]: c["error"] for c in doc["clips"] if c["error"]}
    assert set(errors) == {"floating", "junk.fbx", "walk"} and len(doc["errors"]) == 3
    assert "no foot ever touches the ground" in errors["floating"] and "not a finite number" in errors["walk"]
    assert len(err.splitlines()) == 3
    # nothing readable at all: 2
    assert cli(["analyze", f["junk.fbx"], f["junk.glb"], "--json"]) == 2
    out, err = capsys.readouterr()
    assert [c["name"] for c in json.loads(out)["clips"]] == ["junk.fbx", "junk.glb"] and len(err.splitlines()) == 2


def test_analyze_a_library_with_a_clip_it_refuses(cli, capsys, made, tmp_path):
    lib = str(tmp_path / "lib.blend")
    assert cli(["import-clips", "--out", lib, "--name", "Hero", made["files"]["takes"]["fbx"],
                made["files"]["floating"]]) == 0
    capsys.readouterr()
    assert cli(["analyze", lib]) == 1
    out = capsys.readouterr().out
    print(out)
    (row,) = [line for line in out.splitlines() if line.startswith("floating ")]
    assert "refused: " in row and "no foot ever touches the ground" in row
    assert all(any(line.startswith(n + " ") for line in out.splitlines()) for n in TAKES)


def test_the_import_operator_reports_what_it_imported_and_refused(fp, empty_scene, made):
    import bpy

    f = made["files"]
    folder = os.path.dirname(f["junk.fbx"])
    assert bpy.ops.footstep.import_clips(directory=folder, files=[{"name": "takes.glb"}, {"name": "junk.fbx"}],
                                         target="NEW") == {"FINISHED"}
    ob = empty_scene.footstep.character
    assert ob.name == "takes" and sorted(c.name for c in ob.data.footstep.clips) == list(TAKES)
    report = empty_scene.footstep.last_report
    print(report)
    assert report.startswith("imported 3 clip(s) into takes; refused 1: ") and "junk.fbx: not a valid FBX" in report
    before = sorted(o.name for o in bpy.data.objects), sorted(a.name for a in bpy.data.actions)
    with pytest.raises(RuntimeError, match="imported no clip; refused 1: .*junk.glb"):
        bpy.ops.footstep.import_clips(directory=folder, files=[{"name": "junk.glb"}], target="NEW")
    assert (sorted(o.name for o in bpy.data.objects), sorted(a.name for a in bpy.data.actions)) == before
