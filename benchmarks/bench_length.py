"""Cost against the path's length (issue 28): a planned path laid end to end 1, 2, 4, 8
and 16 times on an open floor, synthesized (smoothing to blend groups), its pose blended
and its feet solved (IK) as a bake does, each stage's least time over ``--repeat`` runs
and its ratio to the single path's. Linear in the path: 16 times the path costs at most
17 times the time.

    .venv/bin/python benchmarks/bench_length.py [--scene jumps] [--library cmu|mannequin] [--repeat 3]
        [--lengths 1,2,4,8,16]

The path is the scene's own plan (its footprints' heights laid on the floor, z = 0),
from standing to standing as ``planning.synthesize`` plays it; each copy turned and moved
so its first footprint falls where the previous copy's last one stands
(``bench_synthesis.repeat_path``).
"""

from __future__ import annotations

import argparse
import copy
import os
import sys
import time
from dataclasses import replace

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_synthesis import repeat_path  # noqa: E402
from library import MOCAP, cmu_files  # noqa: E402  (benchmarks/library.py: the CMU library)

STAGES = ("smoothing", "refinement", "body_trajectory", "blend_groups", "pose_blend", "ik")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scene", default="jumps")
    ap.add_argument("--library", choices=("cmu", "mannequin"), default="cmu")
    ap.add_argument("--mocap", default=MOCAP)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--lengths", default="1,2,4,8,16")
    ap.add_argument("--clock", choices=("cpu", "wall"), default="cpu",
                    help="stage times in this process's CPU seconds (default: steadier on a shared machine) "
                         "or wall-clock seconds")
    args = ap.parse_args()
    if args.clock == "cpu":  # (every stage timer reads time.perf_counter)
        time.perf_counter = time.process_time
    import bpy

    from footstep_planner import register
    from footstep_planner.blender.command import batch
    from footstep_planner.blender.sample import mannequin
    from footstep_planner.blender import planning
    from footstep_planner.core.solve.frames import solve
    from footstep_planner.blender.sample.sample_scenes import build
    from footstep_planner.blender.read.surfaces import BvhGround
    from footstep_planner.core.base.settings import Settings
    from footstep_planner.core.plan.surface import TriMesh

    register()
    bpy.ops.wm.read_homefile(use_empty=True)
    scene = build(args.scene)
    scene.render.fps = 30
    if args.library == "cmu":
        from footstep_planner.blender.read.clips import import_clips

        ob, _ = import_clips(cmu_files(args.mocap), name="CMU")
        if ob.animation_data:
            ob.animation_data.action = None
    else:
        ob, _ = mannequin.add_to_scene(scene, "Start")
    goal, heading, start = batch.goal_and_start(scene, "Goal", None, "Start")
    result, setup = planning.plan(scene, ob, goal, heading, start)
    big = 5000.0
    floor = BvhGround(TriMesh(np.array([[-big, -big, 0], [big, -big, 0], [big, big, 0], [-big, big, 0]], float),
                              np.array([[0, 1, 2], [0, 2, 3]]), np.zeros(2, np.int64), ("floor",)))
    planner = copy.copy(setup.planner)
    planner.ground, planner.obstacles = floor, None
    flat = [replace(f, position=np.array([f.position[0], f.position[1], 0.0])) for f in result.footprints]
    start = [replace(f, position=np.array([f.position[0], f.position[1], 0.0])) for f in setup.start or ()]
    floor_setup = replace(setup, planner=planner, start=start or None)
    lengths = [int(x) for x in args.lengths.split(",")]
    rows = {}
    for k in lengths:
        path = flat if k == 1 else repeat_path(flat, k)
        res_k = replace(result, footprints=path)
        best = {}
        for _ in range(args.repeat):
            syn = planning.synthesize(scene, res_k, floor_setup)
            t0 = time.perf_counter()
            solved = solve(syn, floor_setup, Settings())
            whole = time.perf_counter() - t0
            sec = {s: syn.seconds[s] for s in STAGES[:4]}
            sec.update(pose_blend=solved.pose_seconds, ik=solved.ik_seconds)
            sec["solve"] = whole
            for s, v in sec.items():
                best[s] = min(best.get(s, np.inf), v)
        rows[k] = (len(path), len(syn.t), best)
        print(f"x{k}: {len(path)} footprints, {len(syn.t)} frames", flush=True)
    cols = STAGES + ("total",)
    base = rows[lengths[0]][2]
    base_total = sum(base[s] for s in STAGES)
    head = f"{'length':>6s} {'footprints':>10s} {'frames':>7s} " + " ".join(f"{c:>17s}" for c in cols)
    print(f"\ncost against the path's length ({args.library} library, {args.scene} path on a floor), "
          f"{args.clock} ms (least of {args.repeat}) and the ratio to x{lengths[0]}")
    print(head + "\n" + "-" * len(head))
    for k in lengths:
        n, frames, best = rows[k]
        total = sum(best[s] for s in STAGES)
        cells = [f"{best[s] * 1e3:8.1f} ({best[s] / max(base[s], 1e-12):5.1f})" for s in STAGES]
        cells.append(f"{total * 1e3:8.1f} ({total / base_total:5.1f})")
        print(f"{'x%d' % k:>6s} {n:10d} {frames:7d} " + " ".join(f"{c:>17s}" for c in cells))
    worst = max(rows[lengths[-1]][2][s] / max(base[s], 1e-12) for s in STAGES)
    grown = rows[lengths[-1]][1] / rows[lengths[0]][1]
    print(f"largest ratio at x{lengths[-1]}: {worst:.1f} for {grown:.1f} times the frames "
          f"(linear: at most {lengths[-1] / lengths[0] + 1:.0f}); "
          f"machine: {os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
