"""Build sample scenes and save them, so anyone can regenerate them.

    .venv/bin/python sample_scenes/build.py [jumps turns obstacles stairs] [--mannequin] [--out DIR]

With no names, builds them all into sample_scenes/out/NAME.blend. The scenes are made
by footstep_planner/blender/sample/sample_scenes.py (Jumps: platforms with bends and two 1 m
gaps; Turns: bends onto a curved platform; Obstacles: walls, pillars, a doorway, a narrow
corridor, a 15 cm step and a 15-degree ramp; Stairs: 17 cm risers, 28 cm treads, a flight
up, a landing, a turn and a flight down). With --mannequin, each scene also gets the
Footstep Mannequin (footstep_planner/blender/sample/mannequin.py) standing at its Start, with
its generated clips analysed (the scene at 30 fps), as the planner's character.
"""

import argparse
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))
from footstep_planner.blender.sample.sample_scenes import SCENES  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("names", nargs="*", metavar="NAME", help=f"{', '.join(SCENES)} (default: all)")
    ap.add_argument("--out", default=os.path.join(HERE, "out"), metavar="DIR")
    ap.add_argument("--mannequin", action="store_true", help="put the sample character, with its clips, at Start")
    args = ap.parse_args()
    bad = [n for n in args.names if n not in SCENES]
    if bad:
        ap.error(f"unknown scene {bad[0]!r}; choose from {', '.join(SCENES)}")
    import bpy

    from footstep_planner import register
    from footstep_planner.blender.sample import mannequin
    from footstep_planner.blender.sample.sample_scenes import build

    register()
    os.makedirs(args.out, exist_ok=True)
    for name in args.names or SCENES:
        scene = build(name)
        if args.mannequin:
            scene.render.fps = 30
            mannequin.add_to_scene(scene, "Start")
        path = os.path.join(os.path.abspath(args.out), f"{name}.blend")
        bpy.ops.wm.save_as_mainfile(filepath=path, compress=True)
        print(f"saved {path}")


if __name__ == "__main__":
    main()
