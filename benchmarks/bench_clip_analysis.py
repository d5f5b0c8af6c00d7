"""Time the clip pipeline on the CMU clips: BVH import, sampling an Action into arrays
(pose bases + forward kinematics), and the analysis. Prints a table.

    .venv/bin/python benchmarks/bench_clip_analysis.py [--fps 30] [--repeat 3]
"""

import argparse
import glob
import os
import sys
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--mocap", default=os.path.join(os.path.dirname(ROOT), "shared", "mocap", "cmu"))
    ap.add_argument("--fps", type=float, default=120)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    import bpy

    from footstep_planner import register
    from footstep_planner.blender.read.clips import import_clips
    from footstep_planner.blender.read.scene import clip_from_action, rig_from_armature
    from footstep_planner.core.clips.analysis import analyze_clip, forget_analyses

    register()
    files = sorted(glob.glob(os.path.join(args.mocap, "*.bvh")))
    if not files:
        sys.exit(f"no BVH files in {args.mocap}")
    bpy.ops.wm.read_homefile(use_empty=True)
    bpy.context.scene.render.fps = int(args.fps)
    print(f"{'clip':36s} {'frames':>6s} {'import ms':>9s} {'sample ms':>9s} {'analyse ms':>10s} {'per frame us':>12s}"
          f" {'again ms':>8s}")
    totals = np.zeros(4)
    nframes = 0
    for path in files:
        t = [[], [], [], []]
        for _ in range(args.repeat):
            t0 = time.perf_counter()
            ob, (act,) = import_clips([path])
            t1 = time.perf_counter()
            rig = rig_from_armature(ob)
            motion = clip_from_action(ob, act, rig)
            t2 = time.perf_counter()
            forget_analyses()  # (the analysis itself, not the one kept from the repeat before)
            analyze_clip(motion)
            t3 = time.perf_counter()
            analyze_clip(motion)  # (again: the kept analysis, as a re-plan gets it)
            t4 = time.perf_counter()
            for i, d in enumerate((t1 - t0, t2 - t1, t3 - t2, t4 - t3)):
                t[i].append(d)
        best = np.array([min(x) for x in t]) * 1e3
        totals += best
        nframes += motion.n
        print(f"{os.path.basename(path)[:-4]:36s} {motion.n:6d} {best[0]:9.1f} {best[1]:9.1f} {best[2]:10.1f} "
              f"{1e3 * best[1:3].sum() / motion.n:12.1f} {best[3]:8.1f}")
    print(f"{'total':36s} {nframes:6d} {totals[0]:9.1f} {totals[1]:9.1f} {totals[2]:10.1f} "
          f"{1e3 * totals[1:3].sum() / nframes:12.1f} {totals[3]:8.1f}")
    print(f"(best of {args.repeat}; sampling at {args.fps:g} fps; 'again': the same clip analysed a second time, "
          f"given the analysis kept; machine: {os.cpu_count()} cores, load {os.getloadavg()[0]:.2f})")


if __name__ == "__main__":
    main()
