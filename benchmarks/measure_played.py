"""Measure a saved bake as Blender plays it, in a fresh process, independently of the
planner's own evaluation: open the .blend, ``scene.frame_set`` every baked frame, read the
character's evaluated foot bones through the depsgraph (every NLA track, the active
action, constraints, as they are in the file), and compute foot skate, planted foot to
footprint and goal error with the same pure measures the report uses.

    .venv/bin/python benchmarks/measure_played.py BAKED.blend REPORT.json [--json]

The report (``bake --report``) gives the character, the baked frames, the stances and the
heel and toe points of each foot bone (``feet``); nothing else of the planner's is used.
"""

import argparse
import json
import os
import sys

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)


def played(blend: str, doc: dict) -> dict:
    """The played scene's figures for the bake that ``doc`` reports."""
    import bpy

    from footstep_planner.core.report.metrics import foot_skate, footprint_error

    bpy.ops.wm.open_mainfile(filepath=blend)
    scene = bpy.context.scene
    ob = scene.objects[doc["character"]]
    first, last = int(doc["frame_start"]), int(doc["frame_end"])
    feet = doc["feet"]
    heel_local, toe_local = np.array(feet["heel_local"]), np.array(feet["toe_local"])
    n = last - first + 1
    heel, toe = np.empty((2, n, 3)), np.empty((2, n, 3))
    body = np.empty((n, 3))
    depsgraph = bpy.context.evaluated_depsgraph_get()
    for i in range(n):
        scene.frame_set(first + i)
        ev = ob.evaluated_get(depsgraph)
        mw = np.array(ev.matrix_world)
        body[i] = mw[:3, 3]
        for k, name in enumerate(feet["bones"]):
            m = mw @ np.array(ev.pose.bones[name].matrix)
            heel[k, i] = (m @ heel_local[k])[:3]
            toe[k, i] = (m @ toe_local[k])[:3]
    stances = [{"foot": "LR".index(f["foot"]), "start": f["planted_frames"][0] - first,
                "end": f["planted_frames"][1] - first, "stance": f["frame"] - first,
                "position": np.array(f["position"]), "heading": f["heading"]} for f in doc["footprints"]]
    skate, err = foot_skate(heel, toe, stances), footprint_error(heel, toe, stances)
    goal = np.array(doc["goal"])
    return {"frames": n, "skate_mean_mm": skate["mean_mm"], "skate_max_mm": skate["max_mm"],
            "footprint_error_max_mm": err["max_mm"],
            "goal_cm": float(np.linalg.norm(body[-1, :2] - goal[:2]) * 100),
            "active_action": ob.animation_data.action.name if ob.animation_data and ob.animation_data.action else None}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("blend")
    ap.add_argument("report")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    with open(args.report) as fh:
        doc = json.load(fh)
    out = played(os.path.abspath(args.blend), doc)
    if args.json:
        print(json.dumps(out))
    else:
        for k, v in out.items():
            print(f"{k:24s} {v}")


if __name__ == "__main__":
    main()
