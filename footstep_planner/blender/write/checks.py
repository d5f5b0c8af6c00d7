"""What a bake refuses before it writes anything, each in one line that names the fault and
the fix: keys the animator edited since the bake (``check_unedited``, by the digest the
bake recorded), the NLA in tweak mode, scene states that would make the bake play
elsewhere than planned (``check_scene``: a moving parent, constraints, a time remap, a
soloed track), constraints on the legs, and a bake that would overlap another in time.
"""

from __future__ import annotations

import json

import numpy as np

from ...core.clips.rig import Rig
from .owned import (BEFORE_PROP, BODY_ON, REST_PROP, BakeError, bake_name, character_state, owned_tracks,
                    track_frames)


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
