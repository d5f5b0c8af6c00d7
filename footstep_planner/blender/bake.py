"""The result baked into the character: one slotted Action per bake, in an NLA track the
planner owns, and the quality of what was baked, measured on the baked action itself.

What the planner owns is marked: its actions carry the custom property ``OWNED_PROP``
(the character's name) and its NLA tracks are named ``TRACK_PREFIX`` + the plan's name,
holding only such actions; its timeline markers start with ``MARKER_PREFIX``. A re-bake
removes those and nothing else: the user's actions, tracks, strips, keyframes and
markers are never touched.
"""

from __future__ import annotations

import numpy as np
import bpy
from scipy.spatial.transform import Rotation

from ..core.errors import FootstepError
from ..core.ik import IKResult, body_frames
from ..core.rig import Rig, forward_kinematics
from .scene import scene_fps

OWNED_PROP = "footstep_bake"
#: The character's own object transform before the first bake (row-major 4x4), put back
#: by ``clear``: the bake animates the object, and Blender leaves the last evaluated
#: transform in it when the animation goes.
REST_PROP = "footstep_rest_matrix"
#: Where the bake put the body: "OBJECT" or "ROOT".
BODY_PROP = "footstep_body_on"
TRACK_PREFIX = "Footstep: "
MARKER_PREFIX = "FP "


class BakeError(FootstepError):
    pass


def _linear():
    return bpy.types.Keyframe.bl_rna.properties["interpolation"].enum_items["LINEAR"].value


def owned_tracks(ob) -> list:
    """The planner's own NLA tracks on ``ob``."""
    ad = ob.animation_data
    if ad is None:
        return []
    return [tr for tr in ad.nla_tracks if tr.name.startswith(TRACK_PREFIX) and tr.strips
            and all(st.action is not None and st.action.get(OWNED_PROP) is not None for st in tr.strips)]


def own_matrix_world(ob) -> np.ndarray:
    """(4, 4) the object's world matrix with its own transform, not the one the
    planner's bake animates it to."""
    m = np.array(ob.matrix_world)
    for tr in owned_tracks(ob):
        for st in tr.strips:
            rest = st.action.get(REST_PROP)
            if rest is not None and len(rest) == 16:
                basis = np.array([float(v) for v in rest]).reshape(4, 4)
                return m @ np.linalg.inv(np.array(ob.matrix_basis)) @ basis
    return m


def clear(ob, scene=None) -> int:
    """Remove the planner's tracks, their actions (when nothing else uses them) and its
    markers. Returns how many tracks went."""
    tracks = owned_tracks(ob)
    acts = {st.action for tr in tracks for st in tr.strips}
    rest = next((a.get(REST_PROP) for a in acts if a.get(REST_PROP) is not None), None)
    for tr in tracks:
        ob.animation_data.nla_tracks.remove(tr)
    if rest is not None and len(rest) == 16:  # the object's own transform, as it was
        from mathutils import Matrix

        vals = [float(v) for v in rest]
        ob.matrix_basis = Matrix([vals[0:4], vals[4:8], vals[8:12], vals[12:16]])
    for act in acts:
        if act.users == 0 or (act.users == 1 and act.use_fake_user):
            bpy.data.actions.remove(act)
    if scene is not None:
        for m in [m for m in scene.timeline_markers if m.name.startswith(MARKER_PREFIX)]:
            scene.timeline_markers.remove(m)
    return len(tracks)


def _euler(q_xyzw: np.ndarray, mode: str) -> np.ndarray:
    """(F, 3) Euler angles in Blender's rotation_mode order, unwrapped over frames."""
    # Blender's "XYZ" applies X first: extrinsic x-y-z, which scipy spells "xyz"
    e = Rotation.from_quat(q_xyzw).as_euler(mode.lower())
    out = np.empty_like(e)
    for i, axis in enumerate(mode):
        out[:, "XYZ".index(axis)] = e[:, i]
    return np.unwrap(out, axis=0)


def _wxyz(q_xyzw: np.ndarray) -> np.ndarray:
    q = np.roll(q_xyzw, 1, axis=-1)
    flip = np.cumprod(np.where(np.sum(q[1:] * q[:-1], axis=-1) < 0, -1.0, 1.0), axis=0)
    q[1:] *= flip[..., None]
    return q


BODY_ON = ("OBJECT", "ROOT")


def root_bone(ob, rig: Rig) -> int:
    """Index of the rig's root bone (the 'root' role, an ancestor of the hips)."""
    bone = rig.roles.roles.get("root")
    if not bone:
        raise BakeError(f"armature {ob.name!r} has no root bone to carry the body: map the 'root' role "
                        "in the Footstep tab, or bake the body onto the object")
    r = rig.index(bone)
    b = rig.role_index("hips")
    while b >= 0 and b != r:
        b = rig.parents[b]
    if b != r:
        raise BakeError(f"armature {ob.name!r}: root bone {bone!r} does not carry the hips "
                        f"({rig.roles.bone('hips')!r} is not its child)")
    return r


def bake(ob, scene, rig: Rig, res: IKResult, spin: float, name: str, frame_start: int,
         footsteps=None, planted=None, markers: bool = False, body_on: str = "OBJECT"):
    """Key ``res`` into a new Action on the armature ``ob`` in a new NLA track of the
    planner's, starting at ``frame_start``: the body on the object's transform
    (``body_on="OBJECT"``) or on the rig's root bone (``"ROOT"``, the object stays put),
    every bone's rotation, and the hips' location. The planner's earlier bake of this
    character is replaced. ``planted`` holds (strike, stance, liftoff) seconds per
    footprint of ``footsteps``, for the optional markers."""
    _check(ob, rig, body_on)
    basis = _root_carries_body(ob, rig, res, spin) if body_on == "ROOT" else res.basis
    rest = _own_rest(ob)  # (read before clearing frees the old action, and its property with it)
    clear(ob, scene)
    act, slot, keys = _new_action(ob, name, rest, body_on, frame_start + np.arange(res.frames, dtype=np.float64))
    if body_on == "OBJECT":
        _key_body(keys, ob, res.body_pos, spin + res.body_heading)
    _key_bones(keys, ob, basis)
    track = _add_track(ob, name, act, slot, frame_start)
    if markers and footsteps is not None and planted is not None:
        _add_markers(scene, footsteps, planted, frame_start)
    return act, track


def _check(ob, rig: Rig, body_on: str) -> None:
    if tuple(pb.name for pb in ob.pose.bones) != tuple(rig.names):
        raise BakeError(f"armature {ob.name!r} changed since it was read (bones differ)")
    if body_on not in BODY_ON:
        raise BakeError(f"the body goes on one of {', '.join(BODY_ON)}, not {body_on!r}")


def _root_carries_body(ob, rig: Rig, res: IKResult, spin: float) -> np.ndarray:
    """(F, B, 4, 4) the IK's bone bases with the root bone carrying the body frame
    relative to the object (which stays where it is): with the root posed by
    M = O^-1 Body, every bone under it is where the object carrying the body would
    have put it."""
    r = root_bone(ob, rig)
    M = np.linalg.inv(own_matrix_world(ob))[None] @ body_frames(res.body_pos, spin + res.body_heading)
    basis = res.basis.copy()
    basis[:, r] = np.linalg.inv(rig.rest[r])[None] @ M @ rig.rest[r][None]
    return basis


def _own_rest(ob) -> list[float]:
    """The object's own transform (16 floats, row by row): the one an earlier bake of
    the planner's kept, else the object's current one."""
    old = [[float(v) for v in st.action[REST_PROP]] for tr in owned_tracks(ob) for st in tr.strips
           if st.action.get(REST_PROP) is not None]
    return old[0] if old else [v for row in ob.matrix_basis for v in row]


class _Keys:
    """Writes whole F-Curves of linear keys at ``frames`` into a channel bag."""

    def __init__(self, cbag, frames: np.ndarray):
        self.cbag, self.frames, self.lin = cbag, frames, _linear()

    def __call__(self, path: str, values: np.ndarray, group: str) -> None:
        """Key ``values`` (F,) or (F, K) on ``path``, one F-Curve per column (array index)."""
        values = np.asarray(values, float).reshape(len(self.frames), -1)
        n = len(self.frames)
        for i in range(values.shape[1]):
            kp = self.cbag.fcurves.new(path, index=i, group_name=group)
            points = kp.keyframe_points
            points.add(n)
            co = np.empty(2 * n, np.float32)
            co[0::2] = self.frames
            co[1::2] = values[:, i]
            points.foreach_set("co", co)
            points.foreach_set("interpolation", np.full(n, self.lin, np.int32))
            kp.update()


def _new_action(ob, name: str, rest: list[float], body_on: str, frames: np.ndarray):
    """A new slotted Action of the planner's for ``ob``: (action, slot, key writer)."""
    act = bpy.data.actions.new(f"Footstep {name}")
    act[OWNED_PROP] = ob.name
    act[REST_PROP] = [float(v) for v in rest]
    act[BODY_PROP] = body_on
    slot = act.slots.new(id_type="OBJECT", name=ob.name)
    cbag = act.layers.new("Layer").strips.new(type="KEYFRAME").channelbag(slot, ensure=True)
    return act, slot, _Keys(cbag, frames)


def _key_rotation(keys: _Keys, path: str, q_xyzw: np.ndarray, mode: str, group: str, axis0) -> None:
    """Key rotations (F, 4) (scipy x, y, z, w) in Blender's ``mode`` on ``path``
    (``<path>.rotation_quaternion`` / ``_axis_angle`` / ``_euler``); ``axis0`` is the
    axis-angle axis of a zero rotation."""
    if mode == "QUATERNION":
        keys(f"{path}rotation_quaternion", _wxyz(q_xyzw), group)
    elif mode == "AXIS_ANGLE":
        rv = Rotation.from_quat(q_xyzw).as_rotvec()
        ang = np.linalg.norm(rv, axis=1)
        axis = np.where(ang[:, None] > 1e-12, rv / np.maximum(ang, 1e-12)[:, None], axis0)
        keys(f"{path}rotation_axis_angle", np.c_[ang, axis], group)
    else:
        keys(f"{path}rotation_euler", _euler(q_xyzw, mode), group)


def _key_body(keys: _Keys, ob, body_pos: np.ndarray, yaw: np.ndarray) -> None:
    """The body on the object: its location and yaw (its tilt, if any, is kept)."""
    keys("location", body_pos, "Object Transforms")
    base = ob.matrix_basis.to_euler("XYZ")
    n = len(yaw)
    qz = Rotation.from_euler("xyz", np.c_[np.full(n, base.x), np.full(n, base.y), yaw]).as_quat()
    _key_rotation(keys, "", qz, ob.rotation_mode, "Object Transforms", [0.0, 0.0, 1.0])


def _key_bones(keys: _Keys, ob, basis: np.ndarray) -> None:
    """Every bone's rotation (in its own rotation mode) and the location of the bones
    that move (the hips, a root carrying the body)."""
    F, B = basis.shape[:2]
    q = Rotation.from_matrix(basis[..., :3, :3].reshape(-1, 3, 3)).as_quat().reshape(F, B, 4)
    moved = np.abs(basis[..., :3, 3]).max(axis=0).max(axis=1) > 1e-6
    for b, pb in enumerate(ob.pose.bones):
        path = f'pose.bones["{bpy.utils.escape_identifier(pb.name)}"].'
        _key_rotation(keys, path, q[:, b], pb.rotation_mode, pb.name, [0.0, 1.0, 0.0])
        if moved[b]:
            keys(f"{path}location", basis[:, b, :3, 3], pb.name)


def _add_track(ob, name: str, act, slot, frame_start: int):
    """A new NLA track of the planner's playing ``act`` from ``frame_start``."""
    ad = ob.animation_data_create()
    track = ad.nla_tracks.new()
    track.name = f"{TRACK_PREFIX}{name}"
    strip = track.strips.new(act.name, int(frame_start), act)
    strip.action_slot = slot
    strip.extrapolation = "HOLD_FORWARD"
    strip.blend_type = "REPLACE"
    return track


def _add_markers(scene, footsteps, planted, frame_start: int) -> None:
    """A timeline marker ``FP <n> <L|R>`` at each footprint's stance frame."""
    rate = scene_fps(scene)
    for i, (f, (_, st, _)) in enumerate(zip(footsteps, planted)):
        scene.timeline_markers.new(f"{MARKER_PREFIX}{i} {'LR'[f.foot]}", frame=int(round(frame_start + st * rate)))


def evaluate(ob, rig: Rig, act, frame_start: int, frames: int):
    """The baked action evaluated as Blender plays it: (world bone matrices (F, B, 4, 4),
    body positions (F, 3), body yaw (F,), bone rotations (F, B, 4) (x, y, z, w)). The
    action's curves are evaluated per frame onto a copy of the pose state, which is
    restored; the object's own transform comes from the action's object curves."""
    pbones = ob.pose.bones
    B = len(pbones)
    saved = np.empty(B * 16, dtype=np.float32)
    pbones.foreach_get("matrix_basis", saved)
    basis = np.empty((frames, B, 4, 4))
    buf = np.empty(B * 16, dtype=np.float32)
    try:
        for i in range(frames):
            ob.pose.apply_pose_from_action(act, evaluation_time=float(frame_start + i))
            pbones.foreach_get("matrix_basis", buf)
            basis[i] = buf.reshape(B, 4, 4).transpose(0, 2, 1)
    finally:
        pbones.foreach_set("matrix_basis", saved)
    slot = act.slots[0]
    cbag = act.layers[0].strips[0].channelbag(slot)
    fr = frame_start + np.arange(frames, dtype=np.float64)

    def curve(path, i):
        fc = cbag.fcurves.find(path, index=i)
        return np.array([fc.evaluate(f) for f in fr])

    pose = forward_kinematics(rig, basis)
    if act.get(BODY_PROP) == "ROOT":
        # the object stays put; the body is the root bone's frame (its rest put back)
        r = root_bone(ob, rig)
        obm = np.tile(own_matrix_world(ob), (frames, 1, 1))
        body = obm @ pose[:, r] @ np.linalg.inv(rig.rest[r])
        world = obm[:, None] @ pose
        loc = body[:, :3, 3]
        yaw = np.arctan2(body[:, 1, 0], body[:, 0, 0])
        q = Rotation.from_matrix(basis[..., :3, :3].reshape(-1, 3, 3)).as_quat().reshape(frames, B, 4)
        return world, loc, np.unwrap(yaw), q
    loc = np.stack([curve("location", i) for i in range(3)], axis=1)
    mode = ob.rotation_mode
    if mode == "QUATERNION":
        qw = np.stack([curve("rotation_quaternion", i) for i in range(4)], axis=1)
        rot = Rotation.from_quat(np.roll(qw, -1, axis=1))
    elif mode == "AXIS_ANGLE":
        aa = np.stack([curve("rotation_axis_angle", i) for i in range(4)], axis=1)
        rot = Rotation.from_rotvec(aa[:, 1:] * aa[:, :1])
    else:
        e = np.stack([curve("rotation_euler", i) for i in range(3)], axis=1)
        rot = Rotation.from_euler(mode.lower(), e[:, ["XYZ".index(a) for a in mode]])
    yaw = rot.as_euler("xyz")[:, 2]
    obm = np.tile(np.eye(4), (frames, 1, 1))
    obm[:, :3, :3] = rot.as_matrix()
    obm[:, :3, 3] = loc
    world = obm[:, None] @ pose
    q = Rotation.from_matrix(basis[..., :3, :3].reshape(-1, 3, 3)).as_quat().reshape(frames, B, 4)
    return world, loc, np.unwrap(yaw), q


__all__ = ["bake", "clear", "evaluate", "own_matrix_world", "owned_tracks", "root_bone", "BakeError"]
