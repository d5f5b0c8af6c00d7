"""The panel's shot: a list of characters with their goals (and waypoints), baked together
in one space and time (**Bake Together**, what ``bake --job JOBS.json --together`` does).

Each row is turned into a job as the command line reads it (``batch.check_jobs``: the
same checks, the same messages), in the list's order as priority: each character is
planned round those above it and all are measured together as Blender plays the scene
(``batch.together_steps``). Esc before the end takes back every bake of the run.
"""

from __future__ import annotations

import bpy

from ...core.base.errors import FootstepError
from .operators import _settings, _Stepped, _status, character, panel_doc, route_fields


def _row_job(context, row) -> dict:
    """The job (``core.jobs`` fields, by the objects' names) of one row of the list."""
    scene, fs = context.scene, context.scene.footstep
    job = {"character": row.character.name if row.character else "",
           "frame_start": int(scene.frame_current + row.delay)}
    if row.goal is not None:
        job["goal"] = row.goal.name
    if row.start is not None:
        job["start"] = row.start.name
    names, pause, arrive = route_fields(scene, row.waypoints, row.goal)
    if names:
        job["via"] = names
    if pause:
        job["pause"] = {n: float(v) for n, v in pause.items()}
    if arrive:
        job["arrive"] = {n: int(v) for n, v in arrive.items()}
    if fs.body_on != "OBJECT":
        job["body_on"] = fs.body_on.lower()
    return job


def cast_jobs(context) -> list:
    """The list's rows as checked jobs (``batch.Job``), in order; FootstepError naming the
    rows at fault (no character, no goal, one character twice, or what the command line
    would refuse in the job)."""
    from ..command import batch

    rows = list(context.scene.footstep.cast)
    if not rows:
        raise FootstepError(EMPTY_LIST)
    problems, seen, raw = [], {}, []
    for n, row in enumerate(rows, 1):
        ob = row.character
        label = f"row {n}" + (f" ({ob.name})" if ob is not None else "")
        if ob is None:
            problems.append(f"{label}: pick its character (an armature)")
        elif ob.as_pointer() in seen:
            problems.append(f"{label}: {ob.name!r} is in row {seen[ob.as_pointer()]} too (each character once)")
        else:
            seen[ob.as_pointer()] = n
        if row.goal is None:
            problems.append(f"{label}: pick its goal (an object to walk to)")
        raw.append(_row_job(context, row))
    if problems:
        raise FootstepError("Bake Together: " + "; ".join(problems))
    runnable, invalid = batch.check_jobs(context.scene, raw)
    if invalid:
        raise FootstepError("Bake Together: " + "; ".join(f"row {o.number}: {o.error}" for o in invalid))
    return [batch.Job(n, f"row {n} ({job['character']})", job) for n, _, job in runnable]


def _commons(context, jobs) -> list[dict]:
    fs = context.scene.footstep
    return [{"keep_frame_range": not fs.grow_frame_range} for _ in jobs]


def _row_active(cls, context) -> bool:
    """Whether a row of the list is active (else the greyed button's reason)."""
    fs = context.scene.footstep
    if 0 <= fs.cast_index < len(fs.cast):
        return True
    cls.poll_message_set(EMPTY_LIST if not len(fs.cast) else "pick a row of the list of characters to bake together")
    return False


#: Why the list's buttons are greyed out when it is empty
EMPTY_LIST = "the list of characters to bake together is empty: add each character with +"


class FOOTSTEP_OT_cast_add(bpy.types.Operator):
    """Add a character to the list baked together: the panel's character with its goal,
    start and waypoints (or, once that one is listed, the active armature)"""

    bl_idname = "footstep.cast_add"
    bl_label = "Add Character"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        fs = context.scene.footstep
        listed = {r.character.as_pointer() for r in fs.cast if r.character is not None}
        ob = character(context)
        same = ob is not None and ob == fs.character
        if ob is not None and ob.as_pointer() in listed:
            act = context.active_object
            ob = act if act is not None and act.type == "ARMATURE" and act.as_pointer() not in listed else None
            same = False
        row = fs.cast.add()
        if ob is not None:
            row.character = ob
            if same:  # (the panel's own goal, start and waypoints go with its character)
                row.goal, row.start, row.waypoints = fs.goal, fs.start, fs.waypoints
        fs.cast_index = len(fs.cast) - 1
        return {"FINISHED"}


class FOOTSTEP_OT_cast_remove(bpy.types.Operator):
    """Remove the active row from the list baked together (its character's bakes stay)"""

    bl_idname = "footstep.cast_remove"
    bl_label = "Remove Character"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        return _row_active(cls, context)

    def execute(self, context):
        fs = context.scene.footstep
        fs.cast.remove(fs.cast_index)
        fs.cast_index = min(fs.cast_index, len(fs.cast) - 1)
        return {"FINISHED"}


class FOOTSTEP_OT_cast_move(bpy.types.Operator):
    """Move the active row up or down the list: a row goes round those above it"""

    bl_idname = "footstep.cast_move"
    bl_label = "Move Character"
    bl_options = {"REGISTER", "UNDO"}

    direction: bpy.props.EnumProperty(items=[("UP", "Up", ""), ("DOWN", "Down", "")])

    @classmethod
    def poll(cls, context):
        return _row_active(cls, context)

    def execute(self, context):
        fs = context.scene.footstep
        i = fs.cast_index
        j = i - 1 if self.direction == "UP" else i + 1
        if 0 <= j < len(fs.cast):
            fs.cast.move(i, j)
            fs.cast_index = j
        return {"FINISHED"}


class FOOTSTEP_OT_bake_together(_Stepped, bpy.types.Operator):
    """Plan, synthesize and bake every character of the list in one space and time, in its
    order as priority (each goes round those above it), then measure them together as
    Blender plays the scene. Each keeps its own NLA track; Esc before the end takes back
    every bake of the run"""

    bl_idname = "footstep.bake_together"
    bl_label = "Bake Together"
    bl_options = {"REGISTER", "UNDO"}

    _steps = None
    _ended: list = []
    _jobs: list = []

    @classmethod
    def poll(cls, context):
        if not len(context.scene.footstep.cast):
            cls.poll_message_set(EMPTY_LIST)
            return False
        return True

    def _start(self, context):
        from ..command import batch

        self._jobs = cast_jobs(context)
        self._ended = []
        return batch.together_steps(context.scene, self._jobs, _commons(context, self._jobs), _settings(context),
                                    lambda job, doc, error, spent: self._ended.append((job, doc, error)))

    def execute(self, context):
        try:
            for _ in self._start(context):
                pass
        except FootstepError as ex:
            self.report({"ERROR"}, str(ex))
            return {"CANCELLED"}
        return self._finish(context)

    def invoke(self, context, event):
        return self._stepping(context)

    def modal(self, context, event):
        if event.type == "ESC":
            self._end(context)
            self._steps.close()
            msg = "bake together cancelled: every bake of the run was taken back"
            context.scene.footstep.last_report = msg
            self.report({"INFO"}, msg)
            return {"CANCELLED"}
        if event.type != "TIMER":
            return {"PASS_THROUGH"}
        try:
            fraction, stage = next(self._steps)
            context.window_manager.progress_update(int(fraction * 100))
            _status(context, f"Footstep, together: {stage}... (Esc to cancel)")
            return {"RUNNING_MODAL"}
        except StopIteration:
            self._end(context)
            return self._finish(context)

    def _finish(self, context):
        """The run's summary in the panel: each row baked (its nearest other character) or
        why not; the panel's character's report in the panel's figures."""
        fs = context.scene.footstep
        lines, baked = [], 0
        for job, doc, error in sorted(self._ended, key=lambda e: e[0].number):
            if doc is None:
                from ..command.batch import _failure

                lines.append(f"{job.label} failed: {_failure(error)}")
                continue
            baked += 1
            near = min(doc["quality"].get("others") or [], key=lambda o: o["least_distance_m"], default=None)
            order = doc.get("shot") or {}
            lines.append(f"{job.label} baked into {doc['track']!r}" + (
                "" if near is None else f", nearest {near['character']} {near['least_distance_m']:.2f} m "
                                        f"at frame {near['least_distance_frame']}") + (
                f" (planned {order['planned']} of {order['of']}: {order['moved_ahead']})"
                if order.get("moved_ahead") else ""))
            if fs.character is not None and job.fields["character"] == fs.character.name:
                fs.plan_json = panel_doc(doc)
            if fs.edit_footprints:
                _handles(context.scene, job)
        fs.last_report = f"{baked} of {len(self._jobs)} characters baked together. " + "; ".join(lines)
        self.report({"INFO"} if baked == len(self._jobs) else {"WARNING"}, fs.last_report)
        return {"FINISHED"} if baked else {"CANCELLED"}


def _handles(scene, job) -> None:
    """Footprint handles for a character the shot baked (its path as the overlay shows
    it), each waypoint's footprint locked: edited and re-planned, it leads and those it
    then meets give way (``directing.rebake_steps``)."""
    import numpy as np

    from .. import planning
    from ..read.scene import rotation_heading
    from . import handles, overlay

    ob = scene.objects.get(job.fields["character"])
    got = None if ob is None else overlay.path_of(scene, ob)
    if got is None:
        return
    path, forward = got
    goal, heading = planning.goal_of(scene, job.fields.get("goal"))
    heading = None if heading is None else rotation_heading(heading, forward)
    pos = np.array([f.position for f in path], float)
    reached = {}
    after = 0
    for name in job.fields.get("via") or []:  # (in order along the path: the nearest after the last)
        wp = scene.objects.get(name)
        if wp is None or after >= len(path):
            continue
        i = after + int(np.argmin(np.linalg.norm(pos[after:, :2] - np.array(wp.matrix_world.translation)[:2], axis=1)))
        reached[i], after = wp, i + 1
    handles.make_handles(scene, ob, path, forward, goal, heading, waypoints=reached)


CLASSES = (FOOTSTEP_OT_cast_add, FOOTSTEP_OT_cast_remove, FOOTSTEP_OT_cast_move, FOOTSTEP_OT_bake_together)


def register():
    for cls in CLASSES:
        bpy.utils.register_class(cls)


def unregister():
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)


__all__ = ["CLASSES", "cast_jobs", "register", "unregister"]
