"""The Ray worker's side of a batch (``ray_batch`` is the driver's): one job baked in this
process from the scene file's bytes, with the command line's own ``cli_main``, and
nothing of it left for the next job. Imported on the worker only (``ray_batch.default_task``).
"""

from __future__ import annotations

import contextlib
import io
import os
import platform
import shutil
import sys
import tempfile
import time

from ...core.jobs import job_argv
from .. import planning
from .cli import cli_main


def _ready_worker() -> None:
    """bpy imported and the add-on registered, once per worker process."""
    try:
        import bpy
    except ImportError:
        raise ImportError(f"this Ray worker's Python ({sys.executable}) has no bpy module: "
                          "pip install bpy==5.0.1 there") from None
    if not hasattr(bpy.types.Object, "footstep"):
        from .. import register

        register()


def bake_here(scene: bytes, scene_name: str, job: dict, common: dict, want_out: bool) -> dict:
    """Bake one job in this process (a Ray worker) from the scene file's bytes, in a
    temporary folder removed after. Returns {status (cli_main's exit status), stderr,
    report (the JSON text), out (the baked .blend's bytes, if wanted), seconds, tmp, pid,
    host}."""
    t0 = time.perf_counter()
    _ready_worker()
    tmp = tempfile.mkdtemp(prefix="footstep-ray-")
    result = {"tmp": tmp, "pid": os.getpid(), "host": platform.node(), "report": None, "out": None}
    try:
        os.mkdir(os.path.join(tmp, "scene"))
        blend = os.path.join(tmp, "scene", scene_name)
        with open(blend, "wb") as fh:
            fh.write(scene)
        out = os.path.join(tmp, "out.blend") if want_out else None
        report = os.path.join(tmp, "report.json")
        err = io.StringIO()
        with contextlib.redirect_stderr(err):
            status = cli_main(job_argv(job, blend=blend, out=out, report=report, common=common))
        sys.stderr.write(err.getvalue())  # (the worker's own log keeps it too)
        result.update(status=status, stderr=err.getvalue()[-8000:])
        if status == 0:
            with open(report, encoding="utf-8") as fh:
                result["report"] = fh.read()
            if out:
                with open(out, "rb") as fh:
                    result["out"] = fh.read()
    finally:
        _forget_scene()
        shutil.rmtree(tmp, ignore_errors=True)
    result["seconds"] = time.perf_counter() - t0
    return result


def _forget_scene() -> None:
    """An empty file in this worker between jobs, and the planner's support cache
    emptied: nothing of a job is left for the next to see, so a job bakes here as it
    bakes alone in a fresh Blender, whichever jobs its worker ran before."""
    import bpy

    with contextlib.suppress(Exception):
        bpy.ops.wm.read_homefile(use_empty=True)
    planning.forget_support_caches()


__all__ = ["bake_here"]
