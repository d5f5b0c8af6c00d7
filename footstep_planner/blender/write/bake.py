"""The result baked into the character: one slotted Action per bake, in an NLA track the
planner owns, and the scene read back as Blender plays it.

What the planner owns it finds by identity, never by name: its actions carry the owner
tag ``OWNED_PROP`` (the character's name) and the bake's name (``BAKE_NAME_PROP``); its
NLA tracks are those holding only such actions (named ``TRACK_PREFIX`` + the bake's name
when made, whatever the user renames them to); its timeline markers are the ones each
action recorded making (``MARKERS_PROP``: a user's "FP review" is never touched). A
bake replaces only the planner's bake of its name; several bakes of one character live
side by side, stacked by time (``check_overlap`` refuses one that would overlap another),
and a bake whose keys the animator edited is not baked over unless asked
(``KEYS_PROP``, ``check_unedited``). The user's actions, tracks, strips, keyframes and
markers are never touched.

So that what plays is what was baked: Blender plays a character's active action over
its NLA stack, so a bake *stashes* the active action the way Blender does (a muted NLA
track ``[Action Stash]`` holding it, the active slot cleared). The scene's frame range
grows to cover the bake (never shrinks). Every bake of a character carries the record of
the character as it was before its first bake (``CARRIED``: its transform values as
typed, pose channels and modes, the stash, the range); when the last goes, ``clear``
gives it all back exactly. Scene states that would make a bake play elsewhere than
planned are refused before anything changes (``check_scene``, ``check_leg_constraints``).

The tags and the record of the character as it was are in ``owned.py``, what a bake
refuses before it writes in ``checks.py``; this module writes the bake and reads it back.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, replace

import numpy as np
import bpy
from scipy.spatial.transform import Rotation

from ...core.solve.ik import IKResult, body_frames
from ...core.base.quat import continuous, rotations
from ...core.clips.body import scaled_bases, scaled_rig
from ...core.clips.rig import Rig, armature_basis, forward_kinematics
from .. import rigify
from .checks import (BESIDE_PROP, EditedBakeError, _check, _first_records, check_leg_constraints, check_not_tweaking,
                     check_overlap, check_scene, check_unedited, new_track_name, record_keys)
from .keys import CONSTANT, fill_keys, new_fcurve
from .owned import (BAKE_NAME_PROP, BEFORE_PROP, BODY_ON, BODY_PROP, CARRIED, MARKER_PREFIX, MARKERS_PROP, OWNED_PROP,
                    RANGE_PROP, REST_PROP, STASH_PROP, STASH_SLOT_PROP, STASH_TRACK, STASH_TRACK_PROP, TRACK_PREFIX,
                    BakeError, bake_name, character_state, give_back_state, is_owned, own_frame, own_matrix_world,
                    owned_tracks, track_frames, unscaled)
from ..read.scene import object_scale, scene_fps

def _records(act) -> dict:
    """The records ``CARRIED`` of ``act``, as plain Python values (an ID property array
    is a view into the action, gone with it)."""
    out = {}
    for k in CARRIED:
        v = act.get(k)
        if v is not None:
            out[k] = v.to_list() if hasattr(v, "to_list") else v
    return out


def _carried(ob) -> dict:
    """The records of the character's state before its first bake, from the planner's
    bakes it has (empty when it has none)."""
    for tr in owned_tracks(ob):
        for st in tr.strips:
            if st.action.get(BEFORE_PROP) is not None or st.action.get(REST_PROP) is not None:
                return _records(st.action)
    return {}


def clear(ob, scene=None, name: str | None = None) -> int:
    """Remove the planner's tracks of ``ob`` (all, or only the bake ``name``), their
    actions (when nothing else uses them) and the markers they made; when the last goes,
    give back what the first bake changed (the active action it stashed, the object's
    and pose bones' channels, the frame range if still as the bake left it). Returns how
    many tracks went. Nothing found by name alone is touched: tracks are the planner's by
    their actions' owner tag, markers by the bake's own record of them."""
    return remove_tracks(ob, scene, owned_tracks(ob, name))


def remove_tracks(ob, scene, tracks: list) -> int:
    """``clear`` of the given tracks of the planner's."""
    acts = {st.action for tr in tracks for st in tr.strips}
    carried = next((_records(a) for a in acts if a.get(BEFORE_PROP) is not None or a.get(REST_PROP) is not None), {})
    made = [tuple(m) for a in acts for m in json.loads(a.get(MARKERS_PROP) or "[]")]
    ad = ob.animation_data
    for tr in tracks:
        ad.nla_tracks.remove(tr)
    for act in acts:
        if act.users == 0 or (act.users == 1 and act.use_fake_user):
            bpy.data.actions.remove(act)
    if scene is not None:
        _remove_markers(scene, made)
    if not owned_tracks(ob):
        _give_back(ob, scene, carried)
    return len(tracks)


def _remove_markers(scene, made) -> None:
    """Remove one timeline marker for each (name, frame) the planner made."""
    for name, frame in made:
        m = next((m for m in scene.timeline_markers if m.name == name and m.frame == int(frame)), None)
        if m is not None:
            scene.timeline_markers.remove(m)


def _give_back(ob, scene, carried: dict) -> None:
    """What the character's first bake changed, as it was: the stashed active action,
    the object's and pose bones' channels, the frame range (if still as the bakes left
    it), no animation data if it had none."""
    _unstash(ob, carried)
    if scene is not None:
        _give_back_range(scene, carried)
    before = carried.get(BEFORE_PROP)
    if before:
        state = json.loads(before)
        give_back_state(ob, state)
        ad = ob.animation_data
        if (not state.get("anim_data") and ad is not None and ad.action is None and not len(ad.nla_tracks)
                and not len(ad.drivers)):
            ob.animation_data_clear()
    else:
        rest = carried.get(REST_PROP)
        if rest is not None and len(rest) == 16:  # (a bake made before states were recorded)
            from mathutils import Matrix

            vals = [float(v) for v in rest]
            ob.matrix_basis = Matrix([vals[0:4], vals[4:8], vals[8:12], vals[12:16]])


def _stash_active(ob, act) -> None:
    """Stash ``ob``'s active action (not one of the planner's) as Blender does, in a muted
    NLA track of its own at the bottom of the stack, and clear the active action so the
    baked track plays; ``act`` (the bake's action) records what to give back."""
    ad = ob.animation_data
    user = ad.action if ad is not None else None
    if user is None or is_owned(user):
        return
    slot = ad.action_slot
    track = ad.nla_tracks.new()  # (on top of the stack: muted, it plays nowhere)
    track.name = STASH_TRACK
    start = int(np.floor(user.frame_range[0]))
    strip = track.strips.new(user.name, start, user)
    if slot is not None:
        strip.action_slot = slot
    track.mute = True
    act[STASH_PROP] = user.name
    act[STASH_SLOT_PROP] = slot.identifier if slot is not None else ""
    act[STASH_TRACK_PROP] = track.name
    bpy.context.view_layer.update()  # (clearing the action of a never-evaluated armature crashes)
    ad.action = None


def _unstash(ob, rec) -> None:
    """Give back the active action a bake stashed (unless the user has set another since),
    and remove the stash track the bake made (``rec``: the bake's records)."""
    name = rec.get(STASH_PROP)
    ad = ob.animation_data
    if not name or ad is None:
        return
    user = bpy.data.actions.get(name)
    track = next((t for t in reversed(ad.nla_tracks) if t.name == rec.get(STASH_TRACK_PROP, "") and t.mute
                  and len(t.strips) == 1 and t.strips[0].action == user), None)
    if track is not None:
        ad.nla_tracks.remove(track)
    if user is not None and ad.action is None:
        ad.action = user
        slot = user.slots.get(rec.get(STASH_SLOT_PROP, "")) if rec.get(STASH_SLOT_PROP) else None
        if slot is not None:
            ad.action_slot = slot


def _grow_range(scene, act, ob, first: int, last: int) -> None:
    """Grow the scene's frame range to cover frames ``first`` to ``last`` (never shrink it);
    ``act`` records the range before the character's first bake and the one now, as do
    the character's other bakes (whichever goes last gives it back)."""
    rng = act.get(RANGE_PROP)
    now = (scene.frame_start, scene.frame_end)
    before = (int(rng[0]), int(rng[1])) if rng is not None and len(rng) == 4 else now
    after = (min(now[0], first), max(now[1], last))
    if after != now:
        scene.frame_start, scene.frame_end = after
    if after != before:
        for a in {st.action for tr in owned_tracks(ob) for st in tr.strips} | {act}:
            a[RANGE_PROP] = [*before, *after]


def _give_back_range(scene, rec) -> None:
    """The scene's frame range as it was before the bake grew it, if it is still as the
    bake left it."""
    rng = rec.get(RANGE_PROP)
    if rng is not None and len(rng) == 4 and (scene.frame_start, scene.frame_end) == (int(rng[2]), int(rng[3])):
        scene.frame_start, scene.frame_end = int(rng[0]), int(rng[1])


def _euler(q_xyzw: np.ndarray, mode: str) -> np.ndarray:
    """(F, 3) Euler angles in Blender's rotation_mode order, unwrapped over frames."""
    # Blender's "XYZ" applies X first: extrinsic x-y-z, which scipy spells "xyz"
    e = Rotation.from_quat(q_xyzw).as_euler(mode.lower())
    out = np.empty_like(e)
    for i, axis in enumerate(mode):
        out[:, "XYZ".index(axis)] = e[:, i]
    return np.unwrap(out, axis=0)


def _wxyz(q_xyzw: np.ndarray) -> np.ndarray:
    """(F, 4) Blender's (w, x, y, z) of scipy quaternions, without sign flips between frames."""
    return continuous(np.roll(q_xyzw, 1, axis=-1))




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


@dataclass(frozen=True)
class BakeOptions:
    """How ``bake`` writes a bake (what ``planning.BakeRequest`` asks for, resolved):

    - ``name``: the bake's name (its track is ``TRACK_PREFIX`` + it; the planner's earlier
      bake of this name is replaced);
    - ``frame_start``: the scene frame (an integer frame) its first frame is keyed at;
    - ``markers``: a timeline marker at each footprint's stance frame;
    - ``body_on``: the body keyed on the object's transform (``"OBJECT"``) or on the rig's
      root bone (``"ROOT"``, the object stays put);
    - ``frame_range``: the scene's frame range grown to cover the bake;
    - ``rigify_ik_feet``: on a Rigify rig, the legs keyed on their IK controls
      (``rigify.key_controls(leg_ik=True)``) instead of the FK ones;
    - ``force``: an earlier bake of this name replaced even when its keys were edited since;
    - ``beside``: the name of a bake this one is made beside (``new_track_name``), which it
      may overlap (the new track plays over it); None for none."""

    name: str
    frame_start: int
    markers: bool = False
    body_on: str = "OBJECT"
    frame_range: bool = True
    rigify_ik_feet: bool = False
    force: bool = False
    beside: str | None = None


def bake(ob, scene, rig: Rig, res: IKResult, spin: float, opts: BakeOptions, path=None, planted=None,
         replaced: list | None = None):
    """Key ``res`` into a new Action on the armature ``ob`` in a new NLA track of the
    planner's, as ``opts`` asks (``BakeOptions``), from ``opts.frame_start``: the body on the
    object's transform or on the rig's root bone (``opts.body_on``), every bone's rotation,
    and the location of the hips and of any bone that moves from its parent (``res.basis``,
    under the planner's hierarchy, is keyed under the armature's,
    ``core.clips.rig.armature_basis``: a foot parented to the root moves from it).
    The planner's earlier bake of this name is replaced; its other bakes of this
    character stay (a bake that would overlap one of them in time is refused, before
    anything changes). With ``replaced`` (a list), the earlier bake of this name is only
    muted and its tracks put in the list, for the caller to ``settle`` (remove them) or
    ``discard`` (take the new bake back and unmute them). The character's active action
    is stashed (see the module's doc) and, with ``opts.frame_range``, the scene's frame
    range grows to cover the bake. ``planted`` holds (strike, stance, liftoff) seconds per
    footprint of ``path``, for the optional markers. Returns (action, track)."""
    first, last = int(opts.frame_start), int(opts.frame_start) + res.frames - 1
    _check(ob, rig, opts.body_on)
    check_not_tweaking(ob)
    check_overlap(ob, opts.name, first, last, opts.beside)
    old = owned_tracks(ob, opts.name)
    if not opts.force:
        check_unedited(ob, old, opts.name)
    rig, res = _in_armature_units(ob, rig, res)
    on_controls = rigify.is_rigify(ob)
    basis = _root_carries_body(ob, rig, res, spin) if opts.body_on == "ROOT" and not on_controls else res.basis
    carried = _set_aside(ob, scene, old, replaced)
    frames = opts.frame_start + np.arange(res.frames, dtype=np.float64)
    act, slot, keys = _new_action(ob, opts.name, carried, opts.body_on, frames)
    if opts.beside is not None:
        act[BESIDE_PROP] = opts.beside
    if opts.body_on == "OBJECT":
        _key_body(keys, ob, res.body_pos, spin + res.body_heading)
    if on_controls:
        _key_rigify_controls(ob, rig, act, slot, frames, res, spin, opts.body_on, opts.rigify_ik_feet)
    else:  # (keys are Blender's bases: a foot parented to the root keyed relative to it)
        _key_bones(keys, ob, armature_basis(rig, basis))
    track = _add_track(ob, opts.name, act, slot, opts.frame_start)
    _stash_active(ob, act)
    if opts.frame_range:
        _grow_range(scene, act, ob, first, last)
    if opts.markers and path is not None and planted is not None:
        _add_markers(scene, act, path, planted, opts.frame_start)
    return act, track


def _in_armature_units(ob, rig: Rig, res: IKResult) -> tuple[Rig, IKResult]:
    """The rig and the IK's bases in the armature's units: planned in world units, keyed
    (or posed) under the object's even scale."""
    s = object_scale(ob)
    if s == 1.0:
        return rig, res
    return scaled_rig(rig, 1.0 / s), replace(res, basis=scaled_bases(res.basis, 1.0 / s))


def pose_frame(ob, rig: Rig, res: IKResult, spin: float, frame: int, body_on: str = "OBJECT") -> None:
    """Set on ``ob`` unkeyed the pose ``bake`` would key at ``frame`` (an index into
    ``res``): every bone's basis and, with the body on the object, its location and yaw. A
    preview: Blender shows it until the frame changes, when the keys play again, so call it
    only where the planner's bake keys every one of those channels (a Rigify rig's DEF
    bones follow its controls: not posed here)."""
    from mathutils import Euler, Matrix

    one = replace(res, body_pos=res.body_pos[frame:frame + 1], body_heading=res.body_heading[frame:frame + 1],
                  basis=res.basis[frame:frame + 1])
    rig, one = _in_armature_units(ob, rig, one)
    basis = _root_carries_body(ob, rig, one, spin) if body_on == "ROOT" else one.basis
    for pb, m in zip(ob.pose.bones, armature_basis(rig, basis)[0]):
        pb.matrix_basis = Matrix(m.tolist())
    if body_on == "OBJECT":
        base = ob.matrix_basis.to_euler("XYZ")
        ob.matrix_basis = Matrix.LocRotScale(one.body_pos[0].tolist(),
                                             Euler((base.x, base.y, float(spin + one.body_heading[0])), "XYZ"),
                                             ob.matrix_basis.to_scale())


def _set_aside(ob, scene, old: list, replaced: list | None) -> dict:
    """The earlier bake of this name (its tracks ``old``) set aside for a new one: removed,
    or with ``replaced`` (a list) muted and put in the list (``bake``). Returns the records
    of the character's state before its first bake (from its bakes left, else read now)."""
    if replaced is None:
        remove_tracks(ob, scene, old)  # (the last bake gone: the character as it was, to read again)
        return _carried(ob) or _first_records(ob)
    carried = _carried(ob)
    for tr in old:
        replaced.append((tr, tr.mute))
        tr.mute = True
    return carried or _first_records(ob)


def settle(ob, scene, replaced: list) -> None:
    """The new bake stands: remove the earlier bake of its name (``bake``'s ``replaced``)."""
    remove_tracks(ob, scene, [tr for tr, _ in replaced])
    replaced.clear()


def discard(ob, scene, track, replaced: list) -> None:
    """Take the new bake (``track``) back and put the earlier one of its name (``bake``'s
    ``replaced``) as it was."""
    for tr, mute in replaced:
        tr.mute = mute
    replaced.clear()
    ad = ob.animation_data
    remove_tracks(ob, scene, [t for t in ad.nla_tracks if t == track] if ad is not None else [])




def _root_carries_body(ob, rig: Rig, res: IKResult, spin: float) -> np.ndarray:
    """(F, B, 4, 4) the IK's bone bases with the root bone carrying the body frame
    relative to the object (which stays where it is): with the root posed by
    M = O^-1 Body, every bone under it is where the object carrying the body would
    have put it."""
    r = root_bone(ob, rig)
    M = _in_object(ob, body_frames(res.body_pos, spin + res.body_heading))
    basis = res.basis.copy()
    basis[:, r] = np.linalg.inv(rig.rest[r])[None] @ M @ rig.rest[r][None]
    return basis


def _in_object(ob, frames: np.ndarray) -> np.ndarray:
    """(F, 4, 4) world frames (unit rotations) in the armature's space: in the object's own
    frame, their translations over its even scale."""
    out = np.linalg.inv(own_frame(ob))[None] @ frames
    out[:, :3, 3] /= object_scale(ob)
    return out


class _Keys:
    """Writes whole F-Curves of linear keys at ``frames`` into a channel bag."""

    def __init__(self, cbag, frames: np.ndarray):
        self.cbag, self.frames = cbag, frames

    def __call__(self, path: str, values: np.ndarray, group: str) -> None:
        """Key ``values`` (F,) or (F, K) on ``path``, one F-Curve per column (array index)."""
        values = np.asarray(values, float).reshape(len(self.frames), -1)
        for i in range(values.shape[1]):
            fill_keys(new_fcurve(self.cbag, path, i, group), self.frames, values[:, i])

    def constant(self, path: str, values, group: str) -> None:
        """Key ``values`` (K,) on ``path`` once, at the first frame: held throughout, so the
        channel plays the same whatever value the pose had before (no leftover state)."""
        values = np.asarray(values, float).ravel()
        for i, v in enumerate(values):
            fill_keys(new_fcurve(self.cbag, path, i, group), self.frames[:1], [v], CONSTANT)


def _new_action(ob, name: str, carried: dict, body_on: str, frames: np.ndarray):
    """A new slotted Action of the planner's for ``ob``, tagged with its owner (the
    character) and its bake's name, carrying the records of the character's state before
    its first bake: (action, slot, key writer)."""
    act = bpy.data.actions.new(f"Footstep {name}")
    act[OWNED_PROP] = ob.name
    act[BAKE_NAME_PROP] = name
    for k, v in carried.items():
        act[k] = v
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
    q = rotations(basis[..., :3, :3].reshape(-1, 3, 3)).as_quat().reshape(F, B, 4)
    moved = np.abs(basis[..., :3, 3]).max(axis=0).max(axis=1) > 1e-6
    for b, pb in enumerate(ob.pose.bones):
        path = f'pose.bones["{bpy.utils.escape_identifier(pb.name)}"].'
        _key_rotation(keys, path, q[:, b], pb.rotation_mode, pb.name, [0.0, 1.0, 0.0])
        if moved[b]:
            keys(f"{path}location", basis[:, b, :3, 3], pb.name)
        else:
            keys.constant(f"{path}location", np.zeros(3), pb.name)
        keys.constant(f"{path}scale", np.ones(3), pb.name)


def _key_rigify_controls(ob, rig: Rig, act, slot, frames: np.ndarray, res: IKResult, spin: float,
                         body_on: str, ik_feet: bool = False) -> None:
    """Key a Rigify rig's controls (``rigify.key_controls``: FK legs and arms, torso and
    spine, the IK/FK switches set to FK; with ``ik_feet`` the legs on their IK controls,
    foot_ik, toe_ik and the knee's pole, switched to IK) so that its DEF bones, the
    planner's skeleton, follow the IK's pose; with the body on the rig (``ROOT``) the
    torso carries it and the object stays put."""
    pose = forward_kinematics(rig, res.basis)  # armature space, the body at the object
    if body_on == "ROOT":
        carry = _in_object(ob, body_frames(res.body_pos, spin + res.body_heading))
        pose = carry[:, None] @ pose
    rigify.key_controls(ob, (act, slot), frames, {name: pose[:, b] for b, name in enumerate(rig.names)},
                        leg_ik=ik_feet)


def _add_track(ob, name: str, act, slot, frame_start: int):
    """A new NLA track of the planner's playing ``act`` from ``frame_start``, in the stack
    among the character's other bakes by time (a later bake above an earlier one, so that
    each plays from its start and the one before holds only until then)."""
    ad = ob.animation_data_create()
    ours = [t for t in owned_tracks(ob) if not t.mute]
    before = [t for t in ours if track_frames(t)[0] <= frame_start]
    later = [t for t in ours if track_frames(t)[0] > frame_start]
    tracks = list(ad.nla_tracks)
    if before:
        track = ad.nla_tracks.new(prev=max(before, key=tracks.index))
    elif later and tracks.index(min(later, key=tracks.index)) > 0:
        track = ad.nla_tracks.new(prev=tracks[tracks.index(min(later, key=tracks.index)) - 1])
    else:
        track = ad.nla_tracks.new()
        for t in sorted(later, key=tracks.index):  # (none below them to add under: they move up)
            _move_to_top(ad, t)
    track.name = f"{TRACK_PREFIX}{name}"
    strip = track.strips.new(act.name, int(frame_start), act)
    strip.action_slot = slot
    strip.extrapolation = "HOLD_FORWARD"
    strip.blend_type = "REPLACE"
    return track


_STRIP_COPY = ("action_frame_start", "action_frame_end", "scale", "repeat", "extrapolation", "blend_type",
               "mute", "influence", "use_auto_blend", "blend_in", "blend_out", "use_reverse")


def _move_to_top(ad, tr) -> None:
    """Move a planner's track to the top of the stack (as a copy: tracks have no move)."""
    new = ad.nla_tracks.new()
    new.name, new.mute, new.lock = tr.name, tr.mute, tr.lock
    for st in tr.strips:
        s = new.strips.new(st.name, int(st.frame_start), st.action)
        s.action_slot = st.action_slot
        for k in _STRIP_COPY:
            setattr(s, k, getattr(st, k))
    ad.nla_tracks.remove(tr)


def _add_markers(scene, act, path, planted, frame_start: int) -> None:
    """A timeline marker ``FP <n> <L|R>`` at each footprint's stance frame; ``act``
    records them (the only markers its removal removes)."""
    rate = scene_fps(scene)
    made = []
    for i, (f, (_, st, _)) in enumerate(zip(path, planted)):
        m = scene.timeline_markers.new(f"{MARKER_PREFIX}{i} {'LR'[f.foot]}", frame=int(round(frame_start + st * rate)))
        made.append([m.name, m.frame])
    act[MARKERS_PROP] = json.dumps(made)


def evaluate_played(scene, ob, rig: Rig, frame_start: int, frames: int, root: int | None = None):
    """``ob`` as Blender plays the scene, read through the depsgraph at ``frames`` frames
    from ``frame_start`` (``scene.frame_set``: every NLA track, the active action, the
    constraints, as they are): (world bone matrices (F, B, 4, 4), body positions (F, 3),
    body yaw (F,) unwrapped, bone rotations relative to rest (F, B, 4) scipy x, y, z, w).
    The body is the object's frame, or with ``root`` that bone's frame with its rest
    put back. The scene's current frame is restored."""
    return played_pose(rig, *played_matrices(scene, [(ob, rig)], frame_start, frames)[0][0], root)


def played_matrices(scene, characters, frame_start: int, frames: int, objects=()) -> tuple[list, list]:
    """Each of ``characters`` ((object, Rig) pairs) and ``objects`` as Blender plays the
    scene at ``frames`` frames from ``frame_start``, all read in one pass of
    ``scene.frame_set`` (one depsgraph evaluation a frame, what playing does): (per
    character (the rig's bones' armature-space matrices (F, B, 4, 4), the object's world
    matrix (F, 4, 4)), per object its world matrix (F, 4, 4)). The scene's current frame
    is restored."""
    # (a Rigify rig's skeleton is some of its bones)
    picks = [[ob.pose.bones.find(n) for n in rig.names] for ob, rig in characters]
    pose = [np.empty((frames, len(rig.names), 4, 4)) for _, rig in characters]
    obm = [np.empty((frames, 4, 4)) for _ in characters]
    bufs = [np.empty(len(ob.pose.bones) * 16, dtype=np.float32) for ob, _ in characters]
    moved = [np.empty((frames, 4, 4)) for _ in objects]
    saved = scene.frame_current, scene.frame_subframe
    depsgraph = bpy.context.evaluated_depsgraph_get()
    try:
        for i in range(frames):  # (one depsgraph evaluation per frame: what playing does)
            scene.frame_set(int(frame_start) + i)
            for c, (ob, _) in enumerate(characters):
                ev = ob.evaluated_get(depsgraph)
                ev.pose.bones.foreach_get("matrix", bufs[c])
                pose[c][i] = bufs[c].reshape(-1, 4, 4)[picks[c]].transpose(0, 2, 1)
                obm[c][i] = np.array(ev.matrix_world)
            for c, ob in enumerate(objects):
                moved[c][i] = np.array(ob.evaluated_get(depsgraph).matrix_world)
    finally:
        scene.frame_set(saved[0], subframe=saved[1])
    return list(zip(pose, obm)), moved


def played_world(pose: np.ndarray, obm: np.ndarray) -> np.ndarray:
    """(F, B, 4, 4) the bones' world matrices of one character's ``played_matrices``."""
    return _in_world(pose, obm)[0]


def _in_world(pose: np.ndarray, obm: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(world bone matrices, armature-space bone matrices in world units, the object's
    unscaled world matrices) of ``played_matrices``' (pose, obm): an evenly scaled
    object's scale moved into the bones, as the rig is read in world units."""
    scale = np.cbrt(np.abs(np.linalg.det(obm[:, :3, :3])))
    obm = unscaled(obm)
    pose = pose.copy()
    pose[..., :3, 3] *= scale[:, None, None]
    return obm[:, None] @ pose, pose, obm


def played_pose(rig: Rig, pose: np.ndarray, obm: np.ndarray, root: int | None = None):
    """``evaluate_played``'s figures of one character's ``played_matrices``: (world bone
    matrices (F, B, 4, 4), body positions (F, 3), body yaw (F,) unwrapped, bone rotations
    relative to rest (F, B, 4)); the body the object's frame, or ``root``'s."""
    world, pose, obm = _in_world(pose, obm)
    body = obm if root is None else obm @ pose[:, root] @ np.linalg.inv(rig.rest[root])
    yaw = np.unwrap(np.arctan2(body[:, 1, 0], body[:, 0, 0]))
    return world, body[:, :3, 3].copy(), yaw, local_rotations(rig, pose)


def local_rotations(rig: Rig, pose: np.ndarray) -> np.ndarray:
    """(F, B, 4) each bone's rotation relative to its rest pose (scipy x, y, z, w) from
    armature-space pose matrices (F, B, 4, 4): the rotation part of
    rest_b^-1 rest_parent pose_parent^-1 pose_b (rest_b^-1 pose_b for a root bone), what
    the bone's own keys would be with default inheritance."""
    F, B = pose.shape[:2]
    parents = np.asarray(rig.parents)
    inv_rest = np.linalg.inv(rig.rest)
    has = parents >= 0
    rel = inv_rest.copy()
    rel[has] = inv_rest[has] @ rig.rest[parents[has]]
    parent_inv = np.tile(np.eye(4), (F, B, 1, 1))
    parent_inv[:, has] = np.linalg.inv(pose[:, parents[has]])
    local = rel[None] @ parent_inv @ pose
    return rotations(local[..., :3, :3].reshape(-1, 3, 3)).as_quat().reshape(F, B, 4)


__all__ = ["BODY_ON", "BakeError", "BakeOptions", "EditedBakeError", "STASH_PROP", "bake", "bake_name", "character_state",
           "check_leg_constraints", "check_not_tweaking", "check_overlap", "check_scene", "clear", "discard",
           "evaluate_played", "give_back_state", "local_rotations", "new_track_name", "own_frame", "own_matrix_world",
           "owned_tracks", "played_matrices", "played_pose", "played_world", "record_keys", "remove_tracks", "root_bone", "settle"]
