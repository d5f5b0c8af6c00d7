"""Rigify rigs: detection, the deforming skeleton and its FK controls, and keying the controls
so that the DEF bones land on planner targets (checked through Blender's depsgraph).

The rig is Rigify's human metarig's, generated once per test run (``conftest.rigify_rig``)."""

from importlib import import_module

import numpy as np
import pytest

from conftest import MOD, rigify_rig

MM = 1e-3


# ------------------------------------------------------------------------------------------
# fixtures and helpers


@pytest.fixture(scope="module")
def rigify(fp):
    return import_module(fp.__name__ + ".blender.rigify")


@pytest.fixture(scope="module")
def rig(fp, rigify_cache):
    """(rig, metarig): Rigify's human metarig and the rig generated from it."""
    import addon_utils
    import bpy

    was_enabled = addon_utils.check("rigify")[1]
    bpy.ops.wm.read_homefile(use_empty=True)
    yield rigify_rig(*rigify_cache)
    bpy.ops.wm.read_homefile(use_empty=True)
    if not was_enabled:
        addon_utils.disable("rigify", default_set=True)


def _quat(x=0.0, y=0.0, z=0.0):
    from mathutils import Euler

    return tuple(Euler(np.radians((x, y, z)), "XYZ").to_quaternion())


def _key(cbag, bone, prop, frames, values):
    values = np.atleast_2d(np.asarray(values, float))
    if values.shape[0] == 1 and len(frames) > 1:
        values = np.repeat(values, len(frames), 0)
    sep = "" if prop.startswith("[") else "."
    new_fcurve = import_module(MOD + ".blender.write.keys").new_fcurve  # (on Blender 4.5 and 5.x alike)
    for i in range(values.shape[1]):
        fc = new_fcurve(cbag, f'pose.bones["{bone}"]{sep}{prop}', i, bone)
        fc.keyframe_points.add(len(frames))
        co = np.empty(2 * len(frames), np.float32)
        co[0::2], co[1::2] = frames, values[:, i]
        fc.keyframe_points.foreach_set("co", co)
        fc.update()


def _walk_action(ob, frames, name="FP_test_source"):
    """A made-up walk keyed the way an animator would: torso travelling 1 m with bob and yaw,
    hips/chest/spine/neck/head rotations, FK legs and arms (tens of degrees), switches at FK."""
    import bpy

    act = bpy.data.actions.new(name)
    slot = act.slots.new(id_type="OBJECT", name=ob.name)
    cbag = act.layers.new("L").strips.new(type="KEYFRAME").channelbag(slot, ensure=True)
    n = len(frames)
    ph = np.linspace(0, 2 * np.pi, n)
    s, c = np.sin(ph), np.cos(ph)
    rot = lambda fn: [_quat(*fn(i)) for i in range(n)]  # noqa: E731
    _key(cbag, "torso", "location", frames,
         np.column_stack([0.03 * s, -np.linspace(0, 1, n), 0.04 * np.abs(s) - 0.05]))
    _key(cbag, "torso", "rotation_quaternion", frames, rot(lambda i: (5 * s[i], 3 * c[i], 10 * s[i])))
    _key(cbag, "hips", "rotation_quaternion", frames, rot(lambda i: (8 * c[i], 6 * s[i], -15 * s[i])))
    _key(cbag, "chest", "rotation_quaternion", frames, rot(lambda i: (-6 * s[i], 4 * c[i], 20 * s[i])))
    _key(cbag, "spine_fk.001", "rotation_quaternion", frames, rot(lambda i: (4 * s[i], 0, 5 * c[i])))
    _key(cbag, "spine_fk.003", "rotation_quaternion", frames, rot(lambda i: (-5 * c[i], 3 * s[i], 0)))
    _key(cbag, "neck", "rotation_quaternion", frames, rot(lambda i: (10 * s[i], 0, 15 * c[i])))
    _key(cbag, "head", "rotation_quaternion", frames, rot(lambda i: (-8 * s[i], 5 * c[i], -10 * c[i])))
    for side, sg in (("L", 1), ("R", -1)):
        ss = sg * s
        _key(cbag, f"thigh_fk.{side}", "rotation_quaternion", frames, rot(lambda i: (35 * ss[i], 15 * c[i], 8 * sg)))
        _key(cbag, f"shin_fk.{side}", "rotation_quaternion", frames, rot(lambda i: (-30 - 30 * ss[i], 5 * c[i], 0)))
        _key(cbag, f"foot_fk.{side}", "rotation_quaternion", frames, rot(lambda i: (20 * ss[i], 10 * c[i], 5 * s[i])))
        _key(cbag, f"toe_fk.{side}", "rotation_quaternion", frames, rot(lambda i: (25 * max(ss[i], 0), 0, 0)))
        _key(cbag, f"thigh_parent.{side}", '["IK_FK"]', frames, [[1.0]])
        _key(cbag, f"shoulder.{side}", "rotation_euler", frames,
             [(np.radians(5 * s[i]), 0, np.radians(8 * sg * c[i])) for i in range(n)])
        _key(cbag, f"upper_arm_fk.{side}", "rotation_quaternion", frames,
             rot(lambda i: (-40 * ss[i], 20 * c[i], 50 * sg)))
        _key(cbag, f"forearm_fk.{side}", "rotation_quaternion", frames, rot(lambda i: (30 + 20 * ss[i], 10 * s[i], 0)))
        _key(cbag, f"hand_fk.{side}", "rotation_quaternion", frames, rot(lambda i: (15 * s[i], 10 * c[i], 20 * s[i])))
        _key(cbag, f"upper_arm_parent.{side}", '["IK_FK"]', frames, [[1.0]])
    return act, slot


def _state(ob):
    """Everything key_controls / sample_deform must leave as it was."""
    import bpy

    ad = ob.animation_data
    return {
        "objects": len(bpy.data.objects), "actions": len(bpy.data.actions),
        "armatures": len(bpy.data.armatures),
        "constraints": sum(len(pb.constraints) for o in bpy.data.objects if o.pose for pb in o.pose.bones),
        "selected": sorted(o.name for o in bpy.context.selected_objects),
        "active": bpy.context.view_layer.objects.active.name if bpy.context.view_layer.objects.active else None,
        "mode": bpy.context.mode, "frame": (bpy.context.scene.frame_current, bpy.context.scene.frame_subframe),
        "action": ad.action.name if ad and ad.action else None,
        "nla": len(ad.nla_tracks) if ad else 0,
        "rest": np.array([np.array(b.matrix_local) for b in ob.data.bones]),
        "basis": np.array([np.array(pb.matrix_basis) for pb in ob.pose.bones]),
        "ik_fk": ob.pose.bones["thigh_parent.L"]["IK_FK"],
    }


def _assert_same_state(a, b):
    for k in a:
        if isinstance(a[k], np.ndarray):
            assert np.array_equal(a[k], b[k]), k
        else:
            assert a[k] == b[k], k


def _errors(rigify, ob, got, want, names):
    gh, gt = rigify.heads_tails(ob, got, names)
    wh, wt = rigify.heads_tails(ob, want, names)
    return np.maximum(np.linalg.norm(gh - wh, axis=-1), np.linalg.norm(gt - wt, axis=-1))  # (F, B)


# ------------------------------------------------------------------------------------------
# tests


def test_detection(rigify, rig):
    import bpy

    ob, meta = rig
    assert rigify.is_rigify(ob) and not rigify.rigify_metarig(ob)
    assert rigify.rigify_metarig(meta) and not rigify.is_rigify(meta)
    plain = bpy.data.objects.new("plain", bpy.data.armatures.new("plain"))
    try:
        assert not rigify.is_rigify(plain) and not rigify.rigify_metarig(plain)
        assert not rigify.is_rigify(None) and not rigify.rigify_metarig(None)
    finally:
        arm = plain.data
        bpy.data.objects.remove(plain)
        bpy.data.armatures.remove(arm)
    with pytest.raises(ValueError, match="generate"):
        rigify.deform_chain(meta)


def test_deform_chain(rigify, rig):
    import bpy

    ob, _ = rig
    info = rigify.deform_chain(ob)
    sp = info["spine"]
    assert sp["deform"] == ["DEF-spine", "DEF-spine.001", "DEF-spine.002", "DEF-spine.003"]
    assert sp["fk"] == ["spine_fk", "spine_fk.001", "spine_fk.002", "spine_fk.003"] and sp["pivot"] == 2
    leg = info["limbs"]["thigh.L"]
    assert leg["kind"] == "leg" and leg["fk"] == ["thigh_fk.L", "shin_fk.L", "foot_fk.L", "toe_fk.L"]
    assert leg["deform"] == [["DEF-thigh.L", "DEF-thigh.L.001"], ["DEF-shin.L", "DEF-shin.L.001"],
                             ["DEF-foot.L"], ["DEF-toe.L"]]
    arm = info["limbs"]["upper_arm.R"]
    assert arm["fk"] == ["upper_arm_fk.R", "forearm_fk.R", "hand_fk.R"]
    assert (arm["parent_control"], arm["parent_deform"]) == ("shoulder.R", "DEF-shoulder.R")
    assert leg["switch"]["bone"] == "thigh_parent.L" and leg["switch"]["property"] == "IK_FK"
    assert leg["switch"]["fk_value"] == 1.0
    # the rig's own UI script shows the same switch and FK bones
    ui = ob["rig_ui"].as_string() if hasattr(ob["rig_ui"], "as_string") else bpy.data.texts["rig_ui.py"].as_string()
    assert """pose_bones['thigh_parent.L'], '["IK_FK"]'""" in ui
    assert '["thigh_fk.L", "shin_fk.L", "foot_fk.L", "toe_fk.L"]' in ui
    sk = info["skeleton"]
    assert sk["DEF-spine"] is None and sk["DEF-thigh.L"] == "DEF-spine"
    assert sk["DEF-shin.L"] == "DEF-thigh.L.001" and sk["DEF-toe.R"] == "DEF-foot.R"
    assert sk["DEF-shoulder.L"] == "DEF-spine.003" and sk["DEF-upper_arm.L"] == "DEF-shoulder.L"
    assert sk["DEF-pelvis.L"] == "DEF-spine" and not any("lip" in n or "f_index" in n for n in sk)
    assert info["roles"]["hips"] == "DEF-spine" and info["roles"]["foot.R"] == "DEF-foot.R"
    assert info["controls"]["DEF-shin.L"] == ["shin_fk.L"]
    # FK value really turns the IK copy off (the driver is 1 - IK_FK)
    pb = ob.pose.bones["thigh_parent.L"]
    old = pb["IK_FK"]
    try:
        pb["IK_FK"] = leg["switch"]["fk_value"]
        ob.update_tag()
        bpy.context.view_layer.update()
        ik_copy = ob.pose.bones["ORG-thigh.L"].constraints[1]
        assert ik_copy.subtarget == "thigh_ik.L" and ik_copy.influence == 0.0
    finally:
        pb["IK_FK"] = old
        ob.update_tag()
        bpy.context.view_layer.update()


def test_round_trip_through_the_depsgraph(rigify, rig):
    import bpy

    ob, _ = rig
    info = rigify.deform_chain(ob)
    names = list(info["skeleton"])
    frames = np.arange(1, 31)
    src, _ = _walk_action(ob, frames)
    src_curves = [(fc.data_path, fc.array_index, tuple(fc.keyframe_points[3].co))
                  for fc in src.layers[0].strips[0].channelbags[0].fcurves]
    before = _state(ob)
    targets_all = rigify.sample_deform(ob, src, frames, names=names)
    _assert_same_state(before, _state(ob))
    targets = {n: targets_all[:, i] for i, n in enumerate(names)}
    hips_path = np.linalg.norm(targets["DEF-spine"][-1, :3, 3] - targets["DEF-spine"][0, :3, 3])
    assert hips_path > 0.9  # the torso really travels about 1 m

    dst = bpy.data.actions.new("FP_test_keyed")
    before = _state(ob)
    res = rigify.key_controls(ob, dst, frames, targets, verify=3)
    _assert_same_state(before, _state(ob))
    assert res["max_error"] < 1 * MM
    keyed = {fc.data_path for fc in res["channelbag"].fcurves}
    for c in ("torso", "spine_fk", "thigh_fk.L", "shin_fk.R", "foot_fk.L", "toe_fk.R", "upper_arm_fk.L",
              "hand_fk.R", "shoulder.L", "neck", "head"):
        assert any(p.startswith(f'pose.bones["{c}"].rotation') for p in keyed), c
    assert not any(p.startswith('pose.bones["root"]') or p.startswith('pose.bones["DEF-') for p in keyed)
    assert not any(p.startswith('pose.bones["ORG-') or p.startswith('pose.bones["MCH-') for p in keyed)
    sw = res["channelbag"].fcurves.find('pose.bones["thigh_parent.R"]["IK_FK"]')
    assert sw is not None and sw.evaluate(15) == 1.0

    got = rigify.sample_deform(ob, dst, frames, names=names)
    err = _errors(rigify, ob, got, targets_all, names)
    print(f"\nround trip: {len(names)} DEF bones x {len(frames)} frames, "
          f"max head/tail error {err.max() * 1000:.4f} mm")
    assert err.max() < 1 * MM, names[int(err.max(0).argmax())]
    # bones Rigify moves rigidly with one FK control also match in orientation
    rot = import_module(rigify.__name__ + ".solver")._rot
    for n in ("DEF-spine", "DEF-spine.003", "DEF-shin.L", "DEF-foot.R", "DEF-toe.L", "DEF-hand.R",
              "DEF-shoulder.L", "DEF-spine.006"):
        i = names.index(n)
        assert np.abs(rot(got[:, i]) - rot(targets_all[:, i])).max() < 1e-4, n

    # the same action played from an NLA strip (no active action)
    ad = ob.animation_data
    frame0 = bpy.context.scene.frame_current
    track = ad.nla_tracks.new()
    try:
        strip = track.strips.new("keyed", 1, dst)
        strip.action_slot = res["slot"]
        ev_names = [pb.name for pb in ob.pose.bones]
        idx = [ev_names.index(n) for n in names]
        for f in (1, 12, 30):
            bpy.context.scene.frame_set(f)
            ev = ob.evaluated_get(bpy.context.evaluated_depsgraph_get())
            m = np.array([np.array(ev.pose.bones[i].matrix) for i in idx])
            e = _errors(rigify, ob, m[None], targets_all[f - 1][None], names)
            assert e.max() < 1 * MM, (f, names[int(e.argmax())])
    finally:
        ad.nla_tracks.remove(track)
        bpy.context.scene.frame_set(frame0)

    # the source action is untouched
    assert src_curves == [(fc.data_path, fc.array_index, tuple(fc.keyframe_points[3].co))
                          for fc in src.layers[0].strips[0].channelbags[0].fcurves]
    bpy.data.actions.remove(dst)
    bpy.data.actions.remove(src)


def test_partial_targets_channelbag_and_rekey(rigify, rig):
    """Spine and legs only, into a given channelbag, keyed twice (curves replaced, not doubled)."""
    import bpy

    ob, _ = rig
    info = rigify.deform_chain(ob)
    frames = np.arange(10, 22)
    src, _ = _walk_action(ob, frames)
    legs = [x for key in ("thigh.L", "thigh.R") for seg in info["limbs"][key]["deform"] for x in seg]
    names = info["spine"]["deform"] + legs
    m = rigify.sample_deform(ob, src, frames, names=names)
    targets = {n: m[:, i] for i, n in enumerate(names)}

    act = bpy.data.actions.new("FP_test_cbag")
    slot = act.slots.new(id_type="OBJECT", name=ob.name)
    cbag = act.layers.new("Layer").strips.new(type="KEYFRAME").channelbag(slot, ensure=True)
    res = rigify.key_controls(ob, cbag, frames, targets, verify=len(frames))
    n1 = len(cbag.fcurves)
    res = rigify.key_controls(ob, cbag, frames, targets, verify=len(frames))
    assert len(cbag.fcurves) == n1 and len(act.slots) == 1 and len(act.layers) == 1
    assert res["max_error"] < 1 * MM
    paths = {fc.data_path for fc in cbag.fcurves}
    assert 'pose.bones["thigh_parent.L"]["IK_FK"]' in paths
    assert 'pose.bones["upper_arm_parent.R"]["IK_FK"]' in paths  # all_fk: arms ride along in FK
    assert not any("upper_arm_fk" in p or "neck" in p for p in paths)  # arms/neck not asked for

    with pytest.raises(ValueError, match="spine"):
        rigify.key_controls(ob, act, frames, {n: targets[n] for n in legs})
    bpy.data.actions.remove(act)
    bpy.data.actions.remove(src)


def test_key_controls_on_a_long_clip(rigify, rig):
    """500 frames keyed (the key writing is vectorised over frames; its speed is the
    benchmarks' business) and every tenth of them checked through the depsgraph."""
    import bpy

    ob, _ = rig
    info = rigify.deform_chain(ob)
    names = list(info["skeleton"])
    frames30 = np.arange(1, 31)
    src, _ = _walk_action(ob, frames30)
    m = rigify.sample_deform(ob, src, frames30, names=names)
    frames = np.arange(1, 501)
    targets = {n: np.resize(m[:, i], (len(frames), 4, 4)) for i, n in enumerate(names)}
    dst = bpy.data.actions.new("FP_test_speed")
    rigify.key_controls(ob, dst, frames, targets)
    got = rigify.sample_deform(ob, dst, frames[::50], names=names)
    assert _errors(rigify, ob, got, m[(frames[::50] - 1) % 30], names).max() < 1 * MM
    bpy.data.actions.remove(dst)
    bpy.data.actions.remove(src)
