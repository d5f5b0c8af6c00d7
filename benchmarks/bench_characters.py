"""Characters as users bring them, baked on the sample scenes and measured as Blender
plays the saved file: the report's figures next to those of an independent evaluation
(``measure_played.py``: a fresh process opens the saved .blend and reads the depsgraph
frame by frame).

    .venv/bin/python benchmarks/bench_characters.py [--characters mannequin,walk,cmu]
        [--scenes turns,obstacles] [--out DIR]

Characters: ``mannequin`` (the sample character and its 12 generated clips), ``walk``
(the sample character with its walk clip only), ``cmu`` (CMU subject 16's BVH library
and the 49_05 leap, imported with ``import-clips``, its first clip left active as every
importer leaves it). Each stands at the scene's Start (no Start object is given to the
planner: it starts where it stands) and walks to the Goal, arriving with its heading.
"""

import argparse
import json
import os
import subprocess
import sys
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)
from library import MOCAP, cmu_files  # noqa: E402

CHARACTERS = ("mannequin", "walk", "cmu")


def add_character(kind: str, scene):
    """The character ``kind`` standing on the scene's Start."""
    from footstep_planner.blender import mannequin
    from footstep_planner.blender.character import analyze_and_propose
    from footstep_planner.blender.clips import import_bvh_clips

    if kind == "mannequin":
        return mannequin.add_to_scene(scene, "Start")[0]
    if kind == "walk":
        ob, _ = mannequin.add_to_scene(scene, "Start", clips=False)
        mannequin.generate_clips(ob, names=["walk"])
        analyze_and_propose(ob)
        return ob
    if kind == "cmu":
        ob, _ = import_bvh_clips(cmu_files(MOCAP), name="CMU")
        start = scene.objects["Start"]
        ob.location, ob.rotation_euler.z = start.location, start.rotation_euler.z
        return ob
    raise SystemExit(f"unknown character {kind!r}; choose from {', '.join(CHARACTERS)}")


def bake_one(kind: str, scene_name: str, out: str) -> dict:
    import bpy

    from footstep_planner.blender import planning
    from footstep_planner.blender.sample_scenes import build

    bpy.ops.wm.read_homefile(use_empty=True)
    scene = build(scene_name)
    scene.render.fps = 30
    ob = add_character(kind, scene)
    goal, heading = planning.goal_of(scene, "Goal")
    t0 = time.perf_counter()
    doc = planning.run(scene, ob, goal, heading, None, name=f"{kind} {scene_name}", frame_start=1)
    seconds = time.perf_counter() - t0
    stem = os.path.join(out, f"{kind}_{scene_name}")
    with open(stem + ".json", "w") as fh:
        json.dump(doc, fh)
    bpy.ops.wm.save_as_mainfile(filepath=stem + ".blend", compress=True)
    res = subprocess.run([sys.executable, os.path.join(ROOT, "benchmarks", "measure_played.py"),
                          stem + ".blend", stem + ".json", "--json"], capture_output=True, text=True, check=True)
    played = json.loads(res.stdout.strip().splitlines()[-1])
    return {"doc": doc, "played": played, "seconds": seconds}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--characters", default=",".join(CHARACTERS))
    ap.add_argument("--scenes", default="turns,obstacles")
    ap.add_argument("--out", default=os.path.join(ROOT, "sample_scenes", "out", "characters"))
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    from footstep_planner import register

    register()
    head = (f"{'character':10s} {'scene':10s} {'frames':>6s} {'run s':>6s} | {'skate max mm':>12s} "
            f"{'fp err max mm':>13s} {'goal cm':>7s} | {'played: skate':>13s} {'fp err':>7s} {'goal cm':>7s} "
            f"{'active action':>13s}")
    print("report (planner's evaluation of the scene after the bake) | played (fresh process, saved file, depsgraph)")
    print(head)
    print("-" * len(head))
    for kind in args.characters.split(","):
        for name in args.scenes.split(","):
            r = bake_one(kind, name, args.out)
            q, p = r["doc"]["quality"], r["played"]
            print(f"{kind:10s} {name:10s} {p['frames']:6d} {r['seconds']:6.2f} | {q['foot_skate']['max_mm']:12.3f} "
                  f"{q['footprint_error']['max_mm']:13.3f} {q['goal']['distance_m'] * 100:7.1f} | "
                  f"{p['skate_max_mm']:13.3f} {p['footprint_error_max_mm']:7.3f} {p['goal_cm']:7.1f} "
                  f"{str(p['active_action']):>13s}")
    print(f"(saved scenes and reports in {args.out}; machine: {os.cpu_count()} cores, load "
          f"{os.getloadavg()[0]:.2f})")


if __name__ == "__main__":
    main()
