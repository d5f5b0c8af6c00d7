"""Importing BVH clips into a character: one armature, one Action per file.

The first file of a new library gives the armature (Blender's own BVH importer, metres,
Z up, keys at the scene's frame rate whatever the file's). Every further file, or every
file imported into an existing armature, is retargeted onto that armature's bones in the
BVH sense (each joint's rotation relative to the rest pose is kept) and added as a new
Action: nothing of the user's is replaced or renamed.
"""

from __future__ import annotations

import contextlib
import io
import os

import bpy
import numpy as np
from scipy.spatial.transform import Rotation

from ..core.bvh import BvhError, read_skeleton
from ..core.roles import map_roles
from .scene import (ARMATURE_PROP, SOURCE_FILE_PROP, SOURCE_FPS_PROP, _matrices, sample_basis)
from ..core.errors import FootstepError


class ClipImportError(FootstepError):
    """An import that cannot be done; names the file or bone at fault."""


def import_bvh_clips(paths, target=None, name: str | None = None, scale: float | None = None):
    """Import BVH files as Actions of one armature.

    ``target``: an existing armature object to add the clips to; when None the first
    file's skeleton becomes a new armature (named ``name`` or after the file).
    ``scale``: metres per file unit; None guesses from the skeleton's height.
    Returns ``(armature_object, [actions])``. On error nothing is left in the scene.
    """
    paths = [os.path.abspath(p) for p in paths]
    if not paths:
        raise ClipImportError("no BVH files given")
    skeletons = [_legged_skeleton(p) for p in paths]
    _check_one_skeleton(skeletons, target)
    with _selection_kept():
        return _import_all(skeletons, target, name, scale)


def _legged_skeleton(path: str):
    """The file's BvhSkeleton; ClipImportError naming the file when it cannot be read or
    its legs cannot be mapped to roles."""
    try:
        sk = read_skeleton(path)
    except BvhError as ex:
        raise ClipImportError(str(ex)) from None
    roles = map_roles(sk.names, sk.parents, sk.heads_z_up(), sk.tails_z_up())
    if not roles.ok:
        raise ClipImportError(f"{path}: skeleton has no usable legs: {roles.describe()}")
    return sk


def _check_one_skeleton(skeletons, target) -> None:
    """ClipImportError unless the clips share one skeleton: every joint is a bone of
    armature ``target``, or (no target) every file has the first file's joints and
    parents."""
    if target is not None:
        if target.type != "ARMATURE":
            raise ClipImportError(f"{target.name!r} is not an armature")
        have = {b.name for b in target.data.bones}
        for sk in skeletons:
            missing = [n for n in sk.names if n not in have]
            if missing:
                raise ClipImportError(
                    f"{sk.path}: joints {', '.join(missing[:6])} are not bones of armature "
                    f"{target.name!r}; clips of one library must share one skeleton")
        return
    first = skeletons[0]
    for sk in skeletons[1:]:
        if sk.names != first.names or sk.parents != first.parents:
            raise ClipImportError(f"{sk.path}: its skeleton differs from {first.path}'s; "
                                  "clips of one library must share one skeleton")


@contextlib.contextmanager
def _selection_kept():
    """Put the user's selection and active object back afterwards, whatever happens (the
    importer selects what it makes)."""
    view_layer = bpy.context.view_layer
    selected = list(bpy.context.selected_objects)
    active = view_layer.objects.active
    try:
        yield
    finally:
        names = {o.name for o in selected}
        for o in bpy.data.objects:
            if o.name in view_layer.objects:
                o.select_set(o.name in names)
        if active is not None and active.name in view_layer.objects:
            view_layer.objects.active = active


def _import_all(skeletons, target, name, scale):
    """(armature, [one action per skeleton]): each file imported by Blender, the first
    becoming the armature when ``target`` is None, the others retargeted onto it. The
    importer's scratch objects and actions are removed; on error, everything made."""
    created_objects, created_actions = [], []
    try:
        actions = []
        for sk in skeletons:
            target, act = _import_one(sk, target, name, scale, created_objects, created_actions)
            actions.append(act)
        # the retargeted sources are scratch data of ours
        for act in created_actions:
            if act not in actions:
                bpy.data.actions.remove(act)
        for ob in created_objects:
            _remove_object(ob)
        return target, actions
    except BaseException:
        for act in created_actions:
            if act.name in bpy.data.actions:
                bpy.data.actions.remove(act)
        for ob in created_objects:
            _remove_object(ob)
        raise


def _import_one(sk, target, name, scale, created_objects: list, created_actions: list):
    """(target, the clip's action) for one file. Without a ``target`` the imported
    armature becomes it (named ``name`` or after the file); else the import is
    retargeted onto it. What is made is appended to ``created_objects`` and
    ``created_actions``, the new target excepted."""
    ob, act = _blender_import(sk, scale)
    created_objects.append(ob)
    created_actions.append(act)
    if target is None:
        target = ob
        target.name = name or os.path.splitext(os.path.basename(sk.path))[0]
        created_objects.remove(ob)
        _tag_source(act, sk, target)
        return target, act
    new = _retarget(ob, act, target, sk)
    created_actions.append(new)
    return target, new


def _remove_object(ob):
    """Delete object ``ob``, and its armature data when nothing else uses it."""
    data = ob.data
    bpy.data.objects.remove(ob)
    if data is not None and data.users == 0:
        bpy.data.armatures.remove(data)


def _tag_source(act, sk, target):
    """Mark a clip as imported for ``target``; a fake user keeps it in the file while no
    object plays it."""
    act[SOURCE_FPS_PROP] = sk.fps
    act[SOURCE_FILE_PROP] = os.path.basename(sk.path)
    act[ARMATURE_PROP] = target.data.name
    act.use_fake_user = True


def _blender_import(sk, scale):
    """(armature object, action) made by Blender's BVH importer from ``sk``'s file
    (``scale`` metres per file unit, default guessed; Y up, -Z forward; quaternions;
    keyed from frame 1 at the scene's rate), the action named after the file.
    ClipImportError when the importer fails or makes anything but one of each."""
    before = set(bpy.data.objects)
    before_actions = set(bpy.data.actions)
    try:
        with contextlib.redirect_stdout(io.StringIO()):  # the importer's progress chatter
            res = bpy.ops.import_anim.bvh(
                filepath=sk.path, target="ARMATURE", global_scale=scale or sk.unit_scale(),
                frame_start=1, use_fps_scale=True, update_scene_fps=False,
                update_scene_duration=False, rotate_mode="QUATERNION",
                axis_forward="-Z", axis_up="Y")
    except (RuntimeError, BvhError) as ex:
        for o in set(bpy.data.objects) - before:
            _remove_object(o)
        raise ClipImportError(f"{sk.path}: Blender's BVH importer failed: {ex}") from None
    new_obs = [o for o in set(bpy.data.objects) - before if o.type == "ARMATURE"]
    new_actions = list(set(bpy.data.actions) - before_actions)
    if res != {"FINISHED"} or len(new_obs) != 1 or len(new_actions) != 1:
        raise ClipImportError(f"{sk.path}: Blender's BVH importer made no armature")
    ob, act = new_obs[0], new_actions[0]
    act.name = os.path.splitext(os.path.basename(sk.path))[0]
    # Blender 5.0: an armature that was never evaluated has no pose yet.
    bpy.context.view_layer.update()
    return ob, act


def _key_frames(act) -> np.ndarray:
    """Sorted distinct frames (rounded to 1e-6) keyed on any F-curve of ``act``."""
    frames = set()
    for layer in act.layers:
        for strip in layer.strips:
            for cb in strip.channelbags:
                for fc in cb.fcurves:
                    co = np.empty(len(fc.keyframe_points) * 2)
                    fc.keyframe_points.foreach_get("co", co)
                    frames.update(np.round(co[0::2], 6).tolist())
    return np.array(sorted(frames))


def _retarget(src_ob, src_act, target, sk):
    """A new Action on ``target`` that poses each of its bones as ``src_act`` poses the
    same-named bone of ``src_ob``, relative to each skeleton's own rest pose; the hips'
    translation is scaled by the ratio of the skeletons' hip heights."""
    frames = _key_frames(src_act)
    src_basis = sample_basis(src_ob, src_act, frames)
    src_names = [pb.name for pb in src_ob.pose.bones]
    src_rest = _matrices(src_ob.data.bones, "matrix_local")[
        [src_ob.data.bones.find(n) for n in src_names]]
    tgt_names = [pb.name for pb in target.pose.bones]
    tgt_rest = _matrices(target.data.bones, "matrix_local")[
        [target.data.bones.find(n) for n in tgt_names]]
    s_idx = {n: i for i, n in enumerate(src_names)}
    roles = map_roles(src_names, [s_idx[b.parent.name] if b.parent else -1
                                  for b in (src_ob.data.bones[n] for n in src_names)],
                      src_rest[:, :3, 3])
    hips = roles.bone("hips")
    ratio = _hip_height(tgt_names, tgt_rest, hips) / _hip_height(src_names, src_rest, hips)

    name = src_act.name
    src_act.name = "footstep_scratch"  # the importer's copy is scratch: free its name
    act = bpy.data.actions.new(name)
    _tag_source(act, sk, target)
    slot = act.slots.new(id_type="OBJECT", name=target.name)
    cbag = act.layers.new("Layer").strips.new(type="KEYFRAME").channelbag(slot, ensure=True)
    for ti, bname in enumerate(tgt_names):
        if bname not in s_idx:
            continue
        si = s_idx[bname]
        ms, mt = src_rest[si, :3, :3], tgt_rest[ti, :3, :3]
        rb = src_basis[:, si, :3, :3]
        world_rel = ms @ rb @ ms.T  # the joint's rotation in armature axes
        rot = Rotation.from_matrix(mt.T @ world_rel @ mt)
        pb = target.pose.bones[bname]
        base = f'pose.bones["{bpy.utils.escape_identifier(bname)}"]'
        _write_rotation(cbag, base, bname, pb.rotation_mode, rot, frames)
        if bname == hips:
            head = (src_rest[si] @ src_basis[:, si])[:, :3, 3] * ratio
            loc = (head - tgt_rest[ti, :3, 3]) @ mt  # into the bone's rest axes
            for i in range(3):
                _curve(cbag, f"{base}.location", i, bname, frames, loc[:, i])
    return act


def _hip_height(names, rest, hips):
    """Height of bone ``hips``' rest head above the lowest rest head (``rest`` (B, 4, 4)
    armature-space matrices in ``names`` order), at least 1 mm."""
    return max(float(rest[names.index(hips), 2, 3] - rest[:, 2, 3].min()), 1e-3)


def _write_rotation(cbag, base, group, mode, rot, frames):
    """Key ``rot`` (F rotations) at ``frames`` (F,) on the rotation channels of the pose
    bone at data path ``base`` in rotation mode ``mode``: quaternions (w first, signs
    kept continuous), axis-angle, or Euler angles (unwrapped) of that order."""
    if mode == "QUATERNION":
        q = rot.as_quat()[:, [3, 0, 1, 2]]
        flip = np.cumsum(np.r_[False, np.einsum("ij,ij->i", q[1:], q[:-1]) < 0]) % 2 == 1
        q[flip] *= -1
        for i in range(4):
            _curve(cbag, f"{base}.rotation_quaternion", i, group, frames, q[:, i])
    elif mode == "AXIS_ANGLE":
        rv = rot.as_rotvec()
        ang = np.linalg.norm(rv, axis=1)
        axis = np.where(ang[:, None] > 1e-12, rv / np.maximum(ang, 1e-12)[:, None], [0, 1, 0])
        vals = np.column_stack([ang, axis])
        for i in range(4):
            _curve(cbag, f"{base}.rotation_axis_angle", i, group, frames, vals[:, i])
    else:  # Euler 'XYZ' etc.: Blender's order is scipy's extrinsic lower-case order
        e = np.unwrap(rot.as_euler(mode.lower()), axis=0)
        for i in range(3):
            _curve(cbag, f"{base}.rotation_euler", i, group, frames, e[:, _euler_slot(mode, i)])


def _euler_slot(mode: str, axis: int) -> int:
    """Column of scipy's ``as_euler(mode.lower())`` that holds the angle about ``axis``."""
    return mode.lower().index("xyz"[axis])


_LINEAR = None


def _curve(cbag, path, index, group, frames, values):
    """A new F-curve ``path[index]`` in channel group ``group`` of ``cbag``, keyed
    ``values`` (F,) at ``frames`` (F,) with linear interpolation."""
    global _LINEAR
    if _LINEAR is None:
        _LINEAR = bpy.types.Keyframe.bl_rna.properties["interpolation"].enum_items["LINEAR"].value
    fc = cbag.fcurves.new(path, index=index, group_name=group)
    kp = fc.keyframe_points
    kp.add(len(frames))
    co = np.empty(2 * len(frames), dtype=np.float32)
    co[0::2] = frames
    co[1::2] = values
    kp.foreach_set("co", co)
    kp.foreach_set("interpolation", np.full(len(frames), _LINEAR, dtype=np.int32))
    fc.update()
