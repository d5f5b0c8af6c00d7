"""Live re-plan (issue 30): how long one update takes while a footprint handle is dragged.

On each sample scene, with the sample character or the CMU subject-16 library, the path
is baked with its footprint handles; the two footprints nearest 5 m before and after the
path's middle are locked (a span of about 10 m between them) and the middle footprint is
dragged: moved 4 and 8 cm sideways in turn (the middle footprint nearest the path's
middle that is no jump's take-off or landing), each move followed by the update the timer
runs once the hand rests (``blender.ui.live.update``: the span's search, its synthesis, the
IK and pose of the preview at the current frame, the dragged footprint's, and the overlay).
Prints each scene's median and worst update (wall clock, ms), the search's, the synthesis's
and the preview's share, and how many updates were refused; writes nothing.

    .venv/bin/python benchmarks/bench_live.py [--scenes jumps,turns,obstacles,stairs]
        [--library sample|cmu] [--drags 12]
"""

import argparse
import os
import statistics
import sys
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from library import MOCAP, cmu_files  # noqa: E402  (benchmarks/library.py: the CMU library)

SPAN = 10.0  # m between the two locks


def _span_locks(fps) -> tuple[int, int, int]:
    """(lock before, the middle footprint, lock after): about SPAN m of path between the locks."""
    pos = np.array([f.position[:2] for f in fps])
    along = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(pos, axis=0), axis=1))]
    jumpy = np.array([f.jump for f in fps]) | np.r_[np.array([f.jump for f in fps])[1:], False]
    order = np.argsort(np.abs(along - along[-1] / 2))  # (the middle: not a jump's take-off or landing)
    mid = int(next(i for i in order if not (jumpy[max(i - 1, 0):i + 2].any())))
    a = int(np.argmin(np.abs(along - (along[mid] - SPAN / 2))))
    b = int(np.argmin(np.abs(along - (along[mid] + SPAN / 2))))
    return max(a, 1), mid, min(b, len(fps) - 2)


def run(name: str, library: str, drags: int, mocap: str) -> dict:
    import bpy

    from footstep_planner.blender import planning
    from footstep_planner.blender.read.clips import import_clips
    from footstep_planner.blender.sample import mannequin
    from footstep_planner.blender.sample.sample_scenes import build
    from footstep_planner.blender.ui import handles, live
    from footstep_planner.core.plan import navgraph
    from footstep_planner.core.perform import run as perform

    bpy.ops.wm.read_homefile(use_empty=True)
    scene = build(name)
    scene.render.fps = 30
    if library == "cmu":
        ob, _ = import_clips(cmu_files(mocap), name="CMU")
        if ob.animation_data:
            ob.animation_data.action = None
    else:
        ob, _ = mannequin.add_to_scene(scene, "Start")
    goal = np.array(scene.objects["Goal"].location)
    planned = planning.plan_and_synthesize(scene, ob, goal, None, scene.objects["Start"])
    doc = planning.run(scene, ob, goal, start_marker=scene.objects["Start"], name=name, frame_start=1)
    fps = planned.result.footprints
    handles.make_handles(scene, ob, fps, planned.setup.forward, goal, planned.goal_heading)
    a, mid, b = _span_locks(fps)
    hs = handles.handles(ob)
    handles.set_locked([hs[a], hs[b]], True)
    scene.frame_set(int(doc["footprints"][mid]["frame"]))  # (the preview: the dragged footprint's frame)

    spent = {"search": 0.0, "synthesis": 0.0, "preview": 0.0}
    plan0, perf0 = navgraph.Planner.plan, perform.perform_plan

    def timed(key, fn):
        def call(*args, **kw):
            t = time.perf_counter()
            try:
                return fn(*args, **kw)
            finally:
                spent[key] += time.perf_counter() - t
        return call

    navgraph.Planner.plan = timed("search", plan0)
    planning.perform_plan = timed("synthesis", perf0)
    preview0 = live.preview
    live.preview = timed("preview", preview0)
    times, searches, synths, previews, refused = [], [], [], [], 0
    home = np.array(hs[mid].location, float)
    try:
        for k in range(drags):  # (4 and 8 cm aside in turn: never back where it was planned)
            hs = handles.handles(ob)
            hs[mid].location = home + [0.0, 0.04 if k % 2 == 0 else 0.08, 0.0]
            spent["search"] = spent["synthesis"] = spent["preview"] = 0.0
            got = live.update(scene, ob)
            if "problem" in got:
                refused += 1
                continue
            times.append(got["seconds"])
            searches.append(spent["search"])
            synths.append(spent["synthesis"])
            previews.append(spent["preview"])
    finally:
        navgraph.Planner.plan = plan0
        planning.perform_plan = perf0
        live.preview = preview0
    span = float(np.sum(np.linalg.norm(np.diff([f.position[:2] for f in fps[a:b + 1]], axis=0), axis=1)))
    return {"scene": name, "span": span, "n": len(times), "refused": refused,
            "median": 1e3 * statistics.median(times) if times else float("nan"),
            "worst": 1e3 * max(times) if times else float("nan"),
            "search": 1e3 * statistics.median(searches) if searches else float("nan"),
            "synthesis": 1e3 * statistics.median(synths) if synths else float("nan"),
            "preview": 1e3 * statistics.median(previews) if previews else float("nan")}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenes", default="jumps,turns,obstacles,stairs")
    ap.add_argument("--library", choices=("sample", "cmu"), default="sample")
    ap.add_argument("--drags", type=int, default=12)
    ap.add_argument("--mocap", default=MOCAP)
    args = ap.parse_args()
    from footstep_planner import register

    register()
    rows = [run(name, args.library, args.drags, args.mocap) for name in args.scenes.split(",")]
    print(f"\nLive re-plan, {args.library} character: one update while a footprint is dragged (a {SPAN:g} m span "
          f"between two locks; wall clock; load {os.getloadavg()[0]:.1f})")
    print(f"{'scene':12s} {'span m':>7s} {'updates':>8s} {'median ms':>10s} {'worst ms':>9s} {'search ms':>10s} "
          f"{'synthesis ms':>13s} {'preview ms':>11s} {'refused':>8s}")
    for r in rows:
        print(f"{r['scene']:12s} {r['span']:7.1f} {r['n']:8d} {r['median']:10.0f} {r['worst']:9.0f} "
              f"{r['search']:10.0f} {r['synthesis']:13.0f} {r['preview']:11.0f} {r['refused']:8d}")


if __name__ == "__main__":
    main()
