"""A job list of 8 bakes, serially and on a local Ray instance with 2 workers (issue 13).

The Obstacles sample scene with the Footstep Mannequin at Start, and 8 jobs: the scene's
Goal and six more goals on the floor, and one goal far off every surface, which fails at
run time (its check passes: the object exists). Prints both runs' summary tables and
wall times:

    .venv/bin/python benchmarks/bench_ray_batch.py [--workers 2] [--fresh-workers] [--keep DIR]

The serial run is ``python -m footstep_planner bake SCENE --job JOBS.json`` in a
subprocess (one Blender, one job after another); the Ray run is ``bake ... --ray
local:N`` when the command line has ``--ray``, else ``ray_batch.run_on_ray`` called as
the command line calls it. ``--fresh-workers`` runs each Ray job in a new worker process
(max_calls=1) to measure what that costs. Last, for each job: whether it planned the
same footprints both ways, and where not, which one the job baked alone agrees with.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CHARACTER = "Footstep Mannequin"
#: goals on the Obstacles scene's floor (x, y, z, heading: 0 faces -Y, pi faces +Y), each
#: planned in about a second; "Island" is off every surface
GOALS = {"NearWall": (-5, -3, 0, math.pi), "West": (-7, -1, 0, math.pi), "Centre": (-1, 0, 0, math.pi),
         "SouthWest": (-8, -5, 0, math.pi), "Middle": (-3, 0, 0, math.pi), "East": (1, -1, 0, math.pi),
         "Island": (40, 40, 0, 0.0)}


def build_batch(folder: str, package: str = "footstep_planner") -> tuple[str, str, list[dict]]:
    """The scene file and the job list of the benchmark in ``folder`` (package: the name
    the add-on is imported by, registered): (scene path, JOBS.json path, jobs)."""
    from importlib import import_module

    import bpy

    sample = import_module(package + ".blender.sample.sample_scenes")
    mannequin = import_module(package + ".blender.sample.mannequin")
    bpy.ops.wm.read_homefile(use_empty=True)
    scene = sample.build("obstacles")
    scene.render.fps = 30
    mannequin.add_to_scene(scene, "Start")
    for name, (x, y, z, heading) in GOALS.items():
        ob = bpy.data.objects.new(name, None)
        ob.location, ob.rotation_euler.z = (x, y, z), heading
        scene.collection.objects.link(ob)
    os.makedirs(folder, exist_ok=True)
    path = os.path.join(folder, "obstacles.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path, compress=True)
    jobs = [{"character": CHARACTER, "goal": goal, "name": goal.lower()} for goal in ["Goal", *GOALS]]
    jobs_path = os.path.join(folder, "jobs.json")
    with open(jobs_path, "w", encoding="utf-8") as fh:
        json.dump(jobs, fh, indent=1)
    return path, jobs_path, jobs


def run_serial(scene: str, jobs_path: str, out_dir: str) -> tuple[float, str, int]:
    """(wall s, stdout, exit status) of the job list run one after another in one Blender."""
    args = [sys.executable, "-m", "footstep_planner", "bake", scene, "--job", jobs_path,
            "--report", os.path.join(out_dir, "serial.json")]
    t0 = time.perf_counter()
    p = subprocess.run(args, cwd=ROOT, capture_output=True, text=True)
    return time.perf_counter() - t0, p.stdout, p.returncode


def _cli_has_ray() -> bool:
    """Whether ``bake`` takes ``--ray`` yet."""
    p = subprocess.run([sys.executable, "-m", "footstep_planner", "bake", "--help"], cwd=ROOT,
                       capture_output=True, text=True)
    return "--ray" in p.stdout


def run_ray(scene: str, jobs_path: str, out_dir: str, workers: int, fresh: bool) -> tuple[float, str, int]:
    """(wall s, summary, exit status) of the job list on a local Ray instance."""
    if _cli_has_ray() and not fresh:
        args = [sys.executable, "-m", "footstep_planner", "bake", scene, "--job", jobs_path, "--ray",
                f"local:{workers}", "--report", os.path.join(out_dir, "ray.json"),
                "--out", os.path.join(out_dir, "ray.blend")]
        t0 = time.perf_counter()
        p = subprocess.run(args, cwd=ROOT, capture_output=True, text=True)
        return time.perf_counter() - t0, p.stdout, p.returncode
    return _run_ray_direct(scene, jobs_path, out_dir, workers, fresh)


def _run_ray_direct(scene, jobs_path, out_dir, workers, fresh):
    from footstep_planner.core.base.files import Outputs
    from footstep_planner.core.jobs import exit_status, job_label, normalised, summary_table
    from footstep_planner.blender.command.ray_batch import run_on_ray

    with open(jobs_path, encoding="utf-8") as fh:
        raw = json.load(fh)
    jobs = [(n, job_label(n, job), normalised(job)) for n, job in enumerate(raw, 1)]
    common = {"markers": False, "keep_frame_range": False, "body_on": "object", "traversable": None,
              "obstacles": None, "set": []}
    t0 = time.perf_counter()
    with Outputs([scene, jobs_path]) as outs:
        dest = {n: {"out": outs.claim(os.path.join(out_dir, f"ray_{n}.blend"), f"scene of job {n}"),
                    "report": outs.claim(os.path.join(out_dir, f"ray_{n}.json"), f"report of job {n}")}
                for n, _, _ in jobs}
        outcomes = run_on_ray(f"local:{workers}", scene, jobs, common, dest, outs, max_calls=1 if fresh else 0,
                              progress=lambda o: print(f"  {o.label}: {o.status}", file=sys.stderr))
        outs.commit()
    wall = time.perf_counter() - t0
    return wall, summary_table(outcomes, wall), exit_status(outcomes)


def compare_plans(folder: str, scene: str, jobs: list[dict]) -> None:
    """Whether each baked job planned the same footprints serially and on Ray; where not,
    which of the two the job baked alone (a fresh process, from the file) agrees with."""
    print("same footprints serially and on Ray (else: which one the job baked alone matches):")
    for n, job in enumerate(jobs, 1):
        paths = [os.path.join(folder, f"{kind}_{n}.json") for kind in ("serial", "ray")]
        if not all(os.path.exists(p) for p in paths):
            continue
        serial, ray = (json.load(open(p, encoding="utf-8"))["footprints"] for p in paths)
        verdict = "same"
        if serial != ray:
            alone = os.path.join(folder, f"alone_{n}.json")
            subprocess.run([sys.executable, "-m", "footstep_planner", "bake", scene, "--character", job["character"],
                            "--goal", job["goal"], "--name", job["name"], "--report", alone], cwd=ROOT,
                           capture_output=True)
            mine = json.load(open(alone, encoding="utf-8"))["footprints"]
            verdict = "differ; alone matches " + ("Ray" if mine == ray else "serial" if mine == serial else "neither")
        print(f"  job {n} {job['name']:<10s} {verdict}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--fresh-workers", action="store_true", help="a new worker process per job (max_calls=1)")
    ap.add_argument("--keep", metavar="DIR", help="build and write into DIR (default: a temporary folder)")
    ap.add_argument("--skip-serial", action="store_true")
    args = ap.parse_args(argv)
    sys.path.insert(0, ROOT)
    import footstep_planner

    footstep_planner.register()
    folder = args.keep or tempfile.mkdtemp(prefix="bench_ray_batch_")
    scene, jobs_path, jobs = build_batch(folder)
    print(f"{len(jobs)} jobs on {scene} ({os.cpu_count()} cores here)\n")
    if not args.skip_serial:
        wall, table, status = run_serial(scene, jobs_path, folder)
        print(f"serially, one Blender ({wall:.1f} s wall, exit status {status}):\n{table}")
    mode = "a fresh worker process per job" if args.fresh_workers else "workers reused"
    wall, table, status = run_ray(scene, jobs_path, folder, args.workers, args.fresh_workers)
    print(f"on local Ray, {args.workers} workers, {mode} ({wall:.1f} s wall incl. Ray's start and stop, "
          f"exit status {status}):\n{table}\n")
    compare_plans(folder, scene, jobs)
    return 0


if __name__ == "__main__":
    sys.exit(main())
