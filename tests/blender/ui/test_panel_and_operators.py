"""The sidebar panel (drawn into a recording stub) and the operators behind it."""

from importlib import import_module

import pytest

from conftest import Recorder, cmu, draw_tab, needs_cmu


def _draw(fp, context):
    return draw_tab(fp, context)


def test_panel_without_a_character_offers_import(fp, empty_scene):
    import bpy

    log = _draw(fp, bpy.context)
    ops = [a[0] for name, a, _ in log if name == "operator"]
    assert "footstep.import_clips" in ops


@needs_cmu
def test_import_analyze_edit_and_reset_the_library(fp, empty_scene):
    import bpy

    empty_scene.render.fps = 30
    d = cmu("16_16").rsplit("/", 1)[0]
    files = [{"name": n} for n in ("cmu_16_16_walk.bvh", "cmu_16_35_run_jog.bvh", "cmu_49_05_run_leap_run.bvh")]
    assert bpy.ops.footstep.import_clips(directory=d, files=files, target="NEW") == {"FINISHED"}
    ob = empty_scene.footstep.character
    assert ob is not None and ob.type == "ARMATURE"
    props = ob.data.footstep
    usage = {c.name: c.usage for c in props.clips}
    assert usage == {"cmu_16_16_walk": "TURN", "cmu_16_35_run_jog": "TURN", "cmu_49_05_run_leap_run": "JUMP"}
    assert not props.library_edited
    assert "walk" in props.clips["cmu_16_16_walk"].summary

    # the panel shows roles (with bone pickers) and the clip list
    log = _draw(fp, bpy.context)
    searched = [a[1] for name, a, _ in log if name == "prop_search"]
    assert "role_thigh_l" in searched and "role_foot_r" in searched
    assert any(name == "template_list" for name, _, _ in log)
    ul = import_module(fp.__name__ + ".blender.ui.panel").FOOTSTEP_UL_clips
    for item in props.clips:
        rows = Recorder()
        ul.draw_item(None, bpy.context, rows, props, item, 0, props, "clip_index", 0)
        assert any(name == "prop" for name, _, _ in rows.log)

    # the user edits: the leap is excluded; analysing again keeps the edit
    props.clips["cmu_49_05_run_leap_run"].usage = "EXCLUDED"
    assert props.library_edited
    assert bpy.ops.footstep.analyze_clips() == {"FINISHED"}
    assert props.clips["cmu_49_05_run_leap_run"].usage == "EXCLUDED"
    character = import_module(fp.__name__ + ".blender.read.character")
    lib = character.read_library(ob)
    assert lib.excluded == ["cmu_49_05_run_leap_run"] and lib.edited
    # ... until reset to the proposal
    assert bpy.ops.footstep.analyze_clips(reset=True) == {"FINISHED"}
    assert props.clips["cmu_49_05_run_leap_run"].usage == "JUMP" and not props.library_edited


@needs_cmu
def test_roles_set_by_hand_override_the_mapping(fp, empty_scene):
    scene_mod = import_module(fp.__name__ + ".blender.read.scene")
    clips = import_module(fp.__name__ + ".blender.read.clips")
    ob, _ = clips.import_clips([cmu("16_16")])
    assert scene_mod.rig_from_armature(ob).roles.roles["toe_l"] == "LeftToeBase"
    ob.data.footstep.set_override("toe_l", "LeftFoot")
    ob.data.footstep.set_override("toe_l", "")
    ob.data.footstep.role_thigh_l = "LHipJoint"
    rig = scene_mod.rig_from_armature(ob)
    assert rig.roles.roles["thigh_l"] == "LHipJoint" and rig.roles.how["thigh_l"] == "manual"
    ob.data.footstep.role_thigh_l = "NoSuchBone"
    with pytest.raises(Exception, match="NoSuchBone"):
        scene_mod.rig_from_armature(ob)


def test_settings_props_mirror_the_dataclass(fp, empty_scene):
    props = import_module(fp.__name__ + ".blender.ui.props")
    Settings = import_module(fp.__name__ + ".core.base.settings").Settings
    pg = empty_scene.footstep.settings
    s = props.settings_from_props(pg)
    assert s == Settings()
    pg.smoothing_iterations = 6
    pg.speed_sigma = 3.0
    assert props.settings_from_props(pg) == Settings(smoothing_iterations=6, speed_sigma=3.0)
    assert "Footsteps taken" in pg.bl_rna.properties["speed_sigma"].description


def _bare_character(scene):
    import bpy

    ob = bpy.data.objects.new("Bare", bpy.data.armatures.new("Bare"))
    scene.collection.objects.link(ob)
    scene.footstep.character = ob
    return ob


def test_the_tab_is_split_into_sub_panels_the_rare_ones_closed(fp, empty_scene):
    import bpy

    panel = import_module(fp.__name__ + ".blender.ui.panel")
    subs = panel.TAB_PANELS[1:]
    order = [cls.bl_idname for cls in panel.TAB_PANELS]
    for cls in subs:  # each hangs under the tab, its parent registered before it
        assert cls.bl_parent_id in order and order.index(cls.bl_parent_id) < order.index(cls.bl_idname)
        assert isinstance(getattr(bpy.types, cls.bl_idname), type)
    labels = {cls.bl_label for cls in subs}
    assert {"Character and Clips", "Goal and Waypoints", "Plan and Bake", "Directing", "Settings"} <= labels
    closed = {cls.bl_label for cls in subs if "DEFAULT_CLOSED" in getattr(cls, "bl_options", set())}
    assert {"Settings", "Bone Roles"} | {label for label, _ in panel.SETTING_GROUPS} <= closed
    assert not closed & {"Character and Clips", "Goal and Waypoints", "Plan and Bake"}
    # without a character only the tab itself draws
    assert not [cls for cls in subs if cls.poll(bpy.context)]
    _bare_character(empty_scene)
    assert all(cls.poll(bpy.context) for cls in subs)


def test_every_setting_is_drawn_once_in_its_group(fp, empty_scene):
    import bpy

    panel = import_module(fp.__name__ + ".blender.ui.panel")
    Settings = import_module(fp.__name__ + ".core.base.settings").Settings
    groups = panel.setting_groups()
    assert all(names for _, names in groups)
    assert [n for _, names in groups for n in names] == Settings.names()
    _bare_character(empty_scene)
    log = draw_tab(fp, bpy.context)
    drawn = [a[1] for name, a, _ in log if name == "prop" and len(a) > 1 and a[1] in Settings.names()]
    assert sorted(drawn) == sorted(Settings.names())
    # the bare armature has no bones to give roles to: the tab says so, it does not raise
    assert any(name == "label" and kw.get("icon") == "ERROR" for name, _, kw in log)
