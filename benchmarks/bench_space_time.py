"""What the check round other characters costs the search when none of them is near (issue
29: "the space-time check costs at most 2 times today's step check per expansion when no
other character is near"). Each of ``bench_planner``'s thirty scenes is planned alone,
then with 8 and with 49 other characters walking the whole time beside the scene (20 m
off its ground, their feet planted step by step: bodies and footprints the check has to
look at and put aside). The paths must be the very same; the table gives the search's CPU
time per expansion each way and the ratio to alone, with medians and worsts.

    .venv/bin/python benchmarks/bench_space_time.py [--library cmu|sample] [--character FILE.npz]
        [--others 8,49] [--repeat 3] [--only NAME,...]

Times are the process's CPU time, the least of ``--repeat`` plans each way, interleaved
(alone, then each crowd, scene by scene): this machine's speed swings within a minute.
"""

import argparse
import os
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))
sys.path.insert(0, HERE)
from bench_planner import load_character  # noqa: E402
from scene_generator import benchmark_scenes, make_planner  # noqa: E402

FPS = 30.0
#: s: how long the others walk (every plan of the benchmark ends well within it)
SHOT = 90.0
#: m: how far beside the scene's ground the others walk
OFF = 20.0


def far_walkers(scene, count: int, seed: int = 0):
    """``count`` characters walking back and forth at 1.3 m/s in lanes 1 m apart, 20 m
    beside the scene's ground (past its largest x), for ``SHOT`` s, each foot planted for
    0.35 s of every 1 s (``core.plan.others.Others``)."""
    from footstep_planner.core.plan.navgraph import HIPS_HEIGHT
    from footstep_planner.core.plan.others import BODY_RADIUS, Others

    rng = np.random.default_rng(seed)
    x0 = max(p[1] for p in scene.plates) + OFF  # (plates' rows: x0, x1, y0, y1, ...)
    y0 = 0.5 * (scene.start[1] + scene.goal[1])
    times = np.arange(0, SHOT, 1 / FPS)
    phase = rng.uniform(0, 2 * np.pi, count)
    lane = x0 + np.arange(count, dtype=float)
    y = y0 + 10.0 * np.sin(1.3 * times[None, :] / 10.0 + phase[:, None])  # (N, F)
    hips = np.stack([np.repeat(lane[:, None], len(times), 1), y, np.full_like(y, HIPS_HEIGHT)], axis=-1)
    soles = np.stack([hips.copy(), hips.copy()], axis=1)
    soles[:, 0, :, 0] -= 0.1
    soles[:, 1, :, 0] += 0.1
    soles[..., 2] = 0.0
    cycle = (times[None, :] + phase[:, None]) % 1.0
    planted = np.stack([cycle < 0.35, (cycle >= 0.5) & (cycle < 0.85)], axis=1)
    return Others.of([f"Walker {i}" for i in range(count)], times, hips, np.full(count, BODY_RADIUS), soles, planted,
                     np.full(count, 0.26))


def plan(scene, character, others, repeat: int):
    """(result or None, the least CPU seconds of ``repeat`` plans, each with a fresh planner)."""
    from footstep_planner.core.plan.navgraph import PlanError

    best, res = np.inf, None
    for _ in range(max(1, repeat)):
        pl, start, goal = make_planner(scene, character)
        pl.others = others
        t = time.process_time()
        try:
            res = pl.plan(start, goal)
        except PlanError:
            res = None
        best = min(best, time.process_time() - t)
    return res, best


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--library", choices=("cmu", "sample"), default="cmu")
    ap.add_argument("--character", default="", help="npz file freezing the library (bench_planner's)")
    ap.add_argument("--others", default="8,49")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--only", default="")
    ap.add_argument("--seed", type=int, default=15)
    args = ap.parse_args(argv)
    counts = [int(c) for c in args.others.split(",") if c]
    character = load_character(args.character, args.library)
    scenes = benchmark_scenes(args.seed)
    if args.only:
        keep = set(args.only.split(","))
        scenes = [s for s in scenes if s.name in keep]
    head = f"{'scene':<16}{'expanded':>9}{'alone us/exp':>14}" + "".join(
        f"{f'{n} far us/exp':>15}{'ratio':>7}" for n in counts) + "  same path"
    print(head)
    ratios = {n: [] for n in counts}
    for scene in scenes:
        alone, t_alone = plan(scene, character, None, args.repeat)
        if alone is None:
            print(f"{scene.name:<16}  (no path alone: left out)")
            continue
        per = t_alone / max(alone.expanded, 1) * 1e6
        row, same = f"{scene.name:<16}{alone.expanded:>9}{per:>14.1f}", True
        for n in counts:
            res, t = plan(scene, character, far_walkers(scene, n), args.repeat)
            if res is None:
                row += f"{'failed':>15}{'':>7}"
                same = False
                continue
            same &= [tuple(f.position) for f in res.footprints] == [tuple(f.position) for f in alone.footprints]
            p = t / max(res.expanded, 1) * 1e6
            ratios[n].append(p / per)
            row += f"{p:>15.1f}{p / per:>7.2f}"
        print(row + f"  {'yes' if same else 'NO'}", flush=True)
    print()
    for n in counts:
        r = np.array(ratios[n])
        if len(r):
            print(f"{n} others far: per-expansion time over alone, median {np.median(r):.2f}, worst {r.max():.2f} "
                  f"({len(r)} scenes; target at most 2)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
