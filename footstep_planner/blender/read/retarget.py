"""A clip retargeted onto another armature of the same skeleton (``_retarget``): a new
Action posing each of its bones as the clip poses the same-named bone, in the BVH sense (each
joint's rotation relative to the rest pose kept) or the FBX and glTF sense (each bone's rotation
relative to its parent kept), the hips' travel scaled by the skeletons' sizes.
"""

from __future__ import annotations

import bpy
import numpy as np

from ...core.base.quat import rotations
from ...core.clips.roles import map_roles
from .clip_checks import _tag_source
from .clip_keys import _curve, _key_frames, _write_rotation
from .scene import _matrices, sample_basis


def _retarget(src_ob, src_act, target, src, local: bool = False):
    """A new Action on ``target`` that poses each of its bones as ``src_act`` poses the
    same-named bone of ``src_ob``; the hips' translation is scaled by the ratio of the
    skeletons' sizes.

    BVH sense (``local`` False): each joint's rotation relative to its skeleton's own rest
    pose is kept (the rest poses are taken to be the same pose), and the size is the hip
    height. FBX and glTF sense (``local``): each bone's rotation relative to its parent is
    kept (the bones' axes are the file's joint axes, the same in every file of a rig, while
    the rest pose is whatever pose the file was written in), and the size is the legs'
    length."""
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
    if local:
        ratio = _leg_length(tgt_names, tgt_rest, roles) / _leg_length(src_names, src_rest, roles)
    else:
        ratio = _hip_height(tgt_names, tgt_rest, hips) / _hip_height(src_names, src_rest, hips)

    name = src_act.name
    src_act.name = "footstep_scratch"  # the importer's copy is scratch: free its name
    act = bpy.data.actions.new(name)
    _tag_source(act, src, target)
    slot = act.slots.new(id_type="OBJECT", name=target.name)
    cbag = act.layers.new("Layer").strips.new(type="KEYFRAME").channelbag(slot, ensure=True)
    for ti, bname in enumerate(tgt_names):
        if bname not in s_idx:
            continue
        si = s_idx[bname]
        ms, mt = src_rest[si, :3, :3], tgt_rest[ti, :3, :3]
        rb = src_basis[:, si, :3, :3]
        if local:  # the bone's rest in its parent's axes, in each skeleton
            ms = _parent_rest(src_ob, src_names, src_rest, bname).T @ ms
            mt = _parent_rest(target, tgt_names, tgt_rest, bname).T @ mt
            rot = rotations(mt.T @ ms @ rb)
        else:
            world_rel = ms @ rb @ ms.T  # the joint's rotation in armature axes
            rot = rotations(mt.T @ world_rel @ mt)
        pb = target.pose.bones[bname]
        base = f'pose.bones["{bpy.utils.escape_identifier(bname)}"]'
        _write_rotation(cbag, base, bname, pb.rotation_mode, rot, frames)
        if bname == hips:
            mt = tgt_rest[ti, :3, :3]
            head = (src_rest[si] @ src_basis[:, si])[:, :3, 3] * ratio
            loc = (head - tgt_rest[ti, :3, 3]) @ mt  # into the bone's rest axes
            for i in range(3):
                _curve(cbag, f"{base}.location", i, bname, frames, loc[:, i])
    return act


def _parent_rest(ob, names, rest, bone: str) -> np.ndarray:
    """The rest rotation (3, 3, armature axes) of bone ``bone``'s parent; the identity
    for a root bone. ``rest`` (B, 4, 4) in ``names`` order."""
    parent = ob.data.bones[bone].parent
    return np.eye(3) if parent is None else rest[names.index(parent.name), :3, :3]


def _leg_length(names, rest, roles) -> float:
    """Length of the legs, whatever their pose: thigh to shin to foot heads, both sides
    averaged (``rest`` (B, 4, 4) in ``names`` order), at least 1 mm."""
    total = 0.0
    for side in ("l", "r"):
        heads = [rest[names.index(roles.bone(f"{part}_{side}")), :3, 3] for part in ("thigh", "shin", "foot")]
        total += np.linalg.norm(heads[1] - heads[0]) + np.linalg.norm(heads[2] - heads[1])
    return max(total / 2, 1e-3)


def _hip_height(names, rest, hips):
    """Height of bone ``hips``' rest head above the lowest rest head (``rest`` (B, 4, 4)
    armature-space matrices in ``names`` order), at least 1 mm."""
    return max(float(rest[names.index(hips), 2, 3] - rest[:, 2, 3].min()), 1e-3)
