"""The Footstep Mannequin: the project's own sample character (issue 6, first part)."""

from importlib import import_module

import numpy as np
import pytest


@pytest.fixture
def mannequin(fp, empty_scene):
    import bpy

    assert bpy.ops.footstep.add_mannequin() == {"FINISHED"}
    ob = bpy.context.view_layer.objects.active
    return ob, bpy.data.objects[f"{ob.name} Body"]


def test_adult_proportions_metarig_names_and_every_role_mapped(fp, mannequin):
    ob, body = mannequin
    names = {b.name for b in ob.data.bones}
    assert {"spine", "spine.006", "thigh.L", "shin.R", "foot.L", "toe.R", "upper_arm.L"} <= names
    scene = import_module(fp.__name__ + ".blender.read.scene")
    rig = scene.rig_from_armature(ob)
    rig.require_legs()
    assert rig.roles.bone("hips") == "spine" and rig.roles.bone("thigh_l") == "thigh.L"
    assert rig.roles.roles.get("toe_r") == "toe.R"
    np.testing.assert_allclose(rig.forward_axis(), [0.0, -1.0, 0.0], atol=1e-9)
    tops = np.array([ob.matrix_world @ b.tail_local for b in ob.data.bones])
    assert tops[:, 2].max() == pytest.approx(1.75, abs=0.01)
    leg = np.linalg.norm(np.array(ob.data.bones["thigh.L"].head_local) - np.array(ob.data.bones["foot.L"].head_local))
    assert 0.8 < leg < 0.9  # about half the height, as in an adult


def test_the_body_is_skinned_to_every_deforming_bone(fp, mannequin):
    ob, body = mannequin
    assert body.parent == ob and body.modifiers["Armature"].object == ob
    groups = {g.name for g in body.vertex_groups}
    deform = {b.name for b in ob.data.bones if b.use_deform}
    assert groups == deform
    assert all(len(v.groups) == 1 for v in body.data.vertices)  # rigid: one bone each
    # a posed knee moves the shin's capsule with it
    import bpy

    pb = ob.pose.bones["shin.L"]
    dg = bpy.context.evaluated_depsgraph_get()
    before = np.array([v.co[:] for v in body.evaluated_get(dg).to_mesh().vertices])
    pb.rotation_quaternion = (0.7071, 0.7071, 0.0, 0.0)
    bpy.context.view_layer.update()
    dg = bpy.context.evaluated_depsgraph_get()
    after = np.array([v.co[:] for v in body.evaluated_get(dg).to_mesh().vertices])
    gi = body.vertex_groups["shin.L"].index
    mine = np.array([any(g.group == gi for g in v.groups) for v in body.data.vertices])
    assert np.abs(after[mine] - before[mine]).max() > 0.1
    assert np.abs(after[~mine & (before[:, 2] > 1.0)] - before[~mine & (before[:, 2] > 1.0)]).max() < 1e-6


def test_nothing_of_the_users_is_touched(fp, empty_scene):
    import bpy

    bpy.ops.mesh.primitive_cube_add()
    cube = bpy.context.active_object
    before = {o.name for o in bpy.data.objects}
    import_module(fp.__name__ + ".blender.sample.mannequin").build()
    after = {o.name for o in bpy.data.objects}
    assert before <= after and len(after - before) == 2 and cube.name in after


def test_the_numpy_rig_is_the_armature_blender_builds(fp, mannequin):
    ob, _ = mannequin
    scene = import_module(fp.__name__ + ".blender.read.scene")
    core = import_module(fp.__name__ + ".core.sample.mannequin").rig()
    rig = scene.rig_from_armature(ob)
    order = [core.names.index(n) for n in rig.names]
    np.testing.assert_allclose(core.rest[order], rig.rest, atol=1e-4)  # (Blender keeps float32)
    assert [core.parents[i] for i in order] == [core.names.index(rig.names[p]) if p >= 0 else -1
                                              for p in rig.parents]


def test_generated_clips_are_actions_the_analysis_reads_as_the_core_made_them(fp, mannequin):
    import bpy

    ob, _ = mannequin
    bpy.context.scene.render.fps = 30
    m = import_module(fp.__name__ + ".blender.sample.mannequin")
    character = import_module(fp.__name__ + ".blender.read.character")
    acts = m.generate_clips(ob)
    assert len(acts) == 12 and all(a.use_fake_user for a in acts)
    assert acts[0].frame_range[0] == 1.0
    result = character.analyze_character(ob)
    assert not result.errors
    by = {a.name: a for a in result.analyses}
    assert by["walk"].gait == "walk" and 1.2 <= by["walk"].speed <= 1.5
    assert by["run"].gait == "run" and by["run_jump"].kind == "jump"
    assert by["walk_start"].kind == "start" and by["walk_stop"].kind == "stop" and by["idle"].kind == "idle"
    lib = character.library_for(ob, result)
    groups = {g.gait: [c.clip for c in g.clips] for g in lib.turn_groups.values()}
    assert set(groups["walk"]) == {"walk", "walk_turn_left_sharp", "walk_turn_right_sharp",
                                   "walk_turn_left_wide", "walk_turn_right_wide"}
    # generating again rewrites the generator's own clips in place, and nothing else
    mine = bpy.data.actions.new("walk_mine")
    walk = bpy.data.actions["walk"]
    tr = ob.animation_data_create().nla_tracks.new()
    strip = tr.strips.new("walk", 1, walk)
    keys = len(walk.layers[0].strips[0].channelbag(walk.slots[0]).fcurves)
    again = m.generate_clips(ob, names=["walk"])
    assert again == [walk] and "walk.001" not in bpy.data.actions
    assert strip.action == walk and strip.action_slot == walk.slots[0]  # the strip still plays it
    assert len(walk.layers) == 1 and len(walk.layers[0].strips[0].channelbag(walk.slots[0]).fcurves) == keys
    assert "walk_mine" in bpy.data.actions and mine.name == "walk_mine"
    assert len([a for a in bpy.data.actions if a.get(m.GENERATED_PROP)]) == 12


def test_the_add_mannequin_operator_makes_the_clips_too(fp, empty_scene):
    import bpy

    assert bpy.ops.footstep.add_mannequin(clips=True) == {"FINISHED"}
    ob = bpy.context.view_layer.objects.active
    scene = import_module(fp.__name__ + ".blender.read.scene")
    assert len(scene.armature_actions(ob)) == 12


def test_generate_clips_operator_on_the_character_and_a_clear_refusal_for_a_legless_rig(fp, empty_scene):
    import bpy

    assert bpy.ops.footstep.add_mannequin(clips=False) == {"FINISHED"}
    ob = bpy.context.view_layer.objects.active
    assert bpy.context.scene.footstep.character == ob
    assert bpy.ops.footstep.generate_clips() == {"FINISHED"}
    assert len(ob.data.footstep.clips) == 12  # analysed, the library proposed
    # an armature without legs: one message naming it, nothing made
    arm = bpy.data.armatures.new("Stick")
    stick = bpy.data.objects.new("Stick", arm)
    bpy.context.scene.collection.objects.link(stick)
    bpy.context.view_layer.objects.active = stick
    bpy.ops.object.mode_set(mode="EDIT")
    eb = arm.edit_bones.new("Bone")
    eb.head, eb.tail = (0, 0, 0), (0, 0, 1)
    bpy.ops.object.mode_set(mode="OBJECT")
    bpy.context.scene.footstep.character = stick
    before = len(bpy.data.actions)
    with pytest.raises(RuntimeError, match="Stick"):
        bpy.ops.footstep.generate_clips()
    assert len(bpy.data.actions) == before


def test_add_to_scene_stands_on_the_marker_as_the_character_and_adds_only_itself(fp, empty_scene):
    import bpy

    scenes = import_module(fp.__name__ + ".blender.sample.sample_scenes")
    m = import_module(fp.__name__ + ".blender.sample.mannequin")
    scene = scenes.build("turns", bpy.context.scene)
    scene.render.fps = 30
    before = {o.name for o in bpy.data.objects}
    ob, result = m.add_to_scene(scene, "Start")
    assert {o.name for o in bpy.data.objects} - before == {ob.name, f"{ob.name} Body"}
    start = scene.objects["Start"]
    np.testing.assert_allclose(ob.location, start.location, atol=1e-6)
    assert ob.rotation_euler.z == pytest.approx(start.rotation_euler.z)
    assert scene.footstep.character == ob and len(result.analyses) == 12 and not result.errors
