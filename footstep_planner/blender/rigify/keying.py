"""Keying the controls (``key_controls``): every chain with targets solved (the spine first),
the controls' bases and the neutral bones and properties written as whole F-Curves into the
action's channelbag, and optionally played back to measure the error.
"""

from __future__ import annotations

import bpy
import numpy as np
from mathutils import Matrix

from ..write.keys import CONSTANT, LINEAR, fill_keys, new_fcurve
from .fk import _solve_head, _solve_limb, _solve_spine
from .sampling import _slot_for, sample_deform
from .skeleton import deform_chain, is_rigify, rigify_metarig
from .solver import _Solver, _bases, _inv, _mat_to_quat, _rest, _rot, heads_tails


def _channelbag(ob, dst):
    """(action, slot, channelbag) from an Action, a channelbag, or an (Action, ActionSlot) pair."""
    if isinstance(dst, bpy.types.ActionChannelbag):
        act = dst.id_data
        return act, dst.slot, dst
    if isinstance(dst, (tuple, list)):
        act, slot = dst
    elif isinstance(dst, bpy.types.Action):
        act, slot = dst, _slot_for(ob, dst)
    else:
        raise TypeError("expected an Action, an ActionChannelbag or (Action, ActionSlot)")
    if len(act.layers) == 0:
        act.layers.new("Layer")
    layer = act.layers[0]
    strip = layer.strips[0] if len(layer.strips) else layer.strips.new(type="KEYFRAME")
    return act, slot, strip.channelbag(slot, ensure=True)


def _write(cbag, path, index, frames, values, group, interp=LINEAR):
    fc = cbag.fcurves.find(path, index=index)
    if fc is not None:
        cbag.fcurves.remove(fc)
    fc = new_fcurve(cbag, path, index, group)
    fill_keys(fc, frames, values, interp)
    return fc


def _key_bone(cbag, ob, name, frames, basis, with_location=True):
    """Key rotation (in the bone's rotation mode) and, for unconnected bones, location."""
    pb = ob.pose.bones[name]
    base = f'pose.bones["{bpy.utils.escape_identifier(name)}"]'
    count = 0
    one = len(frames) == 1
    interp = CONSTANT if one else LINEAR
    bone = ob.data.bones[name]
    if with_location and not bone.use_connect:
        loc = basis[:, :3, 3]
        if not bone.use_local_location:  # location in the parent's axes, not the bone's own
            par = _rest(ob, bone.parent.name) if bone.parent is not None else np.eye(4)
            loc = loc @ _rot(_inv(par) @ _rest(ob, name)).T
        for i in range(3):
            _write(cbag, base + ".location", i, frames, loc[:, i], name, interp)
            count += 1
    r = _rot(basis)
    mode = pb.rotation_mode
    if mode == "QUATERNION":
        q = _mat_to_quat(r)
        for i in range(4):
            _write(cbag, base + ".rotation_quaternion", i, frames, q[:, i], name, interp)
        count += 4
    elif mode == "AXIS_ANGLE":
        q = _mat_to_quat(r)
        ang = 2 * np.arctan2(np.linalg.norm(q[:, 1:], axis=1), q[:, 0])
        axis = q[:, 1:] / np.maximum(np.linalg.norm(q[:, 1:], axis=1, keepdims=True), 1e-12)
        axis[np.linalg.norm(q[:, 1:], axis=1) < 1e-12] = (0.0, 1.0, 0.0)
        vals = np.column_stack([ang, axis])
        for i in range(4):
            _write(cbag, base + ".rotation_axis_angle", i, frames, vals[:, i], name, interp)
        count += 4
    else:
        eul = np.empty((len(r), 3))
        prev = None
        for f in range(len(r)):
            e = Matrix(r[f].tolist()).to_euler(mode, prev) if prev is not None else Matrix(r[f].tolist()).to_euler(mode)
            eul[f] = e
            prev = e
        for i in range(3):
            _write(cbag, base + ".rotation_euler", i, frames, eul[:, i], name, interp)
        count += 3
    return count


def _key_scale(cbag, name, frame0):
    base = f'pose.bones["{bpy.utils.escape_identifier(name)}"]'
    for i in range(3):
        _write(cbag, base + ".scale", i, np.array([frame0]), np.array([1.0]), name, CONSTANT)
    return 3


def key_controls(ob, dst, frames, targets: dict, *, neutral: bool = True, all_fk: bool = True,
                 leg_ik: bool = False, verify: int = 0) -> dict:
    """Key the FK controls of Rigify rig ``ob`` so its DEF bones follow ``targets``.

    ``dst``: an Action (the slot for ``ob`` is found or made; layer/strip/channelbag ensured),
    an ActionChannelbag, or an (Action, ActionSlot) pair. Existing F-Curves for the same
    channels are replaced; nothing else in the action is touched.
    ``frames``: (F,) frame numbers. ``targets``: {DEF bone name: (F, 4, 4) armature-space}.
    Chains are solved when their DEF bones are given: the spine (all of DEF-spine ... up to the
    chest; required as soon as a limb is given), the neck/head (optional), each leg (thigh, shin,
    foot, toe) and each arm (upper_arm, forearm, hand; the shoulder if its DEF bone is given).
    The ``.001`` twist segments are optional (they follow). Each solved limb's IK/FK switch is
    keyed to FK. ``neutral``: also key tweaks/hips/chest at rest, scale 1, FK_limb_follow 0.
    ``all_fk``: key every limb's switch to FK, also limbs without targets (a freshly generated
    rig is in IK mode, IK_FK = 0, and IK hands/feet stay behind with the root when the body walks;
    in FK they ride along with their current FK pose).
    ``leg_ik``: key the legs on their IK controls instead (``_solve_leg_ik``: foot_ik, toe_ik,
    the knee's pole control with ``pole_vector`` on, IK_FK at IK); nothing on the FK leg
    controls. The arms stay FK (with ``all_fk``), the spine and torso as without it.
    ``verify``: number of frames (spread over the range) to play through the depsgraph afterwards.

    Returns {"action", "slot", "channelbag", "controls", "neutral", "properties", "fcurves",
    "ignored", "max_error" (metres, heads and tails, or None)}.
    """
    if not is_rigify(ob):
        raise ValueError(f"{ob.name!r} is not a generated Rigify rig"
                         + (" (generate the metarig first)" if rigify_metarig(ob) else ""))
    frames = np.asarray(frames, np.float64).ravel()
    info = deform_chain(ob)
    s = _Solver(ob, targets, frames)
    used = _solve_all(s, info, neutral, leg_ik)
    if all_fk:
        for lb in info["limbs"].values():
            s.props.setdefault(lb["switch"]["data_path"], float(lb["switch"]["fk_value"]))
    neutral_bones = sorted(s.neutral - set(s.want)) if neutral else []
    bases = _bases(ob, s.want, set(neutral_bones), s.via)
    act, slot, cbag = _channelbag(ob, dst)
    count = _write_keys(ob, cbag, frames, bases, neutral_bones, s.props, neutral)
    result = {"action": act, "slot": slot, "channelbag": cbag, "controls": list(bases),
              "neutral": neutral_bones, "properties": dict(s.props), "fcurves": count,
              "ignored": sorted(set(s.t) - used), "max_error": None}
    if verify:
        result["max_error"] = _verify(ob, act, slot, frames, s.t, sorted(used), int(verify))
    return result


def _solve_all(s: "_Solver", info: dict, neutral: bool, leg_ik: bool = False) -> set:
    """Solve every chain that has targets (the spine first: the limbs hang from it);
    ValueError naming the targets a chain misses. Returns the DEF bones used."""
    used: set[str] = set()
    sp = info["spine"]
    limbs_given = [lb for lb in info["limbs"].values()
                   if any(x in s.t for seg in lb["deform"] for x in seg)]
    if sp is not None and any(x in s.t for x in sp["deform"]):
        missing = [x for x in sp["deform"] if x not in s.t]
        if missing:
            raise ValueError(f"spine targets missing: {missing}")
        _solve_spine(s, sp)
        used.update(sp["deform"])
        h = sp["head"]
        if h is not None and any(x in s.t for x in h["deform"]):
            need = [h["deform"][0], h["deform"][-1]]
            if any(x not in s.t for x in need):
                raise ValueError(f"neck/head targets need {need}")
            _solve_head(s, h)
            used.update(h["deform"])
    elif limbs_given:
        raise ValueError("limb targets need the spine targets too (the limbs hang from the hips/chest): "
                         + str(sp["deform"] if sp else None))
    for lb in limbs_given:
        missing = [seg[0] for seg in lb["deform"] if seg[0] not in s.t]
        if missing:
            raise ValueError(f"limb {lb['org'][0][4:]} targets missing: {missing}")
        _solve_limb(s, lb, neutral, leg_ik)
        used.update(x for seg in lb["deform"] for x in seg)
        if lb["parent_deform"] in s.t:
            used.add(lb["parent_deform"])
    return used


def _write_keys(ob, cbag, frames, bases: dict, neutral_bones: list, props: dict, neutral: bool) -> int:
    """Key the solved controls' bases, the neutral bones at rest and the properties
    (switches, follows) into ``cbag``; returns the F-Curves written."""
    count = 0
    for c, b in bases.items():
        count += _key_bone(cbag, ob, c, frames, b)
        if neutral:
            count += _key_scale(cbag, c, frames[0])
    eye = np.eye(4)[None]
    for c in neutral_bones:
        count += _key_bone(cbag, ob, c, frames[:1], eye)
        count += _key_scale(cbag, c, frames[0])
    for path, val in props.items():
        _write(cbag, path, 0, frames[:1], np.array([val]), path.split('"')[1], CONSTANT)
        count += 1
    return count


def _verify(ob, act, slot, frames, targets: dict, names: list, k: int) -> float:
    """The largest head or tail distance (m) of ``names`` from their targets, played
    through the depsgraph at ``k`` frames spread over the range."""
    idx = np.unique(np.linspace(0, len(frames) - 1, k).round().astype(int))
    got = sample_deform(ob, act, frames[idx], names=names, slot=slot)
    want = np.stack([targets[n][idx] for n in names], axis=1)
    gh, gt = heads_tails(ob, got, names)
    wh, wt = heads_tails(ob, want, names)
    return float(max(np.linalg.norm(gh - wh, axis=-1).max(), np.linalg.norm(gt - wt, axis=-1).max()))
