"""The command line's clip verbs: ``import-clips`` (every file imported that can be, each
refused one reported) and ``analyze`` (a row for every clip, with the reason beside each
refused one; plots on request). The exit status counts the failures.
"""

from __future__ import annotations

import json
import os
import sys

import bpy

from ...core.base.errors import FootstepError
from ...core.base.files import Outputs
from ...core.report.tables import format_library, format_table
from .blend_io import (CliError, blend_writer, check_input, claim_blend, empty_scene, find_armature, open_blend,
                       set_scene_fps, settings_from_args)
from .console import say


def _clip_files_or_blend(args) -> tuple[list, list]:
    """(clip files, .blend files) among ``analyze``'s inputs; CliError for anything else,
    or a mix."""
    from ..read.clips import CLIP_EXTENSIONS

    files = [p for p in args.inputs if p.lower().endswith(CLIP_EXTENSIONS)]
    blends = [p for p in args.inputs if p.lower().endswith(".blend")]
    other = [p for p in args.inputs if p not in files and p not in blends]
    if other:
        raise CliError(f"{other[0]}: neither a clip file ({', '.join(CLIP_EXTENSIONS)}) nor a .blend file")
    if files and blends or len(blends) > 1:
        raise CliError("give clip files (BVH, FBX, glTF), or one .blend, not both")
    return files, blends


def _characters_of_blend(args, blends) -> list:
    """The armatures with clips of the .blend (or the open file), or ``--character``."""
    if blends:
        open_blend(blends[0])
    if args.fps:
        set_scene_fps(bpy.context.scene, args.fps)
    if args.character:
        return [find_armature(args.character)]
    from ..read.scene import armature_actions

    characters = [o for o in bpy.data.objects if o.type == "ARMATURE" and armature_actions(o)]
    if not characters:
        raise CliError(f"{bpy.data.filepath or 'the scene'} has no armature with clips")
    return characters


def _each_clip_file(files, fps):
    """Each clip file imported on its own into an empty scene (files of different
    skeletons are fine; each file's clips keep their names): yields (armature or None,
    {clip or file: message} of those refused) while that scene is open."""
    from ..read.clips import import_clip_files

    fps = fps or _first_fps(files)
    for path in files:
        empty_scene(fps)
        outcomes, readable = _readable([path])
        ob = None
        if readable:
            done = import_clip_files(readable)
            ob, outcomes = done.armature, done.outcomes
        yield ob, {o.take or os.path.basename(o.path): o.error for o in outcomes if o.error}


def _readable(paths) -> tuple[list, list]:
    """(outcomes refusing the paths that are no readable file, the others)."""
    from ..read.clips import ClipOutcome

    refused, readable = [], []
    for path in paths:
        try:
            readable.append(check_input(path, "clip file"))
        except CliError as ex:
            refused.append(ClipOutcome(os.path.abspath(path), error=str(ex)))
    return refused, readable


def _first_fps(paths) -> float | None:
    """The frame rate of the first of ``paths`` that can be read, or None."""
    from ..read.clips import clip_fps

    for path in paths:
        try:
            return clip_fps(check_input(path, "clip file"))
        except FootstepError:
            continue
    return None


# -- the verbs ----------------------------------------------------------------------

def _import_clips(args) -> int:
    from ..read.clips import ClipImport, import_clip_files

    with Outputs(args.clips + [args.blend or bpy.data.filepath]) as outs:
        out = claim_blend(outs, args.out, "--out library")
        if args.blend:
            open_blend(args.blend)
        elif bpy.data.filepath == "" and not args.into:
            empty_scene(args.fps or _first_fps(args.clips))
        if args.fps and args.blend:
            set_scene_fps(bpy.context.scene, args.fps)
        target = find_armature(args.into) if args.into else None
        unreadable, readable = _readable(args.clips)
        done = (import_clip_files(readable, target=target, name=args.name, scale=args.scale) if readable
                else ClipImport(target))
        order = {os.path.abspath(p): i for i, p in reversed(list(enumerate(args.clips)))}
        done.outcomes = sorted(unreadable + done.outcomes, key=lambda o: order.get(o.path, len(order)))
        for o in done.refused:
            print(f"footstep: error: {o.error}", file=sys.stderr)
        for line in done.report():
            say(line)
        if not done.actions:
            return 2  # (nothing imported: nothing written)
        ob = done.armature
        if not ob.animation_data:
            ob.animation_data_create()
        if ob.animation_data.action is None:
            ob.animation_data.action = done.actions[0]
            ob.animation_data.action_slot = done.actions[0].slots[0]
        outs.stage(out, blend_writer(out))
        outs.commit()
    say(f"saved {out}")
    return min(100, len(done.refused))


def _analyze(args) -> int:
    settings = settings_from_args(args.set)
    with Outputs(args.inputs + [bpy.data.filepath]) as outs:
        if args.plot:
            outs.claim(os.path.join(args.plot, ".footstep-plots"), "--plot folder")
        files, blends = _clip_files_or_blend(args)
        characters = (_each_clip_file(files, args.fps) if files
                      else ((ob, {}) for ob in _characters_of_blend(args, blends)))
        names: set[str] = set()  # (every clip's, whatever --clip selects)
        out = [_analyze_one(args, settings, outs, ob, refused, names) for ob, refused in characters]
        outs.commit()
    failed = [msg for *_, errors in out for msg in errors.values()] + _clips_not_found(args, names)
    _print_analyses(args, out, failed, bool(files))
    for msg in failed:
        print(f"footstep: error: {msg}", file=sys.stderr)
    if files and all(name is None for name, *_ in out):
        return 2  # (no clip file could be read)
    return min(100, len(failed))


def _analyze_one(args, settings, outs: Outputs, ob, refused: dict, names: set) -> tuple:
    """(armature's name, analyses, library, {clip: reason refused}) of one character
    (None: a clip file refused as a whole), only the ``--clip`` clips; every clip's name
    is added to ``names``."""
    from ..read.character import analyze_character, library_for

    wanted = lambda name: not args.clip or name in args.clip  # noqa: E731
    if ob is None:  # (a file refused as a whole: its clips' names are unknown, its message stands)
        return None, [], None, dict(refused)
    errors = {n: m for n, m in refused.items() if wanted(n)}
    result = analyze_character(ob, settings)
    names.update(refused, (a.name for a in result.analyses), result.errors)
    analyses = [a for a in result.analyses if wanted(a.name)]
    errors.update((n, m) for n, m in result.errors.items() if wanted(n))
    if args.plot:
        _plot_clips(outs, analyses, args.plot)
    return ob.name, analyses, library_for(ob, result) if analyses else None, errors


def _clips_not_found(args, names: set) -> list[str]:
    """A message for each ``--clip`` name that is none of the clips' ``names`` (else
    ``analyze --clip walk`` on files whose clip is named otherwise said nothing, exit 2)."""
    known = ", ".join(sorted(names))
    return [f"--clip {name!r}: no clip of that name" + (f" (the clips: {known})" if known else "")
            for name in dict.fromkeys(args.clip or ()) if name not in names]


def _plot_clips(outs: Outputs, analyses, folder: str) -> None:
    from ...core.report.plots import plot_clip

    scratch = outs.scratch(folder)
    for a in analyses:
        made = plot_clip(a, os.path.join(scratch, f"{a.name}.png"))
        outs.adopt(made, os.path.join(folder, os.path.basename(made)))


def _print_analyses(args, out, failed, from_files) -> None:
    """The table (or JSON) of every clip: each analysed one's figures, each refused one
    with its reason (``"error"``)."""
    def rows(analyses, errors):
        return [{**a.to_dict(), "error": None} for a in analyses] + [
            {"name": n, "error": m} for n, m in errors.items()]

    if args.json:
        doc = {"characters": [
            {"armature": name, "clips": rows(analyses, errors),
             "library": lib.to_dict() if lib else None} for name, analyses, lib, errors in out if name is not None],
            "errors": failed}
        if from_files:  # clip files: one object per clip, flat, in file order
            doc = {"clips": [r for _, analyses, _, errors in out for r in rows(analyses, errors)], "errors": failed}
        say(json.dumps(doc, indent=1))
    elif from_files:
        say(format_table("clip files", [a for _, analyses, _, _ in out for a in analyses],
                         [(n, m) for *_, errors in out for n, m in errors.items()]))
    else:
        for name, analyses, lib, errors in out:
            say(format_table(name, analyses, list(errors.items())))
            if lib is not None:
                say(format_library(lib))
