"""Characters planned together (issue 29): sample characters cross a square through its
middle from its four sides (two lanes a side past four), baked as a job list with
``bake --job JOBS.json --together`` (the command line's own entry, in this process), and
measured as Blender plays the saved scene (each job's report: ``quality.others``, that
job's body against every other character of the shot, measured in one pass at the end).

    .venv/bin/python benchmarks/bench_crowd.py [--counts 1,2,4,8] [--size 12] [--out DIR]
    .venv/bin/python benchmarks/bench_crowd.py --layout plaza --counts 50 --size 40

``--layout plaza``: the issue's plaza instead, ``count`` characters crossing a square
``size`` m across from its four sides in lanes spread along each side (each straight over
to the opposite side; the lanes of opposite sides between each other's), all setting off
at once: flows that cross everywhere, not only in the middle.

Per count: the wall and CPU seconds of the job list, against the count times the first
character's bake alone on the same scene (the issue: 8 characters in under 8 times one's
time); the least distance between two bodies over the shot (capsules, so negative where
they overlap), its pair and frame, the frames two bodies overlap and two feet stand on one
footprint, the worst goal distance, and the stands the characters made to let others
pass. Writes the scenes and reports under ``--out`` (a temporary folder by default).
"""

import argparse
import json
import math
import os
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)


def lanes(count: int, size: float) -> list[tuple[tuple, tuple, float]]:
    """(start (x, y), goal (x, y), heading rad) of ``count`` characters crossing a square
    ``size`` m across through its middle: one from each side, in turn W, S, E, N, then a
    second lane a side, 1.5 m beside the first; the heading a marker's Z rotation."""
    half = 0.5 * size - 1.0
    out = []
    for k in range(count):
        side, lane = k % 4, k // 4
        off = (0.0, 1.5, -1.5, 3.0, -3.0)[lane % 5]
        ang = side * math.pi / 2  # (W walks east, S north, E west, N south)
        d = (math.cos(ang), math.sin(ang))
        n = (-d[1], d[0])
        start = (-half * d[0] + off * n[0], -half * d[1] + off * n[1])
        goal = (half * d[0] + off * n[0], half * d[1] + off * n[1])
        out.append((start, goal, ang + math.pi / 2))  # (a marker's Z rotation: pi/2 faces +X)
    return out


def plaza(count: int, size: float) -> list[tuple[tuple, tuple, float]]:
    """(start (x, y), goal (x, y), heading rad) of ``count`` characters crossing a plaza
    ``size`` m across: in turn from the W, S, E and N sides, each side's lanes spread evenly
    along it 1 m in from its corners, those of the E and N sides half a lane between the W
    and S sides' (no two walk one lane head-on)."""
    half = 0.5 * size - 1.0
    per = -(-count // 4)
    gap = (2 * half - 2.0) / max(per, 1)
    out = []
    for k in range(count):
        side, lane = k % 4, k // 4
        off = -half + 1.0 + gap * (lane + (0.25 if side < 2 else 0.75))
        ang = side * math.pi / 2
        d = (math.cos(ang), math.sin(ang))
        n = (-d[1], d[0])
        if side >= 2:  # (the lane's place measured the same way as the opposite side's)
            off = -off
        start = (-half * d[0] + off * n[0], -half * d[1] + off * n[1])
        goal = (half * d[0] + off * n[0], half * d[1] + off * n[1])
        out.append((start, goal, ang + math.pi / 2))
    return out


LAYOUTS = {"square": lanes, "plaza": plaza}


def build(path: str, count: int, size: float, layout: str = "square") -> list[str]:
    """The square, its markers and ``count`` sample characters, saved at ``path``; their names."""
    import bpy

    from footstep_planner.blender.sample import mannequin, sample_scenes

    bpy.ops.wm.read_homefile(use_empty=True)
    scene = bpy.context.scene
    scene.render.fps, scene.render.fps_base = 30, 1.0
    floor = sample_scenes._collection(scene, "Traversable", "TRAVERSABLE")
    h = 0.5 * size
    sample_scenes._box(floor, "Square", -h, h, -h, h, -0.2, 0.0)
    names = []
    for k, (start, goal, heading) in enumerate(LAYOUTS[layout](count, size)):
        sample_scenes._marker(scene, f"Start{k}", (*start, 0.0), heading)
        sample_scenes._marker(scene, f"Goal{k}", (*goal, 0.0), heading)
        ob, _ = mannequin.add_to_scene(scene, f"Start{k}")
        ob.name = f"Walker {k}"
        names.append(ob.name)
    bpy.ops.wm.save_as_mainfile(filepath=path)
    return names


def bake(path: str, names: list[str], out: str, together: bool) -> tuple[float, float, list[dict]]:
    """(wall s, CPU s, the reports) of baking ``names`` (each from its Start to its Goal)
    from the command line."""
    from footstep_planner.blender.command.cli import cli_main

    folder = os.path.dirname(out)
    jobs = [{"character": n, "start": f"Start{k}", "goal": f"Goal{k}", "name": f"cross {k}",
             "report": os.path.join(folder, f"r{len(names)}_{k}.json")} for k, n in enumerate(names)]
    jobs_file = os.path.join(folder, f"jobs{len(names)}.json")
    with open(jobs_file, "w") as f:
        json.dump(jobs, f)
    args = ["bake", path, "--job", jobs_file, "--out", out] + (["--together"] if together else [])
    w0, c0 = time.perf_counter(), time.process_time()
    status = cli_main(args)
    wall, cpu = time.perf_counter() - w0, time.process_time() - c0
    docs = []
    for j in jobs:
        if os.path.exists(j["report"]):
            with open(j["report"]) as f:
                docs.append(json.load(f))
    if status != 0:
        print(f"  ({status} job(s) of {len(names)} did not bake)")
    return wall, cpu, docs


def figures(docs: list[dict]) -> dict:
    """The shot's pair figures from its reports (each job against every other: each pair
    counted once)."""
    least, pair, frame, overlap, shared, seen = math.inf, "-", "-", 0, 0, set()
    for d in docs:
        for o in d["quality"].get("others", []):
            if frozenset((d["character"], o["character"])) in seen:
                continue
            seen.add(frozenset((d["character"], o["character"])))
            overlap += o["frames_overlapping"]
            shared += o["frames_on_one_footprint"]
            if o["least_distance_m"] < least:
                least, pair, frame = o["least_distance_m"], f"{d['character']} / {o['character']}", o["least_distance_frame"]
    goal = max((d["quality"]["goal"]["distance_m"] for d in docs), default=math.nan)
    stands = sum(len(d.get("stands", [])) for d in docs)
    return {"least": least, "pair": pair, "frame": frame, "overlap": overlap, "shared": shared, "goal": goal,
            "stands": stands}


def sheet(count: int, path: str, docs: list[dict], fig: dict, out: str) -> str:
    """The review sheet of the baked shot at ``path`` (its reports ``docs``)."""
    import bpy

    from footstep_planner.blender.command.review import crowd_sheet

    bpy.ops.wm.open_mainfile(filepath=path)
    scene = bpy.context.scene
    shot = [(scene.objects[d["character"]], d) for d in docs]
    return crowd_sheet(scene, shot, out, f"square{count}", [] if fig["frame"] == "-" else [int(fig["frame"])])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--counts", default="1,2,4,8")
    ap.add_argument("--size", type=float, default=12.0)
    ap.add_argument("--layout", choices=sorted(LAYOUTS), default="square")
    ap.add_argument("--out", default=None)
    ap.add_argument("--sheet", action="store_true",
                    help="the review sheet of the largest shot (top view, each character in its colour; the frame "
                         "two pass nearest), as square<N>_review.png under --out")
    args = ap.parse_args(argv)
    import footstep_planner

    footstep_planner.register()
    out = args.out or tempfile.mkdtemp(prefix="bench_crowd_")
    os.makedirs(out, exist_ok=True)
    rows = []
    for count in [int(c) for c in args.counts.split(",")]:
        path = os.path.join(out, f"square{count}.blend")
        names = build(path, count, args.size, args.layout)
        alone_wall, alone_cpu, _ = bake(path, names[:1], os.path.join(out, f"alone{count}.blend"), together=False)
        wall, cpu, docs = bake(path, names, os.path.join(out, f"together{count}.blend"), together=True)
        fig = figures(docs)
        rows.append((count, len(docs), wall, cpu, alone_wall, cpu / max(count * alone_cpu, 1e-9), fig))
        last = (count, os.path.join(out, f"together{count}.blend"), docs, fig)
        print(f"  {count} characters: {wall:.1f} s wall, {cpu:.1f} s CPU (alone {alone_wall:.1f} s)", flush=True)
    import resource

    what = "crossing its middle" if args.layout == "square" else "crossing it in lanes from its four sides"
    print(f"\n{args.size:g} m {args.layout}, sample characters {what}, bake --job --together "
          f"(load {os.getloadavg()[0]:.1f}; this process's peak memory "
          f"{resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2 ** 20:.2f} GB)")
    head = ("chars", "baked", "wall s", "CPU s", "alone s", "CPU / n alone", "least m", "frame", "pair",
            "overlap fr", "one fp fr", "goal m", "stands")
    print("  ".join(f"{h:>10}" for h in head))
    for count, baked, wall, cpu, alone, ratio, f in rows:
        cells = (count, baked, f"{wall:.1f}", f"{cpu:.1f}", f"{alone:.1f}", f"{ratio:.2f}",
                 f"{f['least']:.3f}" if math.isfinite(f["least"]) else "-", f["frame"], f["pair"],
                 f["overlap"], f["shared"], f"{f['goal']:.3f}", f["stands"])
        print("  ".join(f"{str(c):>10}" for c in cells))
    if args.sheet and rows:
        print("review sheet:", sheet(*last, out))
    print(f"(scenes and reports in {out})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
