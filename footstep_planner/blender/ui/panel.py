"""The sidebar tab "Footstep" in the 3D View. Drawing only: all state is in props."""

from __future__ import annotations

import bpy

from ...core.clips.roles import ALL_ROLES, REQUIRED_ROLES
from .operators import character


class FOOTSTEP_UL_clips(bpy.types.UIList):
    def draw_item(self, context, layout, data, item, icon, active_data, active_propname, index):
        row = layout.row(align=True)
        row.label(text=item.name, icon="ACTION")
        row.prop(item, "usage", text="")
        if item.usage == "TURN":
            row.prop(item, "gait", text="")
            row.prop(item, "tau", text="tau")
        elif item.usage != "EXCLUDED":
            row.prop(item, "entry_gait", text="")
            row.prop(item, "exit_gait", text="")


class FOOTSTEP_UL_cast(bpy.types.UIList):
    """The characters baked together: each row's character, goal and waypoints."""

    def draw_item(self, context, layout, data, item, icon, active_data, active_propname, index):
        row = layout.row(align=True)
        row.prop(item, "character", text="", icon="OUTLINER_OB_ARMATURE")
        row.prop(item, "goal", text="", icon="EMPTY_ARROWS")
        if item.waypoints is not None:
            row.label(text="", icon="OUTLINER_COLLECTION")


class FOOTSTEP_PT_main(bpy.types.Panel):
    """The planner's tab: the character, then a sub-panel for each step (as Rigify and the
    glTF exporter lay theirs out), the rarely used ones closed."""

    bl_label = "Footstep Planner"
    bl_idname = "FOOTSTEP_PT_main"
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "Footstep"

    def draw(self, context):
        layout = self.layout
        fs = context.scene.footstep
        layout.prop(fs, "character")
        if character(context) is None:
            layout.label(text="Pick an armature, import clips (BVH, FBX, glTF), or add the mannequin", icon="INFO")
            layout.operator("footstep.import_clips", icon="IMPORT").target = "NEW"
            layout.operator("footstep.add_mannequin", icon="OUTLINER_OB_ARMATURE")


class _OnCharacterPanel:
    """A sub-panel of the planner's tab, shown once there is a character."""

    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "Footstep"
    bl_parent_id = "FOOTSTEP_PT_main"

    @classmethod
    def poll(cls, context):
        return character(context) is not None


class FOOTSTEP_PT_character(_OnCharacterPanel, bpy.types.Panel):
    bl_label = "Character and Clips"
    bl_idname = "FOOTSTEP_PT_character"

    def draw(self, context):
        ob = character(context)
        _draw_roles_problem(self.layout, ob)
        _draw_clips(self.layout, ob)


class FOOTSTEP_PT_roles(_OnCharacterPanel, bpy.types.Panel):
    bl_label = "Bone Roles"
    bl_idname = "FOOTSTEP_PT_roles"
    bl_parent_id = "FOOTSTEP_PT_character"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        _draw_roles(self.layout, character(context))


class FOOTSTEP_PT_goal(_OnCharacterPanel, bpy.types.Panel):
    bl_label = "Goal and Waypoints"
    bl_idname = "FOOTSTEP_PT_goal"

    def draw(self, context):
        layout, fs = self.layout, context.scene.footstep
        layout.prop(fs, "goal")
        layout.prop(fs, "start")
        layout.prop(fs, "waypoints")
        _draw_waypoint(layout, context, fs)


class FOOTSTEP_PT_plan(_OnCharacterPanel, bpy.types.Panel):
    bl_label = "Plan and Bake"
    bl_idname = "FOOTSTEP_PT_plan"

    def draw(self, context):
        layout, fs = self.layout, context.scene.footstep
        row = layout.row(align=True)
        row.operator("footstep.build_graph", icon="OUTLINER_DATA_LIGHTPROBE")
        row.operator("footstep.plan", icon="TRACKING_FORWARDS")
        layout.prop(fs, "body_on")
        layout.prop(fs, "grow_frame_range")
        row = layout.row(align=True)
        row.operator("footstep.bake", icon="REC")
        row.operator("footstep.clear", icon="TRASH")
        row = layout.row(align=True)
        row.prop(fs, "show_overlay")
        row.prop(fs, "show_sampled")
        if fs.last_report:
            col = layout.column(align=True)
            for line in _wrap(fs.last_report, 60):
                col.label(text=line)
        _draw_report(layout, fs)


class FOOTSTEP_PT_together(_OnCharacterPanel, bpy.types.Panel):
    """Several characters in one space and time: each row's character goes to its goal
    round those above it (their order is their priority)."""

    bl_label = "Characters Together"
    bl_idname = "FOOTSTEP_PT_together"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        layout, fs = self.layout, context.scene.footstep
        row = layout.row()
        row.template_list("FOOTSTEP_UL_cast", "", fs, "cast", fs, "cast_index", rows=3)
        col = row.column(align=True)
        col.operator("footstep.cast_add", icon="ADD", text="")
        col.operator("footstep.cast_remove", icon="REMOVE", text="")
        col.separator()
        col.operator("footstep.cast_move", icon="TRIA_UP", text="").direction = "UP"
        col.operator("footstep.cast_move", icon="TRIA_DOWN", text="").direction = "DOWN"
        if 0 <= fs.cast_index < len(fs.cast):
            item = fs.cast[fs.cast_index]
            col = layout.column(align=True)
            for name in ("character", "goal", "start", "waypoints", "delay"):
                col.prop(item, name)
        layout.operator("footstep.bake_together", icon="COMMUNITY")


class FOOTSTEP_PT_directing(_OnCharacterPanel, bpy.types.Panel):
    bl_label = "Directing"
    bl_idname = "FOOTSTEP_PT_directing"

    def draw(self, context):
        _draw_footprint_edit(self.layout, context.scene.footstep)


class FOOTSTEP_PT_settings(_OnCharacterPanel, bpy.types.Panel):
    bl_label = "Settings"
    bl_idname = "FOOTSTEP_PT_settings"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        self.layout.label(text="Lengths and speeds are a human's, scaled to the character", icon="INFO")


#: The settings' groups, each from its first setting on (in ``Settings`` order) to the next
SETTING_GROUPS = (("Clip Analysis", "analysis_rate"), ("Path Search", "turn_penalty"),
                  ("Smoothing and Refinement", "smoothing_iterations"), ("Blend Groups", "tau_dt"),
                  ("IK and Bake", "ik_alpha"), ("Turning in Place", "turn_in_place_angle"))


def setting_groups() -> list[tuple[str, list[str]]]:
    """(label, setting names) of each group of the Settings sub-panel: every setting in one."""
    from ...core.base.settings import Settings

    names = Settings.names()
    starts = [names.index(first) for _, first in SETTING_GROUPS] + [len(names)]
    return [(label, names[a:b]) for (label, _), a, b in zip(SETTING_GROUPS, starts, starts[1:])]


def _settings_panel(i: int, label: str):
    """The Settings sub-panel of group ``i`` (closed until opened)."""

    def draw(self, context):
        col = self.layout.column(align=True)
        for name in setting_groups()[i][1]:
            col.prop(context.scene.footstep.settings, name)

    return type(f"FOOTSTEP_PT_settings_{i}", (_OnCharacterPanel, bpy.types.Panel), {
        "bl_label": label, "bl_idname": f"FOOTSTEP_PT_settings_{i}", "bl_parent_id": "FOOTSTEP_PT_settings",
        "bl_options": {"DEFAULT_CLOSED"}, "draw": draw})


SETTINGS_PANELS = tuple(_settings_panel(i, label) for i, (label, _) in enumerate(SETTING_GROUPS))

#: The planner tab's panels, parents before their sub-panels
TAB_PANELS = (FOOTSTEP_PT_main, FOOTSTEP_PT_character, FOOTSTEP_PT_roles, FOOTSTEP_PT_goal, FOOTSTEP_PT_plan,
              FOOTSTEP_PT_together, FOOTSTEP_PT_directing, FOOTSTEP_PT_settings, *SETTINGS_PANELS)


def _draw_footprint_edit(layout, fs) -> None:
    """Editable footprints: lock, unlock, re-plan; why an edit can't be honoured."""
    layout.prop(fs, "edit_footprints")
    if not fs.edit_footprints:
        return
    row = layout.row(align=True)
    row.operator("footstep.lock_footprints", text="Lock", icon="LOCKED").lock = True
    row.operator("footstep.lock_footprints", text="Unlock", icon="UNLOCKED").lock = False
    row.operator("footstep.replan", icon="FILE_REFRESH")
    layout.prop(fs, "live_replan")
    if fs.edit_problem:
        col = layout.column(align=True)
        col.alert = True
        for line in _wrap(fs.edit_problem, 60):
            col.label(text=line, icon="ERROR" if line is fs.edit_problem else "NONE")


def _wrap(text: str, width: int) -> list[str]:
    out, line = [], ""
    for word in text.split():
        if line and len(line) + 1 + len(word) > width:
            out.append(line)
            line = word
        else:
            line = f"{line} {word}".strip()
    return out + ([line] if line else [])


def _draw_waypoint(layout, context, fs):
    """The active object's pause and arrival frame, when it is a waypoint or the goal."""
    ob = context.active_object
    if ob is None:
        return
    way = fs.waypoints is not None and ob.name in fs.waypoints.all_objects
    if not way and ob != fs.goal:
        return
    col = layout.column(align=True)
    col.label(text=f"{'Waypoint' if way else 'Goal'} {ob.name}", icon="EMPTY_SINGLE_ARROW")
    if way:
        col.prop(ob.footstep, "pause")
    row = col.row(align=True)
    row.prop(ob.footstep, "use_arrive")
    sub = row.row(align=True)
    sub.enabled = ob.footstep.use_arrive
    sub.prop(ob.footstep, "arrive")


def _draw_report(layout, fs):
    """The last bake's stage times and quality figures."""
    import json

    try:
        doc = json.loads(fs.plan_json) if fs.plan_json else {}
    except ValueError:
        return
    st, q = doc.get("stages"), doc.get("quality")
    if not st or not q:
        return
    col = layout.column(align=True)
    col.label(text="Stage times (ms)", icon="TIME")
    for key in ("search", "smoothing", "refinement", "body_trajectory", "blend_groups", "ik", "bake"):
        if f"{key}_ms" in st:
            row = col.row()
            row.label(text=key.replace("_", " "))
            row.label(text=f"{st[key + '_ms']:.1f}")
    col = layout.column(align=True)
    col.label(text="Quality (measured on the bake)", icon="CHECKMARK")
    rows = [("foot skate, mean / max", f"{q['foot_skate']['mean_mm']:.1f} / {q['foot_skate']['max_mm']:.1f} mm"),
            ("foot to footprint, max", f"{q['footprint_error']['max_mm']:.1f} mm"),
            ("ground penetration, max", f"{q['penetration']['max_mm']:.1f} mm"),
            ("goal", f"{q['goal']['distance_m'] * 100:.1f} cm"),
            ("pops made by the planner", f"{q['pops']['introduced']['count']}")]
    for other in q.get("others") or ():  # (the other characters baked in the shot)
        rows.append((f"nearest {other['character']}", f"{other['least_distance_m']:.2f} m, frame "
                     f"{other['least_distance_frame']}"))
        if other["frames_on_one_footprint"]:
            rows.append((f"on {other['character']}'s footprints", f"{other['frames_on_one_footprint']} frames"))
    for mover in q.get("moving_obstacles") or ():
        if mover["least_distance_m"] is not None:
            rows.append((f"nearest {mover['obstacle']} (moving)", f"{mover['least_distance_m']:.2f} m, frame "
                         f"{mover['least_distance_frame']}"))
    for t in doc.get("turns_in_place") or ():
        rows.append((f"turns in place at the {t['where']}",
                     f"{t['degrees']:+.0f} deg, frames {t['frames'][0]:g}-{t['frames'][1]:g}"))
    for w in doc.get("waypoints") or ():
        asked = "" if w.get("arrive") is None else f" (asked {w['arrive']:.0f})"
        got = w.get("achieved") if w.get("achieved") is not None else w.get("planned")
        rows.append((f"at {w['name']}", f"frame {got:.1f}{asked}"))
    for name, value in rows:
        row = col.row()
        row.label(text=name)
        row.label(text=value)


def _roles(ob):
    """(the character's roles, None) or (None, why they can't be read)."""
    from ..read.scene import rig_from_armature

    try:
        return rig_from_armature(ob).roles, None
    except Exception as ex:  # a rig we can't read: say so in the panel, never raise in draw
        return None, str(ex)


def _draw_roles_problem(layout, ob) -> None:
    """Why the character's bones can't all be given their roles, if they can't (shown
    whether or not the Bone Roles sub-panel is open)."""
    roles, problem = _roles(ob)
    if problem:
        layout.label(text=problem, icon="ERROR")
    elif not roles.ok:
        layout.label(text="Could not map: " + ", ".join(roles.missing) + " (set them in Bone Roles)", icon="ERROR")


def _draw_roles(layout, ob):
    roles, problem = _roles(ob)
    if roles is None:
        layout.label(text=problem, icon="ERROR")
        return
    col = layout.column(align=True)
    props = ob.data.footstep
    for role in ALL_ROLES:
        row = col.row(align=True)
        bone = roles.roles.get(role, "")
        split = row.split(factor=0.28, align=True)
        split.label(text=role + ("" if role in REQUIRED_ROLES else " (opt.)"),
                    icon="CHECKMARK" if bone else ("ERROR" if role in REQUIRED_ROLES else "BLANK1"))
        split = split.split(factor=0.5, align=True)
        split.label(text=f"{bone or '-'} ({roles.how.get(role, 'unmapped')})")
        # picking a bone here overrides the automatic choice; clearing it restores it
        split.prop_search(props, f"role_{role}", ob.data, "bones", text="")


def _draw_clips(layout, ob):
    box = layout.box()
    props = ob.data.footstep
    row = box.row()
    row.label(text="Clip library" + (" (edited)" if props.library_edited else ""), icon="NLA")
    row.operator("footstep.import_clips", text="", icon="IMPORT").target = "CHARACTER"
    row.operator("footstep.generate_clips", text="", icon="ANIM")
    row.operator("footstep.analyze_clips", text="", icon="FILE_REFRESH")
    box.template_list("FOOTSTEP_UL_clips", "", props, "clips", props, "clip_index", rows=4)
    if 0 <= props.clip_index < len(props.clips):
        box.label(text=props.clips[props.clip_index].summary or "not analysed")
    if props.library_edited:
        box.operator("footstep.analyze_clips", text="Reset to Proposal").reset = True


class FOOTSTEP_PT_object_surface(bpy.types.Panel):
    """Object Properties > Footstep: tag a mesh as traversable or an obstacle."""

    bl_label = "Footstep"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "object"

    @classmethod
    def poll(cls, context):
        return context.object is not None and context.object.type == "MESH"

    def draw(self, context):
        from ..read.surfaces import effective_tag

        ob = context.object
        self.layout.prop(ob.footstep, "surface", text="Surface")
        if ob.footstep.surface == "NONE":
            tag = effective_tag(ob, context.scene)
            if tag != "NONE":
                self.layout.label(text=f"{tag.capitalize()} by its collection", icon="INFO")


class FOOTSTEP_PT_collection_surface(bpy.types.Panel):
    """Collection Properties > Footstep: a tag its objects inherit."""

    bl_label = "Footstep"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "collection"

    @classmethod
    def poll(cls, context):
        return getattr(context, "collection", None) is not None

    def draw(self, context):
        self.layout.prop(context.collection.footstep, "surface", text="Surface")


#: The menu's operators (None: a separator), as (idname, icon)
MENU_OPERATORS = (("footstep.plan", "TRACKING_FORWARDS"), ("footstep.bake", "REC"), ("footstep.replan", "FILE_REFRESH"),
                  ("footstep.clear", "TRASH"), None, ("footstep.import_clips", "IMPORT"),
                  ("footstep.generate_clips", "ANIM"), ("footstep.analyze_clips", "FILE_REFRESH"))


class FOOTSTEP_MT_animation(bpy.types.Menu):
    """Object > Animation > Footstep Planner: the planner's main operators (so F3's search
    finds them too)"""

    bl_idname = "FOOTSTEP_MT_animation"
    bl_label = "Footstep Planner"

    def draw(self, context):
        for item in MENU_OPERATORS:
            if item is None:
                self.layout.separator()
            else:
                self.layout.operator(item[0], icon=item[1])


def _menu_animation(self, context):
    self.layout.separator()
    self.layout.menu(FOOTSTEP_MT_animation.bl_idname, icon="TRACKING")


CLASSES = (FOOTSTEP_UL_clips, FOOTSTEP_UL_cast, *TAB_PANELS, FOOTSTEP_PT_object_surface, FOOTSTEP_PT_collection_surface,
           FOOTSTEP_MT_animation)


def register():
    for cls in CLASSES:
        bpy.utils.register_class(cls)
    bpy.types.VIEW3D_MT_object_animation.append(_menu_animation)


def unregister():
    bpy.types.VIEW3D_MT_object_animation.remove(_menu_animation)
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)
