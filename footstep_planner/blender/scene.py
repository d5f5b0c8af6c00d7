"""Read Blender data into plain arrays: armature -> Rig, action -> ClipMotion.

Nothing here changes the user's data: sampling an action poses the armature through
``Pose.apply_pose_from_action`` and puts every bone's basis back afterwards.
"""

from __future__ import annotations

import bpy
import numpy as np

from ..core.clip import ClipMotion, clip_motion
from ..core.rig import Rig, RigError

#: Custom property on actions: the frame rate of the file a clip was imported from.
SOURCE_FPS_PROP = "footstep_source_fps"
#: Custom property on actions: the source file a clip was imported from.
SOURCE_FILE_PROP = "footstep_source_file"
#: Custom property on actions: the armature data the clip was imported for.
ARMATURE_PROP = "footstep_armature"


def _matrices(collection, attr: str) -> np.ndarray:
    buf = np.empty(len(collection) * 16, dtype=np.float64)
    collection.foreach_get(attr, buf)
    return buf.reshape(-1, 4, 4).transpose(0, 2, 1)


def scene_fps(scene=None) -> float:
    """The scene's frame rate (frames per second), ``fps / fps_base``; the one place it
    is computed."""
    scene = scene or bpy.context.scene
    return float(scene.render.fps) / float(scene.render.fps_base or 1.0)


def role_overrides(ob) -> dict[str, str]:
    """Roles set by hand in the panel (``ob.data.footstep.role_overrides``)."""
    props = getattr(ob.data, "footstep", None)
    return {} if props is None else props.overrides()


def rig_from_armature(ob, overrides: dict | None = None) -> Rig:
    """The rig of an armature object, in the order of ``ob.pose.bones``."""
    if ob is None or ob.type != "ARMATURE":
        raise RigError(f"{getattr(ob, 'name', None)!r} is not an armature object")
    pbones = ob.pose.bones
    bones = [ob.data.bones[pb.name] for pb in pbones]
    names = [b.name for b in bones]
    index = {n: i for i, n in enumerate(names)}
    parents = [index[b.parent.name] if b.parent else -1 for b in bones]
    rest = _matrices(ob.data.bones, "matrix_local")
    order = [ob.data.bones.find(n) for n in names]
    rest = rest[order]
    tails = np.array([b.tail_local for b in bones], dtype=np.float64).reshape(-1, 3)
    ov = role_overrides(ob) if overrides is None else overrides
    odd = [b.name for b in bones
           if not b.use_inherit_rotation or b.inherit_scale not in {"FULL", "NONE_LEGACY"}
           or not b.use_local_location]
    if odd:
        raise RigError(f"armature {ob.name!r}: bones {', '.join(odd[:5])} use non-default "
                       "inherit flags, which the planner does not support yet")
    return Rig.build(ob.name, names, parents, rest, tails, overrides=ov)


def action_frame_range(action) -> tuple[float, float]:
    if action.use_frame_range:
        return float(action.frame_start), float(action.frame_end)
    lo, hi = action.frame_range
    return float(lo), float(hi)


def sample_basis(ob, action, frames: np.ndarray) -> np.ndarray:
    """Pose bases (N, B, 4, 4) of ``action`` on ``ob`` at the given (fractional) frames,
    bones in ``ob.pose.bones`` order. The armature's pose is restored afterwards."""
    pbones = ob.pose.bones
    saved = np.empty(len(pbones) * 16, dtype=np.float32)
    pbones.foreach_get("matrix_basis", saved)
    out = np.empty((len(frames), len(pbones), 4, 4))
    try:
        for i, f in enumerate(frames):
            ob.pose.apply_pose_from_action(action, evaluation_time=float(f))
            out[i] = _matrices(pbones, "matrix_basis")
    finally:
        pbones.foreach_set("matrix_basis", saved)
    return out


def clip_from_action(ob, action, rig: Rig | None = None, fps: float | None = None) -> ClipMotion:
    """Sample ``action`` at ``fps`` (default: the scene's rate) over its frame range."""
    rig = rig or rig_from_armature(ob)
    sfps = scene_fps()
    fps = float(fps or sfps)
    start, end = action_frame_range(action)
    step = sfps / fps  # scene frames per sample
    frames = start + step * np.arange(int(round((end - start) / step)) + 1)
    basis = sample_basis(ob, action, frames)
    src = action.get(SOURCE_FPS_PROP)
    return clip_motion(rig, action.name, basis, fps=fps, frame0=start,
                       source_fps=float(src) if src else None, frame_rate=sfps)


def armature_actions(ob) -> list:
    """The clips of a character, in name order: the actions it uses (active action, NLA
    strips, its clip library) and those imported for it; failing any, every action with
    curves on its bones."""
    own = set()
    ad = ob.animation_data
    if ad is not None:
        if ad.action is not None:
            own.add(ad.action.name)
        own.update(st.action.name for tr in ad.nla_tracks for st in tr.strips if st.action)
    props = getattr(ob.data, "footstep", None)
    if props is not None:
        own.update(item.name for item in props.clips)
    # (the planner's own bakes are results, never clips)
    found = [a for a in bpy.data.actions
             if (a.name in own or a.get(ARMATURE_PROP) == ob.data.name) and a.get("footstep_bake") is None]
    if found:
        return sorted(found, key=lambda a: a.name)
    names = {pb.name for pb in ob.pose.bones}
    for act in bpy.data.actions:
        if act.get("footstep_bake") is not None:
            continue
        for slot in act.slots:
            if slot.target_id_type == "OBJECT" and any(
                    _bone_of(p) in names for p in _action_paths(act, slot)):
                found.append(act)
                break
    return sorted(found, key=lambda a: a.name)


def _action_paths(action, slot) -> set[str]:
    paths = set()
    for layer in action.layers:
        for strip in layer.strips:
            cb = strip.channelbag(slot)
            if cb is not None:
                paths.update(fc.data_path for fc in cb.fcurves)
    return paths


def _bone_of(path: str) -> str | None:
    if path.startswith('pose.bones["'):
        return path[len('pose.bones["'):].split('"]', 1)[0].replace('\\"', '"')
    return None
