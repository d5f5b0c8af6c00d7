"""The review sheet's character camera sees the character past walls."""

from importlib import import_module

import numpy as np


def _wall(bpy, x, y, sx, sy):
    bpy.ops.mesh.primitive_cube_add(location=(x, y, 1.0))
    ob = bpy.context.object
    ob.scale = (sx, sy, 1.0)
    return ob


def test_the_character_camera_goes_round_a_wall_and_hides_what_walls_it_in(fp):
    import bpy

    review = import_module(fp.__name__ + ".blender.command.review")
    bpy.ops.wm.read_homefile(use_empty=True)
    scene = bpy.context.scene
    hips = np.array([0.0, 0.0, 1.0])
    east = _wall(bpy, 2.0, 0.0, 0.1, 3.0)  # beside the character, on its +X side
    bpy.context.view_layer.update()
    spot, hidden = review._camera_spot(scene, hips, 0.0)
    assert hidden == [] and spot[0] < -3.0  # from the other side, clear
    walls = [east, _wall(bpy, -2.0, 0.0, 0.1, 3.0), _wall(bpy, 0.0, 2.0, 3.0, 0.1), _wall(bpy, 0.0, -2.0, 3.0, 0.1)]
    bpy.context.view_layer.update()
    spot, hidden = review._camera_spot(scene, hips, 0.0)
    assert hidden and all(w.hide_render for w in hidden) and set(hidden) <= set(walls)
    np.testing.assert_allclose(spot, hips + [review.CAMERA_DISTANCE, 0.0, review.CAMERA_RISE])
    for w in hidden:  # (the caller restores them)
        w.hide_render = False
