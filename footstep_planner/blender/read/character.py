"""A character: its rig, its clips (the armature's actions), their analysis and the
clip library. Reads Blender data, calls the core, and writes only the planner's own
properties.

A jump clip's mirror image (``core.mirror``: "<clip>~mirror", taking off from the other
foot) is made in memory beside the clips' analyses when they are analysed for planning
(``analyze_character(..., mirrors=True)``), so the planner jumps from either foot; it is
never an action, never stored in the clip list, and re-made at every analysis."""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from ...core.clips.analysis import AnalysisError, ClipAnalysis, analyze_clip
from ...core.clips.body import body_scale
from ...core.clips.library import Library, LibraryError, SpecialClip, TurnGroup, GroupClip, propose_library
from ...core.clips.mirror import MIRRORED_KINDS, MirrorError, is_mirror, mirrored_jumps, mirrored_name
from ...core.clips.clip import SIDES, ClipMotion, clip_motion
from ...core.clips.rig import Rig, RigError, forward_kinematics
from ...core.base.settings import Settings
from .scene import (SOURCE_FPS_PROP, action_frame_range, armature_actions, clip_from_action, rig_from_armature,
                    sample_basis, scene_fps)


@dataclass
class CharacterClips:
    rig: Rig
    # the clips' analyses, then the mirror images of jumps (``mirrors``), which the
    # planner plays like the others
    analyses: list[ClipAnalysis] = field(default_factory=list)
    errors: dict[str, str] = field(default_factory=dict)  # clip name -> message
    mirrors: dict[str, str] = field(default_factory=dict)  # mirror image's name -> its clip's

    @property
    def own(self) -> list[ClipAnalysis]:
        """The analyses of the character's own clips (its actions), without mirrors."""
        return [a for a in self.analyses if a.name not in self.mirrors]


def analyze_character(ob, settings: Settings | None = None, fps: float | None = None,
                      actions=None, mirrors: bool = False) -> CharacterClips:
    """Analyse every clip of ``ob`` (or the given actions). A clip that cannot be analysed
    is reported in ``errors`` and skipped; a rig without legs raises RigError.

    With ``mirrors`` (for planning: ``library_for`` then puts them in the library), the
    analyses end with the mirror images of the jumps, start and stop clips the library
    uses (every such clip's when the library is the proposal) that lead with a foot no
    other clip of the same kind and gaits leads the other way with: "<clip>~mirror",
    taking off (setting off, arriving) with the other foot
    (``core.clips.mirror.mirrored_jumps``; data in memory, nothing made in the scene). A rig
    whose sides cannot be paired gets no mirrors (its jumps stay one-footed); its message
    is kept in ``errors`` under the mirror's name."""
    rig = rig_from_armature(ob)
    rig.require_legs()
    if any(rig.foot_chain(side)[1] is None for side in SIDES):  # (no toe bone: the mesh says where the toes end)
        rig = rig_from_armature(ob, sole="mesh")
    settings = (settings or Settings()).for_body(body_scale(rig))  # (a human's lengths, at this rig's size)
    result = CharacterClips(rig)
    for act in (actions if actions is not None else armature_actions(ob)):
        try:
            motion = read_clip(ob, act, rig, fps=fps)
            result.analyses.append(analyze_clip(motion, settings))
        except (AnalysisError, RigError) as ex:
            result.errors[act.name] = str(ex)
    if mirrors:
        _add_mirrors(ob, result)
    return result


def _add_mirrors(ob, result: CharacterClips) -> None:
    """Append to ``result`` the mirror images of the jumps, start and stop clips the
    character's library plays (an edited library's, else every such clip) where they lead
    with one foot only (``core.clips.mirror.mirrored_jumps``)."""
    jumps = [a for a in result.analyses if a.kind in MIRRORED_KINDS]
    if ob.data.footstep.library_edited:
        used = {sp.clip for sp in read_library(ob).specials if sp.kind in MIRRORED_KINDS}
        jumps = [a for a in jumps if a.name in used]
    if not jumps:
        return
    try:
        made = mirrored_jumps(jumps, result.rig, MIRRORED_KINDS)
    except MirrorError as ex:
        for a in jumps:
            result.errors[mirrored_name(a.name)] = str(ex)
        return
    taken = {a.name for a in result.analyses} | set(result.errors)
    for m in made:
        if m.name not in taken:
            result.analyses.append(m)
            result.mirrors[m.name] = mirrored_name(m.name)


#: Clips of more samples than this are read a chunk of this many samples at a time: their
#: pose bases and forward kinematics (128 bytes a bone and sample, each) are never held
#: whole, only what the ClipMotion keeps.
CHUNK = 4096


def read_clip(ob, action, rig: Rig, fps: float | None = None) -> ClipMotion:
    """``action`` on armature ``ob`` sampled at ``fps`` (default: the scene's rate) over its
    frame range, as ``scene.clip_from_action`` gives it; a clip longer than ``CHUNK``
    samples is read a chunk at a time (``_chunked_clip``), to the same result. (Read each
    time: a digest of its keys costs about what the read does; its analysis is kept by its
    samples, ``core.clips.analysis.analyze_clip``.)"""
    from .. import rigify

    sfps = scene_fps()
    step = sfps / float(fps or sfps)
    start, end = action_frame_range(action)
    frames = start + step * np.arange(int(round((end - start) / step)) + 1)
    if len(frames) <= CHUNK or rigify.is_rigify(ob):
        return clip_from_action(ob, action, rig, fps=fps)
    return _chunked_clip(ob, action, rig, frames, float(fps or sfps))


def _chunked_clip(ob, action, rig: Rig, frames: np.ndarray, fps: float) -> ClipMotion:
    """``core.clips.clip.clip_motion`` of ``action`` sampled at ``frames``, computed on chunks
    of ``CHUNK`` samples and joined: the root's heading unwrapped across the joins, and
    each foot's heel and toe points taken where the foot is lowest in the whole clip
    (``_sole_points``), as the whole clip's ``clip_motion`` takes them. The bones'
    rotations are kept in float32."""
    src = action.get(SOURCE_FPS_PROP)
    extra = dict(source_fps=float(src) if src else None, frame_rate=scene_fps())
    feet = [rig.foot_chain(side)[0] for side in SIDES]
    n, parts = len(frames), []
    local_rot = np.empty((n, len(rig.names), 3, 3), np.float32)  # (half the memory; 1e-7 is plenty)
    foot_pose = np.empty((len(feet), n, 4, 4))
    for a in range(0, n, CHUNK):
        basis = sample_basis(ob, action, frames[a:a + CHUNK], rig)
        part = clip_motion(rig, action.name, basis, fps=fps, frame0=frames[0], **extra)
        local_rot[a:a + len(basis)] = part.local_rot
        foot_pose[:, a:a + len(basis)] = forward_kinematics(rig, basis, bones=feet)[:, feet].swapaxes(0, 1)
        parts.append(replace(part, local_rot=None))
        del basis, part
    heel, toe, heel_local, toe_local = _sole_points(ob, action, rig, frames, foot_pose, fps)
    join = lambda attr: np.concatenate([getattr(p, attr) for p in parts])  # noqa: E731
    return replace(parts[0], times=np.arange(n) / fps, root_pos=join("root_pos"),
                   root_heading=np.unwrap(join("root_heading")), hips_in_root=join("hips_in_root"),
                   local_rot=local_rot, heel=heel, toe=toe, heel_local=heel_local, toe_local=toe_local)


def _sole_points(ob, action, rig: Rig, frames, foot_pose: np.ndarray, fps: float):
    """(heel, toe (2, N, 3), heel_local, toe_local (2, 4)) of a clip whose foot bones'
    armature-space matrices are ``foot_pose`` (2, N, 4, 4): each foot's points placed by
    ``clip_motion`` at the sample where that foot is lowest (the ankle and the ball above
    their own lowest, the higher of the two, least), carried rigidly with the foot."""
    heel, toe = np.empty((2, len(frames), 3)), np.empty((2, len(frames), 3))
    heel_local, toe_local = np.empty((2, 4)), np.empty((2, 4))
    for k, side in enumerate(SIDES):
        fm = foot_pose[k]
        ankle, ball = fm[:, 2, 3], (fm @ rig.ball_local(side))[:, 2]
        flat = int(np.argmin(np.maximum(ankle - ankle.min(), ball - ball.min())))
        one = clip_motion(rig, action.name, sample_basis(ob, action, frames[[flat]], rig), fps=fps)
        heel_local[k], toe_local[k] = one.heel_local[k], one.toe_local[k]
        heel[k] = (fm @ heel_local[k])[:, :3]
        toe[k] = (fm @ toe_local[k])[:, :3]
    return heel, toe, heel_local, toe_local


def analyze_and_propose(ob, settings: Settings | None = None) -> CharacterClips:
    """Analyse ``ob``'s clips and store the proposed library, unless a user edited it.
    The result holds the character's own clips (the mirrors of its jumps are made for a
    plan: ``analyze_character(..., mirrors=True)``)."""
    result = analyze_character(ob, settings)
    if not ob.data.footstep.library_edited:
        write_library(ob, library_for(ob, result), result.analyses)
    return result


_USAGE_OF_KIND = {"jump": "JUMP", "start": "START", "stop": "STOP", "idle": "IDLE"}


def summary(a: ClipAnalysis) -> str:
    parts = [a.kind, a.gait_text, f"{a.speed:.2f} m/s"]
    if a.stride is not None:
        parts.append(f"stride {a.stride:.2f} m")
    if a.cycle is not None:
        parts.append(f"cycle {a.cycle:.2f} s")
    parts.append(f"tau {a.tau:+.2f}")
    if a.jump_flights:
        parts.append("flight " + ", ".join(f"{b - x:.2f} s" for x, b in a.jump_flights))
    return ", ".join(parts)


def write_library(ob, library: Library, analyses: list[ClipAnalysis], edited: bool = False) -> None:
    """Show ``library`` in the armature's clip list (the panel edits that list). Mirror
    images of clips ("<clip>~mirror") are not listed: they are made afresh from their
    clips wherever the library is used (``library_for``)."""
    props = ob.data.footstep
    by_name = {a.name: a for a in analyses}
    props.syncing = True
    try:
        props.clips.clear()
        for gait, group in library.turn_groups.items():
            for c in group.clips:
                item = props.clips.add()
                item.name, item.usage, item.gait = c.clip, "TURN", gait
                item.tau, item.speed = c.tau, c.speed
        for sp in library.specials:
            if is_mirror(sp.clip):
                continue
            item = props.clips.add()
            item.name, item.usage = sp.clip, _USAGE_OF_KIND[sp.kind]
            item.entry_gait, item.exit_gait = sp.entry_gait, sp.exit_gait
        for name in library.excluded:
            item = props.clips.add()
            item.name, item.usage = name, "EXCLUDED"
        for item in props.clips:
            if item.name in by_name:
                item.summary = summary(by_name[item.name])
        props.library_edited = edited
    finally:
        props.syncing = False


def read_library(ob) -> Library:
    """The library as the panel's clip list holds it."""
    lib = Library(edited=bool(ob.data.footstep.library_edited))
    kinds = {v: k for k, v in _USAGE_OF_KIND.items()}
    for item in ob.data.footstep.clips:
        if item.usage == "TURN":
            g = lib.turn_groups.setdefault(item.gait, TurnGroup(f"{item.gait}_turn", item.gait))
            g.clips.append(GroupClip(item.name, float(item.tau), float(item.speed)))
        elif item.usage == "EXCLUDED":
            lib.excluded.append(item.name)
        else:
            lib.specials.append(SpecialClip(item.name, kinds[item.usage], item.entry_gait, item.exit_gait))
    for g in lib.turn_groups.values():
        g.clips.sort(key=lambda c: c.tau)
    return lib


def library_for(ob, clips: CharacterClips) -> Library:
    """The library the planner uses: the user's, once edited; otherwise the proposal from
    the analysis, so a headless run needs no UI step. Either way it holds the mirror
    images ``clips`` has of its jumps, start and stop clips (``analyze_character``) as
    clips of their own of the same kind."""
    if ob.data.footstep.library_edited:
        lib = read_library(ob)
        lib.check({a.name for a in clips.analyses} | set(clips.errors))
        by = {a.name: a for a in clips.analyses}
        jumps = {sp.clip: sp for sp in lib.specials if sp.kind in MIRRORED_KINDS}
        for name, source in clips.mirrors.items():
            sp = jumps.get(source)
            if sp is not None and name not in lib.clips() and name not in lib.excluded and name in by:
                lib.specials.append(SpecialClip(name, sp.kind, by[name].entry_gait, by[name].exit_gait))
        return lib
    return propose_library(clips.analyses)


__all__ = ["CharacterClips", "analyze_and_propose", "analyze_character", "library_for", "read_clip", "read_library",
           "write_library", "summary", "LibraryError"]
