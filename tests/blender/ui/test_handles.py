"""Footprints as handles in the viewport (issue 16): an untouched handle reads back
exactly as planned, a moved or turned one reads back where it was put (and locked),
lock and unlock, and clearing removes only what the planner made."""

from importlib import import_module

import numpy as np
import pytest


@pytest.fixture
def mods(fp, empty_scene):
    return (import_module(fp.__name__ + ".blender.ui.handles"), import_module(fp.__name__ + ".core.plan.navgraph"))


def _path(nav, n=8, forward=(0.0, -1.0, 0.0)):
    rng = np.random.default_rng(3)
    return [nav.PathFootprint(i % 2, np.array([12.345678 + 0.61 * i, -7.654321 + rng.normal(0, 0.1), 0.3]),
                              float(np.pi / 2 + rng.normal(0, 0.2)), 0.55 * i, "walk", "walk", i == 5)
            for i in range(n)]


def _armature(name="Hero"):
    import bpy

    ob = bpy.data.objects.new(name, bpy.data.armatures.new(name))
    bpy.context.scene.collection.objects.link(ob)
    return ob


def test_untouched_handles_read_back_exactly(mods):
    import bpy

    handles, nav = mods
    ob = _armature()
    fps = _path(nav)
    made = handles.make_handles(bpy.context.scene, ob, fps, np.array([0.0, -1.0, 0.0]), goal=[20, -7, 0],
                                goal_heading=1.0, locked=[i == 2 for i in range(len(fps))])
    assert len(made) == len(fps) and all(h.users_collection[0].name == "Footprints: Hero" for h in made)
    bpy.context.view_layer.update()
    plan, moved = handles.read_plan(ob)
    assert not moved.any() and plan.locked.tolist() == [i == 2 for i in range(len(fps))]
    for a, b in zip(fps, plan.footprints):
        assert a.foot == b.foot and np.array_equal(a.position, b.position) and a.heading == b.heading
        assert (a.label, a.gait, a.jump) == (b.label, b.gait, b.jump)
    assert plan.goal.tolist() == [20, -7, 0] and plan.goal_heading == 1.0


def test_a_handle_faces_its_footprints_way(mods):
    """Heading 0 faces the forward (-Y here): the handle's -Y axis points along it."""
    import bpy

    handles, nav = mods
    ob = _armature()
    fps = [nav.PathFootprint(0, np.zeros(3), 0.0, 0.0, "walk", "walk"),
           nav.PathFootprint(1, np.ones(3), np.pi / 2, 0.5, "walk", "walk")]
    h0, h1 = handles.make_handles(bpy.context.scene, ob, fps, np.array([0.0, -1.0, 0.0]))
    bpy.context.view_layer.update()
    assert np.allclose(-np.array(h0.matrix_world.col[1][:3]), [0, -1, 0], atol=1e-6)
    assert np.allclose(-np.array(h1.matrix_world.col[1][:3]), [1, 0, 0], atol=1e-6)  # a quarter turn left


def test_a_moved_or_turned_handle_reads_back_where_it_was_put(mods):
    import bpy

    handles, nav = mods
    ob = _armature()
    fps = _path(nav)
    made = handles.make_handles(bpy.context.scene, ob, fps, np.array([0.0, -1.0, 0.0]))
    made[3].location.x += 0.2
    made[6].rotation_euler.z += 0.3
    bpy.context.view_layer.update()
    plan, moved = handles.read_plan(ob)
    assert moved.tolist() == [i in (3, 6) for i in range(len(fps))]
    assert plan.locked[3] and plan.locked[6]  # moved: locked where the animator put them
    assert abs(plan.footprints[3].position[0] - (fps[3].position[0] + 0.2)) < 1e-5
    assert abs(plan.footprints[6].heading - (fps[6].heading + 0.3)) < 1e-5


def test_lock_unlock_and_clear_touch_only_the_planners_objects(mods):
    import bpy

    handles, nav = mods
    ob = _armature()
    mine = bpy.data.objects.new("mine", None)
    bpy.context.scene.collection.objects.link(mine)
    made = handles.make_handles(bpy.context.scene, ob, _path(nav), np.array([0.0, -1.0, 0.0]))
    assert handles.set_locked([made[1], made[4], mine], True) == 2 and "footstep_locked" not in mine
    plan, _ = handles.read_plan(ob)
    assert np.flatnonzero(plan.locked).tolist() == [1, 4]
    handles.set_locked([made[1]], False)
    assert np.flatnonzero(handles.read_plan(ob)[0].locked).tolist() == [4]
    assert handles.clear_handles(ob) == len(made)
    assert bpy.data.collections.get("Footprints: Hero") is None and "mine" in bpy.data.objects
