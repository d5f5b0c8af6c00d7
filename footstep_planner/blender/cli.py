"""The command line: ``python -m footstep_planner VERB ...`` and, inside Blender,
``blender -b [FILE.blend] -c footstep VERB ...``. One function, ``cli_main``, serves both.

Expected problems (a bad file, a rig without legs, a clip with no footsteps) print one
line ``footstep: error: ...`` naming what is at fault and return a non-zero status; they
never show a traceback and never save anything.
"""

from __future__ import annotations

import argparse
import json
import os
import sys

import bpy
import numpy as np

from ..core.errors import FootstepError
from ..core.pipeline import stage_row
from ..core.settings import Settings

EXPECTED = (FootstepError, OSError)
FOOT = ("L", "R")


class CliError(FootstepError):
    """An expected problem: its message is printed without a traceback."""


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="footstep",
        description="Footstep Planner: clip import and analysis (and, as they arrive, "
                    "planning and baking) from the command line.")
    sub = p.add_subparsers(dest="verb", metavar="VERB")
    sub.required = True

    imp = sub.add_parser(
        "import-clips", help="import BVH files as Actions of one armature and save a .blend",
        description="Import several BVH files of one skeleton as one armature carrying one "
                    "Action per file, in metres, Z up, keyed at the scene's frame rate whatever "
                    "the files' rate. With --blend/--into, the clips are added to an existing "
                    "armature; nothing of the file's is replaced.")
    imp.add_argument("clips", nargs="+", metavar="CLIP.bvh")
    imp.add_argument("--out", required=True, metavar="LIB.blend", help="file to save")
    imp.add_argument("--blend", metavar="IN.blend", help="start from this file (default: the "
                     "file Blender has open, or an empty scene)")
    imp.add_argument("--into", metavar="ARMATURE", help="add the clips to this armature")
    imp.add_argument("--name", help="name of a new armature (default: the first file's name)")
    imp.add_argument("--fps", type=float, help="scene frame rate to key at (default: the "
                     "scene's; an empty scene takes the first file's rate)")
    imp.add_argument("--scale", type=float, help="metres per BVH unit (default: guessed)")

    an = sub.add_parser(
        "analyze", help="analyse clips: contacts, footprints, speed, stride, cycle, tau, gait",
        description="Analyse BVH files, or the clips of the characters in a .blend, after "
                    "Johansen's method. Prints a table, or with --json one object per clip.")
    an.add_argument("inputs", nargs="*", metavar="CLIP.bvh|LIB.blend",
                    help="BVH files, or one .blend (default: the file Blender has open)")
    an.add_argument("--character", metavar="ARMATURE", help="only this armature's clips")
    an.add_argument("--clip", action="append", metavar="NAME", help="only these clips (repeatable)")
    an.add_argument("--fps", type=float, help="sample the clips at this rate (default: the "
                    "scene's; for BVH input, the first file's rate)")
    an.add_argument("--json", action="store_true", help="print JSON")
    an.add_argument("--plot", metavar="DIR", help="also draw each clip's foot curves and "
                    "contacts as PNG into DIR (needs matplotlib)")
    an.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                    help="change a setting, e.g. --set contact_height=0.06 (repeatable)")

    pl = sub.add_parser(
        "plan", help="plan a footstep path for a character to a goal",
        description="Plan the footprints that take a character to a goal across the scene's "
                    "traversable meshes (A* over footprints, jumping gaps where a jump clip can).")
    pl.add_argument("blend", nargs="?", metavar="SCENE.blend",
                    help="the scene (default: the file Blender has open)")
    pl.add_argument("--character", required=True, metavar="ARMATURE")
    pl.add_argument("--goal", metavar="OBJECT", help="walk to this object (default: the 3D cursor)")
    pl.add_argument("--goal-heading", type=float, metavar="DEG",
                    help="arrive facing this way (degrees, 0 = the character's rest forward)")
    pl.add_argument("--start", metavar="OBJECT",
                    help="start standing at this object instead of where the feet are now")
    pl.add_argument("--traversable", default="", metavar="NAME,...", help="tag these objects traversable for this run")
    pl.add_argument("--obstacles", default="", metavar="NAME,...", help="tag these objects obstacles for this run")
    pl.add_argument("--json", action="store_true", help="print JSON: the footprints, the search, "
                    "and the synthesis (per frame: body, clip weights and times, tau and s curves)")
    pl.add_argument("--report", metavar="REPORT.json", help="also write that JSON to this file")
    pl.add_argument("--set", action="append", default=[], metavar="NAME=VALUE")

    bk = sub.add_parser(
        "bake", help="plan, synthesize, IK and bake a character's walk to a goal into NLA",
        description="Plan the footprints to the goal, synthesize the motion, put the feet on "
                    "the footprints (IK) and bake it as a new Action in an NLA track of the "
                    "planner's own on the character, starting at the scene's current frame (or "
                    "--frame-start). Writes the report (plan, stage times, quality measured on "
                    "the baked armature). Several characters and goals: --job JOBS.json, a list "
                    "of {\"character\", \"goal\", \"start\", \"name\", \"frame_start\", "
                    "\"report\"}; they run one after another, a failing job does not stop the "
                    "others, and the exit status is 1 when any failed.")
    bk.add_argument("blend", nargs="?", metavar="SCENE.blend", help="the scene (default: the file open)")
    bk.add_argument("--character", metavar="ARMATURE")
    bk.add_argument("--goal", metavar="OBJECT", help="walk to this object (default: the 3D cursor)")
    bk.add_argument("--goal-heading", type=float, metavar="DEG")
    bk.add_argument("--start", metavar="OBJECT", help="start standing at this object")
    bk.add_argument("--name", help="name of the bake (track and action; default: character to goal)")
    bk.add_argument("--frame-start", type=int, metavar="FRAME")
    bk.add_argument("--markers", action="store_true", help="add a timeline marker at each footstep")
    bk.add_argument("--body-on", choices=("object", "root"), default="object",
                    help="key the body on the armature object (default) or on the rig's root bone")
    bk.add_argument("--job", metavar="JOBS.json", help="several jobs, run one after another")
    bk.add_argument("--out", metavar="OUT.blend", help="save the baked scene here")
    bk.add_argument("--report", metavar="REPORT.json", help="write the report here (with --job: "
                    "REPORT_<n>.json per job unless the job names its own)")
    bk.add_argument("--traversable", default="", metavar="NAME,...")
    bk.add_argument("--obstacles", default="", metavar="NAME,...")
    bk.add_argument("--set", action="append", default=[], metavar="NAME=VALUE")

    pt = sub.add_parser(
        "plot", help="draw a plan report's curves (tau, s) and footprints as PNG",
        description="Draw the synthesis of a plan report (from plan --json or --report) like "
                    "the thesis's figures 4.3 to 4.5: the curvature tau (the plan's clips, the "
                    "estimate from the body trajectory, the low-passed blend parameter), the "
                    "walk/run parameter s, and a top view of the footprints and the body.")
    pt.add_argument("report", metavar="REPORT.json")
    pt.add_argument("--out", required=True, metavar="DIR", help="folder for the PNG files")
    pt.add_argument("--name", help="file name prefix (default: the report's file name)")

    demo = sub.add_parser(
        "demo", help="the whole tool on built-in content: a sample scene, the sample character "
                     "and its generated clips, planned, baked, rendered and reported")
    demo.add_argument("--scene", default="jumps", help="sample scene: jumps, turns or obstacles")
    demo.add_argument("--out", default=None, metavar="DIR",
                      help="output folder (default: sample_scenes/out in the project)")
    return p


def cli_main(argv=None) -> int:
    """Entry point shared by ``python -m footstep_planner`` and ``blender -c footstep``."""
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = _parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as ex:  # --help or a usage error: argparse already printed
        return int(ex.code or 0)
    try:
        return {"import-clips": _import_clips, "analyze": _analyze, "plan": _plan,
                "plot": _plot, "bake": _bake, "demo": _demo}[args.verb](args)
    except EXPECTED as ex:
        print(f"footstep: error: {ex}", file=sys.stderr)
        return 2


# ----------------------------------------------------------------------------------

def settings_from_args(pairs) -> Settings:
    s = Settings()
    changes = {}
    for pair in pairs:
        if "=" not in pair:
            raise CliError(f"--set wants NAME=VALUE, got {pair!r}")
        k, v = pair.split("=", 1)
        default = getattr(s, k.strip(), None)
        if default is None:
            raise CliError(f"unknown setting {k.strip()!r}")
        try:
            if isinstance(default, bool):
                low = v.strip().lower()
                if low not in ("1", "0", "true", "false", "yes", "no", "on", "off"):
                    raise ValueError(v)
                changes[k.strip()] = low in ("1", "true", "yes", "on")
            else:
                changes[k.strip()] = type(default)(v)
        except ValueError:
            raise CliError(f"setting {k.strip()!r} wants a {type(default).__name__}, got {v!r}") from None
    return s.replace(**changes)


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


def _bvh_fps(path: str) -> float:
    from ..core.bvh import read_skeleton

    return read_skeleton(path).fps


def find_armature(name: str):
    ob = bpy.data.objects.get(name)
    if ob is None:
        raise CliError(f"no object named {name!r} in {bpy.data.filepath or 'the scene'}")
    if ob.type != "ARMATURE":
        raise CliError(f"object {name!r} is a {ob.type.lower()}, not an armature")
    return ob


def _import_clips(args) -> int:
    from .clips import import_bvh_clips

    if args.blend:
        open_blend(args.blend)
    elif bpy.data.filepath == "" and not args.into:
        empty_scene(args.fps or _bvh_fps(args.clips[0]))
    if args.fps and args.blend:
        set_scene_fps(bpy.context.scene, args.fps)
    target = find_armature(args.into) if args.into else None
    ob, actions = import_bvh_clips(args.clips, target=target, name=args.name, scale=args.scale)
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
    from .clips import import_bvh_clips

    settings = settings_from_args(args.set)
    bvhs = [p for p in args.inputs if p.lower().endswith(".bvh")]
    blends = [p for p in args.inputs if p.lower().endswith(".blend")]
    other = [p for p in args.inputs if p not in bvhs and p not in blends]
    if other:
        raise CliError(f"{other[0]}: neither a .bvh nor a .blend file")
    if bvhs and blends or len(blends) > 1:
        raise CliError("give BVH files, or one .blend, not both")
    characters = []
    if bvhs:
        empty_scene(args.fps or _bvh_fps(bvhs[0]))
        for path in bvhs:  # one armature per file: files of different skeletons are fine
            ob, _ = import_bvh_clips([path])
            characters.append(ob)
    else:
        if blends:
            open_blend(blends[0])
        if args.fps:
            set_scene_fps(bpy.context.scene, args.fps)
        if args.character:
            characters = [find_armature(args.character)]
        else:
            from .scene import armature_actions

            characters = [o for o in bpy.data.objects if o.type == "ARMATURE" and armature_actions(o)]
        if not characters:
            raise CliError(f"{bpy.data.filepath or 'the scene'} has no armature with clips")

    out, failed = [], []
    for ob in characters:
        result = analyze_character(ob, settings)
        analyses = result.analyses
        if args.clip:
            analyses = [a for a in analyses if a.name in args.clip]
        for name, msg in result.errors.items():
            if not args.clip or name in args.clip:
                failed.append(msg)
        lib = library_for(ob, result) if analyses else None
        out.append((ob, analyses, lib))
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
        if bvhs:  # BVH input: one object per clip, flat
            doc = {"clips": [d for c in doc["characters"] for d in c["clips"]], "errors": failed}
        print(json.dumps(doc, indent=1))
    elif bvhs:
        print(format_table("BVH clips", [a for _, analyses, _ in out for a in analyses]))
    else:
        for ob, analyses, lib in out:
            print(format_table(ob.name, analyses))
            if lib is not None:
                print(format_library(lib))
    for msg in failed:
        print(f"footstep: error: {msg}", file=sys.stderr)
    return 1 if failed else 0


def _names(csv: str) -> list[str]:
    return [n.strip() for n in csv.split(",") if n.strip()]


def _plan(args) -> int:
    import math

    from . import planning

    if args.blend:
        open_blend(args.blend)
    scene = bpy.context.scene
    ob = find_armature(args.character)
    goal, heading = planning.goal_of(scene, args.goal)
    if args.goal_heading is not None:
        heading = math.radians(args.goal_heading)
    start = None
    if args.start:
        start = scene.objects.get(args.start)
        if start is None:
            raise CliError(f"no object named {args.start!r} to start at")
    settings = settings_from_args(args.set)
    result, setup = planning.plan(scene, ob, goal, heading, start, settings,
                                  _names(args.traversable), _names(args.obstacles))
    syn = planning.synthesize(scene, result, setup, settings, goal=goal)
    doc = result.to_dict()
    doc["character"] = ob.name
    doc["goal"] = [round(float(v), 4) for v in goal]
    doc["stages"] = stage_row(len(result.footsteps), result.seconds, syn)
    doc["synthesis"] = syn.to_dict(frame0=float(scene.frame_current))
    if args.report:
        with open(args.report, "w") as fh:
            json.dump(doc, fh)
    if args.json:
        print(json.dumps(doc))
    else:
        print(f"{ob.name}: {len(result.footsteps)} footprints to ({goal[0]:.2f}, {goal[1]:.2f}, "
              f"{goal[2]:.2f}) in {syn.t[-1]:.2f} s of motion ({len(syn.t)} frames)")
        planted = syn.planted()
        rate = planning.scene_rate(scene)
        print(f"{'#':>3s} {'foot':4s} {'x':>7s} {'y':>7s} {'z':>6s} {'head':>6s} {'frame':>7s}  clip")
        pos, head = syn.footprints
        for i, f in enumerate(result.footsteps):
            fr = scene.frame_current + planted[i][1] * rate
            print(f"{i:3d} {'LR'[f.foot]:4s} {pos[i, 0]:7.2f} {pos[i, 1]:7.2f} {pos[i, 2]:6.2f} "
                  f"{math.degrees(head[i]):6.0f} {fr:7.1f}  {f.label}{' (jump)' if f.jump else ''}")
        print(f"search: {result.expanded} footprints expanded, {result.generated} generated, "
              f"{result.seconds * 1e3:.0f} ms")
        print(format_stages([doc["stages"]]))
        print(f"tau {syn.tau_final.min():+.2f} to {syn.tau_final.max():+.2f} 1/m; running "
              f"(s > 0.5) {np.mean(syn.s_final > 0.5) * 100:.0f} % of the frames")
    return 0


def format_stages(rows, names=None) -> str:
    """Rows of stage_row as a table in the layout of thesis Table 4.1."""
    cols = [("footprints", "footprints", "d"), ("frames", "frames", "d"), ("search_ms", "search", ".0f"),
            ("smoothing_ms", "smoothing", ".1f"), ("refinement_ms", "refinement", ".1f"),
            ("body_trajectory_ms", "body traj.", ".1f"), ("blend_groups_ms", "blend groups", ".1f"),
            ("synthesis_ms", "total", ".1f"), ("per_frame_ms", "per frame", ".3f")]
    names = names or [""] * len(rows)
    w0 = max([8] + [len(n) for n in names])
    head = f"{'':{w0}s} " + " ".join(f"{h:>12s}" for _, h, _ in cols)
    lines = ["stage times (ms), thesis Table 4.1 layout (IK and bake: issue 5):", head, "-" * len(head)]
    for n, r in zip(names, rows):
        lines.append(f"{n:{w0}s} " + " ".join(f"{format(r[k], f):>12s}" for k, _, f in cols))
    return "\n".join(lines)


def _bake(args) -> int:
    import math

    from . import planning

    if args.blend:
        open_blend(args.blend)
    scene = bpy.context.scene
    settings = settings_from_args(args.set)
    if args.job:
        try:
            with open(args.job) as fh:
                jobs = json.load(fh)
            assert isinstance(jobs, list) and all(isinstance(j, dict) for j in jobs)
        except (OSError, ValueError, AssertionError) as ex:
            raise CliError(f"cannot read the job list {args.job!r}: it must be a JSON list of objects "
                           f"({ex or 'not a list'})") from None
    else:
        if not args.character:
            raise CliError("bake needs --character (or --job JOBS.json)")
        jobs = [{"character": args.character, "goal": args.goal, "start": args.start, "name": args.name,
                 "frame_start": args.frame_start, "report": args.report, "goal_heading": args.goal_heading}]
    failed = 0
    for n, job in enumerate(jobs):
        label = f"job {n + 1} ({job.get('character')} to {job.get('goal') or 'the 3D cursor'})"
        try:
            ob = find_armature(job.get("character"))
            goal, heading = planning.goal_of(scene, job.get("goal"))
            if job.get("goal_heading") is not None:
                heading = math.radians(float(job["goal_heading"]))
            start = None
            if job.get("start"):
                start = scene.objects.get(job["start"])
                if start is None:
                    raise CliError(f"no object named {job['start']!r} to start at")
            doc = planning.run(scene, ob, goal, heading, start, settings, _names(args.traversable),
                               _names(args.obstacles), name=job.get("name"), frame_start=job.get("frame_start"),
                               markers=args.markers, body_on=str(job.get("body_on", args.body_on)).upper())
        except EXPECTED as ex:
            failed += 1
            print(f"footstep: error: {label}: {ex}", file=sys.stderr)
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


def format_bake(doc) -> str:
    """The stage times (Table 4.1 layout) and the quality figures of one bake."""
    st, q = doc["stages"], doc["quality"]
    cols = [("footprints", "d"), ("frames", "d"), ("search_ms", ".0f"), ("smoothing_ms", ".1f"),
            ("refinement_ms", ".1f"), ("body_trajectory_ms", ".1f"), ("blend_groups_ms", ".1f"),
            ("pose_blend_ms", ".1f"), ("ik_ms", ".1f"), ("bake_ms", ".1f"), ("synthesis_ms", ".1f"),
            ("per_frame_ms", ".3f")]
    head = " ".join(f"{k.replace('_ms', ''):>13s}" for k, _ in cols)
    row = " ".join(f"{format(st[k], f):>13s}" for k, f in cols)
    pops = q["pops"]
    intro = pops["introduced"]
    lines = [
        f"{doc['character']}: baked {doc['name']!r} into NLA track {doc['track']!r}, frames "
        f"{doc['frame_start']}-{doc['frame_end']}",
        "stage times (ms; thesis Table 4.1 layout; 'pose_blend' plays the clips' bone rotations; "
        "'synthesis' sums smoothing to IK):", head, row,
        f"foot skate per stance: mean {q['foot_skate']['mean_mm']:.2f} mm, max {q['foot_skate']['max_mm']:.2f} mm; "
        f"planted foot to footprint: mean {q['footprint_error']['mean_mm']:.2f} mm, max "
        f"{q['footprint_error']['max_mm']:.2f} mm",
        f"ground penetration: max {q['penetration']['max_mm']:.2f} mm ({q['penetration']['frames_over_tolerance']} "
        f"frames over 5 mm); floating while planted: max {q['floating']['max_mm']:.2f} mm",
        f"goal: {q['goal']['distance_m'] * 100:.1f} cm" + (
            f", heading {q['goal']['heading_deg']:.1f} deg" if q['goal'].get('heading_deg') is not None else ""),
        f"pops: largest step {pops['max_rotation_deg']:.1f} deg ({pops['rotation_bone']}, as in its clip); "
        f"made by the planner: {intro['count']} steps over the clips' own, worst "
        f"{intro['max_excess_deg']:.1f} deg over" + (f" ({intro['bone']}, frame {intro['frame']})"
                                                     if intro['bone'] else ""),
    ]
    return "\n".join(lines)


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


def format_table(title: str, analyses) -> str:
    head = (f"{'clip':38s} {'fps':>5s} {'frames':>6s} {'kind':6s} {'gait':5s} {'entry>exit':12s} "
            f"{'speed':>6s} {'stride':>6s} {'cycle':>6s} {'cad.':>5s} {'tau':>7s} {'flights (s)':14s}")
    lines = [f"{title}:", head, "-" * len(head)]
    f = lambda v, fmt: "-" if v is None else format(v, fmt)  # noqa: E731
    for a in analyses:
        fl = ",".join(f"{b - x:.2f}" for x, b in a.jump_flights) or (
            f"{len(a.flights)}x{sum(b - x for x, b in a.flights) / max(len(a.flights), 1):.2f}" if a.flights else "-")
        lines.append(
            f"{a.name:38s} {a.fps:5.0f} {a.frames:6d} {a.kind:6s} {a.gait:5s} "
            f"{a.entry_gait + '>' + a.exit_gait:12s} {a.speed:6.2f} {f(a.stride, '6.2f'):>6s} "
            f"{f(a.cycle, '6.2f'):>6s} {f(a.cadence, '5.0f'):>5s} {a.tau:+7.3f} {fl:14s}")
    lines.append("units: speed m/s, stride m, cycle s, cadence steps/min, tau 1/m (+ turns left); "
                 "flights: jump flights, else count x mean")
    return "\n".join(lines)


def format_library(lib) -> str:
    lines = ["blend groups" + (" (edited)" if lib.edited else " (proposed)") + ":"]
    for gait, g in lib.turn_groups.items():
        lines.append(f"  {g.name}: " + ", ".join(f"{c.clip} ({c.tau:+.2f})" for c in g.clips))
    if lib.speed_group:
        lines.append("  speed: walk_turn (s=0) <-> run_turn (s=1)")
    for sp in lib.specials:
        lines.append(f"  {sp.kind}: {sp.clip} ({sp.entry_gait} -> {sp.exit_gait})")
    return "\n".join(lines)


def _demo(args) -> int:
    """The whole tool on built-in content: a sample scene, the sample character and its
    generated clips; plan, bake, review sheet, report."""
    import time

    from . import mannequin, planning
    from .character import read_library
    from .sample_scenes import SCENES, build

    t0 = time.perf_counter()
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    out_dir = os.path.abspath(args.out or os.path.join(root, "sample_scenes", "out"))
    name = args.scene.lower()
    if name not in SCENES:
        raise CliError(f"no sample scene {args.scene!r}; choose from {', '.join(SCENES)}")
    os.makedirs(out_dir, exist_ok=True)
    scene = build(name)
    set_scene_fps(scene, 30)
    start, goal_ob = scene.objects["Start"], scene.objects["Goal"]
    ob, clips = mannequin.add_to_scene(scene, "Start")
    lib = read_library(ob)  # (as add_to_scene proposed and stored it)
    t_clips = time.perf_counter() - t0
    print(f"demo: the {scene.name} scene, the Footstep Mannequin and its {len(clips.analyses)} generated clips "
          f"({t_clips:.1f} s)")
    print(format_table(ob.name, clips.analyses))
    print(format_library(lib))
    for msg in clips.errors.values():
        print(f"footstep: error: {msg}", file=sys.stderr)

    goal = np.array(goal_ob.location)
    t1 = time.perf_counter()
    doc = planning.run(scene, ob, goal, start_marker=start, name=f"{name} demo", frame_start=1)
    t_run = time.perf_counter() - t1
    scene.frame_start, scene.frame_end = doc["frame_start"], doc["frame_end"]
    jumps = sum(1 for f in doc["footprints"] if f.get("jump"))
    print(f"\nplan: {len(doc['footprints'])} footprints ({jumps} jumps), "
          f"{doc['frame_end'] - doc['frame_start'] + 1} frames at 30 fps, planned, synthesized, "
          f"solved and baked in {t_run:.2f} s")
    print(format_bake(doc))
    doc["clips"] = [a.to_dict() for a in clips.analyses]
    report = os.path.join(out_dir, f"{name}_report.json")
    with open(report, "w") as fh:
        json.dump(doc, fh)
    pngs = []
    try:
        from ..core.plots import plot_synthesis

        pngs = plot_synthesis(doc, out_dir, name)
    except ImportError:
        print("(matplotlib not available: no curves)")
    sheet, shots = _review_sheet(scene, ob, doc, out_dir, name)
    bpath = os.path.join(out_dir, f"{name}_baked.blend")
    scene.frame_set(doc["frame_start"])
    bpy.ops.wm.save_as_mainfile(filepath=bpath, compress=True)
    print(f"\nbaked scene: {bpath}\nreview sheet: {sheet}\n  frames: {', '.join(shots)}\n"
          f"report: {report}" + (f"\ncurves: {', '.join(pngs)}" if pngs else "") +
          f"\ndemo done in {time.perf_counter() - t0:.1f} s")
    return 1 if clips.errors else 0


def _review_sheet(scene, ob, doc, out_dir: str, name: str) -> tuple[str, list[str]]:
    """Workbench renders of the baked character at a few frames along its path (the
    middle of a jump among them, if it jumps) and a top view with the footprints, side by
    side in one PNG. Returns (sheet path, the frame renders' paths)."""
    fps = doc["footprints"]
    n = len(fps)
    picks = [fps[int(i * (n - 1) / 5)]["frame"] for i in (1, 2, 3, 4)]
    jumps = [i for i, f in enumerate(fps) if f.get("jump")]
    airborne = None
    if jumps:  # the first jump's flight, half way between take-off and landing
        i = jumps[0]
        take_off = fps[i - 1]["planted_frames"][1] if i > 0 else fps[i]["frame"]
        airborne = int((take_off + fps[i]["planted_frames"][0]) // 2)
        picks[1] = airborne
    picks = sorted(set(int(f) for f in picks))
    shots = [_render_character(scene, ob, f, os.path.join(out_dir, f"{name}_frame{f:04d}.png")) for f in picks]
    _draw_footprints(scene, doc)
    top = os.path.join(out_dir, f"{name}_top.png")
    scene.frame_set(doc["frame_end"])
    _render_top(scene, top)
    sheet = os.path.join(out_dir, f"{name}_review.png")
    captions = []
    doing = {"walk": "walking", "run": "running"}
    for f in picks:
        near = min(fps, key=lambda fp: abs(fp["frame"] - f))
        what = ("in the air over a gap" if f == airborne
                else f"{doing.get(near.get('gait'), near.get('gait'))} ({near.get('clip', '')})")
        captions.append(f"frame {f}: {what}")
    q = doc["quality"]
    title = (f"{scene.name}: {n} footprints ({len(jumps)} jumps), frames {doc['frame_start']}-{doc['frame_end']}; "
             f"goal {q['goal']['distance_m'] * 100:.1f} cm, foot skate max {q['foot_skate']['max_mm']:.2f} mm")
    try:
        _compose_labelled(top, shots, captions, title, sheet)
    except ImportError:  # (no matplotlib, as inside Blender: the same sheet without words)
        _compose([top] + shots, sheet)
    return sheet, shots + [top]


def _compose_labelled(top: str, shots: list[str], captions: list[str], title: str, out: str) -> None:
    """The review sheet with a title and captions (matplotlib): the top view on the left,
    the frames in two columns beside it."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = (len(shots) + 1) // 2
    fig = plt.figure(figsize=(18, 8.4), dpi=100)
    grid = fig.add_gridspec(rows, 4, width_ratios=[1.15, 1.15, 1, 1], wspace=0.02, hspace=0.12)
    ax = fig.add_subplot(grid[:, :2])
    ax.imshow(plt.imread(top))
    ax.set_title("top view: footprints (left blue, right red, jump landings yellow), body path (orange)",
                 fontsize=10)
    ax.axis("off")
    for k, (png, cap) in enumerate(zip(shots, captions)):
        a = fig.add_subplot(grid[k // 2, 2 + k % 2])
        a.imshow(plt.imread(png))
        a.set_title(cap, fontsize=10)
        a.axis("off")
    fig.suptitle(title, fontsize=12)
    fig.savefig(out, bbox_inches="tight")
    plt.close(fig)


def _compose(paths: list[str], out: str) -> None:
    """One PNG: the first image (square) on the left, the others in a 2-column grid of
    half its height beside it."""
    imgs = []
    for p in paths:
        im = bpy.data.images.load(p)
        a = np.empty(im.size[0] * im.size[1] * 4, np.float32)
        im.pixels.foreach_get(a)
        imgs.append(a.reshape(im.size[1], im.size[0], 4))
        bpy.data.images.remove(im)
    big = imgs[0]
    H = big.shape[0]
    h = H // 2
    cells = []
    for a in imgs[1:]:
        # nearest-neighbour scale to height h
        ys = (np.arange(h) * a.shape[0] / h).astype(int)
        w = int(round(a.shape[1] * h / a.shape[0]))
        xs = (np.arange(w) * a.shape[1] / w).astype(int)
        cells.append(a[ys][:, xs])
    w = max(c.shape[1] for c in cells) if cells else 0
    cols = 2
    rows = (len(cells) + cols - 1) // cols
    sheet = np.ones((max(H, rows * h), big.shape[1] + cols * w, 4), np.float32)
    sheet[sheet.shape[0] - H:, :big.shape[1]] = big
    for k, c in enumerate(cells):
        r, col = divmod(k, cols)
        y0 = sheet.shape[0] - (r + 1) * h  # Blender's pixels start at the bottom row
        x0 = big.shape[1] + col * w
        sheet[y0:y0 + h, x0:x0 + c.shape[1]] = c
    im = bpy.data.images.new("footstep review sheet", sheet.shape[1], sheet.shape[0], alpha=True)
    im.pixels.foreach_set(sheet.ravel())
    im.filepath_raw = out
    im.file_format = "PNG"
    im.save()
    bpy.data.images.remove(im)


def _render_character(scene, ob, frame: int, path: str) -> str:
    """A Workbench render of the character at ``frame``, from the side and a little above."""
    import math

    scene.frame_set(frame)
    bpy.context.view_layer.update()
    hips = np.array(ob.matrix_world @ ob.pose.bones[0].head)
    cam = scene.objects.get("CharacterCamera")
    if cam is None:
        cam = bpy.data.objects.new("CharacterCamera", bpy.data.cameras.new("CharacterCamera"))
        scene.collection.objects.link(cam)
    yaw = ob.matrix_world.to_euler("XYZ").z
    side = np.array([math.cos(yaw), math.sin(yaw), 0.0])  # the rig's +X: the character's side
    cam.location = tuple(hips + 4.0 * side + [0.0, 0.0, 0.8])
    from mathutils import Vector

    cam.rotation_euler = (Vector(hips.tolist()) - cam.location).to_track_quat("-Z", "Y").to_euler()
    scene.camera = cam
    scene.render.engine = "BLENDER_WORKBENCH"
    scene.display.shading.color_type = "MATERIAL"
    scene.render.resolution_x, scene.render.resolution_y = 640, 480
    scene.render.filepath = path
    bpy.ops.render.render(write_still=True)
    return path


def _draw_footprints(scene, doc):
    """The baked footprints (report ``doc``) as small quads (left blue, right red, jump
    landings yellow) and the body trajectory as a thin orange tube, in a collection of the
    demo's own."""
    import math

    coll = bpy.data.collections.new("Footprints (demo)")
    scene.collection.children.link(coll)
    mats = {}
    for key, rgba in (("L", (0.15, 0.35, 0.95, 1)), ("R", (0.95, 0.2, 0.15, 1)), ("J", (1.0, 0.8, 0.1, 1)),
                      ("B", (1.0, 0.5, 0.0, 1))):
        m = bpy.data.materials.new(f"footprint_{key}")
        m.diffuse_color = rgba
        mats[key] = m
    fa = math.atan2(doc["forward"][1], doc["forward"][0])
    for i, f in enumerate(doc["footprints"]):
        x, y, z = f["position"]
        a = f["heading"] + fa
        u = np.array([math.cos(a), math.sin(a)])
        v = np.array([-u[1], u[0]])
        quad = [(x, y) + 0.13 * su * u + 0.05 * sv * v for su, sv in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
        me = bpy.data.meshes.new(f"footprint{i}")
        me.from_pydata([(float(p[0]), float(p[1]), z + 0.01) for p in quad], [], [(0, 1, 2, 3)])
        key = "J" if f.get("jump") else f["foot"]
        me.materials.append(mats[key])
        fob = bpy.data.objects.new(f"footprint{i:03d}", me)
        fob.color = mats[key].diffuse_color
        coll.objects.link(fob)
    cu = bpy.data.curves.new("body_trajectory", "CURVE")
    cu.dimensions = "3D"
    cu.bevel_depth = 0.03
    sp = cu.splines.new("POLY")
    body = np.asarray(doc["synthesis"]["body"]["position"])[::2]
    sp.points.add(len(body) - 1)
    sp.points.foreach_set("co", np.c_[body[:, :2], body[:, 2] + 0.05, np.ones(len(body))].ravel())
    cu.materials.append(mats["B"])
    bob = bpy.data.objects.new("body_trajectory", cu)
    bob.color = mats["B"].diffuse_color
    coll.objects.link(bob)


def _render_top(scene, path):
    """An orthographic top view of the whole scene: traversable surfaces light, obstacles
    dark, the drawn footprints and trajectory in their colours (object colours: the demo's
    own scene, so setting them changes nothing of the user's)."""
    from .surfaces import tagged_objects

    walk, block = tagged_objects(scene)
    for ob in walk:
        ob.color = (0.78, 0.78, 0.74, 1.0)
    for ob in block:
        ob.color = (0.22, 0.25, 0.3, 1.0)
    scene.display.shading.color_type = "OBJECT"
    pts = np.array([ob.matrix_world @ v.co for ob in scene.objects if ob.type == "MESH"
                    for v in ob.data.vertices])
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    cam = bpy.data.objects.new("TopCamera", bpy.data.cameras.new("TopCamera"))
    scene.collection.objects.link(cam)
    cam.data.type = "ORTHO"
    cam.data.ortho_scale = float(max(hi[:2] - lo[:2])) * 1.08
    cam.location = (float(lo[0] + hi[0]) / 2, float(lo[1] + hi[1]) / 2, float(hi[2]) + 20)
    scene.camera = cam
    scene.render.engine = "BLENDER_WORKBENCH"
    scene.render.resolution_x = scene.render.resolution_y = 800
    scene.render.filepath = path
    scene.render.image_settings.file_format = "PNG"
    bpy.ops.render.render(write_still=True)


_HANDLE = None


def register():
    global _HANDLE
    if bpy.app.version >= (4, 2, 0):
        _HANDLE = bpy.utils.register_cli_command("footstep", lambda argv: cli_main(argv))


def unregister():
    global _HANDLE
    if _HANDLE is not None:
        bpy.utils.unregister_cli_command(_HANDLE)
        _HANDLE = None
