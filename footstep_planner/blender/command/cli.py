"""The command line: ``python -m footstep_planner VERB ...`` and, inside Blender,
``blender -b [FILE.blend] -c footstep VERB ...``. One function, ``cli_main``, serves both.

Expected problems (a bad file, a rig without legs, a clip with no footsteps, a folder
that can't be written, Ctrl-C) print one line ``footstep: error: ...`` naming what is at
fault and return a non-zero status; they never show a traceback and never write anything.
``import-clips`` and ``analyze`` go on past a file or clip they refuse: each is named on
its own line, the others are imported (and saved) or analysed, and the exit status is the
number refused.
Every file a verb writes goes through ``core.base.files.Outputs``: claimed before any work
(an output that is an input is refused), written beside its destination, renamed into
place when the verb has succeeded. Stdout carries the verb's results only
(``console.say``); Blender's own log lines and progress go to stderr.

This module holds the argument parser and the plan, bake, plot and demo verbs; the clip
verbs (import-clips, analyze) are in ``clip_verbs.py``, the files and scenes they share in
``blend_io.py``. The tables they print are in ``core/report/tables.py``, the demo's pictures in ``review.py``, the
job lists in ``core/jobs.py`` and ``batch.py``.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import traceback

import bpy
import numpy as np

from ...core.base.errors import FootstepError
from ...core.base.files import Outputs, describe_os_error
from ...core.perform.run import waypoint_rows
from ...core.plan.setup import foot_shape
from ...core.jobs import MAX_FRAME, JobOutcome, exit_status, is_text, read_jobs, summary_table
from ...core.report.document import plan_report
from ...core.base.settings import Settings
from ...core.report.tables import format_bake, format_demo_plan, format_library, format_plan, format_table, format_waypoints
from . import batch
from .batch import BUG_LINE
from .console import Progress, results_on_stdout, say
from ..read.scene import scene_fps
from .blend_io import (CliError, blend_writer, claim_blend, csv_names, find_armature, open_blend, pick_scene,
                       read_text, set_scene_fps, settings_from_args)
from .clip_verbs import _analyze, _import_clips



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


def _typed(convert, what: str, ok, why: str):
    """An argparse type: ``convert(text)``, which must be ``what`` and pass ``ok``."""
    def parse(text: str):
        try:
            value = convert(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"not {what}: {text!r}") from None
        if not ok(value):
            raise argparse.ArgumentTypeError(f"{why}: {text!r}")
        return value
    return parse


_finite = _typed(float, "a number", math.isfinite, "not a finite number")
_text = _typed(str, "text", is_text, "not valid text (undecodable bytes?)")
_positive = _typed(float, "a number", lambda v: math.isfinite(v) and v > 0, "must be a finite number above 0")
#: metres per file unit a clip may be read at: beyond, a skeleton's bones are shorter than a
#: micrometre or longer than a kilometre, and single-precision keys lose them
SCALE_RANGE = (1e-6, 1e6)
_scale = _typed(float, "a number", lambda v: math.isfinite(v) and SCALE_RANGE[0] <= v <= SCALE_RANGE[1],
                f"must be between {SCALE_RANGE[0]:g} and {SCALE_RANGE[1]:g} metres per unit")
_frame = _typed(int, "a whole frame number", lambda v: abs(v) <= MAX_FRAME,
                f"beyond Blender's timeline (±{MAX_FRAME})")


def _set_option(p: argparse.ArgumentParser) -> None:
    p.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                   help="change a setting, e.g. --set contact_height=0.06 (repeatable)")


def _scene_options(character_required: bool) -> argparse.ArgumentParser:
    """The options plan and bake share (a parent parser): the scene, the character, where
    to go from where, the tags, the settings."""
    p = argparse.ArgumentParser(add_help=False)
    p.add_argument("blend", nargs="?", metavar="SCENE.blend",
                   help="the scene (default: the file Blender has open)")
    p.add_argument("--scene", type=_text, metavar="NAME", help="the scene of the file to work in "
                   "(default: the file's active scene)")
    p.add_argument("--character", type=_text, required=character_required, metavar="ARMATURE")
    p.add_argument("--goal", type=_text, metavar="OBJECT", help="walk to this object (default: the 3D cursor)")
    p.add_argument("--goal-heading", type=_finite, metavar="DEG",
                   help="arrive facing this way: the Z rotation in degrees of an empty facing that "
                        "way (empties face their -Y axis: 0 faces -Y, 90 faces +X); default: the "
                        "goal empty's own")
    p.add_argument("--start", type=_text, metavar="OBJECT",
                   help="start standing at this object instead of where the feet are now")
    p.add_argument("--via", type=_text, default="", metavar="NAME,...",
                   help="pass through these objects in order on the way to the goal (an empty you "
                        "turned: facing its way; else facing the next; a curve object: each of its points)")
    p.add_argument("--arrive", type=_text, default="", metavar="NAME=FRAME,...",
                   help="arrive at these waypoints (or the goal) on these scene frames: the walk's pace "
                        "is chosen (see the pace_min and pace_max settings) and, when early, the "
                        "character waits standing at the stop before")
    p.add_argument("--pause", type=_text, default="", metavar="NAME=SECONDS,...",
                   help="stop and stand this long at these waypoints")
    p.add_argument("--traversable", type=_text, default="", metavar="NAME,...", help="tag these objects traversable for this run")
    p.add_argument("--obstacles", type=_text, default="", metavar="NAME,...", help="tag these objects obstacles for this run")
    _set_option(p)
    return p


def _add_import_clips(sub) -> None:
    p = sub.add_parser(
        "import-clips", help="import BVH, FBX or glTF files as Actions of one armature and save a .blend",
        description="Import BVH, FBX, glTF and GLB files (Mixamo downloads too; a mix is fine) of one "
                    "skeleton as one armature carrying one Action per clip, in metres, Z up, with "
                    "an identity object transform, keyed at the scene's frame rate whatever the "
                    "files' rate. A file of several clips (an FBX's takes, a glTF's animations) gives "
                    "one Action per clip, named after it. Where a clip moves the armature object "
                    "itself, that motion is moved onto the hips (the report says so). With "
                    "--blend/--into, the clips are added to an existing armature; nothing of the "
                    "file's is replaced. Every file and clip that can be imported is; each refused "
                    "one is named with its reason on stderr, and the exit status is the number "
                    "refused (0 when all were imported; 2 when none was, and nothing is saved).")
    p.set_defaults(run=_import_clips)
    p.add_argument("clips", nargs="+", metavar="CLIP.bvh|.fbx|.glb|.gltf")
    p.add_argument("--out", required=True, metavar="LIB.blend", help="file to save")
    p.add_argument("--blend", metavar="IN.blend", help="start from this file (default: the "
                   "file Blender has open, or an empty scene)")
    p.add_argument("--into", type=_text, metavar="ARMATURE", help="add the clips to this armature")
    p.add_argument("--name", type=_text, help="name of a new armature (default: the first file's name)")
    p.add_argument("--fps", type=_positive, help="scene frame rate to key at (default: the "
                   "scene's; an empty scene takes the first file's rate)")
    p.add_argument("--scale", type=_scale, help="metres per BVH unit (default: guessed; FBX "
                   "and glTF files carry their unit)")


def _add_analyze(sub) -> None:
    p = sub.add_parser(
        "analyze", help="analyse clips: contacts, footprints, speed, stride, cycle, tau, gait",
        description="Analyse clip files (BVH, FBX, glTF, GLB), or the clips of the characters in a "
                    ".blend, after Johansen's method. Prints a table, or with --json one object per "
                    "clip: a row for every clip, a clip that cannot be read or analysed with its "
                    "reason (its \"error\"). The exit status is the number of clips refused (2 when "
                    "no clip file could be read at all).")
    p.set_defaults(run=_analyze)
    p.add_argument("inputs", nargs="*", metavar="CLIP.bvh|.fbx|.glb|.gltf|LIB.blend",
                   help="clip files, or one .blend (default: the file Blender has open)")
    p.add_argument("--character", type=_text, metavar="ARMATURE", help="only this armature's clips")
    p.add_argument("--clip", action="append", metavar="NAME", help="only these clips (repeatable)")
    p.add_argument("--fps", type=_positive, help="sample the clips at this rate (default: the "
                   "scene's; for clip files, the first file's rate)")
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
    p.add_argument("--out-plan", metavar="PLAN.json", help="write the plan's footprints as data, to edit "
                   "(move, lock) and bake with: bake --plan PLAN.json")


def _add_bake(sub) -> None:
    p = sub.add_parser(
        "bake", parents=[_scene_options(character_required=False)],
        help="plan, synthesize, IK and bake a character's walk to a goal into NLA",
        description="Plan the footprints to the goal, synthesize the motion, put the feet on "
                    "the footprints (IK) and bake it as a new Action in an NLA track of the "
                    "planner's own on the character, starting at the scene's current frame (or "
                    "--frame-start). Writes the report (plan, stage times, quality measured on "
                    "the scene as it plays). Several characters and goals: --job JOBS.json, a list "
                    "of {\"character\", \"goal\", \"start\", \"name\", \"frame_start\", "
                    "\"report\", \"out\", \"goal_heading\", \"body_on\", \"via\": [NAME, ...], \"settings\": {NAME: value}}. "
                    "Every job is checked before the first runs; a job that is invalid or fails is "
                    "reported by number and name and the others still run; a summary table ends the "
                    "run and the exit status is the number of jobs that failed. Files are written "
                    "only when complete, and never over an input.")
    p.set_defaults(run=_bake)
    p.add_argument("--name", type=_text, help="name of the bake (track and action; default: character to goal)")
    p.add_argument("--frame-start", type=_frame, metavar="FRAME")
    p.add_argument("--markers", action="store_true", help="add a timeline marker at each footstep")
    p.add_argument("--body-on", choices=("object", "root"), default="object",
                   help="key the body on the armature object (default) or on the rig's root bone")
    p.add_argument("--keep-frame-range", action="store_true",
                   help="leave the scene's frame range as it is (by default it grows to cover the bake)")
    p.add_argument("--force", action="store_true",
                   help="bake over the planner's earlier bake of this name even when its keys were edited since")
    p.add_argument("--new-track", action="store_true",
                   help="bake beside the planner's earlier bake of this name, under a new name (\"NAME (2)\")")
    p.add_argument("--job", metavar="JOBS.json", help="several jobs, run one after another")
    p.add_argument("--together", action="store_true",
                   help="plan the --job list in one space and time: each job in the list's order goes "
                   "round the characters of the jobs before it (and any other the planner baked in the "
                   "scene) as they play, side-stepping or going round their bodies and never stepping "
                   "where another foot stands (--set avoid_characters=true for every job)")
    p.add_argument("--plan", metavar="PLAN.json", help="bake this plan (from plan --out-plan, maybe edited): "
                   "its locked and moved footprints are kept, the way around what changed is searched "
                   "again, and over an earlier bake of the plan only that span is re-keyed")
    p.add_argument("--ray", metavar="ADDRESS", help="run the --job list as Ray tasks, each job in a "
                   "worker process of its own on a copy of the scene: 'local' (a local instance), "
                   "'auto' (the running cluster) or a cluster's address; each job's scene is saved "
                   "to its \"out\" or OUT_<n>.blend (needs: pip install ray)")
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
    """Entry point shared by ``python -m footstep_planner`` and ``blender -c footstep``.
    Exit status: 0 done; 2 an expected problem (one line on stderr, nothing written); for
    ``bake --job``, the number of jobs that failed; for ``import-clips`` and ``analyze``,
    the number of files, takes or clips refused (2 when none could be imported: nothing
    written); 130 interrupted (nothing written); 70 a bug (its traceback, and a line
    asking to report it)."""
    argv = list(sys.argv[1:] if argv is None else argv)
    try:
        args = _parser().parse_args(argv)
    except SystemExit as ex:  # --help or a usage error: argparse already printed
        return int(ex.code or 0)
    with results_on_stdout():
        return _run_guarded(args)


def _no_empty_paths(args) -> None:
    """An empty path given for a file or folder option is a mistake, not 'none'."""
    for key in ("out", "report", "out_plan", "plan", "job", "blend", "plot", "into"):
        if getattr(args, key, None) == "":
            raise CliError(f"--{key.replace('_', '-')} is empty: give a path")


def _run_guarded(args) -> int:
    """Run a verb; every way it can fail ends in one line on stderr and a status."""
    try:
        _no_empty_paths(args)
        return args.run(args)
    except KeyboardInterrupt:
        print("\nfootstep: interrupted, nothing written", file=sys.stderr)
        return 130
    except FootstepError as ex:
        print(f"footstep: error: {ex}", file=sys.stderr)
        return 2
    except OSError as ex:
        print(f"footstep: error: {describe_os_error(ex)}", file=sys.stderr)
        return 2
    except MemoryError:
        print("footstep: error: out of memory", file=sys.stderr)
        return 2
    except Exception:
        traceback.print_exc()
        print(BUG_LINE, file=sys.stderr)
        return 70


# -- helpers the verbs share --------------------------------------------------------



def _plan(args) -> int:
    from .. import planning

    with Outputs([args.blend or bpy.data.filepath]) as outs:
        report = outs.claim(args.report, "--report") if args.report is not None else None
        out_plan = outs.claim(args.out_plan, "--out-plan") if args.out_plan is not None else None
        settings = settings_from_args(args.set)
        if args.blend:
            open_blend(args.blend)
        scene = pick_scene(args.scene)
        ob = find_armature(args.character)
        goal, heading, start = batch.goal_and_start(scene, args.goal, args.goal_heading, args.start)
        route = _via_route(scene, args, goal, heading)
        planned = planning.plan_and_synthesize(scene, ob, goal, heading, start, settings,
                                               csv_names(args.traversable), csv_names(args.obstacles), route)
        result, syn = planned.result, planned.synthesis
        doc = plan_report(result, syn, ob.name, goal, scene.frame_current)
        if planned.performance is not None:
            doc["waypoints"] = waypoint_rows(planned, scene.frame_current, scene_fps(scene))
        if report:
            outs.write_json(report, doc)
        if out_plan:
            from ..ui.directing import plan_document

            outs.write_json(out_plan, plan_document(ob, planned, goal))
        outs.commit()
    if args.json:
        say(json.dumps(doc))
    else:
        say(format_plan(ob.name, goal, result, syn, scene.frame_current, scene_fps(scene), doc["stages"]))
        if doc.get("waypoints"):
            say(format_waypoints(doc["waypoints"]))
    return 0


def _via_route(scene, args, goal, heading):
    """The route through ``--via``'s waypoints (then the goal), or None."""
    from ..ui.directing import via_route

    return via_route(scene, csv_names(args.via), args.goal or "the goal", goal, heading,
                     _pairs(args.pause, "--pause"), _pairs(args.arrive, "--arrive"))


def _pairs(csv: str, option: str) -> dict:
    """NAME=NUMBER,... as a dict; CliError naming the option and the pair at fault."""
    out = {}
    for item in csv_names(csv):
        name, eq, value = item.rpartition("=")
        try:
            number = float(value)
        except ValueError:
            number = None
        if not eq or not name.strip() or number is None or not np.isfinite(number):
            raise CliError(f"{option}: {item!r} is not NAME=NUMBER")
        out[name.strip()] = number
    return out


def _common(args, names: bool = False) -> dict:
    """The options every job of a bake shares: as ``core.jobs.job_argv`` takes them, or
    with ``names`` the object lists split as ``batch.bake_job`` takes them."""
    common = {"markers": args.markers, "keep_frame_range": args.keep_frame_range, "body_on": args.body_on,
              "force": args.force, "new_track": args.new_track,
              "traversable": args.traversable, "obstacles": args.obstacles, "set": list(args.set)}
    if names:
        common["traversable"], common["obstacles"] = csv_names(args.traversable), csv_names(args.obstacles)
    return common


def _bake(args) -> int:
    if args.ray and not args.job:
        raise CliError("--ray runs a job list: give --job JOBS.json")
    if args.together and not args.job:
        raise CliError("--together plans a job list in one space and time: give --job JOBS.json "
                       "(one bake goes round the characters already baked with --set avoid_characters=true)")
    if args.together and args.ray:
        raise CliError("--together plans each job around the ones before it, in one scene: it runs "
                       "here, not on Ray (leave out --ray)")
    if args.plan and args.job:
        raise CliError("--plan bakes one plan: give it without --job")
    if not args.job and not args.character and not args.plan:
        raise CliError("bake needs --character (or --job JOBS.json, or --plan PLAN.json)")
    with Outputs([args.blend or bpy.data.filepath, args.job, args.plan]) as outs:
        out = claim_blend(outs, args.out, "--out scene")
        plan = _read_plan(args.plan) if args.plan else None
        raw = read_jobs(read_text(args.job, "job list"), args.job) if args.job else None
        settings = settings_from_args(args.set)
        if args.blend:
            open_blend(args.blend)
        pick_scene(args.scene)
        if raw is not None:
            return _bake_jobs(args, raw, settings, outs, out)
        report = outs.claim(args.report, "--report") if args.report is not None else None
        job = {"character": args.character or (plan.character if plan else None), "goal": args.goal,
               "start": args.start, "name": args.name, "frame_start": args.frame_start,
               "goal_heading": args.goal_heading, "body_on": args.body_on, "via": csv_names(args.via),
               "pause": _pairs(args.pause, "--pause"), "arrive": _pairs(args.arrive, "--arrive")}
        problems = batch.scene_problems(bpy.context.scene, job)
        if problems:
            raise CliError(problems[0])
        doc = batch.bake_job(bpy.context.scene, job, _common(args, names=True), settings, plan)
        if report:
            outs.write_json(report, doc)
        if out:
            outs.stage(out, blend_writer(out))
        outs.commit()
    say(format_bake(doc))
    if out:
        say(f"saved {out}")
    return 0


def _read_plan(path: str):
    from ...core.plan.plan_file import read_plan

    return read_plan(read_text(path, "plan"), path)


def _job_paths(args, outs: Outputs, n: int, job: dict, many: bool) -> tuple[str | None, str | None]:
    """(report, scene) paths of job ``n``, claimed: its own, or derived from --report and
    (with --ray, where each job bakes its own copy of the scene) --out."""
    report = job.get("report") or (
        (args.report if not many else f"{os.path.splitext(args.report)[0]}_{n}.json") if args.report is not None else None)
    scene = job.get("out") or (f"{os.path.splitext(args.out)[0]}_{n}.blend" if args.ray and args.out else None)
    return (outs.claim(report, f"report of job {n}") if report else None,
            claim_blend(outs, scene, f"scene of job {n}") if scene else None)


def _prepare_jobs(args, raw: list, outs: Outputs):
    """(jobs to run, invalid outcomes): checked fields, names in the scene and output
    paths, each job on its own."""
    runnable, invalid = batch.check_jobs(bpy.context.scene, raw)
    jobs = []
    for n, label, fields in runnable:
        try:
            report, scene = _job_paths(args, outs, n, fields, len(raw) > 1)
        except FootstepError as ex:
            invalid.append(JobOutcome(n, label, "invalid", error=str(ex)))
            continue
        jobs.append(batch.Job(n, label, fields, report, scene))
    for o in sorted(invalid, key=lambda o: o.number):
        print(f"footstep: error: {o.label}: {o.error}", file=sys.stderr)
    return jobs, invalid


def _bake_jobs(args, raw: list, settings: Settings, outs: Outputs, out: str | None) -> int:
    """Run a job list (one after another here, or on Ray): each job checked first, each
    failure its own; the scene is saved when any job baked; a summary table at the end."""
    import time

    t0 = time.perf_counter()
    jobs, outcomes = _prepare_jobs(args, raw, outs)
    clash = batch.clashing_jobs(bpy.context.scene, jobs)
    if clash:
        raise CliError(clash)
    progress, done = Progress(len(jobs), "jobs"), []

    def tell(o: JobOutcome) -> None:
        done.append(o)
        progress.step(len(done), f"{o.label}: {o.status}" + (f" ({o.error})" if o.error else ""))

    if args.ray:
        outcomes += _on_ray(args, jobs, outs, tell)
    elif args.together:  # (each job round those before it, not the later ones' earlier bakes)
        commons = [dict(_common(args, names=True), not_around=tuple(j.fields["character"] for j in jobs[k + 1:]))
                   for k in range(len(jobs))]
        outcomes += batch.run_together(bpy.context.scene, jobs, commons, settings, outs, blend_writer, tell)
    else:
        for job in jobs:
            tell(batch.run_job(bpy.context.scene, job, _common(args, names=True), settings, outs,
                               blend_writer(job.out or "")))
        outcomes += done
    outcomes.sort(key=lambda o: o.number)
    if out and not args.ray and any(o.status == "baked" for o in outcomes):
        outs.stage(out, blend_writer(out))
    outs.commit()
    say(summary_table(outcomes, time.perf_counter() - t0))
    return exit_status(outcomes)


def _on_ray(args, jobs: list, outs: Outputs, tell) -> list:
    """The jobs as Ray tasks, each in a worker process of its own (``ray_batch``)."""
    from .ray_batch import run_on_ray

    blend = args.blend or bpy.data.filepath
    if not blend:
        raise CliError("--ray ships the scene file to the workers: give SCENE.blend")
    dest = {j.number: {"out": j.out, "report": j.report} for j in jobs}
    return run_on_ray(args.ray, blend, [(j.number, j.label, j.fields) for j in jobs], _common(args), dest, outs,
                      progress=tell)


#: the pictures ``plot`` draws, by suffix (``core.report.plots.plot_synthesis``)
PLOTS = ("tau", "speed", "path")


def _plot(args) -> int:
    from ...core.report.plots import plot_synthesis

    name = args.name or os.path.splitext(os.path.basename(args.report))[0]
    if not name or name in (".", "..") or os.path.basename(name) != name or "/" in name:
        raise CliError(f"--name {name!r} must be a plain file name prefix, without folders")
    with Outputs([args.report]) as outs:
        finals = [outs.claim(os.path.join(args.out, f"{name}_{k}.png"), f"{k} plot") for k in PLOTS]
        doc = _plan_report(args.report)
        scratch = outs.scratch(args.out)
        try:
            made = plot_synthesis(doc, scratch, name)
        except (KeyError, IndexError, TypeError, ValueError, AttributeError, RecursionError) as ex:
            raise CliError(f"{args.report!r} is not a plan report this version can draw: its synthesis lacks "
                           f"or garbles {ex} ({type(ex).__name__}); make it with: footstep plan ... --report "
                           "REPORT.json") from None
        for m in made:
            outs.adopt(m, os.path.join(os.path.dirname(finals[0]), os.path.basename(m)))
        outs.commit()
    for path in outs.committed:
        say(path)
    return 0


def _plan_report(path: str) -> dict:
    """A plan report's document, checked for its synthesis section."""
    try:
        doc = json.loads(read_text(path, "plan report"))
    except (ValueError, RecursionError) as ex:
        raise CliError(f"cannot read the plan report {path!r}: {str(ex)[:200]}") from None
    if not isinstance(doc, dict) or not isinstance(doc.get("synthesis"), dict):
        raise CliError(f"{path!r} is not a plan report (no \"synthesis\" section): make it "
                       "with: footstep plan ... --report REPORT.json")
    return doc


def _demo(args) -> int:
    """The whole tool on built-in content: a sample scene, the sample character and its
    generated clips; plan, bake, review sheet, report. Every file is made in a scratch
    folder and moved into ``--out`` at the end."""
    import time

    from ..sample import mannequin
    from .. import planning
    from ..read.character import read_library
    from ..sample.sample_scenes import SCENES, build

    t0 = time.perf_counter()
    name = args.scene.lower()
    if name not in SCENES:
        raise CliError(f"no sample scene {args.scene!r}; choose from {', '.join(SCENES)}")
    with Outputs() as outs:
        out_dir = os.path.dirname(outs.claim(os.path.join(args.out, f"{name}_report.json"), "demo report"))
        scene = build(name)
        set_scene_fps(scene, 30)
        ob, clips = mannequin.add_to_scene(scene, "Start")
        lib = read_library(ob)  # (as add_to_scene proposed and stored it)
        say(f"demo: the {scene.name} scene, the Footstep Mannequin and its {len(clips.analyses)} generated "
            f"clips ({time.perf_counter() - t0:.1f} s)")
        say(format_table(ob.name, clips.analyses))
        say(format_library(lib))
        for msg in clips.errors.values():
            print(f"footstep: error: {msg}", file=sys.stderr)
        t1 = time.perf_counter()
        goal, heading, start = batch.goal_and_start(scene, "Goal", None, "Start")
        doc = planning.run(scene, ob, goal, heading, start, name=f"{name} demo", frame_start=1)
        scene.frame_start, scene.frame_end = doc["frame_start"], doc["frame_end"]
        say("\n" + format_demo_plan(doc, 30, time.perf_counter() - t1))
        say(format_bake(doc))
        doc["clips"] = [a.to_dict() for a in clips.analyses]
        written = _demo_files(outs, scene, ob, doc, out_dir, name, foot_shape(clips.analyses, clips.rig))
        outs.commit()
    say(f"\nbaked scene: {written['scene']}\nreview sheet: {written['sheet']}\n  frames: "
        f"{', '.join(written['shots'])}\nreport: {written['report']}"
        + (f"\ncurves: {', '.join(written['curves'])}" if written["curves"] else "")
        + f"\ndemo done in {time.perf_counter() - t0:.1f} s")
    return 1 if clips.errors else 0


def _demo_files(outs: Outputs, scene, ob, doc, out_dir: str, name: str, foot) -> dict:
    """Stage the demo's files (curves, review sheet and frames, report, baked scene) into
    ``out_dir``; returns their final paths."""
    from .review import plot_curves, review_sheet

    scratch = outs.scratch(out_dir)
    pngs = plot_curves(doc, scratch, name)
    sheet, shots = review_sheet(scene, ob, doc, scratch, name, foot)
    final = lambda p: os.path.join(out_dir, os.path.basename(p))  # noqa: E731
    for made in [*pngs, sheet, *shots]:
        outs.adopt(made, final(made))
    written = {"curves": [final(p) for p in pngs], "sheet": final(sheet), "shots": [final(p) for p in shots],
               "report": os.path.join(out_dir, f"{name}_report.json"),
               "scene": os.path.join(out_dir, f"{name}_baked.blend")}
    outs.write_json(written["report"], doc)
    scene.frame_set(doc["frame_start"])
    outs.stage(written["scene"], blend_writer(written["scene"]))
    return written


_HANDLE = None


def register():
    global _HANDLE
    _HANDLE = bpy.utils.register_cli_command("footstep", lambda argv: cli_main(argv))


def unregister():
    global _HANDLE
    if _HANDLE is not None:
        bpy.utils.unregister_cli_command(_HANDLE)
        _HANDLE = None
