"""Game rigs whose feet are parented to the root, not to the shins: the planner's hierarchy
(each foot hanging from its shin) against the armature's own, read and written through
Blender.

Two rigs: one built here with edit bones (Quaternius-like: feet and pole targets under
the root at the ground, an end marker under each shin), and the real CC0 Quaternius
character (``../shared/clips/quaternius_male_casual/Male_Casual.fbx``, imported with
Blender's FBX importer at its defaults; its clips exported one per FBX by Blender's FBX
exporter, as a user splitting the file would). What the bake keys is checked as Blender
plays it: ``scene.frame_set`` and the evaluated pose bones' matrices.
"""

import os
from importlib import import_module

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from conftest import QUATERNIUS, needs_quaternius


# bone: (parent, head, tail) of the left side and the middle; the right side mirrors X
GAME = {
    "Bone": (None, (0.0, 0.0, 0.0), (0.0, 0.0, 0.4)),
    "Body": ("Bone", (0.0, -0.03, 0.99), (0.0, -0.03, 1.1)),
    "Hips": ("Body", (0.0, 0.0, 0.95), (0.0, 0.0, 1.1)),
    "Abdomen": ("Hips", (0.0, 0.0, 1.1), (0.0, 0.0, 1.3)),
    "UpperLeg.L": ("Body", (0.1, 0.0, 0.93), (0.1, -0.02, 0.5)),
    "LowerLeg.L": ("UpperLeg.L", (0.1, -0.02, 0.5), (0.1, 0.02, 0.08)),
    "LowerLeg.L_end": ("LowerLeg.L", (0.1, 0.02, 0.08), (0.1, 0.06, -0.34)),
    "FootParent.L": ("Bone", (0.1, 0.1, 0.0), (0.1, 0.1, 0.1)),
    "Foot.L": ("FootParent.L", (0.1, 0.02, 0.08), (0.1, -0.1, 0.075)),
    "Toe.L": ("Foot.L", (0.1, -0.1, 0.075), (0.1, -0.2, 0.07)),
    "PoleTarget.L": ("Bone", (0.1, -0.6, 0.5), (0.1, -0.6, 0.6)),
}


def _mods(fp):
    return (import_module(fp.__name__ + ".blender.read.scene"), import_module(fp.__name__ + ".core.clips.rig"),
            import_module(fp.__name__ + ".blender.write.bake"))


def _game_armature(scene, roll=0.3):
    """An armature object "Game" built with edit bones from ``GAME`` (both sides, rolled
    bones, the object turned and moved), its feet parented to a bone under the root."""
    import bpy

    arm = bpy.data.armatures.new("Game")
    ob = bpy.data.objects.new("Game", arm)
    scene.collection.objects.link(ob)
    ob.location = (0.4, -0.2, 0.0)
    ob.rotation_euler = (0.0, 0.0, 0.5)
    bpy.context.view_layer.objects.active = ob
    bpy.ops.object.mode_set(mode="EDIT")
    for k, (name, (parent, head, tail)) in enumerate(GAME.items()):
        for s, sign in ([("L", 1), ("R", -1)] if ".L" in name else [("", 1)]):
            eb = arm.edit_bones.new(name.replace(".L", f".{s}") if s else name)
            eb.head = (sign * head[0], head[1], head[2])
            eb.tail = (sign * tail[0], tail[1], tail[2])
            eb.roll = sign * roll * (k % 3 - 1)
            if parent:
                eb.parent = arm.edit_bones[parent.replace(".L", f".{s}") if s else parent]
    bpy.ops.object.mode_set(mode="OBJECT")
    return ob


def _key_clip(ob, name, frames, rng):
    """An action on ``ob`` keying every bone's rotation (random, within a gait's range on
    the legs), the hips' location, and the feet's location and rotation relative to their
    parent as an IK rig's feet are keyed; the active action."""
    import bpy

    act = bpy.data.actions.new(name)
    slot = act.slots.new(id_type="OBJECT", name=ob.name)
    cb = act.layers.new("L").strips.new(type="KEYFRAME").channelbag(slot, ensure=True)
    for pb in ob.pose.bones:
        big = 0.5 if pb.name.startswith(("UpperLeg", "LowerLeg", "Foot.")) else 0.15
        q = Rotation.from_rotvec(rng.normal(size=(len(frames), 3)) * big).as_quat()[:, [3, 0, 1, 2]]
        path = f'pose.bones["{pb.name}"]'
        for i in range(4):
            fc = cb.fcurves.new(f"{path}.rotation_quaternion", index=i)
            for f, v in zip(frames, q[:, i]):
                fc.keyframe_points.insert(float(f), float(v))
        if pb.name in ("Body", "Foot.L", "Foot.R"):
            for i in range(3):
                fc = cb.fcurves.new(f"{path}.location", index=i)
                for f in frames:
                    fc.keyframe_points.insert(float(f), float(rng.normal() * 0.1))
    ob.animation_data_create()
    ob.animation_data.action = act
    ob.animation_data.action_slot = slot
    return act


def _played_pose(scene, ob, names, frames):
    """(F, B, 4, 4) armature-space pose matrices of bones ``names`` as Blender plays
    ``frames`` (``frame_set``, the evaluated object)."""
    import bpy

    dg = bpy.context.evaluated_depsgraph_get()
    out = np.empty((len(frames), len(names), 4, 4))
    for i, f in enumerate(frames):
        scene.frame_set(int(f))
        ev = ob.evaluated_get(dg)
        out[i] = [np.array(ev.pose.bones[n].matrix) for n in names]
    return out


def test_game_rig_hangs_its_feet_from_the_shins_and_reads_clips_as_blender_plays_them(fp, empty_scene):
    scene_mod, rig_mod, _ = _mods(fp)
    ob = _game_armature(empty_scene)
    rig = scene_mod.rig_from_armature(ob)
    roles = rig.roles.roles
    assert (roles["foot_l"], roles["shin_l"], roles["toe_l"], roles["hips"]) == ("Foot.L", "LowerLeg.L", "Toe.L",
                                                                               "Body"), rig.roles.describe()
    feet = [rig.index("Foot.L"), rig.index("Foot.R")]
    assert sorted(rig.reparented) == sorted(feet)
    for side, f in zip("LR", feet):
        assert rig.names[rig.parents[f]] == f"LowerLeg.{side}"
        assert rig.names[rig.armature_parents[f]] == f"FootParent.{side}"
    frames = np.arange(1, 8)
    act = _key_clip(ob, "Clip", frames, np.random.default_rng(3))
    own = scene_mod.sample_basis(ob, act, frames.astype(float))
    plan = scene_mod.sample_basis(ob, act, frames.astype(float), rig)
    played = _played_pose(empty_scene, ob, rig.names, frames)
    assert np.abs(rig_mod.forward_kinematics(rig, plan) - played).max() < 1e-5
    assert np.abs(rig_mod.armature_kinematics(rig, own) - played).max() < 1e-5
    assert np.abs(rig_mod.armature_basis(rig, plan) - own).max() < 1e-9
    moved = [b for b in range(len(rig.names)) if b not in feet]
    assert np.array_equal(plan[:, moved], own[:, moved])  # only the feet's bases change


def test_inherit_flags_are_checked_along_the_armatures_own_chain_of_a_foot(fp, empty_scene):
    scene_mod, rig_mod, _ = _mods(fp)
    ob = _game_armature(empty_scene)
    ob.data.bones["FootParent.L"].use_inherit_rotation = False
    with pytest.raises(rig_mod.RigError, match="FootParent.L"):
        scene_mod.rig_from_armature(ob)


def _ik_result(fp, rig, basis, rng):
    ik = import_module(fp.__name__ + ".core.solve.ik")
    F = len(basis)
    pos = np.c_[np.linspace(0.0, 1.2, F), rng.normal(size=F) * 0.05, np.zeros(F)]
    return ik.IKResult(body_pos=pos, body_heading=np.linspace(0.0, 0.8, F), basis=basis, targets=None,
                       hips_drop=np.zeros(F), body_offset=(np.zeros((F, 3)), np.zeros(F)))


def _planned_world(fp, ob, rig, res, spin):
    ik = import_module(fp.__name__ + ".core.solve.ik")
    rig_mod = import_module(fp.__name__ + ".core.clips.rig")
    return ik.body_frames(res.body_pos, spin + res.body_heading)[:, None] @ rig_mod.forward_kinematics(rig, res.basis)


def _bake_and_compare(fp, scene, ob, rig, res, spin, body_on):
    """The largest distance (m) between where the planner's pose puts each foot (its head
    and tail, world space) and where the baked keys put it as Blender plays the scene."""
    _, _, bake = _mods(fp)
    bake.bake(ob, scene, rig, res, spin, bake.BakeOptions("round trip", 1, body_on=body_on))
    world, *_ = bake.evaluate_played(scene, ob, rig, 1, res.frames)
    planned = _planned_world(fp, ob, rig, res, spin)
    feet = [rig.foot_chain(s)[0] for s in "lr"]
    length = np.array([np.linalg.norm(rig.tails[f] - rig.rest[f, :3, 3]) for f in feet])
    err = 0.0
    for k, f in enumerate(feet):
        for along in (0.0, length[k]):  # the head, and the tail
            a = world[:, f, :3, 3] + along * world[:, f, :3, 1] / np.linalg.norm(world[:, f, :3, 1], axis=1)[:, None]
            b = planned[:, f, :3, 3] + along * planned[:, f, :3, 1]
            err = max(err, float(np.linalg.norm(a - b, axis=1).max()))
    return err


@pytest.mark.parametrize("body_on", ["OBJECT", "ROOT"])
def test_bake_keys_a_foot_parented_to_the_root_where_the_planner_put_it(fp, empty_scene, body_on):
    """The planner's bases (each foot under its shin) baked into keys under the armature's
    own hierarchy (the foot under a bone under the root, keyed with location and
    rotation): played back, every foot stands where the planner's pose put it."""
    scene_mod, rig_mod, _ = _mods(fp)
    ob = _game_armature(empty_scene)
    rig = scene_mod.rig_from_armature(ob)
    rng = np.random.default_rng(11)
    F = 12
    basis = np.tile(np.eye(4), (F, len(rig.names), 1, 1))
    for b, n in enumerate(rig.names):
        if n not in ("Bone",):  # (the root at rest, as the planner's poses have it)
            big = 0.6 if n.startswith(("UpperLeg", "LowerLeg", "Foot.", "Toe")) else 0.1
            basis[:, b, :3, :3] = Rotation.from_rotvec(rng.normal(size=(F, 3)) * big).as_matrix()
    basis[:, rig.role_index("hips"), :3, 3] = rng.normal(size=(F, 3)) * 0.05
    res = _ik_result(fp, rig, basis, rng)
    size = float(np.ptp(rig.rest[:, :3, 3], axis=0).max())
    assert _bake_and_compare(fp, empty_scene, ob, rig, res, 0.3, body_on) < 1e-4 * size


# --------------------------------------------------------------------- the real character


@pytest.fixture
def quaternius(fp, empty_scene):
    """The Quaternius character as Blender's FBX importer brings it (defaults)."""
    import bpy

    bpy.ops.import_scene.fbx(filepath=QUATERNIUS)
    return next(o for o in bpy.data.objects if o.type == "ARMATURE")


QUATERNIUS_ROLES = {"hips": "Body", "thigh_l": "UpperLeg.L", "shin_l": "LowerLeg.L", "foot_l": "Foot.L",
                    "thigh_r": "UpperLeg.R", "shin_r": "LowerLeg.R", "foot_r": "Foot.R", "spine": "Abdomen",
                    "root": "Bone"}


@needs_quaternius
def test_quaternius_maps_its_feet_on_the_root(fp, quaternius):
    scene_mod, _, _ = _mods(fp)
    rig = scene_mod.rig_from_armature(quaternius)
    print(rig.roles.describe())
    assert rig.roles.ok and rig.roles.roles == QUATERNIUS_ROLES, rig.roles.describe()
    assert {rig.names[b] for b in rig.reparented} == {"Foot.L", "Foot.R"}
    assert rig.names[rig.armature_parents[rig.index("Foot.L")]] == "Bone"


@needs_quaternius
def test_quaternius_clips_stand_on_their_ground(fp, quaternius):
    """Every clip read through ``clip_from_action``: the heel and toe points of each foot
    reach the clip's ground (within 1% of the character's height), never hang metres
    above it; the same with the soles of the skinned mesh."""
    import bpy

    scene_mod, _, _ = _mods(fp)
    height = 4.85
    for sole in ("bones", "mesh"):
        rig = scene_mod.rig_from_armature(quaternius, sole=sole)
        assert (rig.sole is not None) == (sole == "mesh")
        for act in bpy.data.actions:
            clip = scene_mod.clip_from_action(quaternius, act, rig)
            low = np.minimum(clip.heel[:, :, 2].min(axis=1), clip.toe[:, :, 2].min(axis=1))
            assert np.all(np.abs(low) < 0.01 * height), (act.name, sole, low)


@needs_quaternius
def test_quaternius_sole_from_its_mesh(fp, quaternius):
    """The mesh's heel lies behind the ankle and its toe tip ahead of the ball (the foot
    bone ends at the ball; the file has no toe bone), all three on the sole, the two feet
    mirror images."""
    scene_mod, _, _ = _mods(fp)
    ik = import_module(fp.__name__ + ".core.solve.ik")
    rig = scene_mod.rig_from_armature(quaternius, sole="mesh")
    pts = []
    for k, side in enumerate("lr"):
        f = rig.foot_chain(side)[0]
        heel, ball, tip = [(rig.rest[f] @ p)[:3] for p in rig.sole.local(k)]
        ankle = rig.rest[f, :3, 3]
        assert heel[1] > ankle[1] + 0.03 and tip[1] < rig.tails[f][1] - 0.2  # facing -Y
        assert max(abs(heel[2]), abs(ball[2]), abs(tip[2])) < 0.01
        tip_ik = ik.toe_tip(rig, side, np.tile(rig.rest[f], (2, 1, 1)), None, None, None)
        assert np.allclose(tip_ik, rig.sole.tip[k])
        pts.append(np.array([heel, ball, tip]))
    assert np.allclose(pts[0] * [-1, 1, 1], pts[1], atol=0.03)


@needs_quaternius
def test_quaternius_clips_exported_one_per_fbx_map_the_same(fp, quaternius, tmp_path):
    """Each clip exported to its own FBX by Blender's exporter (each file's rest pose the
    pose it was written in), imported again: every file maps the same roles."""
    import bpy

    scene_mod, _, _ = _mods(fp)
    paths = []
    for act in list(bpy.data.actions):
        quaternius.animation_data.action = act
        path = str(tmp_path / (act.name.split("|")[-1] + ".fbx"))
        with bpy.context.temp_override(selected_objects=[quaternius], active_object=quaternius, object=quaternius):
            bpy.ops.export_scene.fbx(filepath=path, use_selection=True, bake_anim=True, object_types={"ARMATURE"},
                                     bake_anim_use_all_actions=False, bake_anim_use_nla_strips=False)
        paths.append(path)
    rests = set()
    for path in paths:
        bpy.ops.wm.read_homefile(use_empty=True)
        bpy.ops.import_scene.fbx(filepath=path)
        ob = next(o for o in bpy.data.objects if o.type == "ARMATURE")
        rests.add(tuple(np.round(ob.data.bones["Foot.L"].head_local, 3)))
        roles = scene_mod.rig_from_armature(ob).roles
        assert roles.roles == QUATERNIUS_ROLES, (os.path.basename(path), roles.describe())
    assert len(rests) > 3  # (the rest poses do differ)


@needs_quaternius
def test_quaternius_bake_puts_each_foot_where_the_planner_did(fp, quaternius):
    """The walk's own pose (under the planner's hierarchy), its legs bent further, on a
    moving body: baked and played back, each foot (parented to the root in the file) is
    where the planner's pose put it, within 1e-4 of the character's size."""
    import bpy

    scene_mod, rig_mod, _ = _mods(fp)
    scene = bpy.context.scene
    rig = scene_mod.rig_from_armature(quaternius)
    walk = next(a for a in bpy.data.actions if a.name.endswith("Man_Walk"))
    basis = scene_mod.sample_basis(quaternius, walk, np.arange(1.0, 27.0), rig)
    basis[:, rig.index("Bone")] = np.eye(4)  # (the planner's poses keep the bones above the hips at rest)
    rng = np.random.default_rng(5)
    for side in "lr":
        for role in ("thigh", "shin", "foot"):
            b = rig.role_index(f"{role}_{side}")
            basis[:, b, :3, :3] = basis[:, b, :3, :3] @ Rotation.from_rotvec(
                rng.normal(size=(len(basis), 3)) * 0.2).as_matrix()
    res = _ik_result(fp, rig, basis, rng)
    size = float(np.ptp(rig.rest[:, :3, 3], axis=0).max())
    for body_on in ("OBJECT", "ROOT"):
        err = _bake_and_compare(fp, scene, quaternius, rig, res, -0.4, body_on)
        assert err < 1e-4 * size, (body_on, err)
