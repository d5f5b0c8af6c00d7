"""Every frame against a reference commit, side by side (issue 28): today's tree and a
reference tree planned, synthesized, solved and baked on the same sample scene in
interleaved fresh processes, each stage's time and its ratio printed, so a slowdown
shows whatever the machine's speed or load.

    .venv/bin/python benchmarks/bench_paired.py [--ref 341487a | --ref-tree DIR] [--scenes jumps,turns]
        [--library mannequin|cmu] [--rounds 4] [--repeat 3]

``--ref`` makes a temporary git worktree of that commit (removed at the end);
``--ref-tree`` uses a checkout already made. Each round runs one process per tree
(alternating which goes first); each process runs ``planning.run`` (search to bake)
``--repeat`` times on one scene and keeps each stage's least time (the first run of a
process pays for lazy imports: keep ``--repeat`` at 2 or more). The table gives, per
stage, the median over the rounds of each tree's times (ms), their ratio (today over the
reference) and the range over the rounds; ``frame`` is smoothing to bake (IK and bake
included, the search not) over the frames. It also prints the played figures of both
(skate, footprint error, penetration, pops): they should agree.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
MOCAP = os.path.join(os.path.dirname(ROOT), "shared", "mocap", "cmu")

#: stages of ``doc["stages"]`` (``pipeline.stage_row``), in the thesis's order
STAGES = ("search", "smoothing", "refinement", "body_trajectory", "blend_groups", "pose_blend", "ik", "bake")

#: run in each fresh process, in the tree's own folder: one scene planned ``repeat`` times
_CHILD = r"""
import glob, json, os, sys, time
if sys.argv[5] == "cpu":  # (every stage timer reads time.perf_counter)
    time.perf_counter = time.process_time
import importlib
import bpy
from footstep_planner import register


def _mod(*names):  # (the first of the module's homes the tree has: the stage layout, or the flat one before it)
    for name in names:
        try:
            return importlib.import_module("footstep_planner.blender." + name)
        except ModuleNotFoundError:
            continue
    raise ModuleNotFoundError(names[-1])


batch = _mod("command.batch", "batch")
mannequin = _mod("sample.mannequin", "mannequin")
planning = _mod("planning")
build = _mod("sample.sample_scenes", "sample_scenes").build
register()
scene_name, library, repeat, mocap = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4]
names = ["16_16", "16_11", "16_13", "16_17", "16_19", "16_35", "16_37", "16_39", "16_41", "16_43", "49_05"]
best, quality = {}, None
bpy.ops.wm.read_homefile(use_empty=True)
scene = build(scene_name)
scene.render.fps = 30
if library == "cmu":
    import_clips = _mod("read.clips", "clips").import_clips
    ob, _ = import_clips([sorted(glob.glob(os.path.join(mocap, f"cmu_{n}_*.bvh")))[0] for n in names], name="CMU")
    if ob.animation_data:
        ob.animation_data.action = None
else:
    ob, _ = mannequin.add_to_scene(scene, "Start")
goal, heading, start = batch.goal_and_start(scene, "Goal", None, "Start")
for i in range(repeat):
    doc = planning.run(scene, ob, goal, heading, start, name="paired", frame_start=1)
    for k, v in doc["stages"].items():
        best[k] = v if k not in best or not k.endswith("_ms") else min(best[k], v)
    q = doc["quality"]
    pen = q["penetration"]
    quality = {"skate_max_mm": q["foot_skate"]["max_mm"], "skate_mean_mm": q["foot_skate"]["mean_mm"],
               "fp_err_max_mm": q["footprint_error"]["max_mm"], "penetration_mm": pen["max_mm"],
               "tip_mm": pen.get("tip_max_mm"), "lowest_mm": pen.get("lowest_mm"),
               "floating_mm": q["floating"]["max_mm"], "pops": q["pops"]["introduced"]["count"],
               "goal_cm": round(q["goal"]["distance_m"] * 100, 2)}
print("PAIRED " + json.dumps({"stages": best, "quality": quality}))
"""


def run_child(tree: str, scene: str, library: str, repeat: int, mocap: str, clock: str) -> dict:
    """One fresh process in ``tree``: its stage times (least of ``repeat``) and figures."""
    env = dict(os.environ, PYTHONPATH=tree, BLENDER_USER_RESOURCES=tempfile.mkdtemp(prefix="fp_paired_"))
    res = subprocess.run([sys.executable, "-c", _CHILD, scene, library, str(repeat), mocap, clock], cwd=tree,
                         env=env, capture_output=True, text=True)
    shutil.rmtree(env["BLENDER_USER_RESOURCES"], ignore_errors=True)
    lines = [ln for ln in res.stdout.splitlines() if ln.startswith("PAIRED ")]
    if res.returncode != 0 or not lines:
        sys.exit(f"{tree}: {scene} failed ({res.returncode}):\n{res.stderr[-3000:]}")
    return json.loads(lines[-1][7:])


def frame_ms(st: dict) -> float:
    """ms a frame from smoothing to bake (the search left out)."""
    return sum(st[f"{k}_ms"] for k in STAGES[1:]) / max(st["frames"], 1)


def table(scene: str, runs: dict) -> str:
    """The paired table of one scene: per stage the medians, their ratio and ranges."""
    rows = [f"{scene}: {runs['new'][0]['stages']['frames']} frames (today), "
            f"{runs['ref'][0]['stages']['frames']} (reference); ms, median of {len(runs['new'])} rounds [range]",
            f"{'stage':16s} {'today':>20s} {'reference':>20s} {'ratio':>6s}"]
    for k in STAGES + ("frame",):
        vals = {w: np.array([frame_ms(r["stages"]) if k == "frame" else r["stages"][f"{k}_ms"] for r in runs[w]])
                for w in ("new", "ref")}
        cell = {w: f"{np.median(v):8.3f} [{v.min():.3f}-{v.max():.3f}]" if k == "frame" else
                f"{np.median(v):8.1f} [{v.min():.0f}-{v.max():.0f}]" for w, v in vals.items()}
        ratio = np.median(vals["new"]) / max(np.median(vals["ref"]), 1e-9)
        rows.append(f"{k:16s} {cell['new']:>20s} {cell['ref']:>20s} {ratio:6.2f}")
    for w in ("new", "ref"):
        rows.append(f"played ({'today' if w == 'new' else 'reference'}): " + json.dumps(runs[w][-1]["quality"]))
    return "\n".join(rows)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--ref", default="341487a", help="reference commit (a temporary worktree is made)")
    ap.add_argument("--ref-tree", help="a checkout of the reference already made (overrides --ref)")
    ap.add_argument("--tree", default=ROOT, help="today's tree (default: this one)")
    ap.add_argument("--scenes", default="jumps")
    ap.add_argument("--library", choices=("mannequin", "cmu"), default="mannequin")
    ap.add_argument("--mocap", default=MOCAP)
    ap.add_argument("--rounds", type=int, default=4)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--clock", choices=("cpu", "wall"), default="cpu",
                    help="stage times in the processes' CPU seconds (default: steadier on a shared machine) "
                         "or wall-clock seconds")
    args = ap.parse_args()
    made = None
    ref = args.ref_tree
    if ref is None:
        made = tempfile.mkdtemp(prefix="fp_ref_")
        ref = os.path.join(made, "tree")
        subprocess.run(["git", "-C", args.tree, "worktree", "add", "--detach", ref, args.ref], check=True,
                       capture_output=True)
    try:
        for tree in (args.tree, ref):  # (a fresh checkout's modules compiled before any round)
            subprocess.run([sys.executable, "-m", "compileall", "-q", os.path.join(tree, "footstep_planner")],
                           capture_output=True)
        load = [os.getloadavg()[0]]
        for scene in args.scenes.split(","):
            runs = {"new": [], "ref": []}
            for r in range(args.rounds):
                order = (("new", args.tree), ("ref", ref)) if r % 2 == 0 else (("ref", ref), ("new", args.tree))
                for who, tree in order:
                    runs[who].append(run_child(tree, scene, args.library, args.repeat, args.mocap, args.clock))
                load.append(os.getloadavg()[0])
            print(table(scene, runs), flush=True)
            print()
        print(f"{args.clock} clock; library {args.library}; today {args.tree}, reference {args.ref_tree or args.ref}; "
              f"machine: {os.cpu_count()} CPUs, load average {min(load):.2f} to {max(load):.2f}")
    finally:
        if made:
            subprocess.run(["git", "-C", args.tree, "worktree", "remove", "--force", ref], capture_output=True)
            shutil.rmtree(made, ignore_errors=True)


if __name__ == "__main__":
    main()
