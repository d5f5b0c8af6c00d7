"""Bake jobs (``bake --job JOBS.json``): what a job may say, how it is checked, the one
command line that bakes it alone, and how a batch's outcomes are summed up.

Pure Python. Every job of a list is checked (types, ranges, the settings' own ranges)
before any runs; a job that fails the check is reported by number and name and the
others still run. The same job runs the same way one after another in one Blender, as a
Ray task (``blender/command/ray_batch.py``) or as a Flamenco task (``flamenco/footstep_bake.js``,
which builds the command ``job_argv`` builds).
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field

from .base.errors import FootstepError
from .base.settings import Settings

#: the fields of a job and what each must be; all may be missing or null but the character
JOB_FIELDS = {
    "character": "an armature's name", "goal": "an object's name", "start": "an object's name",
    "name": "text", "report": "a file path", "out": "a file path", "frame_start": "a whole number",
    "goal_heading": "a number (degrees)", "body_on": '"object" or "root"',
    "via": "a list of objects' names (waypoints, in order)",
    "arrive": "an object of scene frames to arrive on (NAME: frame), waypoints or the goal",
    "pause": "an object of seconds to stand at waypoints (NAME: seconds)",
    "settings": "an object of settings (NAME: value)"}

#: a frame number beyond which Blender's timeline (1,048,574) has no room for a bake
MAX_FRAME = 1_000_000


class JobError(FootstepError):
    """A job list that can't be read at all (not JSON, not a list, empty)."""


def _number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _field_problem(field: str, value) -> str | None:
    """Why ``value`` is not a valid ``field``, or None."""
    if value is None:
        return "it is missing" if field == "character" else None
    kind = JOB_FIELDS[field]
    if kind in ("text", "an object's name", "an armature's name", "a file path"):
        if not isinstance(value, str) or (kind != "text" and not value.strip()):
            return f"got {json.dumps(value)[:40]}"
        if "\x00" in value:
            return "it holds a NUL character"
        if not is_text(value):
            return f"got {value.encode('utf-8', 'backslashreplace').decode()[:40]!r}, which is not valid text"
        return None
    if field == "frame_start":
        if not _number(value) or not float(value).is_integer():
            return f"got {json.dumps(value)[:40]}"
        return None if abs(value) <= MAX_FRAME else f"got {value}: beyond Blender's timeline (±{MAX_FRAME})"
    if field == "goal_heading":
        ok = _number(value) and abs(float(value)) < 1e6
        return None if ok else f"got {json.dumps(value)[:40]}"
    if field == "via":
        ok = isinstance(value, list) and all(isinstance(v, str) and v.strip() and "," not in v and is_text(v)
                                             for v in value)
        return None if ok else f"got {json.dumps(value)[:40]}"
    if field in ("arrive", "pause"):
        top = MAX_FRAME if field == "arrive" else 600
        ok = isinstance(value, dict) and all(
            isinstance(k, str) and k.strip() and is_text(k) and _number(v) and 0 <= v <= top for k, v in value.items())
        return None if ok else f"got {json.dumps(value)[:40]} (names with numbers from 0 to {top})"
    if field == "body_on":
        ok = isinstance(value, str) and value.lower() in ("object", "root")
        return None if ok else f"got {json.dumps(value)[:40]}"
    return None if isinstance(value, dict) else f"got {json.dumps(value)[:40]}"


def is_text(value: str) -> bool:
    """Whether ``value`` is text Blender can take (valid Unicode: no lone surrogates, as a
    JSON "\\ud800" or a file name's undecodable bytes give)."""
    try:
        value.encode("utf-8")
    except UnicodeEncodeError:
        return False
    return True


def job_label(n: int, job) -> str:
    """``job 3 'hero walk' (Hero to Door)``: how messages name a job."""
    if not isinstance(job, dict):
        return f"job {n}"
    text = lambda v: isinstance(v, str) and v and is_text(v)  # noqa: E731
    name = f" {job['name']!r}" if text(job.get("name")) else ""
    who = job.get("character") if text(job.get("character")) else "?"
    goal = job.get("goal") if text(job.get("goal")) else "the 3D cursor"
    return f"job {n}{name} ({who} to {goal})"


def check_job(n: int, job) -> list[str]:
    """Every problem of one job (empty when it is fine), each naming the field."""
    if not isinstance(job, dict):
        return [f"job {n} is not an object but {json.dumps(job)[:40]}"]
    problems = [f"unknown field {k!r} (fields: {', '.join(JOB_FIELDS)})" for k in job if k not in JOB_FIELDS]
    for f in JOB_FIELDS:
        why = _field_problem(f, job.get(f))
        if why:
            problems.append(f"{f!r} must be {JOB_FIELDS[f]}; {why}")
    if isinstance(job.get("settings"), dict):
        for k, v in job["settings"].items():
            try:
                Settings.coerce(k, v)
            except FootstepError as ex:
                problems.append(str(ex))
    return problems


def read_jobs(text: str, path: str) -> list:
    """The raw list of a JOBS.json's text; a JobError when it is not a non-empty list."""
    try:
        jobs = json.loads(text)
    except ValueError as ex:
        raise JobError(f"cannot read the job list {path!r}: it is not JSON ({ex})") from None
    if not isinstance(jobs, list):
        raise JobError(f"the job list {path!r} must be a JSON list of objects, not {type(jobs).__name__}")
    if not jobs:
        raise JobError(f"the job list {path!r} is empty: nothing to bake")
    return jobs


def normalised(job: dict) -> dict:
    """A checked job with its settings converted (``Settings.coerce``) and body_on upper-case."""
    job = dict(job)
    job["settings"] = {k: Settings.coerce(k, v) for k, v in (job.get("settings") or {}).items()}
    if job.get("body_on"):
        job["body_on"] = job["body_on"].upper()
    return job


def job_argv(job: dict, *, blend: str | None = None, out: str | None = None, report: str | None = None,
             common: dict | None = None) -> list[str]:
    """The ``footstep bake`` arguments that bake ``job`` alone (with the batch's ``common``
    options: ``markers``, ``keep_frame_range``, ``force``, ``new_track``, ``traversable``,
    ``obstacles``, ``body_on``, ``set`` (a list of NAME=VALUE)). Flamenco's job type builds the same command."""
    common = common or {}
    argv = ["bake"] + ([blend] if blend else []) + ["--character", job["character"]]
    for key, flag in (("goal", "--goal"), ("start", "--start"), ("name", "--name")):
        if job.get(key):
            argv += [flag, str(job[key])]
    if job.get("frame_start") is not None:
        argv += ["--frame-start", str(int(job["frame_start"]))]
    if job.get("goal_heading") is not None:
        argv += ["--goal-heading", repr(float(job["goal_heading"]))]
    if job.get("via"):
        argv += ["--via", ",".join(job["via"])]
    for key in ("arrive", "pause"):
        if job.get(key):
            argv += [f"--{key}", ",".join(f"{k}={v!r}" for k, v in job[key].items())]
    argv += ["--body-on", str(job.get("body_on") or common.get("body_on") or "object").lower()]
    for key in ("traversable", "obstacles"):
        if common.get(key):
            argv += [f"--{key}", common[key]]
    argv += ["--markers"] if common.get("markers") else []
    argv += ["--keep-frame-range"] if common.get("keep_frame_range") else []
    argv += ["--force"] if common.get("force") else []
    argv += ["--new-track"] if common.get("new_track") else []
    pairs = list(common.get("set") or []) + [f"{k}={v}" for k, v in (job.get("settings") or {}).items()]
    for pair in pairs:
        argv += ["--set", pair]
    argv += (["--out", out] if out else []) + (["--report", report] if report else [])
    return argv


@dataclass
class JobOutcome:
    """What became of one job: ``status`` is ``baked``, ``failed`` (at run time) or
    ``invalid`` (refused by the check); figures from the bake's report."""
    number: int
    label: str
    status: str
    seconds: float = 0.0
    frames: int | None = None
    skate_mm: float | None = None
    goal_cm: float | None = None
    error: str | None = None
    outputs: list = field(default_factory=list)
    attempts: int = 1
    # m: the least distance from its body to another character's baked in the shot (and
    # whose), from the report's ``quality.others``; None where there is none
    nearest_m: float | None = None
    nearest: str | None = None

    @classmethod
    def from_report(cls, number: int, label: str, doc: dict, seconds: float, outputs=()) -> "JobOutcome":
        q = doc.get("quality") or {}
        near = min(q.get("others") or [], key=lambda o: o["least_distance_m"], default=None)
        return cls(number, label, "baked", seconds, frames=doc["frame_end"] - doc["frame_start"] + 1,
                   skate_mm=(q.get("foot_skate") or {}).get("max_mm"),
                   goal_cm=100 * (q.get("goal") or {}).get("distance_m", float("nan")), outputs=list(outputs),
                   nearest_m=None if near is None else near["least_distance_m"],
                   nearest=None if near is None else near["character"])

    def to_dict(self) -> dict:
        return asdict(self)


def summary_table(outcomes: list[JobOutcome], wall_seconds: float | None = None) -> str:
    """The batch's summary: one row per job (status, frames, time, quality, the nearest
    another character baked in the shot came (m, whose body) or the error) and the counts."""
    rows = [f"{'job':<40s} {'status':>8s} {'frames':>7s} {'time s':>7s} {'skate mm':>9s} {'goal cm':>8s} "
            f"{'nearest m':>9s}  error or nearest character"]
    for o in outcomes:
        num = lambda v, f: format(v, f) if v is not None else "-"  # noqa: E731
        rows.append(f"{o.label[:40]:<40s} {o.status:>8s} {num(o.frames, 'd'):>7s} {o.seconds:7.1f} "
                    f"{num(o.skate_mm, '.2f'):>9s} {num(o.goal_cm, '.1f'):>8s} {num(o.nearest_m, '.2f'):>9s}  "
                    f"{(o.error or o.nearest or '')[:120]}")
    failed = sum(o.status != "baked" for o in outcomes)
    tail = f"{len(outcomes) - failed} of {len(outcomes)} jobs baked, {failed} failed"
    if wall_seconds is not None:
        tail += f", {wall_seconds:.1f} s wall time"
    return "\n".join(rows + [tail])


def exit_status(outcomes: list[JobOutcome]) -> int:
    """0 when every job baked, else the number that did not (at most 100)."""
    return min(100, sum(o.status != "baked" for o in outcomes))


__all__ = ["JOB_FIELDS", "JobError", "JobOutcome", "check_job", "exit_status", "is_text", "job_argv", "job_label",
           "normalised", "read_jobs", "summary_table"]
