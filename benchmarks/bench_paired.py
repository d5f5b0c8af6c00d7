"""Today's tree against a reference commit, side by side on one machine: each stage's time
over the reference's, so a slowdown shows whatever the machine's speed (issue 28).

    .venv/bin/python benchmarks/bench_paired.py [--reference 341487a] [--rounds 3]
        [--scenes jumps,turns] [--character mannequin|cmu]

The reference is checked out in a temporary git worktree (detached, removed at the end).
Two worker processes, one per tree (each imports its own ``footstep_planner``), run the
whole tool on each sample scene (``planning.run``: plan, synthesize, IK, bake, measure)
with the character standing at its Start, the rounds interleaved (A B, then B A, ...) so
both trees meet the same machine load. Each stage's figure is the median over the rounds
of the report's own stage times (``stages``: search, refinement, body trajectory, blend
groups, pose blend, IK, bake; the whole frame is the synthesis from smoothing to IK over
the frames, as the report's ``per_frame_ms``); the table prints both medians and their
ratio (today over the reference), with the date and the machine's load.
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

#: The stages printed (the report's ``stages`` keys, less "_ms"), in the pipeline's order.
STAGES = ("search", "smoothing", "refinement", "body_trajectory", "blend_groups", "pose_blend", "ik", "bake",
          "per_frame")


def worker(tree: str, character: str) -> None:
    """Serve scene names on stdin: each line's scene run once, its stages (ms) a JSON
    line on stdout. Imports the add-on from ``tree``."""
    sys.path.insert(0, tree)
    sys.path.insert(0, os.path.join(tree, "benchmarks"))
    import bpy

    from footstep_planner import register
    from footstep_planner.blender import planning
    from footstep_planner.blender.sample.sample_scenes import build

    register()
    print("ready", flush=True)
    for line in sys.stdin:
        name = line.strip()
        bpy.ops.wm.read_homefile(use_empty=True)
        scene = build(name)
        scene.render.fps = 30
        ob = _character(character, scene)
        goal, heading = planning.goal_of(scene, "Goal")
        t = time.process_time()
        doc = planning.run(scene, ob, goal, heading, None, None, name=f"paired {name}", frame_start=1)
        stages = dict(doc["stages"])
        stages["cpu_s"] = time.process_time() - t
        print(json.dumps(stages), flush=True)


def _character(kind: str, scene):
    """The character standing at the scene's Start: the sample character, or CMU's library."""
    if kind == "mannequin":
        from footstep_planner.blender.sample import mannequin
        return mannequin.add_to_scene(scene, "Start")[0]
    from library import ENDS, LIBRARY, MOCAP, cmu_files

    from footstep_planner.blender.read.clips import import_clips

    ob, _ = import_clips(cmu_files(MOCAP, LIBRARY + ENDS), name="CMU")
    start = scene.objects["Start"]
    ob.location, ob.rotation_euler.z = start.location, start.rotation_euler.z
    return ob


def _start(tree: str, character: str) -> subprocess.Popen:
    env = dict(os.environ, PYTHONPATH=tree)
    p = subprocess.Popen([sys.executable, os.path.abspath(__file__), "--worker", tree, "--character", character],
                         stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, cwd=tree, env=env)
    line = p.stdout.readline().strip()
    if line != "ready":
        raise SystemExit(f"the worker for {tree} did not start (it said {line!r})")
    return p


def _ask(p: subprocess.Popen, scene: str) -> dict:
    p.stdin.write(scene + "\n")
    p.stdin.flush()
    line = p.stdout.readline()
    if not line:
        raise SystemExit(f"a worker stopped on scene {scene!r}")
    return json.loads(line)


def table(runs: dict, scenes: list, ref: str) -> str:
    """The paired table: per scene and stage, the medians (ms) and today over the reference."""
    out = [f"{'scene':10s} {'stage':16s} {'today ms':>10s} {ref + ' ms':>12s} {'ratio':>7s}"]
    for sc in scenes:
        for st in STAGES:
            key = st + "_ms"
            a = [r[key] for r in runs["new"][sc] if key in r]
            b = [r[key] for r in runs["ref"][sc] if key in r]
            if not a or not b:
                continue
            ma, mb = float(np.median(a)), float(np.median(b))
            ratio = ma / mb if mb > 0 else float("nan")
            out.append(f"{sc:10s} {st:16s} {ma:10.3f} {mb:12.3f} {ratio:7.2f}")
    return "\n".join(out)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--reference", default="341487a", help="the commit to compare with (default 341487a)")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--scenes", default="jumps", help="sample scenes, comma separated")
    ap.add_argument("--character", choices=("mannequin", "cmu"), default="mannequin")
    ap.add_argument("--worker", default="", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.worker:
        worker(args.worker, args.character)
        return
    scenes = [s for s in args.scenes.split(",") if s]
    tmp = tempfile.mkdtemp(prefix="fp_paired_")
    ref_tree = os.path.join(tmp, "reference")
    made = subprocess.run(["git", "-C", ROOT, "worktree", "add", "--detach", ref_tree, args.reference],
                          capture_output=True, text=True)
    if made.returncode != 0:
        raise SystemExit(f"cannot check out {args.reference!r}: {made.stderr.strip()}")
    try:
        procs = {"new": _start(ROOT, args.character), "ref": _start(ref_tree, args.character)}
        runs = {k: {s: [] for s in scenes} for k in procs}
        for r in range(args.rounds):
            order = ("new", "ref") if r % 2 == 0 else ("ref", "new")
            for sc in scenes:
                for k in order:
                    runs[k][sc].append(_ask(procs[k], sc))
            print(f"round {r + 1} of {args.rounds} done", file=sys.stderr, flush=True)
        for p in procs.values():
            p.stdin.close()
            p.wait(timeout=60)
    finally:
        subprocess.run(["git", "-C", ROOT, "worktree", "remove", "--force", ref_tree], capture_output=True)
    print(f"Paired stages: today's tree over {args.reference}, {args.character}, {args.rounds} interleaved rounds, "
          f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, {os.cpu_count()} cores, "
          f"load {os.getloadavg()[0]:.2f}")
    print(table(runs, scenes, args.reference))


if __name__ == "__main__":
    main()
