"""What a kept result of a clip is keyed by: an action's digest
(``blender.read.scene.action_digest``, the key of the Rigify clips kept) tells what shapes
its curves, and not its name."""

from importlib import import_module


def _mods(fp):
    return (import_module(fp.__name__ + ".blender.read.character"), import_module(fp.__name__ + ".blender.read.scene"),
            import_module(fp.__name__ + ".blender.sample.mannequin"))


def _mannequin(fp):
    import bpy

    _, scene, man = _mods(fp)
    ob, _ = man.build(bpy.context.scene.collection)
    acts = man.generate_clips(ob)
    return ob, acts[0]  # (the walk: the library's first)


def test_an_actions_digest_tells_what_shapes_its_curves_and_not_its_name(fp):
    """``scene.action_digest`` (the key of the clips kept): another value, a Bezier key's
    handle, an eased key's easing each give another digest; a linear key's handle (which
    shapes nothing) and the action's name do not."""
    import bpy

    bpy.ops.wm.read_homefile(use_empty=True)
    scene = _mods(fp)[1]
    ob, act = _mannequin(fp)
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
