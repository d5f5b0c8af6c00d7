"""A character: its rig, its clips (the armature's actions), their analysis and the
clip library. Reads Blender data, calls the core, and writes only the planner's own
properties."""

from __future__ import annotations

from dataclasses import dataclass, field

from ..core.analysis import AnalysisError, ClipAnalysis, analyze_clip
from ..core.library import Library, LibraryError, SpecialClip, TurnGroup, GroupClip, propose_library
from ..core.rig import Rig, RigError
from ..core.settings import Settings
from .scene import armature_actions, clip_from_action, rig_from_armature


@dataclass
class CharacterClips:
    rig: Rig
    analyses: list[ClipAnalysis] = field(default_factory=list)
    errors: dict[str, str] = field(default_factory=dict)  # clip name -> message


def analyze_character(ob, settings: Settings | None = None, fps: float | None = None,
                      actions=None) -> CharacterClips:
    """Analyse every clip of ``ob`` (or the given actions). A clip that cannot be analysed
    is reported in ``errors`` and skipped; a rig without legs raises RigError."""
    rig = rig_from_armature(ob)
    rig.require_legs()
    result = CharacterClips(rig)
    for act in (actions if actions is not None else armature_actions(ob)):
        try:
            motion = clip_from_action(ob, act, rig, fps=fps)
            result.analyses.append(analyze_clip(motion, settings))
        except (AnalysisError, RigError) as ex:
            result.errors[act.name] = str(ex)
    return result


def analyze_and_propose(ob, settings: Settings | None = None) -> CharacterClips:
    """Analyse ``ob``'s clips and store the proposed library, unless a user edited it."""
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
    """Show ``library`` in the armature's clip list (the panel edits that list)."""
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
    the analysis, so a headless run needs no UI step."""
    if ob.data.footstep.library_edited:
        lib = read_library(ob)
        lib.check({a.name for a in clips.analyses} | set(clips.errors))
        return lib
    return propose_library(clips.analyses)


__all__ = ["CharacterClips", "analyze_and_propose", "analyze_character", "library_for", "read_library", "write_library",
           "summary", "LibraryError"]
