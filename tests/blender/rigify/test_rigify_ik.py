"""The Rigify bake's IK option (``rigify_ik_feet``): the legs keyed on their IK controls
(foot_ik, toe_ik, the knee's pole control, IK/FK switch at IK) instead of the FK ones,
and, played by Blender, the DEF bones still on the plan's pose within 1 mm.

One short plan (a rig generated from Rigify's human metarig walks 3 m on a floor with one
generated walk clip), baked both ways."""

from importlib import import_module

import numpy as np
import pytest

from conftest import rigify_rig

MM = 1e-3
LEGS_FK = ("thigh_fk", "shin_fk", "foot_fk", "toe_fk")


def _mod(fp, name):
    return import_module(f"{fp.__name__}.{name}")


def _floor_scene():
    """A tagged 12 x 8 m floor, a Start empty facing +X at the origin and a Goal 3 m on."""
    import bpy

    scene = bpy.context.scene
    scene.render.fps, scene.render.fps_base = 30, 1.0
    coll = bpy.data.collections.new("Traversable")
    scene.collection.children.link(coll)
    coll.footstep.surface = "TRAVERSABLE"
    me = bpy.data.meshes.new("Floor")
    me.from_pydata([(-3, -4, 0), (9, -4, 0), (9, 4, 0), (-3, 4, 0)], [], [(0, 1, 2, 3)])
    coll.objects.link(bpy.data.objects.new("Floor", me))
    for name, x in (("Start", 0.0), ("Goal", 3.0)):
        ob = bpy.data.objects.new(name, None)
        ob.location, ob.rotation_euler.z = (x, 0.3 * (name == "Goal"), 0.0), np.pi / 2
        scene.collection.objects.link(ob)
    return scene


@pytest.fixture(scope="module")
def walk(fp, rigify_cache):
    """(scene, rig, planned, solved, settings): the plan solved, nothing baked yet."""
    import bpy

    bpy.ops.wm.read_homefile(use_empty=True)
    scene = _floor_scene()
    rig, _ = rigify_rig(*rigify_cache)
    rig.rotation_euler.z = np.pi / 2
    _mod(fp, "blender.sample.mannequin").generate_clips(rig, names=["walk"])
    planning = _mod(fp, "blender.planning")
    settings = _mod(fp, "core.base.settings").Settings(rigify_ik_feet=True)
    goal, heading = planning.goal_of(scene, "Goal")
    planned = planning.plan_and_synthesize(scene, rig, goal, heading, scene.objects["Start"], settings)
    yield scene, rig, planned, _mod(fp, "core.solve.frames").solve(planned.synthesis, planned.setup, settings), settings
    bpy.ops.wm.read_homefile(use_empty=True)


def _bake(fp, walk, ik_feet: bool):
    """Bake the solved plan (IK or FK legs): (action, DEF world matrices as played, the
    plan's DEF world matrices, the quality measured as played)."""
    scene, rig, planned, solved, settings = walk
    bake, planning = _mod(fp, "blender.write.bake"), _mod(fp, "blender.planning")
    r = planned.setup.rig
    bake.clear(rig, scene)  # (each bake measured alone: bakes of other names would overlap it)
    act, _ = bake.bake(rig, scene, r, solved.ik, solved.spin,
                       bake.BakeOptions("ik" if ik_feet else "fk", 1, rigify_ik_feet=ik_feet),
                       planned.result.footprints, planned.synthesis.planted())
    fk, body = _mod(fp, "core.clips.rig").forward_kinematics, _mod(fp, "core.solve.ik").body_frames
    want = body(solved.ik.body_pos, solved.spin + solved.ik.body_heading)[:, None] @ fk(r, solved.ik.basis)
    timing = _mod(fp, "core.report.document").BakeTiming(1, solved.ik.frames, 30.0)
    played = {}  # (one evaluation through the depsgraph for the report and the caller's checks)
    q = planning.measure(scene, rig, planned, solved, timing, planning.goal_of(scene, "Goal")[0], played=played)
    return act, played["world"], want, q


def _fcurves(act):
    return {(fc.data_path, fc.array_index): fc for layer in act.layers for st in layer.strips
            for cb in st.channelbags for fc in cb.fcurves}


def test_the_setting_parses_and_reaches_the_panel(fp, walk):
    import bpy

    Settings = _mod(fp, "core.base.settings").Settings
    assert Settings().rigify_ik_feet is False
    assert Settings.parse("rigify_ik_feet", "true") is True
    assert Settings.from_pairs(["rigify_ik_feet=on"]).rigify_ik_feet is True
    assert _mod(fp, "blender.command.cli").settings_from_args(["rigify_ik_feet=yes"]).rigify_ik_feet is True
    with pytest.raises(_mod(fp, "core.base.settings").SettingsError, match="rigify_ik_feet"):
        Settings.parse("rigify_ik_feet", "IK")
    pg = bpy.context.scene.footstep.settings
    assert pg.rigify_ik_feet is False
    pg.rigify_ik_feet = True
    try:
        assert _mod(fp, "blender.ui.props").settings_from_props(pg).rigify_ik_feet is True
    finally:
        pg.rigify_ik_feet = False


def test_ik_legs_follow_the_plan_as_played(fp, walk):
    """DEF bones within 1 mm of the plan (and of the FK bake), heels and toes as planted
    as with FK; the legs keyed on foot_ik, toe_ik and the pole, IK_FK at IK, nothing on
    the FK leg controls; the arms FK."""
    scene, rig, planned, solved, settings = walk
    act_fk, world_fk, want, q_fk = _bake(fp, walk, False)
    fk_paths = {p for p, _ in _fcurves(act_fk)}  # (the IK bake replaces this one)
    act, world, want, q = _bake(fp, walk, True)
    names = planned.setup.rig.names
    err = np.linalg.norm(world[..., :3, 3] - want[..., :3, 3], axis=-1)
    err_fk = np.linalg.norm(world_fk[..., :3, 3] - want[..., :3, 3], axis=-1)
    print(f"\nDEF bones vs plan, {solved.ik.frames} frames: FK {err_fk.max() / MM:.4f} mm, "
          f"IK {err.max() / MM:.4f} mm")
    assert err.max() < 1 * MM, names[int(err.max(0).argmax())]
    assert err_fk.max() < 1 * MM
    feet = [i for i, n in enumerate(names) if n.startswith(("DEF-foot", "DEF-toe"))]
    assert np.abs(world[:, feet, :3, 3] - world_fk[:, feet, :3, 3]).max() < 1 * MM
    assert q["foot_skate"]["max_mm"] < 5.0
    assert abs(q["foot_skate"]["max_mm"] - q_fk["foot_skate"]["max_mm"]) < 1.0
    assert abs(q["footprint_error"]["max_mm"] - q_fk["footprint_error"]["max_mm"]) < 1.0

    curves = _fcurves(act)
    paths = {p for p, _ in curves}
    for side in "LR":
        assert curves[(f'pose.bones["thigh_parent.{side}"]["IK_FK"]', 0)].evaluate(10) == 0.0
        assert curves[(f'pose.bones["thigh_parent.{side}"]["pole_vector"]', 0)].evaluate(10) == 1.0
        assert curves[(f'pose.bones["upper_arm_parent.{side}"]["IK_FK"]', 0)].evaluate(10) == 1.0
        for ctrl in (f"foot_ik.{side}", f"toe_ik.{side}", f"thigh_ik_target.{side}"):
            fc = curves[(f'pose.bones["{ctrl}"].location', 0)]
            assert len(fc.keyframe_points) == solved.ik.frames, ctrl
        assert (f'pose.bones["foot_ik.{side}"].rotation_quaternion', 0) in curves
        assert not [p for p in paths if any(f'"{c}.{side}"' in p for c in LEGS_FK)]
    # the only keys off the controls: the IK constraints' stretch, keyed off
    internal = {p for p in paths if p.startswith(('pose.bones["MCH-', 'pose.bones["ORG-', 'pose.bones["DEF-'))}
    assert internal and all(p.endswith(".use_stretch") for p in internal)
    assert all(curves[(p, 0)].evaluate(10) == 0.0 for p in internal)
    assert {f'pose.bones["{c}.L"].rotation_quaternion' for c in LEGS_FK} <= fk_paths


def test_the_setting_reaches_the_bake(fp, walk):
    """``planning.run`` with ``rigify_ik_feet`` (what the operator and the CLI's
    ``--set rigify_ik_feet=true`` call) keys the IK controls."""
    import bpy

    scene, rig, planned, solved, settings = walk
    planning = _mod(fp, "blender.planning")
    goal, heading = planning.goal_of(scene, "Goal")
    _mod(fp, "blender.write.bake").clear(rig, scene)  # (the other tests' bakes, at the same frames)
    doc = planning.run(scene, rig, goal, heading, scene.objects["Start"], settings, name="run ik", frame_start=1)
    paths = {p for p, _ in _fcurves(bpy.data.actions[doc["action"]])}
    assert 'pose.bones["foot_ik.L"].location' in paths and 'pose.bones["thigh_fk.L"].rotation_quaternion' not in paths
