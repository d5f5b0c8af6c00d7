"""Straight is straight (issue 14): a character walks 10 m along a straight 2 m wide
strip, from standing, facing along it, to a goal straight ahead. Printed per character:
the plan's clip labels (how many differ from the straight walk), the blended curvature
tau on the middle 8 m, and the body's sideways deviation from the line as Blender plays
the saved-then-reopened scene (``scene.frame_set``), raw and beyond the clip's own
sway (a running mean over one gait cycle).

    .venv/bin/python benchmarks/bench_straight.py [--characters mannequin,cmu] [--length 10]

Targets: |tau| <= 0.05 1/m, deviation beyond the sway < 3 cm.
"""

import argparse
import os
import sys
import tempfile
from importlib import import_module

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))


def strip_scene(length: float, pkg: str = "footstep_planner"):
    """A scene with a straight strip along +X, Start at x = 0 and Goal at ``length``, both
    facing +X (``pkg``: the add-on's module, as the tests load it)."""
    import bpy

    ss = import_module(pkg + ".blender.sample.sample_scenes")
    bpy.ops.wm.read_homefile(use_empty=True)
    scene = bpy.context.scene
    scene.name = "Strip"
    scene.render.fps = 30
    t = ss._collection(scene, "Traversable", "TRAVERSABLE")
    ss._box(t, "Strip", -1.5, length + 1.5, -1.0, 1.0, -0.3, 0.0)
    ss._marker(scene, "Start", (0.0, 0.0, 0.0), ss.EAST)
    ss._marker(scene, "Goal", (length, 0.0, 0.0), ss.EAST)
    bpy.context.view_layer.update()
    return scene


def measure(kind: str, length: float, settings=None, pkg: str = "footstep_planner") -> dict:
    """The figures of character ``kind`` (``bench_characters``; with another ``pkg``, as
    the tests load the add-on, the sample character or CMU's) on the strip, with
    ``settings``."""
    import bpy

    baking = import_module(pkg + ".blender.write.bake")
    planning = import_module(pkg + ".blender.planning")
    scene = strip_scene(length, pkg)
    if pkg == "footstep_planner":
        from bench_characters import add_character

        ob = add_character(kind, scene)
    elif kind == "cmu":
        from library import MOCAP, cmu_files

        ob, _ = import_module(pkg + ".blender.read.clips").import_clips(cmu_files(MOCAP), name="CMU")
        start = scene.objects["Start"]
        ob.location, ob.rotation_euler.z = start.location, start.rotation_euler.z
    elif kind == "mannequin":
        ob, _ = import_module(pkg + ".blender.sample.mannequin").add_to_scene(scene, "Start")
    else:
        raise ValueError(f"character {kind!r}: with package {pkg!r} only 'mannequin' and 'cmu'")
    bpy.context.view_layer.update()
    goal, heading = planning.goal_of(scene, "Goal")
    planned = planning.plan_and_synthesize(scene, ob, goal, heading, settings=settings)
    syn = planned.synthesis
    labels = [f.label for f in planned.result.footprints[2:-2]]
    walk = max(set(labels), key=labels.count) if labels else ""
    x = syn.body_position[:, 0]
    mid = (x > 1.0) & (x < length - 1.0)
    tau = np.asarray(syn.tau_final)[mid]
    doc = planning.run(scene, ob, goal, heading, settings=settings, name="straight")
    name = ob.name
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "strip.blend")
        bpy.ops.wm.save_as_mainfile(filepath=path)
        bpy.ops.wm.open_mainfile(filepath=path)
        scene = bpy.context.scene
        ob = bpy.data.objects[name]
        setup = planning.plan_setup(scene, ob, settings)
        first = doc["frame_start"]
        _, body, _, _ = baking.evaluate_played(scene, ob, setup.rig, first, doc["frame_end"] - first + 1)
    on = (body[:, 0] > 1.0) & (body[:, 0] < length - 1.0)
    cycle = max(int(round(1.05 * scene.render.fps)), 1)
    mean = np.convolve(body[:, 1], np.ones(cycle) / cycle, mode="same")
    edge = np.zeros(len(body), bool)
    edge[cycle // 2:len(body) - cycle // 2] = True
    return {"character": kind, "footprints": len(planned.result.footprints),
            "off_label": sum(lab != walk for lab in labels), "labels": len(labels), "walk": walk,
            "tau_max": float(np.abs(tau).max()) if len(tau) else float("nan"),
            "dev_max_cm": float(np.abs(body[on, 1]).max() * 100),
            "drift_max_cm": float(np.abs(mean[on & edge]).max() * 100),
            "goal_cm": doc["quality"]["goal"]["distance_m"] * 100}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--characters", default="mannequin,cmu")
    ap.add_argument("--length", type=float, default=10.0)
    ap.add_argument("--curvature-penalty", type=float, default=None,
                    help="Settings.curvature_penalty (default: the settings' own)")
    args = ap.parse_args()
    from footstep_planner.core.base.settings import Settings

    settings = Settings() if args.curvature_penalty is None else Settings(curvature_penalty=args.curvature_penalty)
    from footstep_planner import register

    register()
    rows = [measure(k, args.length, settings) for k in args.characters.split(",")]
    print(f"Straight {args.length:.0f} m strip, from standing to standing (played through the depsgraph), "
          f"curvature_penalty {settings.curvature_penalty:g}")
    print(f"{'character':10} {'footprints':>10} {'not walk':>9}  {'max |tau| 1/m':>13} {'dev max cm':>10} "
          f"{'beyond sway cm':>14} {'goal cm':>7}  most used step")
    for r in rows:
        print(f"{r['character']:10} {r['footprints']:>10} {r['off_label']:>4} of {r['labels']:<3} "
              f"{r['tau_max']:>13.3f} {r['dev_max_cm']:>10.1f} {r['drift_max_cm']:>14.1f} {r['goal_cm']:>7.1f}  "
              f"{r['walk']}")
    print("targets: |tau| <= 0.05 1/m, beyond the sway < 3 cm")


if __name__ == "__main__":
    main()
