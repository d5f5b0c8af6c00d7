"""Footstep planning: time and memory on the sample scenes and on open floors of growing
size, with the CMU subject-16 library and its running leap. Prints two tables.

    .venv/bin/python benchmarks/bench_navigation.py [--sizes 10,30,100] [--repeat 3]

'field' is the heuristic's distance field (built per plan), 'search' the lazy A* with
its support queries (the lazy equivalent of building the graph); 'cached' is a second
plan on unchanged geometry, reusing the support answers.
"""

import argparse
import os
import resource
import sys
import time
import tracemalloc

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)
from library import MOCAP, cmu_files  # noqa: E402  (benchmarks/library.py: the CMU library)



def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--mocap", default=MOCAP)
    ap.add_argument("--sizes", default="10,30,100")
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    import bpy

    from footstep_planner import register
    from footstep_planner.blender import planning
    from footstep_planner.blender.read.clips import import_clips
    from footstep_planner.blender.sample.sample_scenes import _box, _collection, _marker, _prism, build
    from footstep_planner.core.clips.analysis import forget_analyses

    register()
    files = cmu_files(args.mocap)

    def with_character():
        sc = bpy.context.scene
        sc.render.fps = 30
        ob, _ = import_clips(files, name="CMU")
        return sc, ob

    def run(sc, ob):
        goal = np.array(sc.objects["Goal"].location)
        forget_analyses()  # (the setup as a character's first plan: its clips analysed afresh)
        t = time.perf_counter()
        setup = planning.plan_setup(sc, ob)
        t_setup = time.perf_counter() - t
        start = planning.marker_footprints(sc.objects["Start"], setup)
        pl = setup.planner
        pl.cache.table.clear()
        first = pl.plan(start, goal)
        cached = min((pl.plan(start, goal) for _ in range(args.repeat)), key=lambda r: r.seconds)
        # memory in a separate traced plan (tracing slows the search many times over)
        pl.cache.table.clear()
        tracemalloc.start()
        pl.plan(start, goal)
        mem = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        return setup, first, cached, mem, t_setup

    print("Sample scenes (CMU library: 10 clips of subject 16 and the 49_05 leap)")
    head = (f"{'scene':10s} {'steps':>5s} {'footprints':>10s} {'expanded':>8s} {'field ms':>8s} "
            f"{'search ms':>9s} {'cached ms':>9s} {'peak MB':>7s}")
    print(head)
    print("-" * len(head))
    for name in ("jumps", "turns", "obstacles"):
        build(name)
        sc, ob = with_character()
        setup, first, cached, mem, t_setup = run(sc, ob)
        print(f"{name:10s} {setup.planner.steps.n:5d} {len(first.footprints):10d} {first.expanded:8d} "
              f"{first.field_seconds * 1e3:8.0f} {(first.seconds - first.field_seconds) * 1e3:9.0f} "
              f"{(cached.seconds - cached.field_seconds) * 1e3:9.0f} {mem / 2**20:7.1f}")
    print(f"(setup, clip analysis of the library: {t_setup * 1e3:.0f} ms, once per character)")

    print("\nOpen floor with scattered pillars (one per 25 m2), corner to corner")
    head = (f"{'floor m':>8s} {'pillars':>7s} {'footprints':>10s} {'expanded':>8s} {'field ms':>8s} "
            f"{'search ms':>9s} {'cached ms':>9s} {'peak MB':>7s}")
    print(head)
    print("-" * len(head))
    rng = np.random.default_rng(5)
    for size in [float(v) for v in args.sizes.split(",")]:
        bpy.ops.wm.read_homefile(use_empty=True)
        sc = bpy.context.scene
        t_, o_ = _collection(sc, "Traversable", "TRAVERSABLE"), _collection(sc, "Obstacles", "OBSTACLE")
        _box(t_, "Floor", 0, size, 0, size, -0.3, 0.0)
        n = int(size * size / 25)
        placed = 0
        for x, y in rng.uniform(2, size - 2, (n * 2, 2)):
            if placed == n:
                break
            if min(np.hypot(x - 1.5, y - 1.5), np.hypot(x - size + 1.5, y - size + 1.5)) < 3:
                continue
            _prism(o_, f"P{placed}", [(x + 0.3 * np.cos(a), y + 0.3 * np.sin(a))
                                       for a in np.linspace(0, 2 * np.pi, 8, endpoint=False)], 2.5, 0.0)
            placed += 1
        _marker(sc, "Start", (1.5, 1.5, 0.0), np.pi * 0.75)
        _marker(sc, "Goal", (size - 1.5, size - 1.5, 0.0), np.pi * 0.75)
        sc2, ob = with_character()
        setup, first, cached, mem, _ = run(sc2, ob)
        print(f"{size:4.0f}x{size:<3.0f} {placed:7d} {len(first.footprints):10d} {first.expanded:8d} "
              f"{first.field_seconds * 1e3:8.0f} {(first.seconds - first.field_seconds) * 1e3:9.0f} "
              f"{(cached.seconds - cached.field_seconds) * 1e3:9.0f} {mem / 2**20:7.1f}")
    print(f"(machine: {os.cpu_count()} cores, load {os.getloadavg()[0]:.2f}; "
          f"process max RSS {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} MB)")


if __name__ == "__main__":
    main()
