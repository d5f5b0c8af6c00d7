"""Forward kinematics in numpy against Blender's own pose evaluation."""

import glob
import os

import numpy as np
import pytest

from conftest import CMU, needs_cmu


def _blender_pose(ob, frames):
    """Armature-space head and tail of every pose bone, evaluated by Blender (frame_set)."""
    import bpy

    scene = bpy.context.scene
    heads = np.empty((len(frames), len(ob.pose.bones), 3))
    tails = np.empty_like(heads)
    for i, f in enumerate(frames):
        scene.frame_set(int(f))
        for j, pb in enumerate(ob.pose.bones):
            heads[i, j] = pb.head
            tails[i, j] = pb.tail
    return heads, tails


def _numpy_pose(fp, ob, action, frames):
    from importlib import import_module

    scene_mod = import_module(fp.__name__ + ".blender.read.scene")
    rig_mod = import_module(fp.__name__ + ".core.clips.rig")
    rig = scene_mod.rig_from_armature(ob)
    basis = scene_mod.sample_basis(ob, action, frames)
    pose = rig_mod.forward_kinematics(rig, basis)
    lengths = np.array([ob.data.bones[n].length for n in rig.names])
    heads = pose[:, :, :3, 3]
    tails = heads + pose[:, :, :3, 1] * lengths[:, None]  # bones point along local +Y
    return heads, tails


@needs_cmu
@pytest.mark.parametrize("path", sorted(glob.glob(os.path.join(CMU, "*.bvh"))),
                         ids=lambda p: os.path.basename(p)[:10])
def test_fk_matches_blender_on_every_frame_of_cmu(fp, empty_scene, path):
    from importlib import import_module

    clips = import_module(fp.__name__ + ".blender.read.clips")
    empty_scene.render.fps = 120
    ob, (act,) = clips.import_clips([path])
    ob.animation_data_create()
    ob.animation_data.action = act
    ob.animation_data.action_slot = act.slots[0]
    lo, hi = act.frame_range
    frames = np.arange(int(lo), int(hi) + 1)
    hb, tb = _blender_pose(ob, frames)
    hn, tn = _numpy_pose(fp, ob, act, frames)
    assert np.abs(hn - hb).max() < 1e-4
    assert np.abs(tn - tb).max() < 1e-4


def test_fk_matches_blender_on_a_rig_with_rolls_offsets_locations_and_scale(fp, empty_scene):
    """A hand-made rig: bone rolls, disconnected children, and poses that move, rotate
    and scale bones (Blender's default inheritance)."""
    import bpy

    rng = np.random.default_rng(7)
    arm = bpy.data.armatures.new("Synth")
    ob = bpy.data.objects.new("Synth", arm)
    empty_scene.collection.objects.link(ob)
    bpy.context.view_layer.objects.active = ob
    bpy.ops.object.mode_set(mode="EDIT")
    names = ["hips", "thigh.L", "shin.L", "foot.L", "thigh.R", "shin.R", "foot.R", "spine"]
    parents = [None, "hips", "thigh.L", "shin.L", "hips", "thigh.R", "shin.R", "hips"]
    for n, p in zip(names, parents):
        eb = arm.edit_bones.new(n)
        eb.head = rng.normal(size=3) * 0.3
        eb.tail = np.array(eb.head) + rng.normal(size=3) * 0.2 + np.array([0, 0, 0.1])
        eb.roll = rng.uniform(-3, 3)
        if p:
            eb.parent = arm.edit_bones[p]
            eb.use_connect = bool(rng.integers(2)) and p != "hips"
    bpy.ops.object.mode_set(mode="OBJECT")
    act = bpy.data.actions.new("SynthPose")
    slot = act.slots.new(id_type="OBJECT", name=ob.name)
    cb = act.layers.new("L").strips.new(type="KEYFRAME").channelbag(slot, ensure=True)
    frames = np.arange(1, 6)
    for pb in ob.pose.bones:
        base = f'pose.bones["{pb.name}"]'
        q = rng.normal(size=(len(frames), 4))
        q /= np.linalg.norm(q, axis=1, keepdims=True)
        for i in range(4):
            fc = cb.fcurves.new(f"{base}.rotation_quaternion", index=i)
            for f, v in zip(frames, q[:, i]):
                fc.keyframe_points.insert(f, v)
        if not pb.bone.use_connect:
            for i in range(3):
                fc = cb.fcurves.new(f"{base}.location", index=i)
                for f in frames:
                    fc.keyframe_points.insert(f, rng.normal() * 0.1)
        for i in range(3):
            fc = cb.fcurves.new(f"{base}.scale", index=i)
            for f in frames:
                fc.keyframe_points.insert(f, rng.uniform(0.7, 1.3))
    ob.animation_data_create()
    ob.animation_data.action = act
    ob.animation_data.action_slot = slot
    hb, tb = _blender_pose(ob, frames)
    hn, tn = _numpy_pose(fp, ob, act, frames)
    assert np.abs(hn - hb).max() < 1e-5
    assert np.abs(tn - tb).max() < 1e-5


def test_sampling_leaves_the_users_pose_as_it_was(fp, empty_scene):
    import bpy
    from importlib import import_module

    scene_mod = import_module(fp.__name__ + ".blender.read.scene")
    arm = bpy.data.armatures.new("A")
    ob = bpy.data.objects.new("A", arm)
    empty_scene.collection.objects.link(ob)
    bpy.context.view_layer.objects.active = ob
    bpy.ops.object.mode_set(mode="EDIT")
    b = arm.edit_bones.new("b")
    b.tail = (0, 0, 1)
    bpy.ops.object.mode_set(mode="OBJECT")
    pb = ob.pose.bones["b"]
    pb.location = (0.1, 0.2, 0.3)  # an unkeyed pose the user set by hand
    act = bpy.data.actions.new("Other")
    slot = act.slots.new(id_type="OBJECT", name="A")
    cb = act.layers.new("L").strips.new(type="KEYFRAME").channelbag(slot, ensure=True)
    fc = cb.fcurves.new('pose.bones["b"].location', index=0)
    fc.keyframe_points.insert(1, 5.0)
    scene_mod.sample_basis(ob, act, np.array([1.0, 2.0]))
    assert tuple(round(v, 6) for v in pb.location) == (0.1, 0.2, 0.3)
