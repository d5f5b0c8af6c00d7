"""A clip read from its action is kept while what it is made of is unchanged
(``blender.read.character.read_clip``): read again it is what a fresh read gives, read
only; an edited key, another rotation mode, another rig under the same name, another
scale or frame rate, each reads afresh."""

from importlib import import_module

import numpy as np
import pytest


def _mods(fp):
    return (import_module(fp.__name__ + ".blender.read.character"), import_module(fp.__name__ + ".blender.read.scene"),
            import_module(fp.__name__ + ".blender.sample.mannequin"))


def _mannequin(fp, name="Footstep Mannequin"):
    import bpy

    character, scene, man = _mods(fp)
    ob, _ = man.build(bpy.context.scene.collection)
    acts = man.generate_clips(ob)
    ob["walk"] = acts[0].name  # (the walk: the library's first; a second character's "walk.001")
    return ob, scene.rig_from_armature(ob)


def _same(a, b) -> bool:
    from dataclasses import fields

    return all(np.array_equal(getattr(a, f.name), getattr(b, f.name)) if isinstance(getattr(a, f.name), np.ndarray)
               else getattr(a, f.name) == getattr(b, f.name) for f in fields(a))


def _fresh(fp, ob, act, rig, fps=None):
    character = _mods(fp)[0]
    character.forget_read_clips()
    return character.read_clip(ob, act, rig, fps=fps)


def _walk(ob):
    import bpy

    return bpy.data.actions[ob["walk"]]


def test_a_clip_read_again_is_the_fresh_read_kept_read_only(fp):
    import bpy

    bpy.ops.wm.read_homefile(use_empty=True)
    character = _mods(fp)[0]
    ob, rig = _mannequin(fp)
    act = _walk(ob)
    fresh = _fresh(fp, ob, act, rig)
    again = character.read_clip(ob, act, rig)
    assert again is fresh and _same(again, fresh)
    with pytest.raises(ValueError):
        again.root_pos[0, 0] = 1.0  # (kept: read only, the next caller's too)


def test_an_edited_key_a_rotation_mode_a_rig_a_scale_or_a_rate_reads_afresh(fp):
    import bpy

    bpy.ops.wm.read_homefile(use_empty=True)
    character = _mods(fp)[0]
    ob, rig = _mannequin(fp)
    act = _walk(ob)
    first = character.read_clip(ob, act, rig)

    # an edited key: the hips raised 5 cm at one key
    fc = next(fc for ly in act.layers for st in ly.strips for cb in st.channelbags for fc in cb.fcurves
              if fc.data_path.endswith('location"]') or (fc.data_path.endswith("location") and fc.array_index == 2))
    kp = fc.keyframe_points[len(fc.keyframe_points) // 2]
    kp.co[1] += 0.05
    edited = character.read_clip(ob, act, rig)
    assert edited is not first and not np.array_equal(edited.local_rot, first.local_rot) or \
        not np.array_equal(edited.root_pos, first.root_pos) or not np.array_equal(edited.hips_in_root, first.hips_in_root)
    assert _same(edited, _fresh(fp, ob, act, rig))
    kp.co[1] -= 0.05

    # the keys of a curve made Bezier, then one handle moved, then eased: each reads afresh
    # (a linear curve's digest reads only where its keys are; a Bezier one's its handles too),
    # read at twice the keys' rate: between them, where handles and easing shape the curve
    linear = character.read_clip(ob, act, rig, fps=60.0)
    fc = next(fc for ly in act.layers for st in ly.strips for cb in st.channelbags for fc in cb.fcurves
              if "rotation_quaternion" in fc.data_path and fc.array_index == 1 and np.ptp([k.co[1] for k in fc.keyframe_points]) > 0.05)
    for k in fc.keyframe_points:
        k.interpolation = "BEZIER"
    bezier = character.read_clip(ob, act, rig, fps=60.0)
    assert bezier is not linear and _same(bezier, _fresh(fp, ob, act, rig, fps=60.0))
    kp = fc.keyframe_points[len(fc.keyframe_points) // 3]
    kp.handle_right_type = "FREE"
    kp.handle_right[1] += 0.5
    handled = character.read_clip(ob, act, rig, fps=60.0)
    assert handled is not bezier and not np.array_equal(handled.local_rot, bezier.local_rot)
    assert _same(handled, _fresh(fp, ob, act, rig, fps=60.0))
    for k in fc.keyframe_points:
        k.interpolation = "QUAD"
    quad = character.read_clip(ob, act, rig, fps=60.0)
    kp.easing = "EASE_IN"
    eased = character.read_clip(ob, act, rig, fps=60.0)
    assert eased is not quad and _same(eased, _fresh(fp, ob, act, rig, fps=60.0))
    for k in fc.keyframe_points:
        k.interpolation = "LINEAR"

    # another rotation mode on a bone the action keys in quaternions: its keys no longer apply
    base = character.read_clip(ob, act, rig)
    pb = next(pb for pb in ob.pose.bones if any(f'"{pb.name}"].rotation_quaternion' in fc.data_path
                                               for ly in act.layers for st in ly.strips for cb in st.channelbags
                                               for fc in cb.fcurves) and pb.parent is not None)
    pb.rotation_mode = "XYZ"
    moded = character.read_clip(ob, act, rig)
    assert moded is not base and _same(moded, _fresh(fp, ob, act, rig))
    pb.rotation_mode = "QUATERNION"

    # the object scaled: the clip in world units, twice as long
    base = character.read_clip(ob, act, rig)
    ob.scale = (2.0, 2.0, 2.0)
    bpy.context.view_layer.update()
    big_rig = _mods(fp)[1].rig_from_armature(ob)
    big = character.read_clip(ob, act, big_rig)
    assert np.allclose(np.ptp(big.root_pos, axis=0), 2.0 * np.ptp(base.root_pos, axis=0), atol=1e-4)
    ob.scale = (1.0, 1.0, 1.0)
    bpy.context.view_layer.update()

    # another frame rate: other samples
    assert len(character.read_clip(ob, act, rig, fps=60.0).times) > len(base.times)


def test_another_rig_under_the_same_name_reads_its_own_clip(fp):
    """A new file with an armature of the same name and actions of the same names and keys
    but longer legs (the bones' rest moved): its clip is its own, not the one read before."""
    import bpy

    bpy.ops.wm.read_homefile(use_empty=True)
    character, scene, _ = _mods(fp)
    ob, rig = _mannequin(fp)
    name = _walk(ob).name
    before = character.read_clip(ob, bpy.data.actions[name], rig)

    bpy.ops.wm.read_homefile(use_empty=True)
    ob, _ = _mannequin(fp)
    bpy.context.view_layer.objects.active = ob
    bpy.ops.object.mode_set(mode="EDIT")
    for eb in ob.data.edit_bones:  # (every bone's rest a tenth further from the origin)
        eb.head *= 1.1
        eb.tail *= 1.1
    bpy.ops.object.mode_set(mode="OBJECT")
    longer = scene.rig_from_armature(ob)
    after = character.read_clip(ob, bpy.data.actions[name], longer)
    assert after is not before and _same(after, _fresh(fp, ob, bpy.data.actions[name], longer))
    assert not np.allclose(after.heel, before.heel)


def test_a_copy_of_a_clip_under_another_name_reads_as_the_clip_under_its_own_name(fp):
    """Another character's copy of a clip (the same keys, another action's name) is given
    the clip read before, named as its own action."""
    import bpy

    bpy.ops.wm.read_homefile(use_empty=True)
    character = _mods(fp)[0]
    ob, rig = _mannequin(fp)
    act = _walk(ob)
    first = character.read_clip(ob, act, rig)
    copy = act.copy()
    copy.name = "another character's walk"
    again = character.read_clip(ob, copy, rig)
    assert again.name == copy.name and first.name == act.name
    fresh = _fresh(fp, ob, copy, rig)
    assert fresh.name == copy.name and _same(again, fresh)


def test_a_second_character_with_the_same_clips_is_given_the_clips_read_for_the_first(fp):
    """Two characters of one rig with their own copies of one clip library (each its own
    armature, object name and actions): the second's clips are the first's read, named as
    its own, and what a fresh read of its own gives."""
    import bpy

    bpy.ops.wm.read_homefile(use_empty=True)
    character = _mods(fp)[0]
    ob, rig = _mannequin(fp)
    first = character.read_clip(ob, _walk(ob), rig)
    other, other_rig = _mannequin(fp)
    assert other.name != ob.name and _walk(other) != _walk(ob)
    second = character.read_clip(other, _walk(other), other_rig)
    assert second.name == _walk(other).name and np.shares_memory(second.local_rot, first.local_rot)
    assert _same(second, _fresh(fp, other, _walk(other), other_rig))


def test_an_actions_digest_tells_what_shapes_its_curves_and_not_its_name(fp):
    """``scene.action_digest`` (the key of the clips kept): another value, a Bezier key's
    handle, an eased key's easing each give another digest; a linear key's handle (which
    shapes nothing) and the action's name do not."""
    import bpy

    bpy.ops.wm.read_homefile(use_empty=True)
    scene = _mods(fp)[1]
    ob, _ = _mannequin(fp)
    act = _walk(ob)
    fc = next(fc for ly in act.layers for st in ly.strips for cb in st.channelbags for fc in cb.fcurves)
    kp = fc.keyframe_points[1]
    digests = [scene.action_digest(act)]
    kp.handle_right_type = "FREE"
    kp.handle_right[1] += 0.5  # (a linear key's handle: nothing changes)
    act.name = "renamed walk"
    assert scene.action_digest(act) == digests[0]
    kp.interpolation = "BEZIER"
    digests.append(scene.action_digest(act))
    kp.handle_right[1] += 0.5
    digests.append(scene.action_digest(act))
    kp.interpolation = "QUAD"
    digests.append(scene.action_digest(act))
    kp.easing = "EASE_IN"
    digests.append(scene.action_digest(act))
    kp.co[1] += 0.01
    digests.append(scene.action_digest(act))
    assert len(set(digests)) == len(digests), digests
