"""Build the Jumps sample scene and save it.

    .venv/bin/python sample_scenes/jumps.py [--out sample_scenes/out/jumps.blend]
"""

import argparse
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--out", default=os.path.join(HERE, "out", "jumps.blend"))
    args = ap.parse_args()
    import bpy

    from footstep_planner import register
    from footstep_planner.blender.sample_scenes import build

    register()
    build("jumps")
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    bpy.ops.wm.save_as_mainfile(filepath=os.path.abspath(args.out), compress=True)
    print(f"saved {os.path.abspath(args.out)}")


if __name__ == "__main__":
    main()
