"""Memory and time of a long clip (issue 13): a 100,000-frame BVH imported and analysed.

The clip is CMU subject 16's straight walk (``cmu_16_16_walk``, 510 frames at 120 fps)
repeated end to end, each repeat carried on by the walk's own travel so the hips move on
(without ``../shared``, the small walker the tests write). Every step runs in a fresh
``python -m footstep_planner`` process, which reports its own peak resident memory
(``ru_maxrss``: Blender's module and everything it loads included) and the verb's time:

    .venv/bin/python benchmarks/bench_long_clip.py [--frames 100000] [--keep DIR]

Steps: ``bpy at rest`` (Blender's module loaded, the add-on registered, nothing done),
``import-clips`` (the BVH into a saved .blend), ``analyze BVH`` (the BVH imported and
analysed in one process, as ``analyze CLIP.bvh`` does), ``analyze .blend`` (the saved
library analysed). The target is under 1 GB peak for each.

Measured (2 cores, loaded machine; bpy at rest 302 MB), peak MB and the verb's seconds:

    step             before (Blender's BVH importer)   after
    import-clips     2,699 MB   90 s                     631 MB   16 s
    analyze BVH      3,834 MB  146 s                     669 MB   18 s
    analyze .blend   3,215 MB   57 s                     825 MB    8 s

The clip is kept as F-curve samples (``clip_keys.SAMPLED_FRAMES``: 200 MB, not the 900 MB of
keyframes); a .blend opened with it assigned also holds Blender's evaluated copy of it.
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
WALK = os.path.join(os.path.dirname(ROOT), "shared", "mocap", "cmu", "cmu_16_16_walk.bvh")

#: run in each fresh process: load bpy, register, run one verb, print a JSON line
_CHILD = r"""
import json, os, resource, sys, time
t0 = time.perf_counter()
import bpy
from footstep_planner import register
from footstep_planner.blender.command.cli import cli_main
register()
t1 = time.perf_counter()
argv = json.loads(sys.argv[1])
code = cli_main(argv) if argv else 0
t2 = time.perf_counter()
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
print("BENCH " + json.dumps({"code": code, "load_s": t1 - t0, "verb_s": t2 - t1, "peak_mb": peak}))
"""


def long_walk(path: str, frames: int) -> str:
    """Write a ``frames``-frame BVH at ``path``: the CMU walk repeated, each repeat moved
    on by the walk's travel (root X and Z), or without the CMU file the small walker of
    tests/bvh_files.py."""
    src = WALK
    if not os.path.isfile(src):
        sys.path.insert(0, os.path.join(ROOT, "tests"))
        from bvh_files import walker

        src = walker(path + ".walker.bvh", frames=120)
    with open(src) as fh:
        head, motion = fh.read().split("MOTION", 1)
    if src != WALK:
        os.remove(src)
    rows = motion.strip().splitlines()
    data = np.loadtxt(rows[2:], dtype=np.float64)
    step = data[-1, [0, 2]] - data[0, [0, 2]]
    step += step / (len(data) - 1)  # one frame's travel joins the seam
    reps = -(-frames // len(data))
    out = np.tile(data, (reps, 1))[:frames]
    out[:, [0, 2]] += np.repeat(np.arange(reps)[:, None] * step, len(data), axis=0)[:frames]
    with open(path, "w") as fh:
        fh.write(head + f"MOTION\nFrames: {frames}\n{rows[1]}\n")
        np.savetxt(fh, out, fmt="%.4f")
    return path


def run_step(argv: list[str], resources: str) -> dict:
    """One fresh process running ``cli_main(argv)`` (nothing for an empty list), Blender's
    user resources in ``resources``."""
    env = dict(os.environ, PYTHONPATH=ROOT, BLENDER_USER_RESOURCES=resources)
    res = subprocess.run([sys.executable, "-c", _CHILD, json.dumps(argv)], cwd=ROOT, env=env,
                         capture_output=True, text=True)
    lines = [ln for ln in res.stdout.splitlines() if ln.startswith("BENCH ")]
    if res.returncode != 0 or not lines:
        sys.exit(f"step {argv} failed ({res.returncode}):\n{res.stderr[-3000:]}")
    doc = json.loads(lines[-1][6:])
    if doc["code"] != 0:
        sys.exit(f"step {argv} exited {doc['code']}:\n{res.stderr[-3000:]}")
    return doc


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--frames", type=int, default=100_000)
    ap.add_argument("--keep", metavar="DIR", help="build the clip and the .blend here and keep them")
    args = ap.parse_args()
    folder = args.keep or tempfile.mkdtemp(prefix="fp_long_clip_")
    os.makedirs(folder, exist_ok=True)
    bvh = long_walk(os.path.join(folder, "long_walk.bvh"), args.frames)
    blend = os.path.join(folder, "long_walk.blend")
    if os.path.exists(blend):
        os.remove(blend)
    steps = [("bpy at rest", []), ("import-clips", ["import-clips", bvh, "--out", blend]),
             ("analyze BVH", ["analyze", bvh]), ("analyze .blend", ["analyze", blend])]
    print(f"{args.frames:,} frames, BVH {os.path.getsize(bvh) / 2**20:.0f} MB"
          f"{'' if os.path.isfile(WALK) else ' (the tests walker: no CMU file)'}")
    print(f"{'frames':>8s}  {'step':16s} {'load s':>7s} {'verb s':>7s} {'peak MB':>8s}")
    worst = 0.0
    resources = tempfile.mkdtemp(prefix="fp_bench_")
    for name, argv in steps:
        doc = run_step(argv, resources)
        worst = max(worst, doc["peak_mb"])
        print(f"{args.frames:8d}  {name:16s} {doc['load_s']:7.1f} {doc['verb_s']:7.1f} {doc['peak_mb']:8.0f}",
              flush=True)
    print(f"worst peak {worst:.0f} MB (target < 1024 MB); machine: {os.cpu_count()} cores, "
          f"load {os.getloadavg()[0]:.2f}")
    shutil.rmtree(resources, ignore_errors=True)
    if not args.keep:
        shutil.rmtree(folder, ignore_errors=True)


if __name__ == "__main__":
    main()
