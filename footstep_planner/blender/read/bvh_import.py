"""A BVH file imported: its skeleton read and its legs mapped (``_legged_skeleton``), then the
armature and keys Blender's BVH importer would make, made here from the motion ``core.bvh``
reads, one whole F-curve at a time (``_bvh_import``: the bones, ``_bvh_rest`` and
``_bvh_bones``; the keys, ``_bvh_keys`` and ``bvh_quats``).
"""

from __future__ import annotations

import os

import bpy
import numpy as np
from mathutils import Matrix
from scipy.spatial.transform import Rotation

from ...core.clips.bvh import BvhError, read_bvh, read_skeleton
from ...core.clips.roles import map_roles
from .clip_checks import ClipImportError
from .clip_keys import _curve
from .scene import _matrices, scene_fps


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


#: The file's axes (Y up, -Z forward) to Blender's (Z up, -Y forward): (x, y, z) -> (x, -z, y),
#: as Blender's BVH importer turns them (axis_forward "-Z", axis_up "Y").
_BVH_AXES = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])


def _bvh_import(sk, scale, made: list):
    """(armature object, action) of the BVH file of skeleton ``sk``, as Blender's BVH
    importer makes them (the same bones, rolls and connections, Y up turned to Z up,
    quaternion keys, LINEAR, from frame 1 at the scene's rate; ``scale`` metres per file
    unit, default guessed), the action named after the file; made here from the motion
    as ``core.bvh`` reads it, one whole F-curve at a time (``_curve``), so a long clip
    costs seconds and its 32-bit keys, not Python objects per frame and value."""
    sk, motion = _read_bvh(sk.path)
    scale = scale or sk.unit_scale()
    name = os.path.splitext(os.path.basename(sk.path))[0]
    arm = bpy.data.armatures.new(name)
    made.append(arm)
    ob = bpy.data.objects.new(name, arm)
    made.append(ob)
    bpy.context.collection.objects.link(ob)
    bones = _bvh_bones(ob, sk, scale)
    # Blender 5.0: a pose for the new armature (evaluated before its action is assigned:
    # the evaluated copy of a long action would double its memory)
    bpy.context.view_layer.update()
    act = bpy.data.actions.new(name)
    made.append(act)
    _bvh_keys(ob, act, sk, motion, scale, bones)
    return ob, act


def _read_bvh(path: str):
    try:
        return read_bvh(path)
    except BvhError as ex:
        raise ClipImportError(str(ex)) from None


def _bvh_rest(sk, scale: float):
    """(heads, tails (J, 3) and connected (J,) bool) of the joints' bones in the file's
    axes, in metres, laid out as Blender's BVH importer lays them: the tail at the End
    Site, the one child's head or the children's mean head; a bone shorter than 1 mm
    given the length and direction Blender's importer gives it (its parent's, or up)."""
    local, heads = sk.offsets * scale, sk.heads() * scale
    parents = np.array(sk.parents)
    rel = sk.end_sites * scale  # tail - head
    for j in range(len(parents)):
        kids = np.flatnonzero(parents == j)
        if len(kids) and not rel[j].any():
            rel[j] = local[kids].mean(axis=0)
    rel[np.linalg.norm(rel, axis=1) <= 0.001 * scale, 1] += scale / 10  # (the importer's first fix)
    size = np.linalg.norm(rel, axis=1)
    average = float(size[size > 0].mean()) if (size > 0).any() else 0.1
    h32, t32 = heads.astype(np.float32), (heads + rel).astype(np.float32)
    tails = heads + rel
    zero = np.linalg.norm(t32 - h32, axis=1) < 0.001 * (1 + 1e-5)  # (its second: 1 mm is too short)
    for j in np.flatnonzero(zero):
        p = parents[j]
        if p >= 0 and np.linalg.norm(rel[p]) > 0:
            tails[j] += rel[p]
        else:
            tails[j, 1] += average
    has_loc = np.array([any(c.endswith("POSITION") for c in chans) for chans in sk.channels])
    connected = np.array([p >= 0 and not has_loc[j] and not zero[p]
                          and np.allclose(local[p] + rel[p], local[j], rtol=0, atol=1e-7 * scale)
                          for j, p in enumerate(parents)], dtype=bool)
    return heads, tails, connected


def _bvh_bones(ob, sk, scale: float) -> list[str]:
    """Make armature ``ob``'s bones, one per joint (``_bvh_rest``), then turn the
    armature from the file's axes to Blender's; returns the bones' names (Blender may
    shorten a long joint name or number a repeated one)."""
    heads, tails, connected = _bvh_rest(sk, scale)
    view_layer = bpy.context.view_layer
    view_layer.objects.active = ob
    ob.select_set(True)
    try:
        bpy.ops.object.mode_set(mode="EDIT")
        made = [ob.data.edit_bones.new(n) for n in sk.names]
        for eb, h, t in zip(made, heads, tails):
            eb.head, eb.tail = h, t
        for j, p in enumerate(sk.parents):
            if p >= 0:
                made[j].parent = made[p]
                made[j].use_connect = bool(connected[j])
        names = [eb.name for eb in made]
        bpy.ops.object.mode_set(mode="OBJECT")
    except RuntimeError as ex:
        raise ClipImportError(f"{sk.path}: cannot make the armature: {ex}") from None
    axes = np.eye(4)
    axes[:3, :3] = _BVH_AXES
    ob.data.transform(Matrix(axes.tolist()))
    return names


def _bvh_keys(ob, act, sk, motion: np.ndarray, scale: float, bones: list[str]) -> None:
    """Key ``motion`` (F, channels) of file ``sk`` on armature ``ob``'s ``bones`` into
    ``act`` (a slot "Slot", as Blender's importer names it; assigned to ``ob``): each
    joint's position channels as its bone's location, its rotation channels as its
    bone's quaternion, both relative to the bone's rest, Blender's way."""
    rest = _matrices(ob.data.bones, "matrix_local")[[ob.data.bones.find(b) for b in bones], :3, :3]
    frames = 1.0 + np.arange(len(motion)) * (scene_fps() / sk.fps)  # (a rate of 120.0005 is 120)
    slot = act.slots.new(id_type="OBJECT", name="Slot")
    cbag = act.layers.new("Layer").strips.new(type="KEYFRAME").channelbag(slot, ensure=True)
    ad = ob.animation_data_create()
    ad.action, ad.action_slot = act, slot
    first = np.cumsum([0] + [len(c) for c in sk.channels])
    for j, chans in enumerate(sk.channels):
        cols = motion[:, first[j]:first[j + 1]]
        to_bone = rest[j].T @ _BVH_AXES  # file axes -> the bone's rest axes
        base = f'pose.bones["{bpy.utils.escape_identifier(bones[j])}"]'
        pos = [k for k, c in enumerate(chans) if c.endswith("POSITION")]
        if pos:
            p = np.zeros((len(motion), 3))
            for k in pos:
                p[:, "XYZ".index(chans[k][0])] = cols[:, k] * scale
            loc = (p - sk.offsets[j] * scale) @ to_bone.T
            for i in range(3):
                _curve(cbag, f"{base}.location", i, sk.names[j], frames, loc[:, i])
        rot = [k for k, c in enumerate(chans) if c.endswith("ROTATION")]
        if rot:
            q = bvh_quats([chans[k][0] for k in rot], cols[:, rot], to_bone)
            for i in range(4):  # w x y z
                _curve(cbag, f"{base}.rotation_quaternion", i, sk.names[j], frames, q[:, i])


def bvh_quats(axes: list[str], degrees: np.ndarray, to_bone: np.ndarray) -> np.ndarray:
    """Quaternions (F, 4; w x y z, w >= 0 as Blender's importer gives them) of BVH rotation
    channels about ``axes`` ("X", "Y", "Z") by ``degrees`` (F, len(axes)), the first
    outermost (R = R0 R1 R2: scipy's intrinsic order), seen in the bone's rest axes:
    ``to_bone`` R ``to_bone``^T, ``to_bone`` (3, 3) taking the file's axes to the bone's."""
    rot = Rotation.from_euler("".join(axes).upper(), np.asarray(degrees, np.float64), degrees=True)
    m = Rotation.from_matrix(to_bone)
    return (m * rot * m.inv()).as_quat(canonical=True)[:, [3, 0, 1, 2]]
