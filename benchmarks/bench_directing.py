"""The animator directs (issue 16), on the Turns sample scene with the sample character:

1. a bake through three waypoints (A with a pause, B and the goal on given frames),
   saved, reopened and played through the depsgraph: the timing table (asked, planned,
   played frames per waypoint, the pace and the wait chosen) and the bake's quality;
2. a frame too soon, refused with the earliest frame, which is then met; frames too soon
   for walking, met jogging (the walk and the run blended, the stride following the
   speed), and, with the jog off, running;
3. one footprint of a baked path moved (two neighbours locked) and re-baked: review
   sheets before and after, and how many frames were re-keyed; moved further, the
   re-bake keys the whole path rather than let the kept foot slide where keys mix.

    .venv/bin/python benchmarks/bench_directing.py [--out DIR]
"""

import argparse
import json
import os
import re
import sys
import tempfile
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

CHAR = "Footstep Mannequin"


def shot(out: str) -> str:
    """The Turns scene with the sample character at Start and empties A, B near the direct
    path's thirds, saved; its path."""
    import bpy

    from footstep_planner.blender.sample import mannequin, sample_scenes
    from footstep_planner.blender import planning
    bpy.ops.wm.read_homefile(use_empty=True)
    scene = sample_scenes.build("turns")
    scene.render.fps, scene.render.fps_base = 30, 1.0
    ob, _ = mannequin.add_to_scene(scene, "Start")
    goal, heading = planning.goal_of(scene, "Goal")
    fps = planning.plan(scene, ob, goal, heading, scene.objects["Start"])[0].footprints
    for name, i in (("A", len(fps) // 3), ("B", 2 * len(fps) // 3)):
        e = bpy.data.objects.new(name, None)
        e.empty_display_type, e.empty_display_size = "SINGLE_ARROW", 0.5
        e.location = fps[i].position
        scene.collection.objects.link(e)
    path = os.path.join(out, "shot.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path)
    return path


def played_arrivals(path: str, doc: dict) -> list[float]:
    """Each waypoint's arrival frame read off the saved scene as Blender plays it (the body
    through the depsgraph, frame by frame), by the report's windows about its frames."""
    import bpy

    from footstep_planner.core.perform.directed import Mark, arrival_frames

    bpy.ops.wm.open_mainfile(filepath=path)
    scene, ob = bpy.context.scene, bpy.data.objects[CHAR]
    dg = bpy.context.evaluated_depsgraph_get()
    body = []
    for f in range(doc["frame_start"], doc["frame_end"] + 1):
        scene.frame_set(f)
        body.append(np.array(ob.evaluated_get(dg).matrix_world.translation))
    body = np.array(body)
    rows = doc["waypoints"]
    marks = [Mark(r["name"], 0, np.array(scene.objects[r["name"]].matrix_world.translation), stop=r["stops"])
             for r in rows]
    f0 = doc["frame_start"]
    windows = []
    for k, r in enumerate(rows):
        a = int(r["planned"] - f0 - 45)
        b = len(body) - 1 if k + 1 == len(rows) else int(r["planned"] - f0 + 0.8 * r["pause"] * 30 if r["stops"]
                                                         else r["planned"] - f0 + 45)
        windows.append((max(a, 0), min(b, len(body) - 1)))
    return list(f0 + arrival_frames(body, marks, windows))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=None, help="folder for the scenes, reports and review sheets")
    args = ap.parse_args()
    out = args.out or tempfile.mkdtemp(prefix="footstep_directing_")
    os.makedirs(out, exist_ok=True)
    import bpy  # noqa: F401

    from footstep_planner import register
    from footstep_planner.blender.command.cli import cli_main

    register()
    path = shot(out)
    common = [path, "--character", CHAR, "--start", "Start", "--goal", "Goal", "--via", "A,B"]

    # 1. three waypoints: a pause, two arrival frames
    timed = os.path.join(out, "timed.blend")
    t0 = time.perf_counter()
    rc = cli_main(["bake", *common, "--pause", "A=1.5", "--arrive", "B=560,Goal=800", "--out", timed,
                   "--report", os.path.join(out, "timed.json")])
    secs = time.perf_counter() - t0
    doc = json.load(open(os.path.join(out, "timed.json")))
    played = played_arrivals(timed, doc)
    print(f"\n1. three waypoints (exit {rc}, {secs:.1f} s with the search, the pace search, IK, bake, "
          "measure and save)")
    print(f"{'waypoint':<9s} {'asked':>6s} {'planned':>8s} {'report':>8s} {'replayed':>9s} {'pause s':>8s} "
          f"{'pace':>5s} {'waited s':>8s}")
    for r, p in zip(doc["waypoints"], played):
        asked = "-" if r["arrive"] is None else f"{r['arrive']:.0f}"
        print(f"{r['name']:<9s} {asked:>6s} {r['planned']:>8.1f} {r['achieved']:>8.1f} {p:>9.1f} "
              f"{r['pause']:>8.2f} {r['pace']:>5.2f} {r['waited']:>8.2f}")
    q = doc["quality"]
    print(f"quality: skate max {q['foot_skate']['max_mm']:.2f} mm, foot to footprint max "
          f"{q['footprint_error']['max_mm']:.2f} mm, goal {q['goal']['distance_m'] * 100:.1f} cm, planner-made pops "
          f"{q['pops']['introduced']['count']} (worst {q['pops']['introduced']['max_excess_deg']:.1f} deg over)")

    # 2. too soon: refused with the earliest frame, which is then met
    import contextlib
    import io

    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        rc2 = cli_main(["bake", *common, "--arrive", "B=200"])
    m = re.search(r"the earliest is frame (\d+)", err.getvalue())
    print(f"\n2. B on frame 200: exit {rc2}: {err.getvalue().strip().splitlines()[-1]}")
    if m:
        rc3 = cli_main(["bake", *common, "--arrive", f"B={m.group(1)}", "--report", os.path.join(out, "earliest.json")])
        r = json.load(open(os.path.join(out, "earliest.json")))["waypoints"][1]
        print(f"   B on frame {m.group(1)}: exit {rc3}, reached on frame {r['achieved']:.1f} at pace {r['pace']:.2f}"
              f", met by {r.get('met_by')}" + (f" (blend {r['blend']:.2f})" if r.get("blend") else ""))
    # the fastest walk's frame; frames between the walk and the run (a jog); one with the jog off (a run)
    for frame, extra in ((437, []), (380, []), (300, []), (380, ["--set", "jog_to_arrive=false"])):
        t1 = time.perf_counter()
        rc4 = cli_main(["bake", *common, "--arrive", f"B={frame}", *extra, "--report", os.path.join(out, "b.json")])
        took = time.perf_counter() - t1
        d = json.load(open(os.path.join(out, "b.json")))
        r = d["waypoints"][1]
        runs = sum(f["gait"] == "run" for f in d["footprints"][:r["footprint"]])
        how = r.get("met_by") or "-"
        if r.get("blend"):
            how += f" at {r['jog_speed']:.2f} m/s, blend {r['blend']:.2f}"
        print(f"   B on frame {frame}{' (jog off)' if extra else ''}: exit {rc4}, reached on frame "
              f"{r['achieved']:.1f}, pace {r['pace']:.2f}, met by {how}, {r['footprint']} footprints and {runs} "
              f"running steps on the way, waited {r['waited']:.1f} s; skate max "
              f"{d['quality']['foot_skate']['max_mm']:.2f} mm, planner-made pops "
              f"{d['quality']['pops']['introduced']['count']}; {took:.1f} s")

    # 3. an edited footprint, re-baked: review sheets before and after
    from footstep_planner.blender.ui import directing, handles
    from footstep_planner.blender import planning
    from footstep_planner.blender.command.review import review_sheet

    bpy.ops.wm.open_mainfile(filepath=path)
    scene = bpy.context.scene
    ob = bpy.data.objects[CHAR]
    goal, heading = planning.goal_of(scene, "Goal")
    planned = planning.plan_and_synthesize(scene, ob, goal, heading, scene.objects["Start"])
    before = planning.run(scene, ob, goal, heading, scene.objects["Start"], name="turns", frame_start=1)
    handles.make_handles(scene, ob, planned.result.footprints, planned.setup.forward, goal, planned.goal_heading)
    foot = planned.setup.planner.foot
    sheet_before, _ = review_sheet(scene, ob, before, out, "before", foot)
    hs = handles.handles(ob)
    k = len(hs) // 2
    handles.set_locked([hs[k - 3], hs[k + 3]], True)
    hs[k].location.y += 0.15
    after, route, splice = directing.rebake_handles(scene, ob)
    sheet_after, _ = review_sheet(scene, ob, after, out, "after", foot)
    keyed = (f"frames {splice.span.changed()[0]}-{splice.span.changed()[1]} re-keyed" if splice.span is not None
             else after.get("rebaked_whole", "the whole path re-baked"))
    print(f"\n3. footprint {k} moved 15 cm, footprints {k - 3} and {k + 3} locked: re-planned span "
          f"{route.edited.spans}, {keyed} of {before['frame_start']}-{after['frame_end']}; "
          f"skate max {after['quality']['foot_skate']['max_mm']:.2f} mm")
    hs = handles.handles(ob)
    hs[k].location.y += 0.15  # (30 cm in all: too far to splice without a slide)
    far, _, splice = directing.rebake_handles(scene, ob)
    print(f"   moved 15 cm more: {far.get('rebaked_whole') or 'spliced'}; skate max "
          f"{far['quality']['foot_skate']['max_mm']:.2f} mm")
    print(f"   review sheets: {sheet_before}\n                  {sheet_after}")
    print(f"\nfiles in {out}")


if __name__ == "__main__":
    main()
