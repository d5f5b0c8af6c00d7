"""A whole scene as a comparable dict (issue 26): every object (transform values as typed,
custom properties, constraints, pose bones' channels, rotation modes and constraints,
animation data: active action and slot, tweak mode, NLA tracks and strips with their
flags), every action (its custom properties and keys), the timeline markers, the
collections and what they hold, the scenes' frame ranges and custom properties.

``fingerprint() == before`` says nothing the user had was changed, added or lost."""

from __future__ import annotations

import numpy as np


def _v(x, nd=6):
    try:
        return tuple(round(float(v), nd) for v in x)
    except TypeError:
        return round(float(x), nd)


def _props(idb) -> dict:
    """The data-block's custom properties (a registered property group such as the add-on's
    own ``footstep``, which Blender 4.5 lists among them once it is read, is not one)."""
    out = {}
    registered = idb.bl_rna.properties.keys()
    for k in idb.keys():
        if k in registered:
            continue
        v = idb[k]
        out[k] = v.to_dict() if hasattr(v, "to_dict") else v.to_list() if hasattr(v, "to_list") else v
    return repr(sorted(out.items()))


def _constraints(cs) -> list:
    return [(c.name, c.type, c.mute, _v(c.influence)) for c in cs]


def _anim(ad) -> dict | None:
    if ad is None:
        return None
    return {"action": ad.action.name if ad.action else None,
            "slot": ad.action_slot.identifier if ad.action_slot else None,
            "tweak": ad.use_tweak_mode, "influence": _v(ad.action_influence),
            "drivers": [(d.data_path, d.array_index) for d in ad.drivers],
            "tracks": [(t.name, t.mute, t.is_solo, t.lock,
                        [(s.name, s.action.name if s.action else None, _v(s.frame_start), _v(s.frame_end),
                          _v(s.scale), _v(s.repeat), s.mute, s.extrapolation, s.blend_type,
                          s.action_slot.identifier if s.action_slot else None) for s in t.strips])
                       for t in ad.nla_tracks]}


def _object(ob) -> dict:
    d = {"type": ob.type, "parent": ob.parent.name if ob.parent else None, "mode": ob.rotation_mode,
         "location": _v(ob.location), "euler": _v(ob.rotation_euler), "quat": _v(ob.rotation_quaternion),
         "axis_angle": _v(ob.rotation_axis_angle), "scale": _v(ob.scale), "props": _props(ob),
         "constraints": _constraints(ob.constraints), "anim": _anim(ob.animation_data),
         "hide": (ob.hide_viewport, ob.hide_render), "collections": sorted(c.name for c in ob.users_collection)}
    if ob.pose is not None:
        d["bones"] = [(pb.name, pb.rotation_mode, _v(pb.location), _v(pb.rotation_quaternion),
                       _v(pb.rotation_euler), _v(pb.rotation_axis_angle), _v(pb.scale),
                       _constraints(pb.constraints)) for pb in ob.pose.bones]
    return d


def _keys(fc) -> tuple:
    """An F-curve's keys (frame, value) as one flat tuple, rounded as ``_v`` rounds (read
    in one call: a baked action holds hundreds of thousands of them)."""
    co = np.empty(2 * len(fc.keyframe_points), np.float32)
    fc.keyframe_points.foreach_get("co", co)
    return tuple(np.round(co.astype(np.float64), 6).tolist())


def _action(act) -> dict:
    curves = sorted(((fc.data_path, fc.array_index, _keys(fc))
                     for layer in act.layers for strip in layer.strips for cb in strip.channelbags
                     for fc in cb.fcurves))
    return {"props": _props(act), "fake": act.use_fake_user, "slots": [s.identifier for s in act.slots],
            "curves": curves}


def fingerprint() -> dict:
    import bpy

    return {
        "objects": {ob.name: _object(ob) for ob in bpy.data.objects},
        "actions": {a.name: _action(a) for a in bpy.data.actions},
        "collections": {c.name: (sorted(o.name for o in c.objects), sorted(ch.name for ch in c.children), _props(c))
                        for c in bpy.data.collections},
        "scenes": {sc.name: {"range": (sc.frame_start, sc.frame_end), "current": sc.frame_current,
                             "markers": sorted((m.name, m.frame) for m in sc.timeline_markers),
                             "props": _props(sc), "children": sorted(c.name for c in sc.collection.children),
                             "objects": sorted(o.name for o in sc.collection.objects)}
                   for sc in bpy.data.scenes},
    }


def differences(a: dict, b: dict, path: str = "") -> list[str]:
    """Where two fingerprints differ (for a readable assertion message)."""
    if isinstance(a, dict) and isinstance(b, dict):
        out = []
        for k in sorted(set(a) | set(b), key=str):
            if k not in a or k not in b:
                out.append(f"{path}/{k}: {'added' if k not in a else 'gone'}")
            else:
                out += differences(a[k], b[k], f"{path}/{k}")
        return out
    if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)) and len(a) == len(b) and a != b:
        return [d for i, (x, y) in enumerate(zip(a, b)) for d in differences(x, y, f"{path}[{i}]")]
    return [] if a == b else [f"{path}: {str(a)[:200]} -> {str(b)[:200]}"]
