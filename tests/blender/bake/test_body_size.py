"""Any size: a character of another size than a human's plans and bakes on a scene scaled
to it as a human does on the sample scene. The sample character is made 2.77 times its
size (4.85 m tall, the Quaternius game character's height as Blender imports it) and 0.57
times (a 1 m child) the way a rescaled asset is: its bones and its clips' location keys
scaled, their timing kept; the scene, Start and Goal are scaled alike. Every length the
planner names is scaled with it (``Settings.for_body``), so the plan and the bake are the
human's, scaled: measured on the scene as Blender plays it."""

from importlib import import_module

import numpy as np
import pytest

from footstep_planner.core.base.settings import REFERENCE_LEG, Settings

#: the sample character's height (m), and the sizes tried
HEIGHT = 1.75
SIZES = {"giant": 4.85 / HEIGHT, "child": 1.0 / HEIGHT}


def _scaled_scene(fp, name: str, k: float):
    """Sample scene ``name`` with every object's geometry and place scaled ``k`` times about
    the origin (meshes' vertices, empties' locations)."""
    import bpy
    from mathutils import Matrix

    bpy.ops.wm.read_homefile(use_empty=True)
    import_module(fp.__name__ + ".blender.sample.sample_scenes").build(name)
    scene = bpy.context.scene
    scene.render.fps = 30
    s = Matrix.Scale(k, 4)
    for ob in scene.objects:
        if ob.type == "MESH":
            ob.data.transform(s)
        ob.location = ob.location * k
    return scene


def _character(fp, scene, k: float, object_scale: float = 1.0):
    """The sample character at the Start with its clips, made ``k`` times its size as a
    rescaled asset is: its bones, its body and its clips' location keys (values and
    handles) times ``k``, their timing kept; then analysed."""
    from mathutils import Matrix

    mod = import_module(fp.__name__ + ".blender.sample.mannequin")
    start = scene.objects["Start"]
    ob, body = mod.build(scene.collection, location=tuple(start.location))
    ob.rotation_euler.z = start.rotation_euler.z
    for act in mod.generate_clips(ob):
        for layer in act.layers:
            for strip in layer.strips:
                for cb in strip.channelbags:
                    for fc in cb.fcurves:
                        if fc.data_path.endswith(".location"):
                            for attr in ("co", "handle_left", "handle_right"):
                                xy = np.empty(2 * len(fc.keyframe_points))
                                fc.keyframe_points.foreach_get(attr, xy)
                                xy[1::2] *= k
                                fc.keyframe_points.foreach_set(attr, xy)
                            fc.update()
    ob.data.transform(Matrix.Scale(k, 4))
    body.data.transform(Matrix.Scale(k, 4))
    ob.scale = (object_scale,) * 3
    import_module(fp.__name__ + ".blender.read.character").analyze_and_propose(ob)
    scene.footstep.character = ob
    return ob


def _bake(fp, name: str, k: float):
    scene = _scaled_scene(fp, name, k)
    ob = _character(fp, scene, k)
    planning = import_module(fp.__name__ + ".blender.planning")
    goal, heading = planning.goal_of(scene, "Goal")
    doc = planning.run(scene, ob, goal, heading, scene.objects["Start"], name="size", frame_start=1)
    return doc


@pytest.fixture(scope="module")
def human(fp):
    return {name: _bake(fp, name, 1.0) for name in ("turns", "stairs")}


def test_the_body_scale_is_read_from_the_rig(fp):
    from footstep_planner.core.sample import mannequin
    from footstep_planner.core.clips.body import body_scale, leg_length, scaled_rig

    rig = mannequin.rig()
    assert leg_length(rig) == pytest.approx(REFERENCE_LEG, rel=0.01) and body_scale(rig) == 1.0
    for k in (0.5, 2.77):
        assert body_scale(scaled_rig(rig, k)) == pytest.approx(k * leg_length(rig) / REFERENCE_LEG, rel=1e-9)
    # a human's size (legs within 5 %) is planned as tuned; the scale is continuous in the size
    ks = [body_scale(scaled_rig(rig, k)) for k in np.linspace(0.8, 1.25, 200)]
    assert np.abs(np.diff(ks)).max() < 0.01 and body_scale(scaled_rig(rig, 1.04)) == 1.0


def test_settings_for_a_body_scale_lengths_and_speeds_and_keep_the_rest():
    s = Settings()
    g = s.for_body(2.5)
    assert g.goal_radius == pytest.approx(2.5 * s.goal_radius)
    assert g.clearance == pytest.approx(2.5 * s.clearance)
    assert g.contact_speed == pytest.approx(2.5 * s.contact_speed)
    assert g.bend_curvature == pytest.approx(s.bend_curvature / 2.5)
    assert g.turn_penalty == s.turn_penalty and g.transition_time == s.transition_time
    assert g.for_body(1.0).goal_radius == pytest.approx(s.goal_radius)
    assert g.for_body(2.5) is g  # (idempotent)


@pytest.mark.parametrize("size", sorted(SIZES))
@pytest.mark.parametrize("name", ["turns", "stairs"])
def test_a_giant_and_a_child_plan_and_bake_a_scaled_scene_as_a_human_does(fp, human, name, size):
    k = SIZES[size]
    doc, ref = _bake(fp, name, k), human[name]
    q, qr = doc["quality"], ref["quality"]
    # the same path, scaled: as many footprints (within 15 %), the goal met as closely
    n, nr = len(doc["footprints"]), len(ref["footprints"])
    assert abs(n - nr) <= max(3, 0.15 * nr), (n, nr)
    assert q["goal"]["distance_m"] <= k * max(qr["goal"]["distance_m"], 0.01) + 0.01
    assert q["goal"]["heading_deg"] <= max(qr["goal"]["heading_deg"], 1.0) + 2.0
    # planted feet stay planted, on their footprints, and out of the floor, at its size
    assert q["foot_skate"]["max_mm"] <= k * max(qr["foot_skate"]["max_mm"], 0.1) + 0.2
    assert q["footprint_error"]["max_mm"] <= k * max(qr["footprint_error"]["max_mm"], 0.2) + 0.5
    assert q["penetration"]["max_mm"] <= k * max(qr["penetration"]["max_mm"], 1.0) + 1.0
    # (the search's path is the human's to within what a 0.01 % change of the human's own
    # scene changes: the Turns scene's end has two ways of about 46 and 52 footprints, and
    # which one a size takes differs from machine to machine. The 46 footprints' way has
    # knee and ankle pops over the clips' own in its last steps, eased onto the goal: 2.6
    # degrees at most for the human (the scene scaled 0.9999), 3.1 at 1.5 times its size,
    # 3.6 for the giant, on an AMD EPYC machine, where the giant took that way and the
    # human the other)
    assert q["pops"]["introduced"]["max_excess_deg"] <= max(qr["pops"]["introduced"]["max_excess_deg"] + 1.0, 4.0)


@pytest.mark.parametrize("data, scale", [(100.0, 0.01), (0.01, 100.0), (2.77, 1 / 2.77)])
def test_an_evenly_scaled_object_is_taken_as_blender_shows_it(fp, human, data, scale):
    """The sample character's bones and keys in centimetres under an object scaled 0.01 (an
    FBX brought in at its file's unit), the reverse, and a giant set to a human's size by its
    object's scale: planned as the human it looks like, the bake keyed in the armature's own
    units (the object's scale kept, never keyed)."""
    scene = _scaled_scene(fp, "turns", 1.0)
    ob = _character(fp, scene, data, scale)
    planning = import_module(fp.__name__ + ".blender.planning")
    goal, heading = planning.goal_of(scene, "Goal")
    doc = planning.run(scene, ob, goal, heading, scene.objects["Start"], name="scaled", frame_start=1)
    q, qr = doc["quality"], human["turns"]["quality"]
    assert abs(len(doc["footprints"]) - len(human["turns"]["footprints"])) <= 7
    assert q["goal"]["distance_m"] <= max(qr["goal"]["distance_m"], 0.01) + 0.01
    assert q["foot_skate"]["max_mm"] <= max(qr["foot_skate"]["max_mm"], 0.1) + 0.2
    assert q["footprint_error"]["max_mm"] <= max(qr["footprint_error"]["max_mm"], 0.2) + 0.5
    assert q["penetration"]["max_mm"] <= max(qr["penetration"]["max_mm"], 1.0) + 1.0
    assert tuple(ob.scale) == pytest.approx((scale,) * 3)
    ad = ob.animation_data
    keyed = {fc.data_path for tr in ad.nla_tracks for st in tr.strips for layer in st.action.layers
             for s in layer.strips for cb in s.channelbags for fc in cb.fcurves}
    assert "scale" not in keyed


def _refusal(fp, scene, ob, name: str) -> str:
    """The one-line message ``planning.run`` refuses ``ob`` with on ``scene`` (Start to Goal)."""
    planning = import_module(fp.__name__ + ".blender.planning")
    goal, heading = planning.goal_of(scene, "Goal")
    errors = import_module(fp.__name__ + ".core.base.errors")
    with pytest.raises(errors.FootstepError) as ex:
        planning.run(scene, ob, goal, heading, scene.objects["Start"], name=name, frame_start=1)
    return str(ex.value)


def test_an_unevenly_scaled_object_is_refused_in_one_line_naming_the_scale(fp):
    scene = _scaled_scene(fp, "turns", 1.0)
    ob = _character(fp, scene, 1.0)
    ob.scale = (1.0, 1.0, 0.5)
    msg = _refusal(fp, scene, ob, "uneven")
    assert "scaled 1, 1, 0.5 on X, Y, Z" in msg and "Apply > Scale" in msg and "\n" not in msg


def test_a_rig_in_centimetres_under_scale_one_is_told_its_size_first(fp):
    """A rig whose bones and keys are in centimetres, its object at scale 1 (an FBX
    imported without its unit): 84 m legs over a 22 m scene. The one-line refusal says the
    size is wrong and how to scale it, before any step or start is tried (it said the
    Start was off the floor), and the character is left as it was."""
    from fingerprint import differences, fingerprint

    scene = _scaled_scene(fp, "turns", 1.0)
    ob = _character(fp, scene, 100.0, 1.0)
    before = fingerprint()
    msg = _refusal(fp, scene, ob, "cm")
    assert "'Footstep Mannequin' has legs 84 m long" in msg and "centimetres" in msg and "0.01" in msg
    assert "\n" not in msg and "Start" not in msg
    assert not differences(before, fingerprint())
