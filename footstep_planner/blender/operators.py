"""Operators: import clips, analyse them, reset the clip library, set a role by hand.

Each reports expected problems in the status bar (naming the file, bone or clip) and
returns CANCELLED with the user's data untouched."""

from __future__ import annotations

import os

import bpy
from bpy.props import BoolProperty, CollectionProperty, EnumProperty, StringProperty
from bpy_extras.io_utils import ImportHelper

from ..core.errors import FootstepError


def character(context):
    ob = context.scene.footstep.character
    if ob is None and context.active_object is not None and context.active_object.type == "ARMATURE":
        ob = context.active_object
    return ob


class FOOTSTEP_OT_import_clips(bpy.types.Operator, ImportHelper):
    """Import BVH files as clips (one Action each) of the character, or of a new armature"""

    bl_idname = "footstep.import_clips"
    bl_label = "Import BVH Clips"
    bl_options = {"REGISTER", "UNDO"}

    filename_ext = ".bvh"
    filter_glob: StringProperty(default="*.bvh", options={"HIDDEN"})
    files: CollectionProperty(type=bpy.types.OperatorFileListElement, options={"HIDDEN", "SKIP_SAVE"})
    directory: StringProperty(subtype="DIR_PATH", options={"HIDDEN", "SKIP_SAVE"})
    target: EnumProperty(name="Into", items=[
        ("CHARACTER", "Character", "Add the clips to the planner's character"),
        ("NEW", "New Armature", "Make a new armature from the first file's skeleton")])

    def execute(self, context):
        from .character import analyze_character, library_for, write_library
        from .clips import import_bvh_clips

        paths = [os.path.join(self.directory, f.name) for f in self.files if f.name] or [self.filepath]
        target = character(context) if self.target == "CHARACTER" else None
        try:
            ob, actions = import_bvh_clips(paths, target=target)
            if context.scene.footstep.character is None:
                context.scene.footstep.character = ob
            result = analyze_character(ob, _settings(context))
            if not ob.data.footstep.library_edited:
                write_library(ob, library_for(ob, result), result.analyses)
        except FootstepError as ex:
            self.report({"ERROR"}, str(ex))
            return {"CANCELLED"}
        self.report({"INFO"}, f"imported {len(actions)} clip(s) into {ob.name}")
        for name, msg in result.errors.items():
            self.report({"WARNING"}, msg)
        return {"FINISHED"}


def _settings(context):
    from .props import settings_from_props

    return settings_from_props(context.scene.footstep.settings)


class FOOTSTEP_OT_analyze_clips(bpy.types.Operator):
    """Analyse the character's clips (contacts, speed, stride, tau, gait) and, unless the
    clip library was edited by hand, propose its blend groups"""

    bl_idname = "footstep.analyze_clips"
    bl_label = "Analyze Clips"
    bl_options = {"REGISTER", "UNDO"}

    reset: BoolProperty(name="Reset Library", default=False,
                                  description="Replace an edited clip library by the proposal")

    @classmethod
    def poll(cls, context):
        return character(context) is not None

    def execute(self, context):
        from .character import analyze_character, library_for, summary, write_library

        ob = character(context)
        try:
            result = analyze_character(ob, _settings(context))
            if self.reset or not ob.data.footstep.library_edited:
                from ..core.library import propose_library

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


class FOOTSTEP_OT_plan(bpy.types.Operator):
    """Plan the footprints that take the character to the goal (the picked object, or
    the 3D cursor) across the traversable meshes"""

    bl_idname = "footstep.plan"
    bl_label = "Plan"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        return character(context) is not None

    def execute(self, context):
        import json

        from . import planning

        fs = context.scene.footstep
        ob = character(context)
        try:
            goal, heading = planning.goal_of(context.scene, fs.goal.name if fs.goal else None)
            settings = _settings(context)
            result, setup = planning.plan(context.scene, ob, goal, heading, fs.start, settings)
            syn = planning.synthesize(context.scene, result, setup, settings)
        except FootstepError as ex:
            self.report({"ERROR"}, str(ex))
            return {"CANCELLED"}
        from .cli import stage_row

        doc = result.to_dict()
        doc["character"] = ob.name
        doc["stages"] = stage_row(result, syn)
        fs.plan_json = json.dumps(doc)
        st = doc["stages"]
        fs.last_report = (f"{len(result.footsteps)} footprints, {len(syn.t)} frames; search "
                          f"{result.seconds * 1e3:.0f} ms, synthesis {st['synthesis_ms']:.0f} ms "
                          f"(smoothing {st['smoothing_ms']:.0f}, refinement {st['refinement_ms']:.0f}, "
                          f"body {st['body_trajectory_ms']:.0f}, blend groups {st['blend_groups_ms']:.0f})")
        self.report({"INFO"}, fs.last_report)
        return {"FINISHED"}


CLASSES = (FOOTSTEP_OT_import_clips, FOOTSTEP_OT_analyze_clips, FOOTSTEP_OT_plan)


def _menu_import(self, context):
    self.layout.operator(FOOTSTEP_OT_import_clips.bl_idname, text="BVH Clips for Footstep Planner (.bvh)")


def register():
    for cls in CLASSES:
        bpy.utils.register_class(cls)
    bpy.types.TOPBAR_MT_file_import.append(_menu_import)


def unregister():
    bpy.types.TOPBAR_MT_file_import.remove(_menu_import)
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)
