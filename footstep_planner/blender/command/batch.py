"""Bake jobs one after another in this Blender (``bake --job JOBS.json``): each job is
checked against the scene before any runs, each runs on its own, and one that fails (for
any reason, a bug too) is rolled back, reported by number and name, and does not stop
the others. ``core/jobs.py`` holds what a job is; ``ray_batch.py`` runs jobs elsewhere.
"""

from __future__ import annotations

import math
import sys
import time
import traceback
from dataclasses import dataclass

import bpy

from ...core.base.errors import FootstepError
from ...core.base.files import Outputs, describe_os_error
from ...core.jobs import JobOutcome, check_job, job_label, normalised
from ...core.plan.search_state import BlockedError
from ...core.base.settings import Settings

BUG_LINE = ("footstep: this is a bug in Footstep Planner, not a problem with your files: please report "
            "it with the command line and the traceback above")


@dataclass
class Job:
    """A checked job: its number (from 1), label, fields (``core.jobs.normalised``) and the
    paths its report and scene go to (claimed outputs, or None)."""
    number: int
    label: str
    fields: dict
    report: str | None = None
    out: str | None = None


def scene_problems(scene, job: dict) -> list[str]:
    """What in the scene a job names and the scene lacks: the armature, the goal and start
    objects."""
    problems = []
    ob = bpy.data.objects.get(job["character"])
    if ob is None:
        problems.append(f"no object named {job['character']!r} in {bpy.data.filepath or 'the scene'}")
    elif missing_library(ob):
        problems.append(missing_library(ob))
    elif ob.type != "ARMATURE":
        problems.append(f"object {job['character']!r} is a {ob.type.lower()}, not an armature")
    elif scene.objects.get(ob.name) is None:
        problems.append(not_in_scene(scene, ob))
    for key in ("goal", "start"):
        if job.get(key) and scene.objects.get(job[key]) is None:
            problems.append(f"no object named {job[key]!r} for the {key} in scene {scene.name!r}"
                            + _elsewhere(scene, job[key]))
    for name in job.get("via") or ():
        if scene.objects.get(name) is None:
            problems.append(f"no object named {name!r} for a waypoint in scene {scene.name!r}" + _elsewhere(scene, name))
    return problems


def missing_library(ob) -> str | None:
    """One line when ``ob`` (or its data) is linked from a library file that is missing,
    else None."""
    ids = [ob] + ([ob.data] if ob.data is not None else [])
    lib = next((i.library for i in ids if i.library is not None and (i.is_missing or i.library.is_missing)), None)
    if lib is None and not ob.is_missing:
        return None
    where = f"the library {lib.filepath!r}" if lib is not None else "a library"
    return (f"object {ob.name!r} comes from {where}, which is missing (moved or deleted?): relink it (File > "
            "External Data > Find Missing Files, or Relocate in the Outliner's Blender File view) and bake again")


def _elsewhere(scene, name: str) -> str:
    """Where else an object of that name is: ' (it is in scene 'X': --scene X)', or ''."""
    other = [s.name for s in bpy.data.scenes if s != scene and s.objects.get(name) is not None]
    return f" (it is in scene {other[0]!r}: pick that scene with --scene {other[0]!r})" if other else ""


def not_in_scene(scene, ob) -> str:
    """One line: ``ob`` is not in ``scene`` (and which scene it is in)."""
    return f"character {ob.name!r} is not in scene {scene.name!r}" + _elsewhere(scene, ob.name)


def check_jobs(scene, raw: list) -> tuple[list[tuple[int, str, dict]], list[JobOutcome]]:
    """(runnable (number, label, normalised job)), invalid outcomes): every job checked
    for its fields, its settings' ranges and the scene's objects before any runs."""
    runnable, invalid = [], []
    for n, job in enumerate(raw, 1):
        label = job_label(n, job)
        problems = check_job(n, job)
        if not problems:
            problems = scene_problems(scene, job)
        if problems:
            invalid.append(JobOutcome(n, label, "invalid", error="; ".join(problems)))
        else:
            runnable.append((n, label, normalised(job)))
    return runnable, invalid


class Snapshot:
    """What a job may change in the scene, to roll a failed job back: the actions, the
    character's NLA tracks (by identity, not name) and active action, the timeline markers
    (each (name, frame)), the frame range, and the character's channels as typed."""

    def __init__(self, scene, ob):
        from collections import Counter

        from ..write.bake import character_state

        self.scene, self.ob = scene, ob
        self.actions = set(bpy.data.actions)
        ad = ob.animation_data
        self.tracks = {t.as_pointer() for t in ad.nla_tracks} if ad else set()
        self.active = (ad.action, ad.action_slot) if ad else (None, None)
        self.markers = Counter((m.name, m.frame) for m in scene.timeline_markers)
        self.range = (scene.frame_start, scene.frame_end)
        self.state = character_state(ob)

    def restore(self) -> None:
        from collections import Counter

        from ..write import bake as baking

        ad = self.ob.animation_data
        if ad is not None:  # (the job's bakes first, as Clear removes them; then anything else it added)
            baking.remove_tracks(self.ob, self.scene, [t for t in baking.owned_tracks(self.ob)
                                                       if t.as_pointer() not in self.tracks])
            ad = self.ob.animation_data
        if ad is not None:
            for t in [t for t in ad.nla_tracks if t.as_pointer() not in self.tracks]:
                ad.nla_tracks.remove(t)
            if ad.action != self.active[0]:
                ad.action = self.active[0]
                if self.active[1] is not None:
                    ad.action_slot = self.active[1]
        for act in [a for a in bpy.data.actions if a not in self.actions]:
            bpy.data.actions.remove(act)
        have = Counter()
        for m in list(self.scene.timeline_markers):
            have[(m.name, m.frame)] += 1
            if have[(m.name, m.frame)] > self.markers[(m.name, m.frame)]:
                self.scene.timeline_markers.remove(m)
        self.scene.frame_start, self.scene.frame_end = self.range
        baking.give_back_state(self.ob, self.state)


def clashing_jobs(scene, jobs: list) -> str | None:
    """One line naming two jobs of one character that would overlap (they start on the
    same frame) or replace one another (one bake name), or None. A job's length is known
    only once it is planned: a job that overlaps an earlier one's bake when it runs fails
    by itself (``bake.check_overlap``)."""
    seen = {}
    for job in jobs:
        f = job.fields
        ob = bpy.data.objects.get(f["character"])
        start = int(scene.frame_current if f.get("frame_start") is None else f["frame_start"])
        name = f.get("name") or f"{f['character']} to goal"
        for key, why in (((f["character"], "start", start), f"both start on frame {start}"),
                         ((f["character"], "name", name), f"both bake {name!r}")):
            if key in seen:
                return (f"jobs {seen[key].number} and {job.number} {why} on character "
                        f"{ob.name if ob else f['character']!r}: each bake of a character needs its own name and "
                        "frames (give each job a \"name\" and a \"frame_start\" after the other's end)")
            seen[key] = job
    return None


def goal_and_start(scene, goal: str | None, heading_deg, start: str | None):
    """(goal position, goal heading (a Z rotation, rad) or None, start object or None)
    from the names a command or a job gives (``heading_deg``, when given, overrides the
    goal empty's own heading)."""
    from .. import planning

    position, heading = planning.goal_of(scene, goal)
    if heading_deg is not None:
        heading = math.radians(float(heading_deg))
    marker = None
    if start:
        marker = scene.objects.get(start)
        if marker is None:
            raise FootstepError(f"no object named {start!r} to start at")
    return position, heading, marker


def bake_job(scene, job: dict, common: dict, settings: Settings, plan=None) -> dict:
    """Bake one checked job into ``scene``; returns its report. Through the job's ``via``
    waypoints (object names) in order, or along ``plan`` (a ``core.plan.plan_file.PlanFile``:
    its locked and moved footprints kept, only what changed re-planned and, over an
    earlier bake of that plan, re-keyed)."""
    from .. import planning

    return planning.run_to_end(bake_job_steps(scene, job, common, settings, plan))


def bake_job_steps(scene, job: dict, common: dict, settings: Settings, plan=None, shot=None):
    """``bake_job`` one stage at a time (``planning.bake_steps``): a generator yielding
    (fraction done, next stage) and returning the report; in ``shot`` (a
    ``together.Shot``), round the shot's earlier jobs and measured in its pass."""
    from .. import planning

    ob = bpy.data.objects[job["character"]]
    position, heading, start = goal_and_start(scene, job.get("goal"), job.get("goal_heading"), job.get("start"))
    route, splice = _route(scene, job, plan, ob, position, heading)
    if plan is not None and job.get("goal") is None and plan.goal is not None:
        position = plan.goal
    doc = yield from planning.run_steps(
        scene, ob, position, heading, start, settings.replace(**job.get("settings", {})),
        common.get("traversable", ()), common.get("obstacles", ()), name=job.get("name"),
        frame_start=job.get("frame_start"), markers=bool(common.get("markers")),
        body_on=str(job.get("body_on") or common.get("body_on") or "object").upper(),
        frame_range=not common.get("keep_frame_range"), route=route, splice=splice, force=bool(common.get("force")),
        new_track=bool(common.get("new_track")), not_around=tuple(common.get("not_around", ())), shot=shot)
    _route_report(doc, route, splice, job)
    return doc


def _route(scene, job: dict, plan, ob, position, heading):
    """(route, splice) for ``planning.run``: waypoints, an edited plan, or (None, None)."""
    from ..ui import directing

    if plan is not None:
        route = directing.EditedRoute(plan)
        return route, directing.Splice.of(ob, route)
    return directing.via_route(scene, job.get("via"), job.get("goal") or "the goal", position, heading,
                               job.get("pause"), job.get("arrive")), None


def _route_report(doc: dict, route, splice, job: dict) -> None:
    """What a route adds to the report: each waypoint's footprint and frame, or the
    re-planned spans and the frames re-keyed."""
    from ..ui import directing

    if isinstance(route, directing.ViaRoute):
        rows = doc.get("waypoints") or [{"name": w[0]} for w in route.waypoints]
        for row, i in zip(rows, route.route.arrivals):
            i += 1  # (the baked path begins with the other standing foot)
            row.update({"footprint": i, "frame": doc["footprints"][i]["frame"],
                        "position": doc["synthesis"]["footprints"][i]["planned"]})
        doc["waypoints"] = rows
    elif isinstance(route, directing.EditedRoute) and route.edited is not None:
        directing.edit_report(doc, route, splice)


def _failure(ex: BaseException) -> str:
    """The message of a failed job: the expected problem's own, or a bug's traceback on
    stderr and its last line."""
    if isinstance(ex, FootstepError):
        return str(ex)
    if isinstance(ex, OSError):
        return describe_os_error(ex)
    traceback.print_exception(ex, file=sys.stderr)
    print(BUG_LINE, file=sys.stderr)
    return f"internal error: {type(ex).__name__}: {ex}"


def run_job(scene, job: Job, common: dict, settings: Settings, outputs: Outputs, save) -> JobOutcome:
    """Run one job, rolled back if it fails; its report (and scene, when it names an
    ``out``) are staged in ``outputs``. ``save(path)`` saves the scene to a path."""
    ob = bpy.data.objects[job.fields["character"]]
    snap = Snapshot(scene, ob)
    t0 = time.perf_counter()
    staged = []
    try:
        doc = bake_job(scene, job.fields, common, settings)
        if job.report:
            staged.append(outputs.write_json(job.report, doc))
        if job.out:
            staged.append(outputs.stage(job.out, save))
    except Exception as ex:  # one job's failure, whatever it is, stops only that job
        for tmp in staged:
            outputs.unstage(tmp)
        snap.restore()
        return JobOutcome(job.number, job.label, "failed", time.perf_counter() - t0, error=_failure(ex))
    return JobOutcome.from_report(job.number, job.label, doc, time.perf_counter() - t0,
                                  [p for p in (job.report, job.out) if p])


#: The stage at which a job of a shot waits for the others (``planning.bake_steps``).
SHOT_STAGE = "quality"


def together_steps(scene, jobs: list[Job], commons: list[dict], settings: Settings, end):
    """``run_together``'s shot one stage at a time: a generator yielding (fraction done, what
    it is doing) and returning when every job has ended; ``end(job, doc, error, seconds)`` is
    called as each ends (its report, or the exception that stopped it).

    The jobs are planned in the list's order as priority. Where the earlier ones block a
    job (``BlockedError``: alone it has a way, round them none, and no stand lets them pass)
    the shot is planned again once with the blocked jobs first (prioritized planning with
    repair); the order that bakes more jobs is kept (the list's on a tie), and each report's
    ``shot`` says the order planned and why. Closing it before the end (Esc in the panel)
    takes back every bake it made, the latest first, and leaves the scene as it was."""
    n = max(len(jobs), 1)
    listed = list(range(len(jobs)))
    tried = yield from _shot_pass(scene, jobs, commons, settings, listed, n)
    blocked = [i for i, ex, _ in tried[2] if isinstance(ex, BlockedError)]
    order = listed
    if blocked:
        again = blocked + [i for i in listed if i not in blocked]
        _take_back(tried[1])
        yield n / (n + 1), "planning again with " + ", ".join(jobs[i].label for i in blocked) + " first"
        retried = yield from _shot_pass(scene, jobs, commons, settings, again, n)
        if len(retried[1]) > len(tried[1]):
            tried, order = retried, again
        else:  # (no better: the list's order again, as it was)
            _take_back(retried[1])
            tried = yield from _shot_pass(scene, jobs, commons, settings, listed, n)
    shot, going, failed = tried
    why = {i: f"{jobs[i].label} was blocked by those before it in the list (alone it has a way)"
           for i in blocked} if order is not listed else {}

    def with_order(i: int, doc: dict) -> dict:
        doc["shot"] = {"listed": i + 1, "planned": order.index(i) + 1, "of": len(jobs),
                       **({"moved_ahead": why[i]} if i in why else {})}
        return doc

    try:
        for i, ex, spent in failed:
            end(jobs[i], None, ex, spent)
        yield n / (n + 1), "measuring the shot as played"
        from .. import planning

        shot.close(planning.other_characters(scene, None))
        while going:
            i, steps, spent = going[0]
            t0 = time.perf_counter()
            try:
                doc = planning.run_to_end(steps)
            except Exception as ex:  # (its bake taken back by the stage itself; the others stand)
                going.pop(0)
                end(jobs[i], None, ex, spent + time.perf_counter() - t0)
                continue
            going.pop(0)
            end(jobs[i], with_order(i, doc), None, spent + time.perf_counter() - t0)
    except GeneratorExit:
        _take_back(going)
        raise


def _shot_pass(scene, jobs: list[Job], commons: list[dict], settings: Settings, order: list[int], n: int):
    """Plan and bake ``jobs`` in ``order`` (indices) in a new ``together.Shot``, each round
    those before it, up to the stage where each waits for the shot's measure: returns
    (shot, going (index, its stages, s spent), failed (index, exception, s spent)); a job
    that fails is rolled back there and then. Closed before it returns, it takes back every
    bake it made."""
    from ..together import Shot

    shot, going, failed, current = Shot(scene), [], [], None
    try:
        for k, i in enumerate(order):
            job, common = jobs[i], commons[i]
            ob = bpy.data.objects[job.fields["character"]]
            snap, t0 = Snapshot(scene, ob), time.perf_counter()
            steps = bake_job_steps(scene, job.fields, common, settings.replace(avoid_characters=True), shot=shot)
            current = (steps, snap)
            try:
                while True:
                    fraction, stage = next(steps)
                    if stage == SHOT_STAGE:
                        break
                    yield (k + fraction) / (n + 1), f"{job.label}: {stage}"
            except StopIteration:  # (a bake that ends without a measure: not one of today's)
                raise RuntimeError(f"{job.label}: the bake ended before its {SHOT_STAGE!r} stage") from None
            except Exception as ex:  # one job's failure, whatever it is, stops only that job
                steps.close()
                snap.restore()
                current = None
                failed.append((i, ex, time.perf_counter() - t0))
                continue
            current = None
            going.append((i, steps, time.perf_counter() - t0))
    except GeneratorExit:  # (stopped: every bake of this pass taken back, the latest first)
        if current is not None:
            current[0].close()
            current[1].restore()
        _take_back(going)
        raise
    return shot, going, failed


def _take_back(going: list) -> None:
    """Every bake of a ``_shot_pass``'s ``going`` (index, its stages, s) taken back, the
    latest first (each job's stages, closed, take back its bake and give back the frame
    range it grew)."""
    while going:
        going.pop()[1].close()


def run_together(scene, jobs: list[Job], commons: list[dict], settings: Settings, outputs: Outputs, save,
                 tell=None) -> list[JobOutcome]:
    """Run ``jobs`` (each with its ``commons`` entry) in one space and time, in the list's
    order (``together_steps``, a ``together.Shot``): each planned and baked round those
    before it, then all measured in one pass of the scene as Blender plays it, each against
    every other; then their reports (and scenes) are staged in ``outputs``. A job that fails
    before it bakes is rolled back there and then (nothing after it has baked yet); one whose
    bake fails its measure is taken back (``planning.bake_steps``) and the others stand.
    ``tell(outcome)`` is called as each job ends; ``save(path)`` gives what saves the scene at
    a path (the shot's scene, every character in it, for each job that names an ``out``)."""
    outcomes = []

    def end(job: Job, doc, error, spent: float) -> None:
        staged = []
        if doc is not None and job.report:
            try:
                staged.append(outputs.write_json(job.report, doc))
            except Exception as ex:
                doc, error = None, ex
        if doc is None:
            for tmp in staged:
                outputs.unstage(tmp)
            o = JobOutcome(job.number, job.label, "failed", spent, error=_failure(error))
        else:
            o = JobOutcome.from_report(job.number, job.label, doc, spent, [p for p in (job.report, job.out) if p])
        outcomes.append(o)
        if tell is not None:
            tell(o)

    for _ in together_steps(scene, jobs, commons, settings, end):
        pass
    for job in jobs:  # (each job's scene: the shot as it was baked, every character in it)
        if job.out and any(o.number == job.number and o.status == "baked" for o in outcomes):
            outputs.stage(job.out, save(job.out))
    return outcomes


__all__ = ["BUG_LINE", "Job", "Snapshot", "bake_job", "check_jobs", "clashing_jobs", "missing_library", "not_in_scene", "goal_and_start", "run_job", "run_together", "scene_problems",
           "together_steps"]
