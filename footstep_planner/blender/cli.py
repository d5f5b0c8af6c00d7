"""The command line: ``python -m footstep_planner VERB ...`` and, inside Blender,
``blender -b [FILE.blend] -c footstep VERB ...``. One function, ``cli_main``, serves both.

Expected problems (a bad file, a rig without legs, a clip with no footsteps) print one
line ``footstep: error: ...`` naming what is at fault and return a non-zero status; they
never show a traceback and never save anything.

This module holds the verbs only: the argument parser and one function per verb. The
tables they print are in ``core/tables.py``, the demo's pictures in ``review.py``.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys

import bpy
import numpy as np

from ..core.errors import FootstepError
from ..core.report import plan_report
from ..core.settings import Settings
from ..core.tables import format_bake, format_demo_plan, format_library, format_plan, format_table
from .scene import scene_fps

EXPECTED = (FootstepError, OSError)
FOOT = ("L", "R")


class CliError(FootstepError):
    """An expected problem: its message is printed without a traceback."""


# -- the parser ---------------------------------------------------------------------

def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="footstep",
        description="Footstep Planner: clip import and analysis, planning, baking and plots from the "
                    "command line.")
    sub = p.add_subparsers(dest="verb", metavar="VERB")
    sub.required = True
    for add in (_add_import_clips, _add_analyze, _add_plan, _add_bake, _add_plot, _add_demo):
        add(sub)
    return p


def _set_option(p: argparse.ArgumentParser) -> None:
    p.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                   help="change a setting, e.g. --set contact_height=0.06 (repeatable)")


def _scene_options(character_required: bool) -> argparse.ArgumentParser:
    """The options plan and bake share (a parent parser): the scene, the character, where
    to go from where, the tags, the settings."""
    p = argparse.ArgumentParser(add_help=False)
    p.add_argument("blend", nargs="?", metavar="SCENE.blend",
                   help="the scene (default: the file Blender has open)")
    p.add_argument("--character", required=character_required, metavar="ARMATURE")
    p.add_argument("--goal", metavar="OBJECT", help="walk to this object (default: the 3D cursor)")
    p.add_argument("--goal-heading", type=float, metavar="DEG",
                   help="arrive facing this way: the Z rotation in degrees of an empty facing that "
                        "way (empties face their -Y axis: 0 faces -Y, 90 faces +X); default: the "
                        "goal empty's own")
    p.add_argument("--start", metavar="OBJECT",
                   help="start standing at this object instead of where the feet are now")
    p.add_argument("--traversable", default="", metavar="NAME,...", help="tag these objects traversable for this run")
    p.add_argument("--obstacles", default="", metavar="NAME,...", help="tag these objects obstacles for this run")
    _set_option(p)
    return p


def _add_import_clips(sub) -> None:
    p = sub.add_parser(
        "import-clips", help="import BVH or FBX files as Actions of one armature and save a .blend",
        description="Import several BVH or FBX files (Mixamo downloads too; a mix is fine) of one "
                    "skeleton as one armature carrying one Action per file, in metres, Z up, with "
                    "an identity object transform, keyed at the scene's frame rate whatever the "
                    "files' rate. With --blend/--into, the clips are added to an existing "
                    "armature; nothing of the file's is replaced.")
    p.set_defaults(run=_import_clips)
    p.add_argument("clips", nargs="+", metavar="CLIP.bvh|CLIP.fbx")
    p.add_argument("--out", required=True, metavar="LIB.blend", help="file to save")
    p.add_argument("--blend", metavar="IN.blend", help="start from this file (default: the "
                   "file Blender has open, or an empty scene)")
    p.add_argument("--into", metavar="ARMATURE", help="add the clips to this armature")
    p.add_argument("--name", help="name of a new armature (default: the first file's name)")
    p.add_argument("--fps", type=float, help="scene frame rate to key at (default: the "
                   "scene's; an empty scene takes the first file's rate)")
    p.add_argument("--scale", type=float, help="metres per BVH unit (default: guessed; FBX "
                   "files carry their unit)")


def _add_analyze(sub) -> None:
    p = sub.add_parser(
        "analyze", help="analyse clips: contacts, footprints, speed, stride, cycle, tau, gait",
        description="Analyse BVH files, or the clips of the characters in a .blend, after "
                    "Johansen's method. Prints a table, or with --json one object per clip.")
    p.set_defaults(run=_analyze)
    p.add_argument("inputs", nargs="*", metavar="CLIP.bvh|LIB.blend",
                   help="BVH files, or one .blend (default: the file Blender has open)")
    p.add_argument("--character", metavar="ARMATURE", help="only this armature's clips")
    p.add_argument("--clip", action="append", metavar="NAME", help="only these clips (repeatable)")
    p.add_argument("--fps", type=float, help="sample the clips at this rate (default: the "
                   "scene's; for BVH input, the first file's rate)")
    p.add_argument("--json", action="store_true", help="print JSON")
    p.add_argument("--plot", metavar="DIR", help="also draw each clip's foot curves and "
                   "contacts as PNG into DIR (needs matplotlib)")
    _set_option(p)


def _add_plan(sub) -> None:
    p = sub.add_parser(
        "plan", parents=[_scene_options(character_required=True)],
        help="plan a footstep path for a character to a goal",
        description="Plan the footprints that take a character to a goal across the scene's "
                    "traversable meshes (A* over footprints, jumping gaps where a jump clip can).")
    p.set_defaults(run=_plan)
    p.add_argument("--json", action="store_true", help="print JSON: the footprints, the search, "
                   "and the synthesis (per frame: body, clip weights and times, tau and s curves)")
    p.add_argument("--report", metavar="REPORT.json", help="also write that JSON to this file")


def _add_bake(sub) -> None:
    p = sub.add_parser(
        "bake", parents=[_scene_options(character_required=False)],
        help="plan, synthesize, IK and bake a character's walk to a goal into NLA",
        description="Plan the footprints to the goal, synthesize the motion, put the feet on "
                    "the footprints (IK) and bake it as a new Action in an NLA track of the "
                    "planner's own on the character, starting at the scene's current frame (or "
                    "--frame-start). Writes the report (plan, stage times, quality measured on "
                    "the baked armature). Several characters and goals: --job JOBS.json, a list "
                    "of {\"character\", \"goal\", \"start\", \"name\", \"frame_start\", "
                    "\"report\", \"goal_heading\", \"body_on\", \"settings\": {NAME: value}}, all checked "
                    "before the first runs; they run one after another, a failing job does not stop the "
                    "others, and the exit status is 1 when any failed.")
    p.set_defaults(run=_bake)
    p.add_argument("--name", help="name of the bake (track and action; default: character to goal)")
    p.add_argument("--frame-start", type=int, metavar="FRAME")
    p.add_argument("--markers", action="store_true", help="add a timeline marker at each footstep")
    p.add_argument("--body-on", choices=("object", "root"), default="object",
                   help="key the body on the armature object (default) or on the rig's root bone")
    p.add_argument("--keep-frame-range", action="store_true",
                   help="leave the scene's frame range as it is (by default it grows to cover the bake)")
    p.add_argument("--job", metavar="JOBS.json", help="several jobs, run one after another")
    p.add_argument("--out", metavar="OUT.blend", help="save the baked scene here")
    p.add_argument("--report", metavar="REPORT.json", help="write the report here (with --job: "
                   "REPORT_<n>.json per job unless the job names its own)")


def _add_plot(sub) -> None:
    p = sub.add_parser(
        "plot", help="draw a plan report's curves (tau, s) and footprints as PNG",
        description="Draw the synthesis of a plan report (from plan --json or --report) like "
                    "the thesis's figures 4.3 to 4.5: the curvature tau (the plan's clips, the "
                    "estimate from the body trajectory, the low-passed blend parameter), the "
                    "walk/run parameter s, and a top view of the footprints and the body.")
    p.set_defaults(run=_plot)
    p.add_argument("report", metavar="REPORT.json")
    p.add_argument("--out", required=True, metavar="DIR", help="folder for the PNG files")
    p.add_argument("--name", help="file name prefix (default: the report's file name)")


def _add_demo(sub) -> None:
    p = sub.add_parser(
        "demo", help="the whole tool on built-in content: a sample scene, the sample character "
                     "and its generated clips, planned, baked, rendered and reported")
    p.set_defaults(run=_demo)
    p.add_argument("--scene", default="jumps", help="sample scene: jumps, turns or obstacles")
    p.add_argument("--out", default="footstep_demo", metavar="DIR",
                   help="output folder (default: footstep_demo in the current folder)")


def cli_main(argv=None) -> int:
    """Entry point shared by ``python -m footstep_planner`` and ``blender -c footstep``."""
    argv = list(sys.argv[1:] if argv is None else argv)
    try:
        args = _parser().parse_args(argv)
    except SystemExit as ex:  # --help or a usage error: argparse already printed
        return int(ex.code or 0)
    try:
        return args.run(args)
    except EXPECTED as ex:
        print(f"footstep: error: {ex}", file=sys.stderr)
        return 2


# -- helpers the verbs share --------------------------------------------------------

def settings_from_args(pairs) -> Settings:
    """The Settings of ``--set NAME=VALUE`` options, each converted and range-checked by
    the setting's own declaration (a SettingsError names the setting)."""
    return Settings.from_pairs(pairs)


def open_blend(path: str) -> None:
    if not os.path.isfile(path):
        raise CliError(f"{path}: no such file")
    try:
        bpy.ops.wm.open_mainfile(filepath=os.path.abspath(path), load_ui=False)
    except RuntimeError as ex:
        raise CliError(f"{path}: cannot open: {str(ex).strip()}") from None


def empty_scene(fps: float | None) -> None:
    bpy.ops.wm.read_homefile(use_empty=True)
    if fps:
        set_scene_fps(bpy.context.scene, fps)


def set_scene_fps(scene, fps: float) -> None:
    scene.render.fps = max(1, int(round(fps)))
    scene.render.fps_base = scene.render.fps / fps


def find_armature(name: str):
    ob = bpy.data.objects.get(name)
    if ob is None:
        raise CliError(f"no object named {name!r} in {bpy.data.filepath or 'the scene'}")
    if ob.type != "ARMATURE":
        raise CliError(f"object {name!r} is a {ob.type.lower()}, not an armature")
    return ob


def _names(csv: str) -> list[str]:
    return [n.strip() for n in csv.split(",") if n.strip()]


def _goal_and_start(scene, goal: str | None, heading_deg, start: str | None):
    """(goal position, goal heading (a Z rotation, rad) or None, start object or None)
    from the names given to plan and bake (``heading_deg``, when given, overrides the goal
    empty's own heading)."""
    from . import planning

    position, heading = planning.goal_of(scene, goal)
    if heading_deg is not None:
        heading = math.radians(float(heading_deg))
    marker = None
    if start:
        marker = scene.objects.get(start)
        if marker is None:
            raise CliError(f"no object named {start!r} to start at")
    return position, heading, marker


def _characters_to_analyze(args) -> tuple[list, bool]:
    """The armatures ``analyze`` works on, and whether they came from clip files: one per
    BVH or FBX file (imported into an empty scene), or those of a .blend (or the open
    file)."""
    from .clips import CLIP_EXTENSIONS, clip_fps, import_clips

    files = [p for p in args.inputs if p.lower().endswith(CLIP_EXTENSIONS)]
    blends = [p for p in args.inputs if p.lower().endswith(".blend")]
    other = [p for p in args.inputs if p not in files and p not in blends]
    if other:
        raise CliError(f"{other[0]}: neither a .bvh, an .fbx nor a .blend file")
    if files and blends or len(blends) > 1:
        raise CliError("give BVH or FBX files, or one .blend, not both")
    if files:
        empty_scene(args.fps or clip_fps(files[0]))
        # one armature per file: files of different skeletons are fine
        return [import_clips([path])[0] for path in files], True
    if blends:
        open_blend(blends[0])
    if args.fps:
        set_scene_fps(bpy.context.scene, args.fps)
    if args.character:
        return [find_armature(args.character)], False
    from .scene import armature_actions

    characters = [o for o in bpy.data.objects if o.type == "ARMATURE" and armature_actions(o)]
    if not characters:
        raise CliError(f"{bpy.data.filepath or 'the scene'} has no armature with clips")
    return characters, False


#: the fields of a bake job (JOBS.json) and what each must be; all may be missing or
#: null but the character
_JOB_FIELDS = {"character": "an armature's name", "goal": "text", "start": "text", "name": "text", "report": "text",
               "frame_start": "a whole number", "goal_heading": "a number", "body_on": '"object" or "root"',
               "settings": "an object of settings (NAME: value)"}


def _job_field_ok(field: str, value) -> bool:
    kind = _JOB_FIELDS[field]
    number = isinstance(value, (int, float)) and not isinstance(value, bool)
    if value is None:
        return field != "character"
    if field == "character":
        return isinstance(value, str) and value != ""
    if kind == "text":
        return isinstance(value, str)
    if kind == "a number":
        return number
    if kind == "a whole number":
        return number and float(value).is_integer()
    if field == "settings":
        return isinstance(value, dict)
    return isinstance(value, str) and value.lower() in ("object", "root")


def _read_jobs(path: str) -> list[dict]:
    """The jobs of a JOBS.json, checked: a list of objects, each with a character and
    its other fields of the right kind. Names the job (number and name) and the field."""
    try:
        with open(path) as fh:
            jobs = json.load(fh)
    except (OSError, ValueError) as ex:
        raise CliError(f"cannot read the job list {path!r}: it must be a JSON list of objects ({ex})") from None
    if not isinstance(jobs, list):
        raise CliError(f"cannot read the job list {path!r}: it must be a JSON list of objects "
                       f"(not a list but {type(jobs).__name__})")
    for n, job in enumerate(jobs, 1):
        if not isinstance(job, dict):
            raise CliError(f"job list {path!r}: job {n} is not an object but {json.dumps(job)[:40]}")
        for field in _JOB_FIELDS:
            if not _job_field_ok(field, job.get(field)):
                name = f" {job['name']!r}" if isinstance(job.get("name"), str) else ""
                got = "it is missing" if job.get(field) is None else f"got {json.dumps(job[field])[:40]}"
                raise CliError(f"job list {path!r}: job {n}{name} ({job.get('character') or '?'} to "
                               f"{job.get('goal') or 'the 3D cursor'}): {field!r} must be "
                               f"{_JOB_FIELDS[field]}; {got}")
        try:
            job["settings"] = {k: Settings.coerce(k, v) for k, v in (job.get("settings") or {}).items()}
        except FootstepError as ex:
            raise CliError(f"job list {path!r}: job {n} ({job.get('character')}): {ex}") from None
    return jobs


# -- the verbs ----------------------------------------------------------------------

def _import_clips(args) -> int:
    from .clips import clip_fps, import_clips

    if args.blend:
        open_blend(args.blend)
    elif bpy.data.filepath == "" and not args.into:
        empty_scene(args.fps or clip_fps(args.clips[0]))
    if args.fps and args.blend:
        set_scene_fps(bpy.context.scene, args.fps)
    target = find_armature(args.into) if args.into else None
    ob, actions = import_clips(args.clips, target=target, name=args.name, scale=args.scale)
    if not ob.animation_data:
        ob.animation_data_create()
    if ob.animation_data.action is None and actions:
        ob.animation_data.action = actions[0]
    out = os.path.abspath(args.out)
    os.makedirs(os.path.dirname(out), exist_ok=True)
    bpy.ops.wm.save_as_mainfile(filepath=out, compress=True)
    print(f"imported {len(actions)} clip(s) into armature {ob.name!r}: "
          + ", ".join(a.name for a in actions))
    print(f"saved {out}")
    return 0


def _analyze(args) -> int:
    from .character import analyze_character, library_for

    settings = settings_from_args(args.set)
    characters, from_bvh = _characters_to_analyze(args)
    out, failed = [], []
    for ob in characters:
        result = analyze_character(ob, settings)
        analyses = [a for a in result.analyses if not args.clip or a.name in args.clip]
        failed += [msg for name, msg in result.errors.items() if not args.clip or name in args.clip]
        out.append((ob, analyses, library_for(ob, result) if analyses else None))
        if args.plot:
            from ..core.plots import plot_clip

            os.makedirs(args.plot, exist_ok=True)
            for a in analyses:
                plot_clip(a, os.path.join(args.plot, f"{a.name}.png"))

    if args.json:
        doc = {"characters": [
            {"armature": ob.name, "clips": [a.to_dict() for a in analyses],
             "library": lib.to_dict() if lib else None} for ob, analyses, lib in out],
            "errors": failed}
        if from_bvh:  # BVH input: one object per clip, flat
            doc = {"clips": [d for c in doc["characters"] for d in c["clips"]], "errors": failed}
        print(json.dumps(doc, indent=1))
    elif from_bvh:
        print(format_table("clip files", [a for _, analyses, _ in out for a in analyses]))
    else:
        for ob, analyses, lib in out:
            print(format_table(ob.name, analyses))
            if lib is not None:
                print(format_library(lib))
    for msg in failed:
        print(f"footstep: error: {msg}", file=sys.stderr)
    return 1 if failed else 0


def _plan(args) -> int:
    from . import planning

    if args.blend:
        open_blend(args.blend)
    scene = bpy.context.scene
    ob = find_armature(args.character)
    goal, heading, start = _goal_and_start(scene, args.goal, args.goal_heading, args.start)
    settings = settings_from_args(args.set)
    planned = planning.plan_and_synthesize(scene, ob, goal, heading, start, settings,
                                           _names(args.traversable), _names(args.obstacles))
    result, syn = planned.result, planned.synthesis
    doc = plan_report(result, syn, ob.name, goal, scene.frame_current)
    if args.report:
        with open(args.report, "w") as fh:
            json.dump(doc, fh)
    if args.json:
        print(json.dumps(doc))
    else:
        print(format_plan(ob.name, goal, result, syn, scene.frame_current, scene_fps(scene),
                          doc["stages"]))
    return 0


def _bake(args) -> int:
    from . import planning

    if args.blend:
        open_blend(args.blend)
    scene = bpy.context.scene
    settings = settings_from_args(args.set)
    if args.job:
        jobs = _read_jobs(args.job)
    elif not args.character:
        raise CliError("bake needs --character (or --job JOBS.json)")
    else:
        jobs = [{"character": args.character, "goal": args.goal, "start": args.start, "name": args.name,
                 "frame_start": args.frame_start, "report": args.report, "goal_heading": args.goal_heading}]
    failed = 0
    for n, job in enumerate(jobs):
        try:
            ob = find_armature(job.get("character"))
            goal, heading, start = _goal_and_start(scene, job.get("goal"), job.get("goal_heading"),
                                                   job.get("start"))
            doc = planning.run(scene, ob, goal, heading, start, settings.replace(**job.get("settings", {})),
                               _names(args.traversable),
                               _names(args.obstacles), name=job.get("name"), frame_start=job.get("frame_start"),
                               markers=args.markers, body_on=str(job.get("body_on") or args.body_on).upper(),
                               frame_range=not args.keep_frame_range)
        except EXPECTED as ex:
            failed += 1
            print(f"footstep: error: job {n + 1} ({job.get('character')} to "
                  f"{job.get('goal') or 'the 3D cursor'}): {ex}", file=sys.stderr)
            continue
        report = job.get("report") or (args.report if len(jobs) == 1 else (
            f"{os.path.splitext(args.report)[0]}_{n + 1}.json" if args.report else None))
        if report:
            with open(report, "w") as fh:
                json.dump(doc, fh)
        print(format_bake(doc))
    if args.out:
        bpy.ops.wm.save_as_mainfile(filepath=os.path.abspath(args.out), compress=True)
        print(f"saved {args.out}")
    return 1 if failed else 0


def _plot(args) -> int:
    from ..core.plots import plot_synthesis

    try:
        with open(args.report) as fh:
            doc = json.load(fh)
    except (OSError, ValueError) as ex:
        raise CliError(f"cannot read the plan report {args.report!r}: {ex}") from None
    if "synthesis" not in doc:
        raise CliError(f"{args.report!r} is not a plan report (no \"synthesis\" section): make it "
                       "with: footstep plan ... --report REPORT.json")
    name = args.name or os.path.splitext(os.path.basename(args.report))[0]
    for path in plot_synthesis(doc, args.out, name):
        print(path)
    return 0


def _demo(args) -> int:
    """The whole tool on built-in content: a sample scene, the sample character and its
    generated clips; plan, bake, review sheet, report."""
    import time

    from . import mannequin, planning
    from .character import read_library
    from .review import plot_curves, review_sheet
    from .sample_scenes import SCENES, build

    t0 = time.perf_counter()
    out_dir = os.path.abspath(args.out)
    name = args.scene.lower()
    if name not in SCENES:
        raise CliError(f"no sample scene {args.scene!r}; choose from {', '.join(SCENES)}")
    os.makedirs(out_dir, exist_ok=True)
    scene = build(name)
    set_scene_fps(scene, 30)
    ob, clips = mannequin.add_to_scene(scene, "Start")
    lib = read_library(ob)  # (as add_to_scene proposed and stored it)
    print(f"demo: the {scene.name} scene, the Footstep Mannequin and its {len(clips.analyses)} generated clips "
          f"({time.perf_counter() - t0:.1f} s)")
    print(format_table(ob.name, clips.analyses))
    print(format_library(lib))
    for msg in clips.errors.values():
        print(f"footstep: error: {msg}", file=sys.stderr)

    t1 = time.perf_counter()
    goal, heading, start = _goal_and_start(scene, "Goal", None, "Start")
    doc = planning.run(scene, ob, goal, heading, start, name=f"{name} demo", frame_start=1)
    scene.frame_start, scene.frame_end = doc["frame_start"], doc["frame_end"]
    print("\n" + format_demo_plan(doc, 30, time.perf_counter() - t1))
    print(format_bake(doc))
    doc["clips"] = [a.to_dict() for a in clips.analyses]
    report = os.path.join(out_dir, f"{name}_report.json")
    with open(report, "w") as fh:
        json.dump(doc, fh)
    pngs = plot_curves(doc, out_dir, name)
    sheet, shots = review_sheet(scene, ob, doc, out_dir, name, planning.foot_shape(clips.analyses))
    bpath = os.path.join(out_dir, f"{name}_baked.blend")
    scene.frame_set(doc["frame_start"])
    bpy.ops.wm.save_as_mainfile(filepath=bpath, compress=True)
    print(f"\nbaked scene: {bpath}\nreview sheet: {sheet}\n  frames: {', '.join(shots)}\n"
          f"report: {report}" + (f"\ncurves: {', '.join(pngs)}" if pngs else "") +
          f"\ndemo done in {time.perf_counter() - t0:.1f} s")
    return 1 if clips.errors else 0


_HANDLE = None


def register():
    global _HANDLE
    _HANDLE = bpy.utils.register_cli_command("footstep", lambda argv: cli_main(argv))


def unregister():
    global _HANDLE
    if _HANDLE is not None:
        bpy.utils.unregister_cli_command(_HANDLE)
        _HANDLE = None
