"""Reading a rig through the depsgraph (``sample_deform``): an action played on the rig frame
by frame and its bones' armature-space matrices read, the object's animation data, pose,
transform and the scene's frame put back afterwards; the action's slot for the rig
(``_slot_for``).
"""

from __future__ import annotations

import bpy
import numpy as np

from .skeleton import deform_bone_names


def _slot_for(ob, action, create=True):
    """The slot of ``action`` that animates ``ob``: the assigned one, else "OB<name>", else the
    only object slot, else a new one (or ValueError when ``create`` is False)."""
    ad = ob.animation_data
    if ad is not None and ad.action == action and ad.action_slot is not None:
        return ad.action_slot
    for sl in action.slots:
        if sl.identifier == "OB" + ob.name:
            return sl
    objs = [sl for sl in action.slots if sl.target_id_type in ("OBJECT", "UNSPECIFIED")]
    if len(objs) == 1:
        return objs[0]
    if not create:
        raise ValueError(f"action {action.name!r} has no slot for {ob.name!r}; pass slot=")
    return action.slots.new(id_type="OBJECT", name=ob.name)


_POSE_CHANNELS = (("location", 3), ("rotation_quaternion", 4), ("rotation_euler", 3),
                  ("rotation_axis_angle", 4), ("scale", 3))
_OBJECT_CHANNELS = ("location", "rotation_quaternion", "rotation_euler", "rotation_axis_angle", "scale")


def _snapshot(ob):
    """The pose (every bone's loc/rot/scale and numeric custom properties) and the object's
    transform: playing an action writes the channels it keys into them, and they stay."""
    n = len(ob.pose.bones)
    pose = {}
    for attr, k in _POSE_CHANNELS:
        buf = np.empty(n * k, np.float32)
        ob.pose.bones.foreach_get(attr, buf)
        pose[attr] = buf
    props = [(pb.name, key, pb[key]) for pb in ob.pose.bones for key in pb.keys()
             if isinstance(pb[key], (int, float))]
    obj = {a: tuple(getattr(ob, a)) for a in _OBJECT_CHANNELS}
    return pose, props, obj


def _restore(ob, snap):
    pose, props, obj = snap
    for attr, buf in pose.items():
        ob.pose.bones.foreach_set(attr, buf)
    for bone, key, value in props:
        ob.pose.bones[bone][key] = value
    for a, v in obj.items():
        setattr(ob, a, v)


def sample_deform(ob, action, frames, names=None, slot=None, *, isolate: bool = True):
    """(F, B, 4, 4) armature-space matrices of bones ``names`` (default: every deforming bone,
    ``deform_bone_names(ob)``) when ``action`` plays on ``ob`` as its active action, evaluated by
    the depsgraph at each frame. Channels the action does not key keep their current values, as
    in Blender. Afterwards the object's action, slot, influence, blend type, NLA switch, its
    pose (bone loc/rot/scale, pose-bone custom properties), its transform and the scene's frame
    are restored. ``isolate``: mute the NLA while sampling."""
    scene = bpy.context.scene
    names = deform_bone_names(ob) if names is None else list(names)
    frames = np.asarray(frames, np.float64).ravel()
    bpy.context.view_layer.update()  # an armature never evaluated must not lose its action unevaluated
    created = ob.animation_data is None
    ad = ob.animation_data_create()
    if ad.use_tweak_mode:
        raise RuntimeError(f"{ob.name}: the NLA is in tweak mode; leave it before sampling")
    saved = (ad.action, ad.action_slot, ad.action_influence, ad.action_blend_type,
             ad.action_extrapolation, ad.use_nla, ad.last_slot_identifier)
    frame0, sub0 = scene.frame_current, scene.frame_subframe
    snap = _snapshot(ob)
    order = {n: i for i, n in enumerate(ob.pose.bones.keys())}
    idx = np.array([order[n] for n in names], np.int64)
    nb = len(order)
    out = np.empty((len(frames), len(names), 4, 4))
    buf = np.empty(nb * 16, np.float32)
    try:
        slot = slot if slot is not None else _slot_for(ob, action, create=False)
        ad.action = action
        ad.action_slot = slot
        ad.action_influence = 1.0
        ad.action_blend_type = "REPLACE"
        ad.action_extrapolation = "HOLD"
        if isolate:
            ad.use_nla = False
        for i, f in enumerate(frames):
            fi = int(np.floor(f))
            scene.frame_set(fi, subframe=float(f - fi))
            ev = ob.evaluated_get(bpy.context.evaluated_depsgraph_get())
            ev.pose.bones.foreach_get("matrix", buf)
            out[i] = buf.reshape(nb, 4, 4).transpose(0, 2, 1)[idx]
    finally:
        act0, slot0, infl, blend, extrap, use_nla, last_id = saved
        ad.use_nla = use_nla
        ad.action_influence = infl
        ad.action_blend_type = blend
        ad.action_extrapolation = extrap
        ad.action = act0
        if act0 is not None and slot0 is not None:
            ad.action_slot = slot0
        try:
            ad.last_slot_identifier = last_id
        except (AttributeError, TypeError, RuntimeError):
            pass
        if created:
            ob.animation_data_clear()
        _restore(ob, snap)
        scene.frame_set(frame0, subframe=sub0)
    return out
