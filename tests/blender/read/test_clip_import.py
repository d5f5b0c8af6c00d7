"""Importing BVH clips: units, axes, frame rate, and the user's data left alone."""

import os
from importlib import import_module

import numpy as np
import pytest

from bvh_files import edit_frames, legless
from conftest import cmu, needs_cmu

pytestmark = needs_cmu


def _mods(fp):
    return (import_module(fp.__name__ + ".blender.read.clips"), import_module(fp.__name__ + ".blender.read.scene"),
            import_module(fp.__name__ + ".core.clips.rig"))


def _snapshot():
    """Everything of the user's that an import must not touch."""
    import bpy

    snap = {"objects": sorted(o.name for o in bpy.data.objects),
            "armatures": sorted(a.name for a in bpy.data.armatures),
            "actions": {}, "nla": {}}
    for act in bpy.data.actions:
        vals = []
        for layer in act.layers:
            for strip in layer.strips:
                for cb in strip.channelbags:
                    for fc in cb.fcurves:
                        co = np.empty(2 * len(fc.keyframe_points))
                        fc.keyframe_points.foreach_get("co", co)
                        vals.append((fc.data_path, fc.array_index, co.round(6).tolist()))
        snap["actions"][act.name] = sorted(vals)
    for o in bpy.data.objects:
        ad = o.animation_data
        if ad:
            snap["nla"][o.name] = (ad.action.name if ad.action else None,
                                   [(t.name, [(s.name, s.frame_start, s.action.name) for s in t.strips])
                                    for t in ad.nla_tracks])
    return snap


def _user_character():
    """An armature with the user's own animation: an active action and an NLA track."""
    import bpy

    scene = bpy.context.scene
    arm = bpy.data.armatures.new("Hero")
    ob = bpy.data.objects.new("Hero", arm)
    scene.collection.objects.link(ob)
    return ob


def test_import_makes_one_armature_with_one_action_per_file(fp, empty_scene):
    import bpy

    clips, scene_mod, rig_mod = _mods(fp)
    cube = bpy.data.objects.new("UserEmpty", None)
    empty_scene.collection.objects.link(cube)
    bpy.context.view_layer.objects.active = cube
    cube.select_set(True)
    ob, acts = clips.import_clips([cmu("16_16"), cmu("16_35")], name="Subject16")
    assert ob.name == "Subject16" and ob.type == "ARMATURE"
    assert [a.name for a in acts] == ["cmu_16_16_walk", "cmu_16_35_run_jog"]
    assert sorted(o.name for o in bpy.data.objects) == ["Subject16", "UserEmpty"]
    assert bpy.context.view_layer.objects.active == cube and cube.select_get()
    for act, frames in zip(acts, (510, 162)):
        assert act[scene_mod.SOURCE_FPS_PROP] == 120
        assert act.use_fake_user
        # every 120 fps sample is kept, keyed at the 24 fps scene's frames
        fc = next(iter(act.layers[0].strips[0].channelbags[0].fcurves))
        co = np.empty(2 * len(fc.keyframe_points))
        fc.keyframe_points.foreach_get("co", co)
        assert len(fc.keyframe_points) == frames
        assert np.diff(co[0::2]) == pytest.approx(0.2, abs=1e-3)
    # metres and Z up: hips about 1 m above the feet, head above the hips
    rig = scene_mod.rig_from_armature(ob)
    hips = rig.rest[rig.role_index("hips"), :3, 3]
    foot = rig.rest[rig.role_index("foot_l"), :3, 3]
    head = rig.rest[rig.index("Head"), :3, 3]
    assert 0.8 < hips[2] - foot[2] < 1.1 and head[2] > hips[2] + 0.4


def test_import_into_a_users_character_adds_and_never_replaces(fp, empty_scene):
    import bpy

    clips, _, _ = _mods(fp)
    ob, _ = clips.import_clips([cmu("16_16")], name="Hero")
    # the user's own animation: an action they keyed and a track in the NLA
    mine = bpy.data.actions.new("cmu_16_35_run_jog")  # same name as a file imported next
    slot = mine.slots.new(id_type="OBJECT", name=ob.name)
    cb = mine.layers.new("L").strips.new(type="KEYFRAME").channelbag(slot, ensure=True)
    fc = cb.fcurves.new('pose.bones["Hips"].location', index=2)
    fc.keyframe_points.insert(1, 0.5)
    fc.keyframe_points.insert(10, 0.7)
    ob.animation_data_create()
    ob.animation_data.action = mine
    ob.animation_data.action_slot = slot
    track = ob.animation_data.nla_tracks.new()
    track.name = "UserTrack"
    track.strips.new("walk", 1, bpy.data.actions["cmu_16_16_walk"])
    before = _snapshot()
    ob2, acts = clips.import_clips([cmu("16_35"), cmu("16_16")], target=ob)
    assert ob2 == ob
    after = _snapshot()
    for name, curves in before["actions"].items():
        assert after["actions"][name] == curves, f"{name} changed"
    assert after["nla"] == before["nla"] and after["objects"] == before["objects"]
    assert [a.name for a in acts] == ["cmu_16_35_run_jog.001", "cmu_16_16_walk.001"]


def test_reimporting_into_the_same_skeleton_reproduces_the_motion(fp, empty_scene):
    """The retarget path (a file added to an existing armature) is exact on one skeleton."""
    clips, scene_mod, rig_mod = _mods(fp)
    ob, (first,) = clips.import_clips([cmu("16_35")])
    _, (second,) = clips.import_clips([cmu("16_35")], target=ob)
    rig = scene_mod.rig_from_armature(ob)
    frames = np.arange(1, 30, 0.2)
    a = rig_mod.forward_kinematics(rig, scene_mod.sample_basis(ob, first, frames))
    b = rig_mod.forward_kinematics(rig, scene_mod.sample_basis(ob, second, frames))
    assert np.abs(a[..., :3, 3] - b[..., :3, 3]).max() < 1e-4


def test_another_subject_is_retargeted_with_its_hip_height_scaled(fp, empty_scene):
    clips, scene_mod, rig_mod = _mods(fp)
    ob, _ = clips.import_clips([cmu("16_16")])
    own, (own_act,) = clips.import_clips([cmu("49_05")])
    _, (moved,) = clips.import_clips([cmu("49_05")], target=ob)
    frames = np.arange(1, 30, 1.0)
    h16 = scene_mod.rig_from_armature(ob)
    h49 = scene_mod.rig_from_armature(own)
    src = rig_mod.forward_kinematics(h49, scene_mod.sample_basis(own, own_act, frames))
    dst = rig_mod.forward_kinematics(h16, scene_mod.sample_basis(ob, moved, frames))
    hi = h16.role_index("hips")
    ratio = (h16.rest[hi, 2, 3] - h16.rest[:, 2, 3].min()) / (h49.rest[hi, 2, 3] - h49.rest[:, 2, 3].min())
    assert 0.9 < ratio < 1.1  # the skeletons' sizes differ little; their styles differ
    assert dst[:, hi, :3, 3] == pytest.approx(src[:, hi, :3, 3] * ratio, abs=1e-4)
    # joint rotations relative to rest are carried over: the hips turn the same way
    ra, rb = src[:, hi, :3, :3] @ h49.rest[hi, :3, :3].T, dst[:, hi, :3, :3] @ h16.rest[hi, :3, :3].T
    assert np.abs(ra - rb).max() < 1e-4


def test_a_file_of_another_skeleton_is_refused_and_nothing_changes(fp, empty_scene, tmp_path):
    clips, _, _ = _mods(fp)
    ob, _ = clips.import_clips([cmu("16_16")])
    before = _snapshot()
    with pytest.raises(clips.ClipImportError, match="LeftUpLeg|legs"):
        clips.import_clips([cmu("16_35"), legless(str(tmp_path / "legless.bvh"))], target=ob)
    assert _snapshot() == before


def test_a_clip_whose_feet_never_touch_down_is_reported_by_name(fp, empty_scene, tmp_path):
    clips, scene_mod, _ = _mods(fp)
    character = import_module(fp.__name__ + ".blender.read.character")
    high = edit_frames(cmu("16_16"), str(tmp_path / "floating.bvh"),
                       lambda d: d + np.r_[0, 60.0, 0, np.zeros(d.shape[1] - 3)])
    ob, _ = clips.import_clips([cmu("16_16"), high], name="Mixed")
    res = character.analyze_character(ob)
    assert [a.name for a in res.analyses] == ["cmu_16_16_walk"]
    assert "floating" in res.errors and "no foot ever touches the ground" in res.errors["floating"]


def test_root_motion_and_pose_recompose_the_hips(fp, empty_scene):
    """The clip's root motion (ground-projected, heading only) times the hips' matrix in
    the root frame gives back the hips exactly: the separation loses nothing."""
    clips, scene_mod, rig_mod = _mods(fp)
    ob, (act,) = clips.import_clips([cmu("16_17")])
    rig = scene_mod.rig_from_armature(ob)
    motion = scene_mod.clip_from_action(ob, act, rig)
    frames = motion.frame_of(motion.times)
    hips = rig_mod.forward_kinematics(rig, scene_mod.sample_basis(ob, act, frames))[:, rig.role_index("hips")]
    assert np.abs(motion.root_matrices() @ motion.hips_in_root - hips).max() < 1e-9
    assert np.all(motion.root_pos[:, 2] == 0)
    # the heading turns left through the 90-degree left turn
    assert np.degrees(motion.root_heading[-1] - motion.root_heading[0]) == pytest.approx(93, abs=10)
