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
"""

from __future__ import annotations

import json

import numpy as np
import bpy
from scipy.spatial.transform import Rotation

from ...core.base.errors import FootstepError
from ...core.solve.ik import IKResult, body_frames
from ...core.base.quat import continuous
from ...core.clips.rig import Rig, armature_basis
from .keys import new_fcurve
from .keys import CONSTANT, fill_keys
from ..read.scene import object_scale, scene_fps

OWNED_PROP = "footstep_bake"
#: The character's own object transform before the first bake (row-major 4x4), put back
#: by ``clear``: the bake animates the object, and Blender leaves the last evaluated
#: transform in it when the animation goes.
REST_PROP = "footstep_rest_matrix"
#: Where the bake put the body: "OBJECT" or "ROOT".
BODY_PROP = "footstep_body_on"
TRACK_PREFIX = "Footstep: "
MARKER_PREFIX = "FP "
#: The bake's name (on its action): a bake replaces only the planner's bake of its name.
BAKE_NAME_PROP = "footstep_bake_name"
#: The timeline markers the bake made, as JSON [[name, frame], ...]: the only markers
#: the planner ever removes.
MARKERS_PROP = "footstep_markers"
#: The character as it was before the planner's first bake of it (JSON: the object's
#: transform values as typed, every pose bone's channels and rotation mode, whether it
#: had animation data), given back when the planner's last bake of it goes.
BEFORE_PROP = "footstep_before"
#: The user's active action the bake stashed: its name, its slot's identifier, the name
#: of the stash track the bake made.
STASH_PROP = "footstep_stashed_action"
STASH_SLOT_PROP = "footstep_stashed_slot"
STASH_TRACK_PROP = "footstep_stash_track"
#: The scene's frame range before the bake grew it, and the range it grew it to.
RANGE_PROP = "footstep_frame_range"
STASH_TRACK = "[Action Stash]"
#: What every bake of a character carries of the character's state before its first
#: bake (copied from bake to bake, so that whichever goes last gives it back).
CARRIED = (REST_PROP, BEFORE_PROP, STASH_PROP, STASH_SLOT_PROP, STASH_TRACK_PROP, RANGE_PROP)


class BakeError(FootstepError):
    pass


def is_owned(act) -> bool:
    """Whether ``act`` is one of the planner's bakes (its owner tag)."""
    return act is not None and act.get(OWNED_PROP) is not None


def bake_name(act) -> str:
    """The name of the bake ``act`` holds (its tag; a bake made before names were
    tagged: its action's name without the planner's prefix)."""
    name = act.get(BAKE_NAME_PROP)
    if name is not None:
        return str(name)
    return act.name[len("Footstep "):] if act.name.startswith("Footstep ") else act.name


def owned_tracks(ob, name: str | None = None) -> list:
    """The planner's own NLA tracks on ``ob`` (found by their actions' owner tag, whatever
    the tracks are called), or only those of the bake ``name``."""
    ad = ob.animation_data
    if ad is None:
        return []
    out = [tr for tr in ad.nla_tracks if tr.strips and all(is_owned(st.action) for st in tr.strips)]
    if name is not None:
        out = [tr for tr in out if any(bake_name(st.action) == name for st in tr.strips)]
    return out


def track_frames(tr) -> tuple[float, float]:
    return min(st.frame_start for st in tr.strips), max(st.frame_end for st in tr.strips)


def unscaled(m: np.ndarray) -> np.ndarray:
    """(..., 4, 4) ``m`` with its even scale taken out of its rotation (translation kept)."""
    m = np.array(m, float, copy=True)
    s = np.cbrt(np.abs(np.linalg.det(m[..., :3, :3])))
    m[..., :3, :3] /= np.asarray(s)[..., None, None]
    return m


def own_frame(ob) -> np.ndarray:
    """(4, 4) the object's own world frame (``own_matrix_world``) without its even scale:
    where the planner's world-unit rig stands."""
    return unscaled(own_matrix_world(ob))


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


# -- the character as it was --------------------------------------------------------

_OBJECT_CHANNELS = ("location", "rotation_euler", "rotation_quaternion", "rotation_axis_angle", "scale")


def character_state(ob) -> dict:
    """What a bake changes on the character and Clear gives back: the object's transform
    values as they are typed (an Euler beyond 360 degrees too) and rotation mode, every
    pose bone's channels and rotation mode (``scene.pose_channels``), whether it had
    animation data. Plain values (JSON)."""
    from ..read.scene import pose_channels

    state = {"object": {k: [float(v) for v in getattr(ob, k)] for k in _OBJECT_CHANNELS},
             "rotation_mode": ob.rotation_mode, "anim_data": ob.animation_data is not None}
    if ob.pose is not None:
        pose = pose_channels(ob)
        state["pose"] = {k: v.tolist() if hasattr(v, "tolist") else v for k, v in pose.items()}
    return state


def give_back_state(ob, state: dict) -> None:
    """Put the character's channels back as ``character_state`` read them."""
    from ..read.scene import set_pose_channels

    if ob.rotation_mode != state.get("rotation_mode", ob.rotation_mode):
        ob.rotation_mode = state["rotation_mode"]
    for k, v in state.get("object", {}).items():
        setattr(ob, k, v)
    if state.get("pose") is not None and ob.pose is not None:
        set_pose_channels(ob, state["pose"])


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
         path=None, planted=None, markers: bool = False, body_on: str = "OBJECT",
         frame_range: bool = True, rigify_ik_feet: bool = False, replaced: list | None = None,
         force: bool = False, beside: str | None = None):
    """Key ``res`` into a new Action on the armature ``ob`` in a new NLA track of the
    planner's, starting at ``frame_start``: the body on the object's transform
    (``body_on="OBJECT"``) or on the rig's root bone (``"ROOT"``, the object stays put),
    every bone's rotation, and the location of the hips and of any bone that moves from
    its parent (``res.basis``, under the planner's hierarchy, is keyed under the
    armature's, ``core.clips.rig.armature_basis``: a foot parented to the root moves from it).
    The planner's earlier bake of this name is replaced; its other bakes of this
    character stay (a bake that would overlap one of them in time is refused, before
    anything changes). With ``replaced`` (a list), the earlier bake of this name is only
    muted and its tracks put in the list, for the caller to ``settle`` (remove them) or
    ``discard`` (take the new bake back and unmute them). The character's active action
    is stashed (see the module's doc) and, with ``frame_range``, the scene's frame range
    grows to cover the bake.
    ``planted`` holds (strike, stance, liftoff) seconds per footprint of ``path``,
    for the optional markers. ``rigify_ik_feet``: on a Rigify rig, the legs on their IK
    controls (``rigify.key_controls(leg_ik=True)``) instead of the FK ones. ``force``:
    replace an earlier bake of this name even when its keys were edited since. ``beside``:
    the name of a bake this one is made beside (``new_track_name``), which it may overlap
    (the new track plays over it)."""
    from dataclasses import replace

    from ...core.clips.body import scaled_bases, scaled_rig
    from .. import rigify

    _check(ob, rig, body_on)
    check_not_tweaking(ob)
    check_overlap(ob, name, int(frame_start), int(frame_start) + res.frames - 1, beside)
    old = owned_tracks(ob, name)
    if not force:
        check_unedited(ob, old, name)
    s = object_scale(ob)
    if s != 1.0:  # (planned in world units: keyed in the armature's)
        rig, res = scaled_rig(rig, 1.0 / s), replace(res, basis=scaled_bases(res.basis, 1.0 / s))
    on_controls = rigify.is_rigify(ob)
    basis = _root_carries_body(ob, rig, res, spin) if body_on == "ROOT" and not on_controls else res.basis
    carried = _carried(ob)
    if replaced is None:
        remove_tracks(ob, scene, old)  # (the last bake gone: the character as it was, to read again)
        carried = _carried(ob)
    else:
        for tr in old:
            replaced.append((tr, tr.mute))
            tr.mute = True
    if not carried:
        carried = _first_records(ob)
    frames = frame_start + np.arange(res.frames, dtype=np.float64)
    act, slot, keys = _new_action(ob, name, carried, body_on, frames)
    if beside is not None:
        act[BESIDE_PROP] = beside
    if body_on == "OBJECT":
        _key_body(keys, ob, res.body_pos, spin + res.body_heading)
    if on_controls:
        _key_rigify_controls(ob, rig, act, slot, frames, res, spin, body_on, rigify_ik_feet)
    else:  # (keys are Blender's bases: a foot parented to the root keyed relative to it)
        _key_bones(keys, ob, armature_basis(rig, basis))
    track = _add_track(ob, name, act, slot, frame_start)
    _stash_active(ob, act)
    if frame_range:
        _grow_range(scene, act, ob, int(frame_start), int(frame_start) + res.frames - 1)
    if markers and path is not None and planted is not None:
        _add_markers(scene, act, path, planted, frame_start)
    return act, track


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


#: On a bake made beside another of the character's (``new_track_name``): that bake's
#: name (the two may overlap in time: the later track plays over the other).
BESIDE_PROP = "footstep_beside"
#: On the bake's action: a digest of the keys the planner wrote (``keys_digest``), to
#: know a bake the animator has edited since.
KEYS_PROP = "footstep_keys_digest"


def keys_digest(act) -> str:
    """A digest of every key of ``act`` (curve, frame, value, interpolation)."""
    import hashlib

    h = hashlib.sha1()
    curves = [fc for layer in act.layers for strip in layer.strips for cb in strip.channelbags for fc in cb.fcurves]
    for fc in sorted(curves, key=lambda c: (c.data_path, c.array_index)):
        kp = fc.keyframe_points
        co = np.empty(2 * len(kp), np.float32)
        kp.foreach_get("co", co)
        interp = np.empty(len(kp), np.int32)
        kp.foreach_get("interpolation", interp)
        h.update(f"{fc.data_path}[{fc.array_index}]".encode() + co.tobytes() + interp.tobytes())
    return h.hexdigest()


def record_keys(act) -> None:
    """Remember the keys the planner wrote on ``act`` (``edited`` compares)."""
    act[KEYS_PROP] = keys_digest(act)


def edited(act) -> bool:
    """Whether the keys of the planner's ``act`` changed since the planner wrote them."""
    rec = act.get(KEYS_PROP)
    return rec is not None and rec != keys_digest(act)


class EditedBakeError(BakeError):
    """A re-bake over a bake whose keys the animator has edited."""


def check_unedited(ob, tracks: list, name: str) -> None:
    """EditedBakeError when a bake about to be replaced (``tracks``) has keys edited since
    the planner wrote them: nothing is changed."""
    if any(edited(st.action) for tr in tracks for st in tr.strips):
        raise EditedBakeError(f"the planner's bake {name!r} on character {ob.name!r} has keys edited since it was "
                              "baked: baking over it would lose the edits; bake to a new track (--new-track, or "
                              "another --name) or replace it anyway (--force)")


def new_track_name(ob, name: str) -> str:
    """``name``, or the first ``name (2)``, ``name (3)``... that no bake of ``ob`` has."""
    used = {bake_name(st.action) for tr in owned_tracks(ob) for st in tr.strips}
    n, out = 2, name
    while out in used:
        out, n = f"{name} ({n})", n + 1
    return out


def _first_records(ob) -> dict:
    """The records of the character's first bake: its state as it is now."""
    return {REST_PROP: [float(v) for row in ob.matrix_basis for v in row],
            BEFORE_PROP: json.dumps(character_state(ob))}


def check_not_tweaking(ob) -> None:
    """BakeError, in one line, when the character's NLA is in tweak mode (its active
    action is then a strip's, and read-only): nothing is changed."""
    ad = ob.animation_data
    if ad is not None and ad.use_tweak_mode:
        tr = ad.nla_tracks.active
        strip = next((f"strip {st.name!r} of track {t.name!r}" for t in ([tr] if tr else []) + list(ad.nla_tracks)
                      for st in t.strips if st.active or st.select), "a strip")
        raise BakeError(f"character {ob.name!r} has its NLA in tweak mode (editing {strip}): leave tweak mode "
                        "(NLA editor: Tab) and bake or clear again")


def _on(c) -> bool:
    """Whether a constraint acts (enabled, with some influence)."""
    return not getattr(c, "mute", False) and getattr(c, "enabled", True) and c.influence > 0.0


def _moves(ob) -> str | None:
    """Why ``ob`` moves by itself (animated, driven, constrained), or None."""
    ad = ob.animation_data
    if ad is not None:
        if ad.action is not None:
            return f"its action {ad.action.name!r} animates it"
        if any(not t.mute and len(t.strips) for t in ad.nla_tracks):
            return "its NLA tracks animate it"
        if len(ad.drivers):
            return "drivers move it"
    c = next((c for c in ob.constraints if _on(c)), None)
    return f"its constraint {c.name!r} ({c.type}) moves it" if c is not None else None


def check_scene(scene, ob, body_on: str = "OBJECT") -> None:
    """BakeError, in one line naming the object, bone or setting and what to do, for what
    would make the bake play elsewhere than it was planned: the character's NLA in tweak
    mode, a soloed NLA track of the user's (only it plays), the scene's time remapping, a
    constraint on the object, a parent that moves (animated, constrained) or, with the
    body on the object, a parent that moves the object from where its keys put it."""
    check_not_tweaking(ob)
    ad = ob.animation_data
    solo = [t for t in ad.nla_tracks if t.is_solo] if ad is not None else []
    if solo and not all(t in owned_tracks(ob) for t in solo):
        raise BakeError(f"character {ob.name!r} has its NLA track {solo[0].name!r} soloed: only that track plays, "
                        "not the bake; un-solo it (NLA editor: the star beside the track) and bake again")
    r = scene.render
    if r.frame_map_old != r.frame_map_new:
        raise BakeError(f"scene {scene.name!r} remaps time (Output Properties > Frame Range > Time Stretching: old "
                        f"{r.frame_map_old}, new {r.frame_map_new}): the bake would play at another speed; set both "
                        "to the same and bake again")
    c = next((c for c in ob.constraints if _on(c)), None)
    if c is not None:
        raise BakeError(f"character {ob.name!r} has the constraint {c.name!r} ({c.type}) on its object, which moves it "
                        "away from its baked transform: disable, remove or apply it and bake again")
    p = ob.parent
    while p is not None:
        why = _moves(p)
        if why is not None:
            raise BakeError(f"character {ob.name!r} is parented to {p.name!r}, and {why}: the bake is planned in the "
                            "world, not in a moving parent; clear the parent (Object > Parent > Clear and Keep "
                            "Transformation) and bake again")
        p = p.parent
    if ob.parent is not None and body_on == "OBJECT" and not np.allclose(
            np.array(ob.matrix_world), np.array(ob.matrix_basis), atol=1e-5):
        raise BakeError(f"character {ob.name!r} is parented to {ob.parent.name!r}, which places it elsewhere than its "
                        "own transform: the body's keys are world positions; clear the parent (Object > Parent > "
                        "Clear and Keep Transformation) or bake the body on the root bone (--body-on root)")


def check_leg_constraints(ob, rig: Rig) -> None:
    """BakeError naming the bone and constraint, for a constraint on the hips or a leg
    (or their ancestors) of a rig the bake keys directly (a Rigify rig's constraints are
    its own machinery, keyed through its controls)."""
    from .. import rigify

    if rigify.is_rigify(ob):
        return
    from ..read.scene import leg_bones

    for b in leg_bones(rig):
        pb = ob.pose.bones.get(rig.names[b])
        c = next((c for c in pb.constraints if _on(c)), None) if pb is not None else None
        if c is not None:
            raise BakeError(f"bone {pb.name!r} of character {ob.name!r} has the constraint {c.name!r} ({c.type}), "
                            "which overrides the bake's keys on the legs: disable or remove it and bake again")


def check_overlap(ob, name: str, first: int, last: int, beside: str | None = None) -> None:
    """BakeError naming the planner's other bake of the character that frames ``first``
    to ``last`` would overlap (two bakes of one character play one after another; a bake
    made ``beside`` another may overlap that one)."""
    mine = {name, beside} - {None}
    for tr in owned_tracks(ob):
        if any(bake_name(st.action) in mine or st.action.get(BESIDE_PROP) in mine for st in tr.strips):
            continue
        lo, hi = track_frames(tr)
        if first <= hi and lo <= last:
            raise BakeError(f"bake {name!r} (frames {first}-{last}) would overlap the planner's bake "
                            f"{bake_name(tr.strips[0].action)!r} (frames {int(lo)}-{int(hi)}) on character "
                            f"{ob.name!r}: give it that bake's name to replace it, start it elsewhere "
                            "(--frame-start), or clear that bake")


def _check(ob, rig: Rig, body_on: str) -> None:
    from .. import rigify

    names = tuple(pb.name for pb in ob.pose.bones)
    if names != tuple(rig.names) and not (rigify.is_rigify(ob) and set(rig.names) <= set(names)):
        raise BakeError(f"armature {ob.name!r} changed since it was read (bones differ)")
    if body_on not in BODY_ON:
        raise BakeError(f"the body goes on one of {', '.join(BODY_ON)}, not {body_on!r}")


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
    q = Rotation.from_matrix(basis[..., :3, :3].reshape(-1, 3, 3)).as_quat().reshape(F, B, 4)
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
    from ...core.clips.rig import forward_kinematics
    from .. import rigify

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
    B = len(rig.names)
    pick = [ob.pose.bones.find(n) for n in rig.names]  # (a Rigify rig's skeleton is some of its bones)
    pose = np.empty((frames, B, 4, 4))
    obm = np.empty((frames, 4, 4))
    buf = np.empty(len(ob.pose.bones) * 16, dtype=np.float32)
    saved = scene.frame_current, scene.frame_subframe
    depsgraph = bpy.context.evaluated_depsgraph_get()
    try:
        for i in range(frames):  # (one depsgraph evaluation per frame: what playing does)
            scene.frame_set(int(frame_start) + i)
            ev = ob.evaluated_get(depsgraph)
            ev.pose.bones.foreach_get("matrix", buf)
            pose[i] = buf.reshape(-1, 4, 4)[pick].transpose(0, 2, 1)
            obm[i] = np.array(ev.matrix_world)
    finally:
        scene.frame_set(saved[0], subframe=saved[1])
    # (an evenly scaled object: its scale moved into the bones, as the rig is read in world units)
    scale = np.cbrt(np.abs(np.linalg.det(obm[:, :3, :3])))
    obm = unscaled(obm)
    pose[..., :3, 3] *= scale[:, None, None]
    world = obm[:, None] @ pose
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
    return Rotation.from_matrix(local[..., :3, :3].reshape(-1, 3, 3)).as_quat().reshape(F, B, 4)


__all__ = ["bake", "bake_name", "character_state", "give_back_state", "check_not_tweaking", "check_overlap", "clear", "discard", "settle", "evaluate_played", "local_rotations", "own_matrix_world", "owned_tracks", "root_bone", "BakeError"]
