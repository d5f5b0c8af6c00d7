"""Operators: import clips, analyse them, reset the clip library, set a role by hand.

Each reports expected problems in the status bar (naming the file, bone or clip) and
returns CANCELLED with the user's data untouched."""

from __future__ import annotations

import os

import bpy
import numpy as np
from bpy.props import BoolProperty, CollectionProperty, EnumProperty, StringProperty
from bpy_extras.io_utils import ImportHelper

from ...core.base.errors import FootstepError
from ...core.perform.run import waypoint_rows


def character(context):
    ob = context.scene.footstep.character
    if ob is None and context.active_object is not None and context.active_object.type == "ARMATURE":
        ob = context.active_object
    return ob


#: Why an operator on the planner's character is greyed out (its poll's message)
NO_CHARACTER = ("no character: pick an armature as the Footstep panel's Character, or make one "
                "active (import clips or add the Footstep Mannequin to make one)")


class _OnCharacter:
    """Operators that work on the planner's character: available once there is one."""

    @classmethod
    def poll(cls, context):
        if character(context) is None:
            cls.poll_message_set(NO_CHARACTER)
            return False
        return True


def _status(context, text) -> None:
    """The status bar's text (None gives the status bar back)."""
    ws = getattr(context, "workspace", None)
    if ws is not None:
        ws.status_text_set(text)


def _in_ui(context) -> bool:
    """Whether Blender's UI runs this (timer events come): not a background run or a script
    without a window."""
    return not bpy.app.background and getattr(context, "window", None) is not None


class _Stepped:
    """An operator that runs from the UI one step a timer tick (a modal), with the window
    manager's progress and the status bar, both given back however it ends."""

    _timer = None

    def _begin(self, context, steps: int):
        wm = context.window_manager
        wm.progress_begin(0, steps)
        self._timer = wm.event_timer_add(0.01, window=context.window)
        wm.modal_handler_add(self)
        return {"RUNNING_MODAL"}

    def _stepping(self, context):
        """Start ``self._start(context)``'s stages, one a timer tick (``modal``), or report
        the expected problem that stops it before the first."""
        try:
            self._steps = self._start(context)
        except FootstepError as ex:
            self.report({"ERROR"}, str(ex))
            return {"CANCELLED"}
        return self._begin(context, 100)

    def _end(self, context):
        wm = context.window_manager
        if self._timer is not None:
            wm.event_timer_remove(self._timer)
            self._timer = None
        wm.progress_end()
        _status(context, None)


def _owned(ob) -> dict:
    """The planner's NLA tracks on ``ob``: {(track name, its actions' ids): track}."""
    from ..write.bake import owned_tracks

    return {(tr.name, tuple(st.action.as_pointer() for st in tr.strips)): tr for tr in owned_tracks(ob)}


class FOOTSTEP_OT_import_clips(_Stepped, bpy.types.Operator, ImportHelper):
    """Import BVH, FBX, glTF or GLB files (Mixamo too; a file's several takes each a clip) as
    clips (one Action each) of the character, or of a new armature in metres, Z up (from
    the UI: one file at a time with progress; Esc stops between two files, keeping the
    files imported whole and naming them)"""

    bl_idname = "footstep.import_clips"
    bl_label = "Import Clips (BVH, FBX, glTF)"
    bl_options = {"REGISTER", "UNDO"}

    filename_ext = ".bvh"
    filter_glob: StringProperty(default="*.bvh;*.fbx;*.glb;*.gltf", options={"HIDDEN"})
    files: CollectionProperty(type=bpy.types.OperatorFileListElement, options={"HIDDEN", "SKIP_SAVE"})
    directory: StringProperty(subtype="DIR_PATH", options={"HIDDEN", "SKIP_SAVE"})
    target: EnumProperty(name="Into", items=[
        ("CHARACTER", "Character", "Add the clips to the planner's character"),
        ("NEW", "New Armature", "Make a new armature from the first file's skeleton")])

    _paths: list = []
    _done = None

    def _files(self, context):
        paths = [os.path.join(self.directory, f.name) for f in self.files if f.name] or [self.filepath]
        return paths, (character(context) if self.target == "CHARACTER" else None)

    def execute(self, context):
        from ..read.clips import import_clip_files

        paths, target = self._files(context)
        if len(paths) > 1 and _in_ui(context):
            # (in Blender's UI: a file a timer tick; a script's or a background call imports them at once)
            self._paths, self._done = paths, None
            return self._begin(context, len(paths))
        try:
            done = import_clip_files(paths, target=target)
        except FootstepError as ex:
            self.report({"ERROR"}, str(ex))
            return {"CANCELLED"}
        return self._imported(context, done)

    def modal(self, context, event):
        from ..read.clips import import_clip_files

        k = 0 if self._done is None else len({o.path for o in self._done.outcomes})
        if event.type == "ESC":
            self._end(context)
            return self._stopped(context, k)
        if event.type != "TIMER":
            return {"PASS_THROUGH"}
        target = self._files(context)[1] if self._done is None or self._done.armature is None else self._done.armature
        try:
            part = import_clip_files([self._paths[k]], target=target)
        except FootstepError as ex:
            self._end(context)
            self.report({"ERROR"}, str(ex))
            return self._stopped(context, k) if self._done is not None and self._done.actions else {"CANCELLED"}
        if self._done is None:
            self._done = part
        else:
            self._done.armature = self._done.armature or part.armature
            self._done.actions += part.actions
            self._done.outcomes += part.outcomes
        context.window_manager.progress_update(k + 1)
        if k + 1 < len(self._paths):
            _status(context, f"Footstep: imported {os.path.basename(self._paths[k])} ({k + 1} of "
                             f"{len(self._paths)} files)... (Esc to stop)")
            return {"RUNNING_MODAL"}
        self._end(context)
        return self._imported(context, self._done)

    def _stopped(self, context, k: int):
        """Esc between two files: the files imported so far are kept whole (one undo step) and
        named; the rest are not read."""
        done = self._done
        if done is None or not done.actions:
            self.report({"INFO"}, f"import cancelled before {os.path.basename(self._paths[k])}: nothing was changed")
            return {"CANCELLED"}
        kept = sorted({os.path.basename(o.path) for o in done.outcomes if o.clip})
        self.report({"WARNING"}, f"import stopped after {k} of {len(self._paths)} files: kept the clips of "
                                 f"{', '.join(kept)} in {done.armature.name} ({len(done.actions)} clip(s)); "
                                 f"not read: {', '.join(os.path.basename(p) for p in self._paths[k:])}")
        self._imported(context, done)
        return {"FINISHED"}

    def _imported(self, context, done):
        """The import's outcome reported, the armature made the character when none was
        picked, and its clips analysed."""
        from ..read.character import analyze_and_propose

        fs = context.scene.footstep
        try:
            fs.last_report = _import_summary(done)
            if not done.actions:
                self.report({"ERROR"}, fs.last_report)
                return {"CANCELLED"}
            ob = done.armature
            if fs.character is None:
                fs.character = ob
            result = analyze_and_propose(ob, _settings(context))
        except FootstepError as ex:
            self.report({"ERROR"}, str(ex))
            return {"CANCELLED"}
        for o in done.refused:
            self.report({"WARNING"}, o.error)
        for line in done.report()[1:]:
            if line.startswith("  "):
                self.report({"INFO"}, line.strip())
        self.report({"INFO"}, fs.last_report)
        for name, msg in result.errors.items():
            self.report({"WARNING"}, msg)
        return {"FINISHED"}


def _import_summary(done) -> str:
    """One line for the panel: imported N clip(s) into the armature; refused M, with reasons."""
    head = (f"imported {len(done.actions)} clip(s) into {done.armature.name}" if done.actions
            else "imported no clip")
    if not done.refused:
        return head
    return f"{head}; refused {len(done.refused)}: " + "; ".join(o.error for o in done.refused)


def _settings(context):
    from .props import settings_from_props

    return settings_from_props(context.scene.footstep.settings)


class FOOTSTEP_OT_analyze_clips(_OnCharacter, _Stepped, bpy.types.Operator):
    """Analyse the character's clips (contacts, speed, stride, tau, gait) and, unless the
    clip library was edited by hand, propose its blend groups (from the UI: one clip at a
    time with progress; Esc cancels and changes nothing)"""

    bl_idname = "footstep.analyze_clips"
    bl_label = "Analyze Clips"
    bl_options = {"REGISTER", "UNDO"}

    reset: BoolProperty(name="Reset Library", default=False,
                                  description="Replace an edited clip library by the proposal")

    _names: list = []
    _result = None

    def execute(self, context):
        from ..read.character import analyze_character

        ob = character(context)
        try:
            result = analyze_character(ob, _settings(context))
        except FootstepError as ex:
            self.report({"ERROR"}, str(ex))
            return {"CANCELLED"}
        return self._apply(context, ob, result)

    def _apply(self, context, ob, result):
        """Store what the analysis found: the proposed library, or the summaries of an
        edited one (checked to still fit)."""
        from ..read.character import library_for, summary, write_library

        try:
            if self.reset or not ob.data.footstep.library_edited:
                from ...core.clips.library import propose_library

                write_library(ob, propose_library(result.analyses), result.analyses)
            else:
                library_for(ob, result)  # checks the edited library still fits
                by = {a.name: a for a in result.analyses}
                for item in ob.data.footstep.clips:
                    if item.name in by:
                        item.summary = summary(by[item.name])
        except FootstepError as ex:
            self.report({"ERROR"}, str(ex))
            return {"CANCELLED"}
        for msg in result.errors.values():
            self.report({"WARNING"}, msg)
        self.report({"INFO"}, f"{ob.name}: analysed {len(result.analyses)} clip(s)"
                    + (f", {len(result.errors)} failed" if result.errors else ""))
        return {"FINISHED"}

    def invoke(self, context, event):
        from ..read.scene import armature_actions

        self._names, self._result = [a.name for a in armature_actions(character(context))], None
        if len(self._names) < 2:
            return self.execute(context)
        return self._begin(context, len(self._names))

    def modal(self, context, event):
        from ..read.character import analyze_character

        done = 0 if self._result is None else len(self._result.analyses) + len(self._result.errors)
        if event.type == "ESC":
            self._end(context)
            self.report({"INFO"}, f"analysis cancelled after {done} of {len(self._names)} clips: nothing was changed")
            return {"CANCELLED"}
        if event.type != "TIMER":
            return {"PASS_THROUGH"}
        ob, name = character(context), self._names[done]
        try:
            part = analyze_character(ob, _settings(context), actions=[bpy.data.actions[name]])
        except (FootstepError, KeyError) as ex:
            self._end(context)
            self.report({"ERROR"}, str(ex) if isinstance(ex, FootstepError) else f"the clip {name!r} is gone")
            return {"CANCELLED"}
        if self._result is None:
            self._result = part
        else:
            self._result.analyses += part.analyses
            self._result.errors.update(part.errors)
        context.window_manager.progress_update(done + 1)
        if done + 1 < len(self._names):
            _status(context, f"Footstep: analysed {name} ({done + 1} of {len(self._names)} clips)... (Esc to cancel)")
            return {"RUNNING_MODAL"}
        self._end(context)
        return self._apply(context, ob, self._result)


class FOOTSTEP_OT_plan(_OnCharacter, bpy.types.Operator):
    """Plan the footprints that take the character to the goal (the picked object, or
    the 3D cursor) across the traversable meshes"""

    bl_idname = "footstep.plan"
    bl_label = "Plan"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        import json

        from ...core.report.document import plan_report
        from .. import planning

        fs = context.scene.footstep
        ob = character(context)
        try:
            goal, heading = _goal(context)
            route = _via(context, goal, heading)
            planned = planning.plan_and_synthesize(context.scene, ob, goal, heading, fs.start, _settings(context),
                                                   route=route)
        except FootstepError as ex:
            self.report({"ERROR"}, str(ex))
            return {"CANCELLED"}
        result, syn = planned.result, planned.synthesis
        if fs.edit_footprints:
            from . import handles

            handles.make_handles(context.scene, ob, result.footprints, planned.setup.forward, goal,
                                 planned.goal_heading,
                                 waypoints=route.reached(context.scene) if route is not None else None)
        fs.edit_problem = ""
        doc = plan_report(result, syn, ob.name, goal, context.scene.frame_current, synthesis=False)
        if planned.performance is not None:
            from . import overlay

            doc["waypoints"] = waypoint_rows(planned, context.scene.frame_current,
                                                      planning.scene_fps(context.scene))
            overlay.label_waypoints(context.scene, doc["waypoints"])
        fs.plan_json = json.dumps(doc)
        st = doc["stages"]
        fs.last_report = (f"{len(result.footprints)} footprints, {len(syn.t)} frames; search "
                          f"{result.seconds * 1e3:.0f} ms, synthesis {st['synthesis_ms']:.0f} ms "
                          f"(smoothing {st['smoothing_ms']:.0f}, refinement {st['refinement_ms']:.0f}, "
                          f"body {st['body_trajectory_ms']:.0f}, blend groups {st['blend_groups_ms']:.0f})")
        self.report({"INFO"}, fs.last_report)
        return {"FINISHED"}


def _goal(context):
    from .. import planning

    fs = context.scene.footstep
    return planning.goal_of(context.scene, fs.goal.name if fs.goal else None)


def route_fields(scene, waypoints, goal) -> tuple[list[str], dict, dict]:
    """(names, pauses, arrival frames) of a route as the panel sets it: the objects of the
    ``waypoints`` collection in the scene, in name order; each one's pause (s) where it has
    one (name -> s); the arrival frame of each of them and of ``goal`` that asks for one
    (name -> frame)."""
    names = [n for n in sorted(o.name for o in waypoints.all_objects) if n in scene.objects] \
        if waypoints is not None else []
    objs = [scene.objects[n] for n in names]
    pauses = {o.name: o.footstep.pause for o in objs if o.footstep.pause > 0}
    arrive = {o.name: o.footstep.arrive for o in objs + ([goal] if goal else []) if o.footstep.use_arrive}
    return names, pauses, arrive


#: the report's parts the panel keeps of a bake (``plan_json``: its figures, the handles' footprints)
PANEL_KEYS = ("footprints", "search", "character", "stages", "quality", "name", "track", "action", "frame_start",
              "frame_end", "waypoints", "turns_in_place", "stands", "shot")


def panel_doc(doc: dict) -> str:
    """A bake's report as the panel keeps it (``PANEL_KEYS``), JSON."""
    import json

    return json.dumps({k: doc[k] for k in PANEL_KEYS if k in doc})


def _via(context, goal, heading):
    """The route through the panel's Waypoints collection (objects in name order), or None;
    the overlay rings the waypoints."""
    from . import overlay
    from .directing import via_route

    fs = context.scene.footstep
    names, pauses, arrive = route_fields(context.scene, fs.waypoints, fs.goal)
    route = via_route(context.scene, names, fs.goal.name if fs.goal else "the 3D cursor", goal, heading,
                      pauses, arrive)
    wps = route.waypoints[:-1] if route is not None else []
    overlay.mark(context.scene, waypoints=np.array([w[1] for w in wps], float).reshape(-1, 3))
    return route


class FOOTSTEP_OT_build_graph(_OnCharacter, bpy.types.Operator):
    """Analyse the character's clips and build what the search needs: the footsteps of the
    clip library and the walking-distance map to the goal (footprints themselves are
    sampled lazily, during the search)"""

    bl_idname = "footstep.build_graph"
    bl_label = "Build Graph"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        import time

        from .. import planning

        ob = character(context)
        try:
            goal, _ = _goal(context)
            t0 = time.perf_counter()
            setup = planning.plan_setup(context.scene, ob, _settings(context))
            pl = setup.planner
            field = pl.distance_field(goal)
            secs = time.perf_counter() - t0
        except FootstepError as ex:
            self.report({"ERROR"}, str(ex))
            return {"CANCELLED"}
        reach = int(np.isfinite(field.dist).sum())
        context.scene.footstep.last_report = (
            f"graph: {len(setup.analyses)} clips, {pl.steps.n} footsteps ({int(pl.steps.jump.sum())} jumps); "
            f"distance map {reach} cells; {secs * 1e3:.0f} ms")
        self.report({"INFO"}, context.scene.footstep.last_report)
        return {"FINISHED"}


class FOOTSTEP_OT_bake(_OnCharacter, _Stepped, bpy.types.Operator):
    """Plan the walk to the goal, synthesize it, put the feet on the footprints and bake it
    into an NLA track of the planner's own on the character (Esc before the bake is written
    leaves the scene as it was; after, the bake stays and the report names it)"""

    bl_idname = "footstep.bake"
    bl_label = "Bake"
    bl_options = {"REGISTER", "UNDO"}

    markers: BoolProperty(name="Footstep markers", default=False,
                          description="Add a timeline marker at each footstep")
    new_track: BoolProperty(name="New Track", default=False,
                            description="Bake beside the planner's earlier bake of this name, under a new name")
    force: BoolProperty(name="Replace Edits", default=False,
                        description="Bake over the planner's earlier bake of this name even if its keys were edited")

    _steps = None
    _before: set = set()
    _range = (1, 250)
    _written = False
    _route = None

    def _start(self, context):
        from .. import planning

        fs = context.scene.footstep
        goal, heading = _goal(context)
        self._route = _via(context, goal, heading)
        return planning.run_steps(context.scene, character(context), goal, heading, fs.start,
                                  _settings(context), markers=self.markers, body_on=fs.body_on,
                                  frame_range=fs.grow_frame_range, route=self._route,
                                  force=self.force, new_track=self.new_track)

    def _finish(self, context, doc):
        fs = context.scene.footstep
        fs.plan_json = panel_doc(doc)
        q, st = doc["quality"], doc["stages"]
        fs.last_report = (f"{doc['frames'] if 'frames' in doc else st['frames']} frames baked into "
                          f"{doc['track']!r}; skate {q['foot_skate']['max_mm']:.1f} mm max, goal "
                          f"{q['goal']['distance_m'] * 100:.1f} cm; synthesis {st['synthesis_ms']:.0f} ms, "
                          f"IK {st['ik_ms']:.0f} ms, bake {st['bake_ms']:.0f} ms")
        self.report({"INFO"}, fs.last_report)
        if doc.get("waypoints"):
            from . import overlay

            overlay.label_waypoints(context.scene, doc["waypoints"])
        if fs.edit_footprints:
            _handles_of_last_plan(context, self._route)
        stashed = doc.get("stashed_action")
        if stashed:
            self.report({"INFO"}, f"the character's active action {stashed!r} is stashed in a muted NLA track "
                        "so the bake plays; Clear gives it back")

    def execute(self, context):
        from .. import planning

        try:
            self._finish(context, planning.run_to_end(self._start(context)))
            return {"FINISHED"}
        except FootstepError as ex:
            _refused(self, ex)
            return {"CANCELLED"}

    def invoke(self, context, event):
        ob = character(context)
        self._before = set(_owned(ob))
        self._range = (context.scene.frame_start, context.scene.frame_end)
        self._written = False
        return self._stepping(context)

    def modal(self, context, event):
        if event.type == "ESC":
            return self._cancel(context)
        if event.type != "TIMER":
            return {"PASS_THROUGH"}
        try:
            fraction, stage = next(self._steps)
            # run_steps yields its quality stage once the bake is written into the scene
            self._written = self._written or stage == WRITTEN_BEFORE
            context.window_manager.progress_update(int(fraction * 100))
            _status(context, f"Footstep: {stage}... (Esc to cancel)")
            return {"RUNNING_MODAL"}
        except StopIteration as done:
            self._end(context)
            self._finish(context, done.value)
            return {"FINISHED"}
        except FootstepError as ex:
            self._end(context)
            _refused(self, ex)
            return {"CANCELLED"}

    def _cancel(self, context):
        """Esc: stop before the next stage. Stopping takes back whatever the run made (a
        bake written but not yet measured is taken back, ``planning.run_steps``), so the
        scene is as it was; should anything of the run be left in the scene, it is named,
        and it is one undo step."""
        self._end(context)
        self._steps.close()
        ob = character(context)
        kept = [tr for key, tr in _owned(ob).items() if key not in self._before] if ob is not None else []
        if not kept:  # (before the bake, or a bake taken back before its quality was measured)
            self.report({"INFO"}, "bake cancelled: nothing was changed")
            return {"CANCELLED"}
        from ..write.bake import STASH_PROP

        what = "; ".join(f"NLA track {tr.name!r} (action {tr.strips[0].action.name!r}, frames "
                         f"{tr.strips[0].frame_start:.0f}-{tr.strips[-1].frame_end:.0f})" for tr in kept)
        also = [f"the active action {st.action[STASH_PROP]!r} stashed in a muted NLA track"
                for tr in kept for st in tr.strips[:1] if st.action.get(STASH_PROP)]
        sc = context.scene
        if (sc.frame_start, sc.frame_end) != tuple(self._range):
            also.append(f"the scene's frame range {sc.frame_start}-{sc.frame_end} (was {self._range[0]}-"
                        f"{self._range[1]})")
        msg = (f"bake cancelled while its quality was measured: the bake was already written and is kept: "
               f"{what or 'the planner track on ' + ob.name}" + "".join(f", with {a}" for a in also)
               + "; its quality figures were not measured (Clear or Undo removes it)")
        context.scene.footstep.last_report = msg
        self.report({"WARNING"}, msg)
        return {"FINISHED"}  # (what is kept is one undo step)


#: ``planning.run_steps``' stage that comes once the bake is in the scene
WRITTEN_BEFORE = "quality"


def _refused(op, ex) -> None:
    """Report a refused bake; over an edited bake, offer to bake to a new track."""
    from ..write.bake import EditedBakeError

    op.report({"ERROR"}, str(ex))
    if isinstance(ex, EditedBakeError):
        op.report({"WARNING"}, "to keep your edits, bake again with New Track (in the Bake operator's options) "
                  "or give the bake another name; Replace Edits bakes over them")


def _handles_of_last_plan(context, route=None) -> None:
    """Footprint handles for the path the last plan or bake of this scene made (through
    ``route``'s waypoints, a ``directing.ViaRoute``, when it had one: their footprints
    locked, following them)."""
    from . import handles
    from .overlay import LAST

    from ..read.scene import rotation_heading

    last = LAST.get(context.scene.name)
    if last and last.get("path"):
        goal, heading = _goal(context)
        heading = None if heading is None else rotation_heading(heading, last["forward"])
        handles.make_handles(context.scene, character(context), last["path"], last["forward"], goal, heading,
                             waypoints=route.reached(context.scene) if route is not None else None)


def _show_refused(context, ex) -> None:
    """Ring in the warning colour the footprint an edit put where it can't be."""
    from . import handles, overlay

    i = getattr(ex, "footprint", None)
    hs = handles.handles(character(context))
    if i is not None and i < len(hs):
        overlay.mark(context.scene, refused=[np.array(hs[i].matrix_world.translation)])


class FOOTSTEP_OT_lock_footprints(_OnCharacter, bpy.types.Operator):
    """Lock the selected footprints (a re-plan keeps them where they are), or unlock them"""

    bl_idname = "footstep.lock_footprints"
    bl_label = "Lock Footprints"
    bl_options = {"REGISTER", "UNDO"}

    lock: BoolProperty(name="Lock", default=True)

    def execute(self, context):
        from . import handles

        n = handles.set_locked(context.selected_objects, self.lock)
        if not n:
            self.report({"WARNING"}, "select footprint handles (the empties in 'Footprints: ...') first")
            return {"CANCELLED"}
        self.report({"INFO"}, f"{'locked' if self.lock else 'unlocked'} {n} footprint(s)")
        return {"FINISHED"}


class FOOTSTEP_OT_replan(_OnCharacter, _Stepped, bpy.types.Operator):
    """Re-plan around the footprints you moved (they stay where you put them, as do the
    locked ones) and re-bake: only the re-planned span is re-keyed. Round other characters,
    this one leads: those with footprints of their own that it now meets give way round it
    (from the UI: stage by stage with progress; Esc cancels what is not yet baked)"""

    bl_idname = "footstep.replan"
    bl_label = "Re-plan"
    bl_options = {"REGISTER", "UNDO"}

    _steps = None
    _baked: list = []

    def _start(self, context):
        from . import directing

        fs = context.scene.footstep
        self._baked = []
        return directing.rebake_steps(context.scene, character(context), _settings(context), body_on=fs.body_on,
                                      frame_range=fs.grow_frame_range, baked=self._baked)

    def execute(self, context):
        from .. import planning

        try:
            return self._finish(context, *planning.run_to_end(self._start(context)))
        except FootstepError as ex:
            return self._refused(context, ex)

    def invoke(self, context, event):
        self._steps = self._start(context)
        return self._begin(context, 100)

    def modal(self, context, event):
        if event.type == "ESC":
            self._end(context)
            self._steps.close()  # (a bake written but not yet measured is taken back)
            if not self._baked:
                self.report({"INFO"}, "re-plan cancelled: nothing was changed")
                return {"CANCELLED"}
            names = ", ".join(o.name for o in self._baked)
            context.scene.footstep.last_report = (f"re-plan stopped: {names} re-planned and kept; the character "
                                                  "giving way when you stopped it is as it was")
            self.report({"WARNING"}, context.scene.footstep.last_report)
            return {"FINISHED"}
        if event.type != "TIMER":
            return {"PASS_THROUGH"}
        try:
            fraction, stage = next(self._steps)
        except StopIteration as done:
            self._end(context)
            return self._finish(context, *done.value)
        except FootstepError as ex:
            self._end(context)
            return self._refused(context, ex)
        context.window_manager.progress_update(int(100 * fraction))
        _status(context, f"Footstep: re-plan: {stage}... (Esc to cancel)")
        return {"RUNNING_MODAL"}

    def _refused(self, context, ex):
        context.scene.footstep.edit_problem = str(ex)
        _show_refused(context, ex)
        self.report({"ERROR"}, str(ex))
        return {"CANCELLED"}

    def _finish(self, context, doc, route, splice):
        fs = context.scene.footstep
        fs.edit_problem = ""
        fs.last_report = replan_summary(doc, route)
        self.report({"WARNING"} if any("error" in r for r in doc.get("others_replanned") or []) else {"INFO"},
                    fs.last_report)
        return {"FINISHED"}


def replan_summary(doc: dict, route) -> str:
    """The panel's line for a re-plan's bake (``directing.rebake_steps``' report and route)."""
    span = doc.get("rebaked_frames")
    return (f"re-planned {len(route.edited.spans)} span(s); "
            + (f"re-keyed frames {span[0]}-{span[1]} only; " if span
               else f"{doc['rebaked_whole']}; " if doc.get("rebaked_whole") else "baked the whole path; ")
            + f"skate {doc['quality']['foot_skate']['max_mm']:.1f} mm max"
            + "".join(f"; {_gave_way(row)}" for row in doc.get("others_replanned") or []))


def _gave_way(row: dict) -> str:
    """One line of a re-plan's summary for another character it met (``directing.rebake_steps``)."""
    was = f"{row['was_m']:.2f} m at frame {row['was_frame']}"
    if "error" in row:
        return f"{row['character']} came within {was} and could not give way: {row['error']}"
    now = f", now {row['now_m']:.2f} m" if "now_m" in row else ""
    return f"{row['character']} came within {was}: re-planned round it{now}"


class FOOTSTEP_OT_clear(_OnCharacter, bpy.types.Operator):
    """Remove the planner's own bake from the character (its NLA track, action and
    markers); nothing of yours is touched"""

    bl_idname = "footstep.clear"
    bl_label = "Clear"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        from ..write.bake import check_not_tweaking, clear
        from .handles import clear_handles

        try:
            check_not_tweaking(character(context))
        except FootstepError as ex:
            self.report({"ERROR"}, str(ex))
            return {"CANCELLED"}
        from . import overlay

        n = clear(character(context), context.scene)
        clear_handles(character(context))
        overlay.forget(context.scene, character(context))
        self.report({"INFO"}, f"removed {n} planner track(s)" if n else "nothing of the planner's to remove")
        return {"FINISHED"}


CLASSES = (FOOTSTEP_OT_import_clips, FOOTSTEP_OT_analyze_clips, FOOTSTEP_OT_plan, FOOTSTEP_OT_build_graph,
           FOOTSTEP_OT_bake, FOOTSTEP_OT_lock_footprints, FOOTSTEP_OT_replan, FOOTSTEP_OT_clear)


def _menu_import(self, context):
    self.layout.operator(FOOTSTEP_OT_import_clips.bl_idname,
                         text="Clips for Footstep Planner (.bvh, .fbx, .glb, .gltf)")


def register():
    for cls in CLASSES:
        bpy.utils.register_class(cls)
    bpy.types.TOPBAR_MT_file_import.append(_menu_import)


def unregister():
    bpy.types.TOPBAR_MT_file_import.remove(_menu_import)
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)
