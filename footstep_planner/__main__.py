"""``python -m footstep_planner VERB ...`` with Blender as a Python module (bpy).

Runs exactly the code of ``blender -b [FILE] -c footstep VERB ...``.
"""

import signal
import sys


def _load_blender() -> bool:
    """Import bpy with Ctrl-C held off (Blender swallows an interrupt while it loads its
    scripts and is left half-made); False when a Ctrl-C came meanwhile."""
    signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        import bpy  # noqa: F401
    finally:
        interrupted = signal.SIGINT in signal.sigpending()
        if interrupted:
            signal.signal(signal.SIGINT, signal.SIG_IGN)  # (drop the pending one)
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
    return not interrupted


def main() -> int:
    try:
        if not _load_blender():
            print("\nfootstep: interrupted, nothing written", file=sys.stderr)
            return 130
    except ImportError:
        print("footstep: error: this needs Blender's Python module: pip install bpy==5.0.1",
              file=sys.stderr)
        return 2
    from . import register, unregister
    from .blender.command.cli import cli_main

    register()
    try:
        return cli_main(sys.argv[1:])
    finally:
        # Blender 4.5 crashes (exit 139) or hangs as Python exits with the add-on's
        # command and properties still registered: take them down first, so each verb
        # ends with its own status there as on 5.x
        unregister()


def _exit(status: int) -> None:
    """Exit with ``status``, deaf to a late Ctrl-C: once the command has finished, its
    files are in place and its status is the truth."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    sys.stdout.flush()
    sys.stderr.flush()
    sys.exit(status)


if __name__ == "__main__":
    try:
        code = main()
    except KeyboardInterrupt:  # (while Blender and the add-on were still loading)
        print("\nfootstep: interrupted, nothing written", file=sys.stderr)
        code = 130
    _exit(code)
