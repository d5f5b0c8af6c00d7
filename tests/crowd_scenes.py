"""Scenes and measures the tests of characters baked together share (the command line's
``--together`` and the panel's Bake Together)."""

import math
from importlib import import_module

FPS = 30


def _floor(fp):
    """An empty file at FPS: (scene, the sample scenes' module, a Traversable collection)."""
    import bpy

    bpy.ops.wm.read_homefile(use_empty=True)
    scene = bpy.context.scene
    scene.render.fps = FPS
    ss = import_module(fp.__name__ + ".blender.sample.sample_scenes")
    return scene, ss, ss._collection(scene, "Traversable", "TRAVERSABLE")


def crossing(fp, cmu_b: bool = False):
    """An open floor where A (the sample character) walks east along y = 0 and B north
    along x = 0, both 5 m from the crossing: at about one pace they meet there. B is
    another sample character, or with ``cmu_b`` the CMU library's (real motion capture,
    imported from its BVH files). (scene, A, B)."""
    from conftest import cmu_armature

    scene, ss, floor = _floor(fp)
    ss._box(floor, "Floor", -8.0, 8.0, -8.0, 8.0, -0.2, 0.0)
    east, north = math.pi / 2, math.pi
    for name, at, heading in (("StartA", (-5.0, 0.0, 0.0), east), ("GoalA", (5.0, 0.0, 0.0), east),
                              ("StartB", (0.0, -5.0, 0.0), north), ("GoalB", (0.0, 5.0, 0.0), north)):
        ss._marker(scene, name, at, heading)
    man = import_module(fp.__name__ + ".blender.sample.mannequin")
    a, _ = man.add_to_scene(scene, "StartA")
    b = cmu_armature(fp) if cmu_b else man.add_to_scene(scene, "StartB")[0]
    return scene, a, b


def dead_end(fp):
    """A square 6 m across with a dead-end passage 0.9 m wide and 4 m long off its east
    side, between walls (no room for two bodies side by side in it): A (a sample
    character) starts near its mouth and stops in it, at (0.7, 0); B (another) starts across
    the square and goes to its far end, (3.4, 0). (scene, A, B)."""
    scene, ss, floor = _floor(fp)
    ss._box(floor, "Square", -6.0, 0.0, -3.0, 3.0, -0.2, 0.0)
    ss._box(floor, "Passage", 0.0, 4.0, -0.45, 0.45, -0.2, 0.0)
    walls = ss._collection(scene, "Walls", "OBSTACLE")
    ss._box(walls, "WallN", 0.0, 4.2, 0.45, 0.7, -0.2, 2.0)
    ss._box(walls, "WallS", 0.0, 4.2, -0.7, -0.45, -0.2, 2.0)
    ss._box(walls, "WallE", 4.0, 4.2, -0.45, 0.45, -0.2, 2.0)
    east = math.pi / 2
    for name, at in (("StartA", (-1.2, 1.0, 0.0)), ("GoalA", (0.7, 0.0, 0.0)),
                     ("StartB", (-5.0, -1.5, 0.0)), ("GoalB", (3.4, 0.0, 0.0))):
        ss._marker(scene, name, at, east)
    man = import_module(fp.__name__ + ".blender.sample.mannequin")
    return scene, man.add_to_scene(scene, "StartA")[0], man.add_to_scene(scene, "StartB")[0]


def played_bodies(fp, scene, obs, first: int, n: int) -> list:
    """The bodies (``crowd.body_of``) of the characters ``obs`` as Blender plays ``scene``
    over ``n`` frames from ``first`` (one pass of ``scene.frame_set``)."""
    bake = import_module(fp.__name__ + ".blender.write.bake")
    crowd = import_module(fp.__name__ + ".core.report.crowd")
    read = import_module(fp.__name__ + ".blender.read.scene")
    rigs = [read.rig_from_armature(o) for o in obs]
    played, _ = bake.played_matrices(scene, list(zip(obs, rigs)), first, n)
    return [crowd.body_of(o.name, r, bake.played_world(*m), FPS) for o, r, m in zip(obs, rigs, played)]
