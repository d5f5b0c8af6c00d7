"""Properties stored in the .blend: the planner's settings (scene), role overrides and
the editable clip library (armature data). The scene's scratch state (last plan, last
report, edit problem) is kept for the session only (``session.Scratch``)."""

from __future__ import annotations

import bpy
import numpy as np
from bpy.props import (BoolProperty, CollectionProperty, EnumProperty, FloatProperty,
                       IntProperty, PointerProperty, StringProperty)

from ...core.clips.roles import ALL_ROLES
from ...core.base.settings import Settings
from .session import Scratch

USAGES = [
    ("TURN", "Turning group", "Blended with the clips of its gait by path curvature tau"),
    ("JUMP", "Jump", "A special clip: a jump, played whole"),
    ("START", "Start", "A special clip: starts from standing"),
    ("STOP", "Stop", "A special clip: stops to standing"),
    ("IDLE", "Idle", "A special clip: standing"),
    ("EXCLUDED", "Excluded", "Not used by the planner"),
]
GAIT_ITEMS = [("stand", "Stand", ""), ("walk", "Walk", ""), ("run", "Run", "")]


_SUBTYPE = {"m": "DISTANCE", "s": "TIME_ABSOLUTE", "rad": "ANGLE"}


def _settings_class():
    """A PropertyGroup with one property per Settings field: its type, default, range and
    description come from the setting's own declaration (``Settings.spec``)."""
    ann = {}
    for name in Settings.names():
        spec = Settings.spec(name)
        label = name.replace("_", " ").capitalize()
        unit = f" ({spec['unit']})" if spec["unit"] and spec["unit"] not in ("1", "rad") else ""
        desc = (spec["doc"] + unit)[:400]
        bounds = {k: v for k, v in (("min", spec["min"]), ("max", spec["max"])) if v is not None}
        if spec["type"] is bool:
            ann[name] = BoolProperty(name=label, description=desc, default=spec["default"])
        elif spec["type"] is int:
            ann[name] = IntProperty(name=label, description=desc, default=spec["default"], **bounds)
        else:
            ann[name] = FloatProperty(name=label, description=desc, default=spec["default"],
                                      subtype=_SUBTYPE.get(spec["unit"], "NONE"), **bounds)
    return type("FOOTSTEP_PG_settings", (bpy.types.PropertyGroup,), {"__annotations__": ann})


FOOTSTEP_PG_settings = _settings_class()


def settings_from_props(pg) -> Settings:
    """The Settings a panel holds. Blender keeps floats in single precision: a value equal
    to its default in single precision reads as the default, any other as 7 significant
    digits, so the thesis's 0.3 stays 0.3. A value out of its range raises SettingsError
    naming the setting."""
    values = {}
    for name in Settings.names():
        v = getattr(pg, name)
        if not isinstance(v, (bool, int)):
            default = Settings.spec(name)["default"]
            v = default if np.float32(v) == np.float32(default) else float(f"{v:.7g}")
        values[name] = v
    return Settings(**values)


def _is_armature(self, ob):
    return ob.type == "ARMATURE"


class FOOTSTEP_PG_cast(bpy.types.PropertyGroup):
    """One character of the shot the panel bakes together (Bake Together): who goes where."""

    character: PointerProperty(name="Character", type=bpy.types.Object, poll=_is_armature,
                               description="The armature this row animates")
    goal: PointerProperty(name="Goal", type=bpy.types.Object, description="Walk to this object")
    start: PointerProperty(name="Start", type=bpy.types.Object,
                           description="Start standing at this object (empty: where the character's feet are "
                                       "now)")
    waypoints: PointerProperty(name="Waypoints", type=bpy.types.Collection,
                               description="Pass through the objects of this collection on the way to the goal, "
                                           "in the order of their names (their pauses and arrival frames too)")
    delay: IntProperty(name="Delay", min=0, soft_max=600, default=0,
                       description="Frames after the current frame this character sets off")


class FOOTSTEP_PG_scene(bpy.types.PropertyGroup):
    character: PointerProperty(name="Character", type=bpy.types.Object, poll=_is_armature,
                               description="The armature the planner animates")
    goal: PointerProperty(name="Goal", type=bpy.types.Object,
                          description="Walk to this object (empty: the 3D cursor)")
    start: PointerProperty(name="Start", type=bpy.types.Object,
                           description="Start standing at this object (empty: where the "
                                       "character's feet are now)")
    settings: PointerProperty(type=FOOTSTEP_PG_settings)
    grow_frame_range: BoolProperty(name="Grow frame range", default=True,
                                   description="Make the scene's frame range cover the bake (it never "
                                               "shrinks; Clear puts it back)")
    body_on: EnumProperty(name="Body on", default="OBJECT", items=[
        ("OBJECT", "Object", "Key the body's motion on the armature object"),
        ("ROOT", "Root bone", "Key the body's motion on the rig's root bone; the object stays put")])
    show_overlay: BoolProperty(name="Show footprints", default=True,
                               description="Draw the last plan's footprints (by foot and clip) and the "
                                           "body trajectory in the viewport")
    show_sampled: BoolProperty(name="Show sampled footprints", default=False,
                               description="Also draw the footprints the search tested")
    waypoints: PointerProperty(name="Waypoints", type=bpy.types.Collection,
                               description="Pass through the objects of this collection on the way to the "
                                           "goal, in the order of their names (an empty with its heading, "
                                           "else facing the next; a curve: each of its points)")
    cast: CollectionProperty(type=FOOTSTEP_PG_cast, name="Characters",
                             description="The characters Bake Together plans in one space and time, in this "
                                         "order as priority: each goes round those above it")
    cast_index: IntProperty(name="Active character row")
    edit_footprints: BoolProperty(name="Editable footprints", default=True,
                                  description="After Plan and Bake, show each footprint as a small empty "
                                              "(in the collection 'Footprints: <character>') to move, turn, "
                                              "lock and re-plan around")
    live_replan: BoolProperty(name="Live re-plan", default=False,
                              description="While you move or turn a footprint, re-plan around it as soon as "
                                          "the hand rests and show the new footprints and body path in the "
                                          "viewport (nothing is baked until Re-plan or Bake)")

    # scratch state: this session only, never saved in the user's file
    plan_json = Scratch(doc="The last plan (JSON)")
    last_report = Scratch(doc="Summary of the last run")
    edit_problem = Scratch(doc="Why the last edit can't be honoured")


def _edited(self, context):
    arm = self.id_data
    if not arm.footstep.syncing:
        arm.footstep.library_edited = True


SURFACE_ITEMS = [
    ("NONE", "None", "Not part of the walkable scene (inherits its collection's tag)"),
    ("TRAVERSABLE", "Traversable", "The character may walk, run and land on it"),
    ("OBSTACLE", "Obstacle", "The character keeps clear of it"),
]


class FOOTSTEP_PG_surface(bpy.types.PropertyGroup):
    surface: EnumProperty(name="Footstep", items=SURFACE_ITEMS, default="NONE",
                          description="How the footstep planner treats this mesh (objects "
                                      "tagged None inherit their collection's tag)")
    # as a waypoint (in the panel's Waypoints collection) or the goal
    pause: FloatProperty(name="Pause", description="Stop here and stand this long (s) before walking on",
                         min=0.0, max=600.0, unit="TIME_ABSOLUTE")
    use_arrive: BoolProperty(name="Arrive on frame", description="Arrive here on a given frame: the walk's pace "
                             "is chosen, and the character waits standing at the stop before when early")
    arrive: IntProperty(name="Frame", description="The scene frame to arrive here on", min=0)


class FOOTSTEP_PG_clip(bpy.types.PropertyGroup):
    # ``name`` (built in) is the action's name
    usage: EnumProperty(name="Use", items=USAGES, update=_edited)
    gait: EnumProperty(name="Gait", items=GAIT_ITEMS[1:], update=_edited)
    tau: FloatProperty(name="Tau", description="Path curvature 1/r (1/m), positive turning left",
                       update=_edited)
    speed: FloatProperty(name="Speed", unit="VELOCITY", update=_edited)
    entry_gait: EnumProperty(name="Entry", items=GAIT_ITEMS, update=_edited)
    exit_gait: EnumProperty(name="Exit", items=GAIT_ITEMS, update=_edited)
    summary: StringProperty(name="Analysis", description="What the analysis found")


def _armature_class():
    ann = {
        "clips": CollectionProperty(type=FOOTSTEP_PG_clip),
        "clip_index": IntProperty(),
        "library_edited": BoolProperty(
            name="Edited", description="The clip library was edited by hand; Analyze keeps it"),
        "syncing": BoolProperty(options={"HIDDEN", "SKIP_SAVE"}),
    }
    for role in ALL_ROLES:  # one bone picker per role; empty means automatic
        ann[f"role_{role}"] = StringProperty(
            name=role, description=f"Bone that plays the role {role!r}, set by hand "
                                   "(empty: found automatically)")

    def override(self, role: str) -> str:
        return getattr(self, f"role_{role}")

    def set_override(self, role: str, bone: str) -> None:
        if role not in ALL_ROLES:
            raise ValueError(f"unknown role {role!r}")
        setattr(self, f"role_{role}", bone)

    def overrides(self) -> dict[str, str]:
        return {r: getattr(self, f"role_{r}") for r in ALL_ROLES if getattr(self, f"role_{r}")}

    return type("FOOTSTEP_PG_armature", (bpy.types.PropertyGroup,), {
        "__annotations__": ann, "override": override, "set_override": set_override,
        "overrides": overrides})


FOOTSTEP_PG_armature = _armature_class()


CLASSES = (FOOTSTEP_PG_settings, FOOTSTEP_PG_cast, FOOTSTEP_PG_scene, FOOTSTEP_PG_surface, FOOTSTEP_PG_clip,
           FOOTSTEP_PG_armature)


def register():
    for cls in CLASSES:
        bpy.utils.register_class(cls)
    bpy.types.Scene.footstep = PointerProperty(type=FOOTSTEP_PG_scene)
    bpy.types.Armature.footstep = PointerProperty(type=FOOTSTEP_PG_armature)
    bpy.types.Object.footstep = PointerProperty(type=FOOTSTEP_PG_surface)
    bpy.types.Collection.footstep = PointerProperty(type=FOOTSTEP_PG_surface)


def unregister():
    del bpy.types.Collection.footstep
    del bpy.types.Object.footstep
    del bpy.types.Armature.footstep
    del bpy.types.Scene.footstep
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)
