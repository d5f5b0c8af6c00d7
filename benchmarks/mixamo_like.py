"""Mixamo-like FBX files made from the project's own sample character: its bones renamed
to Mixamo's, the armature turned and scaled the way Mixamo files come into Blender (90
degrees about X, scale 0.01, bones and location keys in centimetres), clips optionally
made "in place" (the hips' horizontal travel removed) and cut to one gait cycle (its
first and last frames the same pose, as a Mixamo walk or run download is: 32 frames at 30
fps), written one clip per file by Blender's FBX exporter. Used by tests/blender/read/test_fbx_import.py,
tests/blender/read/test_downloads.py and bench_characters.py."""

import numpy as np

#: mannequin bone -> Mixamo joint (no prefix); the heel markers have no Mixamo joint
MIXAMO = {"spine": "Hips", "spine.001": "Spine", "spine.002": "Spine1", "spine.003": "Spine2",
          "spine.004": "Neck", "spine.005": "Head", "spine.006": "HeadTop_End"}
for _s, _side in (("L", "Left"), ("R", "Right")):
    MIXAMO.update({f"thigh.{_s}": f"{_side}UpLeg", f"shin.{_s}": f"{_side}Leg", f"foot.{_s}": f"{_side}Foot",
                   f"toe.{_s}": f"{_side}ToeBase", f"shoulder.{_s}": f"{_side}Shoulder",
                   f"upper_arm.{_s}": f"{_side}Arm", f"forearm.{_s}": f"{_side}ForeArm",
                   f"hand.{_s}": f"{_side}Hand"})
PREFIX = "mixamorig:"


def curves(act):
    for layer in act.layers:
        for strip in layer.strips:
            for cb in strip.channelbags:
                yield from cb.fcurves


def play(ob, act):
    ob.animation_data_create()
    ob.animation_data.action = act
    ob.animation_data.action_slot = act.slots[0]


def export(path, objects, act, frames):
    """One clip per file, as Mixamo writes them: Y up, centimetres, every frame keyed."""
    import bpy

    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = frames
    for o in bpy.data.objects:
        o.select_set(o in objects)
    if act is not None:
        play(objects[0], act)
    # without a skinned mesh (no bind pose) the file's rest pose is the pose at export:
    # the clip's first frame, as in a Mixamo download without skin
    scene.frame_set(frames[0])
    bpy.ops.export_scene.fbx(
        filepath=path, use_selection=True, object_types={o.type for o in objects}, axis_up="Y",
        axis_forward="-Z", global_scale=1.0, apply_unit_scale=True, apply_scale_options="FBX_SCALE_NONE",
        add_leaf_bones=False, bake_anim=act is not None, bake_anim_use_all_actions=False,
        bake_anim_use_nla_strips=False, bake_anim_force_startend_keying=True,
        bake_anim_simplify_factor=0.0)
    return path


def in_place(ob, act, hips):
    """A copy of ``act`` with the hips' horizontal travel removed (as a Mixamo "in place"
    download)."""
    import bpy

    new = act.copy()
    new.name = act.name + "_in_place"
    rest = np.array(ob.data.bones[hips].matrix_local)[:3, :3]
    base = f'pose.bones["{bpy.utils.escape_identifier(hips)}"].location'
    fcs = sorted((fc for fc in curves(new) if fc.data_path == base), key=lambda fc: fc.array_index)
    co = [np.empty(2 * len(fc.keyframe_points)) for fc in fcs]
    for fc, c in zip(fcs, co):
        fc.keyframe_points.foreach_get("co", c)
    world = np.stack([c[1::2] for c in co], axis=1) @ rest.T
    world[:, :2] = world[0, :2]
    loc = world @ rest
    for i, (fc, c) in enumerate(zip(fcs, co)):
        c[1::2] = loc[:, i]
        fc.keyframe_points.foreach_set("co", c)
        fc.update()
    return new


def mixamoize(ob, body):
    """Rename ``ob``'s bones as Mixamo does (heel markers deleted) and put its rest pose
    and location keys in centimetres, Y up, under an object turned 90 degrees about X
    and scaled 0.01: every bone and vertex stays where it was in the world."""
    import bpy
    from mathutils import Matrix

    view = bpy.context.view_layer
    view.objects.active = ob
    bpy.ops.object.mode_set(mode="EDIT")
    for eb in [eb for eb in ob.data.edit_bones if eb.name.startswith("heel")]:
        ob.data.edit_bones.remove(eb)
    bpy.ops.object.mode_set(mode="OBJECT")
    for old, new in MIXAMO.items():
        ob.data.bones[old].name = PREFIX + new
    for act in bpy.data.actions:
        for fc in curves(act):
            for old, new in MIXAMO.items():
                fc.data_path = fc.data_path.replace(f'pose.bones["{old}"]', f'pose.bones["{PREFIX + new}"]')
            if fc.data_path.endswith(".location"):
                for attr in ("co", "handle_left", "handle_right"):
                    xy = np.empty(2 * len(fc.keyframe_points))
                    fc.keyframe_points.foreach_get(attr, xy)
                    xy[1::2] *= 100.0
                    fc.keyframe_points.foreach_set(attr, xy)
                fc.update()
    g = Matrix.Rotation(np.pi / 2, 4, "X") @ Matrix.Scale(0.01, 4)
    ob.data.transform(g.inverted())
    body.data.transform(g.inverted())
    ob.matrix_world = g
    view.update()


def write_character(out_dir: str, clips=("walk", "run", "walk_turn_left_wide", "walk_turn_right_wide"),
                    in_place_clips: bool = True, one_cycle: bool = False, fps: int | None = None) -> list:
    """A Mixamo-style character as FBX files in ``out_dir``, one per generated clip of the
    sample character (in place unless ``in_place_clips`` is false; with ``one_cycle``, a
    cyclic clip cut to one gait cycle, its last frame the pose of its first), the first
    with its skinned body, at ``fps`` (default the empty scene's). Resets the scene
    (``read_homefile``) before and after. Returns the paths."""
    import os

    import bpy

    from footstep_planner.blender.sample import mannequin
    from footstep_planner.core.sample import gait
    bpy.ops.wm.read_homefile(use_empty=True)
    if fps:
        bpy.context.scene.render.fps, bpy.context.scene.render.fps_base = int(fps), 1.0
    rate = bpy.context.scene.render.fps / bpy.context.scene.render.fps_base
    ob, body = mannequin.build()
    acts = mannequin.generate_clips(ob, names=list(clips))
    specs = {s.name: s for s in gait.library_specs()}
    if in_place_clips:
        acts = [in_place(ob, a, "spine") for a in acts]
    mixamoize(ob, body)
    paths = []
    for k, act in enumerate(acts):
        objects = [ob, body] if k == 0 else [ob]
        frames = (1, int(act.frame_range[1]))
        spec = specs.get(act.name.removesuffix("_in_place"))
        if one_cycle and spec is not None and spec.kind == "cycle":
            frames = (1, 1 + int(round(spec.gait.cycle * rate)))  # (the generator's cycle: whole frames)
        paths.append(export(os.path.join(out_dir, f"{act.name}.fbx"), objects, act, frames))
    bpy.ops.wm.read_homefile(use_empty=True)
    return paths
