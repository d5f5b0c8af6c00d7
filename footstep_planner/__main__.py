"""``python -m footstep_planner VERB ...`` with Blender as a Python module (bpy).

Runs exactly the code of ``blender -b [FILE] -c footstep VERB ...``.
"""

import sys


def main() -> int:
    try:
        import bpy  # noqa: F401
    except ImportError:
        print("footstep: error: this needs Blender's Python module: pip install bpy==5.0.1",
              file=sys.stderr)
        return 2
    from . import register
    from .blender.cli import cli_main

    register()
    return cli_main(sys.argv[1:])


if __name__ == "__main__":
    sys.exit(main())
