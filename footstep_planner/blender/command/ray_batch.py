"""Bake a job list as Ray tasks (``bake --job JOBS.json --ray ADDRESS``): each job in a
worker process, on its own copy of the scene, on this machine or across a cluster.

The driver (this process) reads the scene file once and puts it in Ray's object store.
Each task writes it into a private temporary folder on its worker, runs the single-job
bake there in-process (``cli_main(job_argv(...))``: bpy is imported in the worker) and
returns the report and the baked scene as bytes; the driver stages them in the command's
``Outputs``, which renames them into place at its commit. Nothing needs a shared disk:
the scene and the results travel through Ray, the package through ``runtime_env``.

A worker process runs one job at a time and is kept for the next (a fresh process per
job would load Blender again each time: 2 to 3 s a job on a 2-core machine, more than a
short bake); between jobs it empties its scene and the planner's support cache, so a job
bakes there as it bakes alone from the file. ``max_calls=1`` gives each job a fresh one.

A worker that dies mid-job (killed, out of memory, its machine gone) is retried once, by
this driver, on another worker; dying twice, the job is reported failed. A job that
fails (an expected problem, or a bug) is reported with its error line and the other jobs
run on.

Ray is optional: it is imported here only, inside the functions, when ``--ray`` is given.
"""

from __future__ import annotations

import contextlib
import json
import logging
import os
import sys

from ...core.base.errors import FootstepError
from ...core.base.files import describe_os_error
from ...core.jobs import JobOutcome

#: the package's folder, and the name a worker imports it by: a worker never sees the
#: name the driver may know it by (``bl_ext.user_default.footstep_planner`` in Blender)
PACKAGE_DIR = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
PACKAGE = os.path.basename(PACKAGE_DIR)

RAY_PIN = "ray==2.60.0"
_ERROR = "footstep: error: "


# -- the driver ---------------------------------------------------------------------------

def run_on_ray(address: str, blend: str, jobs: list[tuple[int, str, dict]], common: dict,
               destinations: dict[int, dict], outputs, progress=None, task=None,
               max_calls: int = 0) -> list[JobOutcome]:
    """Bake ``jobs`` ((number, label, normalised job)) of the scene file ``blend`` as Ray
    tasks, with the batch's ``common`` options (as ``core.jobs.job_argv`` takes them).
    ``address``: ``local`` (a new local instance with a CPU per core), ``local:N`` (with N),
    ``auto`` (the cluster running on this machine) or a cluster's address. Each baked job's
    files are staged in ``outputs`` at ``destinations[number]`` (``out``, ``report``: paths
    the caller claimed, or None); ``progress(outcome)`` is called as each job ends. Returns
    the outcomes by job number. ``task`` replaces the remote function (tests); ``max_calls``
    (0: no limit) is how many jobs a worker process runs before Ray replaces it."""
    if not jobs:
        return []
    _ray_environment(address)
    ray = _import_ray()
    try:
        with open(blend, "rb") as fh:
            scene = fh.read()
    except OSError as ex:
        raise FootstepError(f"cannot read the scene to ship to the Ray workers: {describe_os_error(ex, blend)}") \
            from None
    started = _connect(ray, address)
    try:
        remote = ray.remote(num_cpus=1, max_retries=0, retry_exceptions=False, max_calls=max_calls)(
            task or default_task())
        try:
            scene_ref = ray.put(scene)
        except ray.exceptions.RayError as ex:
            raise FootstepError(f"cannot ship the scene to the Ray workers: {_first_line(ex)}") from None
        return _Batch(ray, remote, scene_ref, blend, common, destinations, outputs, progress).run(jobs)
    finally:
        if started:
            ray.shutdown()


def _import_ray():
    try:
        import ray
    except ImportError:
        raise FootstepError(f"--ray needs Ray, which is not installed here ({sys.executable}): "
                            f"pip install '{RAY_PIN}' (make venv installs it)") from None
    return ray


def _init_args(address: str) -> dict:
    """ray.init's arguments for ``address``: quiet (Ray's log lines never reach stdout, nor
    the workers' output the driver's), and a runtime environment that lets a worker import
    the package: its folder on PYTHONPATH on this machine, shipped to a cluster."""
    quiet = dict(log_to_driver=False, logging_level=logging.ERROR, configure_logging=True)
    if address == "local" or address.startswith("local:"):
        cpus = os.cpu_count() or 1
        if address != "local":
            text = address.split(":", 1)[1]
            if not text.isdigit() or int(text) < 1:
                raise FootstepError(f"--ray {address}: the number of workers must be a whole number from 1")
            cpus = int(text)
        path = os.pathsep.join(p for p in (os.path.dirname(PACKAGE_DIR), os.environ.get("PYTHONPATH")) if p)
        return dict(address="local", num_cpus=cpus, include_dashboard=False,
                    runtime_env={"env_vars": {"PYTHONPATH": path}}, **quiet)
    shipped = {"py_modules": [PACKAGE_DIR], "excludes": ["__pycache__", "*.pyc"]}
    return dict(address=address, runtime_env=shipped, **quiet)


def _connect(ray, address: str) -> bool:
    """Start or join the Ray instance at ``address``; False when this process already was
    connected (then it is left as it is)."""
    if ray.is_initialized():
        return False
    kwargs = _init_args(address)
    try:
        ray.init(**kwargs)
    except Exception as ex:  # (whatever keeps Ray from starting: one message, not a traceback)
        where = "a local Ray instance" if kwargs["address"] == "local" else f"the Ray cluster at {address!r}"
        hint = " (start one with: ray start --head)" if address == "auto" else ""
        raise FootstepError(f"cannot start or reach {where}{hint}: {_first_line(ex)}") from None
    return True


def _ray_environment(address: str) -> None:
    """Set before Ray is first imported (it reads them then; changed after, they would
    contradict what it read): no usage statistics sent from a private local instance;
    and when joining a cluster, the token that Ray 2.60 clusters want (ray.init does not
    send it unless told): the one ``ray start`` left in ~/.ray/auth_token, or the one
    RAY_AUTH_TOKEN or RAY_AUTH_TOKEN_PATH gives."""
    if "ray" in sys.modules:
        return
    if address == "local" or address.startswith("local:"):
        os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")
    elif "RAY_AUTH_MODE" not in os.environ and _has_auth_token():
        os.environ["RAY_AUTH_MODE"] = "token"


def _has_auth_token() -> bool:
    path = os.environ.get("RAY_AUTH_TOKEN_PATH") or os.path.join(os.path.expanduser("~"), ".ray", "auth_token")
    return bool(os.environ.get("RAY_AUTH_TOKEN")) or os.path.isfile(path)


def _first_line(ex: BaseException) -> str:
    lines = [ln.strip() for ln in str(ex).splitlines() if ln.strip()]
    return lines[0] if lines else type(ex).__name__


class _Batch:
    """One run: jobs submitted, collected as they end (a death resubmits once), each
    outcome made and its files staged."""

    def __init__(self, ray, remote, scene_ref, blend, common, destinations, outputs, progress):
        self.ray, self.remote, self.scene_ref, self.blend = ray, remote, scene_ref, blend
        self.common, self.dest, self.outputs, self.progress = common, destinations, outputs, progress
        self.pending: dict = {}
        self.attempts: dict[int, int] = {}
        self.deaths: dict[int, list[str]] = {}
        self.deaths_of = (ray.exceptions.WorkerCrashedError, ray.exceptions.NodeDiedError,
                          ray.exceptions.OutOfMemoryError, ray.exceptions.ObjectLostError)

    def submit(self, number: int, label: str, job: dict) -> None:
        self.attempts[number] = self.attempts.get(number, 0) + 1
        want_out = bool((self.dest.get(number) or {}).get("out"))
        ref = self.remote.remote(self.scene_ref, os.path.basename(self.blend), job, self.common, want_out)
        self.pending[ref] = (number, label, job)

    def run(self, jobs) -> list[JobOutcome]:
        for number, label, job in jobs:
            self.submit(number, label, job)
        outcomes = []
        try:
            while self.pending:
                [ref], _ = self.ray.wait(list(self.pending), num_returns=1)
                number, label, job = self.pending.pop(ref)
                outcome = self.collect(ref, number, label)
                if outcome is None:  # its worker died, once: again, on another
                    self.submit(number, label, job)
                    continue
                outcomes.append(outcome)
                if self.progress:
                    self.progress(outcome)
        except BaseException:  # Ctrl-C, or the caller's progress failing: stop the rest
            for ref in self.pending:
                with contextlib.suppress(Exception):
                    self.ray.cancel(ref, force=True)
            raise
        return sorted(outcomes, key=lambda o: o.number)

    def collect(self, ref, number: int, label: str) -> JobOutcome | None:
        """The outcome of a finished task; None when its worker died the first time."""
        tries = self.attempts[number]
        try:
            result = self.ray.get(ref)
        except self.ray.exceptions.RayTaskError as ex:  # the task raised: a bug, or no bpy there
            return JobOutcome(number, label, "failed", error=_task_error(ex), attempts=tries)
        except self.deaths_of as ex:
            self.deaths.setdefault(number, []).append(_first_line(ex))
            if tries < 2:
                return None
            why = "; ".join(dict.fromkeys(self.deaths[number]))
            return JobOutcome(number, label, "failed", error=f"the Ray worker died twice ({why})", attempts=tries)
        except self.ray.exceptions.RayError as ex:
            return JobOutcome(number, label, "failed", error=f"Ray could not run it: {_first_line(ex)}",
                              attempts=tries)
        try:
            return self.outcome(number, label, result, tries)
        except Exception as ex:  # (never the whole batch for one job's result)
            return JobOutcome(number, label, "failed", error=f"internal error: {type(ex).__name__}: {ex}",
                              attempts=tries)

    def outcome(self, number: int, label: str, result: dict, tries: int) -> JobOutcome:
        """A finished task's outcome, its report and scene staged when it baked."""
        dest = self.dest.get(number) or {}
        if result["status"] != 0:
            return JobOutcome(number, label, "failed", result["seconds"], attempts=tries,
                              error=_error_line(result, self.blend, dest))
        doc = json.loads(result["report"])
        staged = []
        try:
            if dest.get("report"):
                staged.append(self.outputs.write_text(dest["report"], result["report"]))
            if dest.get("out"):
                staged.append(self.outputs.stage(dest["out"], _bytes_writer(result["out"])))
        except (OSError, FootstepError) as ex:
            for tmp in staged:
                self.outputs.unstage(tmp)
            why = describe_os_error(ex) if isinstance(ex, OSError) else str(ex)
            return JobOutcome(number, label, "failed", result["seconds"], error=why, attempts=tries)
        outcome = JobOutcome.from_report(number, label, doc, result["seconds"],
                                         [p for p in (dest.get("report"), dest.get("out")) if p])
        outcome.attempts = tries
        return outcome


def _bytes_writer(data: bytes):
    def write(tmp: str) -> None:
        with open(tmp, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
    return write


def _task_error(ex) -> str:
    """A task that raised: its exception's own line (the traceback's last)."""
    cause = getattr(ex, "cause", None)
    if isinstance(cause, BaseException) and not isinstance(cause, type(ex)):
        return f"internal error: {type(cause).__name__}: {_first_line(cause)}"
    lines = [ln.strip() for ln in str(ex).splitlines() if ln.strip()]
    return f"internal error: {lines[-1] if lines else type(ex).__name__}"


def _error_line(result: dict, blend: str, dest: dict) -> str:
    """A failed bake's message: its ``footstep: error:`` line(s), naming the user's files
    rather than the worker's copies; a bug's last traceback line."""
    text, tmp = result.get("stderr") or "", result.get("tmp") or ""
    if tmp:
        for copy, real in ((os.path.join(tmp, "scene", os.path.basename(blend)), blend),
                           (os.path.join(tmp, "out.blend"), dest.get("out") or "the job's scene"),
                           (os.path.join(tmp, "report.json"), dest.get("report") or "the job's report"),
                           (tmp, "the worker's folder")):
            text = text.replace(copy, real)
    lines = [ln.strip() for ln in text.splitlines() if ln.strip()]
    errors = [ln[len(_ERROR):] for ln in lines if ln.startswith(_ERROR)]
    if errors:
        return "; ".join(errors)
    if result["status"] == 130:
        return "interrupted"
    own = [ln for ln in lines if not ln.startswith("footstep:")]
    if result["status"] == 70 and own:
        return f"internal error: {own[-1]}"
    return f"the bake ended with status {result['status']}" + (f": {lines[-1]}" if lines else "")


# -- the worker ---------------------------------------------------------------------------

def default_task():
    """The remote function. Made here, not at module level, so that Ray ships it by value:
    on the worker it imports the package by its own name (PACKAGE), whatever name the
    driver knows it by."""
    package = PACKAGE

    def footstep_bake(scene, scene_name, job, common, want_out):
        import importlib

        worker = importlib.import_module(package + ".blender.command.ray_worker")
        return worker.bake_here(scene, scene_name, job, common, want_out)

    return footstep_bake


__all__ = ["PACKAGE", "PACKAGE_DIR", "default_task", "run_on_ray"]
