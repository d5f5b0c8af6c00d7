"""The sample scenes, built by code so anyone can regenerate them.

- ``jumps`` (thesis figure 4.1): a platform with a bend, a run-up, a 1 m gap to a second
  platform, a sharp bend, a second 1 m gap, and a stop.
- ``turns`` (thesis figure 4.2): a path of bends ending on a curved platform.
- ``obstacles``: an open floor with walls and pillars, a doorway, a narrow corridor with a
  90-degree corner, a 15 cm step up and a 15-degree ramp.
- ``stairs``: real stairs (17 cm risers, 28 cm treads, 1.4 m wide): a flight of five up
  to a landing, a turn left, a flight of five down to a floor, walled all round.

Each scene has a collection "Traversable" and (where it has any) "Obstacles", tagged so
their objects inherit the tag, and two empties: "Start" and "Goal" (their Z rotation is
the heading to start and arrive with; 0 faces -Y). Walkable tops are at z = 0 unless said.
"""

from __future__ import annotations

import math

import bpy
import numpy as np

SCENES = ("jumps", "turns", "obstacles", "stairs")
#: m: the Stairs scene's riser height, tread depth and number of risers per flight.
RISER, TREAD, FLIGHT = 0.17, 0.28, 5
#: Gap widths of the Jumps scene, m.
JUMP_GAP = 1.0


def _collection(scene, name, tag):
    coll = bpy.data.collections.new(name)
    scene.collection.children.link(coll)
    coll.footstep.surface = tag
    return coll


def _mesh(coll, name, verts, faces):
    me = bpy.data.meshes.new(name)
    me.from_pydata([tuple(map(float, v)) for v in verts], [], [tuple(f) for f in faces])
    me.validate()
    ob = bpy.data.objects.new(name, me)
    coll.objects.link(ob)
    return ob


def _prism(coll, name, outline, top, bottom):
    """A solid whose outline (K, 2), counter-clockwise, is extruded from bottom to top;
    ``top`` may be a number or a function of (x, y) for ramps."""
    outline = np.asarray(outline, dtype=float)
    k = len(outline)
    ztop = [top(x, y) if callable(top) else top for x, y in outline]
    verts = [(x, y, z) for (x, y), z in zip(outline, ztop)] + [(x, y, bottom) for x, y in outline]
    faces = [tuple(range(k)), tuple(range(2 * k - 1, k - 1, -1))]
    faces += [(i, (i + 1) % k + 0, (i + 1) % k + k, i + k)[::-1] for i in range(k)]
    return _mesh(coll, name, verts, faces)


def _rect(x0, x1, y0, y1):
    return [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]


def _ribbon(pts: np.ndarray, half_width: float) -> list:
    """Counter-clockwise outline of a path of the given half width along a polyline,
    with mitred bends."""
    d = np.diff(pts, axis=0)
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    n = np.c_[-d[:, 1], d[:, 0]]  # left normals of the segments
    left, right = [], []
    for i, p in enumerate(pts):
        if i == 0 or i == len(pts) - 1:
            m = n[min(i, len(n) - 1)] * half_width
        else:
            bis = n[i - 1] + n[i]
            bis /= np.linalg.norm(bis)
            m = bis * half_width / max(float(bis @ n[i]), 0.3)
        left.append(p + m)
        right.append(p - m)
    return right + left[::-1]


def _box(coll, name, x0, x1, y0, y1, z0, z1):
    return _prism(coll, name, _rect(x0, x1, y0, y1), z1, z0)


def _marker(scene, name, xyz, heading):
    ob = bpy.data.objects.new(name, None)
    ob.empty_display_type = "SINGLE_ARROW" if name == "Goal" else "PLAIN_AXES"
    ob.empty_display_size = 0.5
    ob.location = xyz
    ob.rotation_euler = (0.0, 0.0, heading)
    scene.collection.objects.link(ob)
    return ob


# heading of a character facing +X, +Y, -X (0 faces -Y, positive turns left)
EAST, NORTH, WEST = math.pi / 2, math.pi, -math.pi / 2


def build_jumps(scene):
    t = _collection(scene, "Traversable", "TRAVERSABLE")
    g = JUMP_GAP
    # walk east along a platform, bend left, run up north, gap, ...
    _prism(t, "Platform1", [(0, -1), (9, -1), (9, 8), (7, 8), (7, 1), (0, 1)], 0.0, -0.3)
    # ... land, sharp bend right, run east, second gap, stop
    _prism(t, "Platform2", [(7, 8 + g), (9, 8 + g), (9, 11), (15, 11), (15, 13), (7, 13)], 0.0, -0.3)
    _box(t, "Platform3", 15 + g, 21, 11, 13, -0.3, 0.0)
    _marker(scene, "Start", (1.0, 0.0, 0.0), EAST)
    _marker(scene, "Goal", (19.5, 12.0, 0.0), EAST)


def build_turns(scene):
    t = _collection(scene, "Traversable", "TRAVERSABLE")
    w = 1.0  # half width of the path
    pts = np.array([(0, 0), (6, 0), (9, 4), (7, 9), (12, 12), (15.5, 10), (17, 10)], dtype=float)
    _prism(t, "Path", _ribbon(pts, w), 0.0, -0.3)
    # the curved platform: a ring of radius 4 m around (17, 14), 2 m wide, turning left
    # through 150 degrees
    c = np.array([17.0, 14.0])
    ang = np.linspace(-math.pi / 2, math.radians(60), 26)
    outer = [c + 5.0 * np.array([math.cos(a), math.sin(a)]) for a in ang]
    inner = [c + 3.0 * np.array([math.cos(a), math.sin(a)]) for a in ang[::-1]]
    _prism(t, "CurvedPlatform", outer + inner, 0.0, -0.3)
    _marker(scene, "Start", (0.5, 0.0, 0.0), EAST)
    # the goal: on the ring at 30 degrees, facing along it (travel direction 120 degrees)
    a = math.radians(30)
    _marker(scene, "Goal", (c[0] + 4 * math.cos(a), c[1] + 4 * math.sin(a), 0.0),
            math.radians(120) - math.atan2(-1.0, 0.0))


def build_obstacles(scene):
    t = _collection(scene, "Traversable", "TRAVERSABLE")
    o = _collection(scene, "Obstacles", "OBSTACLE")
    _box(t, "Floor", -10, 10, -10, 10, -0.3, 0.0)
    # walls and pillars in the open
    _box(o, "Wall1", -6, -2, 2, 2.3, 0, 2.5)
    for i, (x, y) in enumerate([(3, 3), (5, -2), (-4, -5), (0, -3)]):
        _prism(o, f"Pillar{i + 1}", [(x + 0.3 * math.cos(a), y + 0.3 * math.sin(a))
                                     for a in np.linspace(0, 2 * math.pi, 12, endpoint=False)], 2.5, 0.0)
    # a wall across x = 6 with a 1 m doorway at y in [4, 5]
    _box(o, "DoorWallA", 6, 6.3, -10, 4, 0, 2.5)
    _box(o, "DoorWallB", 6, 6.3, 5, 10, 0, 2.5)
    # a narrow corridor (1.2 m wide) with a 90-degree corner, north-west
    _box(o, "CorridorOuterA", -9.5, -9.2, 3, 9.5, 0, 2.5)
    _box(o, "CorridorOuterB", -9.5, -3, 9.2, 9.5, 0, 2.5)
    _box(o, "CorridorInnerA", -8.0, -7.7, 3, 7.7, 0, 2.5)
    _box(o, "CorridorInnerB", -8.0, -3, 7.7, 8.0, 0, 2.5)
    # a 15 cm step up, and a 15-degree ramp rising 0.8 m to a landing (beyond the door)
    _box(t, "Step", 7, 10, 2, 7, 0.0, 0.15)
    rise = 0.8
    run = rise / math.tan(math.radians(15))
    _prism(t, "Ramp", _rect(0, run, -9, -7), lambda x, y: x * math.tan(math.radians(15)), 0.0)
    _box(t, "Landing", run, run + 2.0, -9, -7, 0.0, rise)
    _marker(scene, "Start", (-5.0, -8.0, 0.0), NORTH)
    _marker(scene, "Goal", (8.5, 4.5, 0.15), EAST)


def build_stairs(scene):
    t = _collection(scene, "Traversable", "TRAVERSABLE")
    o = _collection(scene, "Obstacles", "OBSTACLE")
    top = RISER * FLIGHT
    x0 = 3.0  # the first riser
    _box(t, "FloorLow", -1, x0, -0.7, 0.7, -0.3, 0.0)
    for i in range(FLIGHT - 1):  # treads 1..4 of the flight up (the fifth step is the landing)
        _box(t, f"StepUp{i + 1}", x0 + i * TREAD, x0 + (i + 1) * TREAD, -0.7, 0.7, -0.3, (i + 1) * RISER)
    xl = x0 + (FLIGHT - 1) * TREAD  # the landing, 1.4 m square, then the way turns left (north)
    _box(t, "Landing", xl, xl + 1.4, -0.7, 0.7, -0.3, top)
    y0 = 0.7  # the flight down, north
    for i in range(FLIGHT - 1):
        _box(t, f"StepDown{i + 1}", xl, xl + 1.4, y0 + i * TREAD, y0 + (i + 1) * TREAD, -0.3, top - (i + 1) * RISER)
    yf = y0 + (FLIGHT - 1) * TREAD
    _box(t, "FloorHigh", xl - 0.5, xl + 1.9, yf, yf + 4.0, -0.3, 0.0)
    # walls all round the stairwell: the way from the low floor to the high one is the stairs
    _box(o, "WallSouth", -1, xl + 1.7, -1.0, -0.7, 0.0, 2.5)
    _box(o, "WallEast", xl + 1.4, xl + 1.7, -0.7, yf, 0.0, 2.5)
    _box(o, "WallNorth", -1, xl, 0.7, 1.0, 0.0, 2.5)
    _box(o, "WallWest", xl - 0.3, xl, 1.0, yf, 0.0, 2.5)
    _marker(scene, "Start", (0.0, 0.0, 0.0), EAST)
    _marker(scene, "Goal", (xl + 0.7, yf + 2.5, 0.0), NORTH)


BUILDERS = {"jumps": build_jumps, "turns": build_turns, "obstacles": build_obstacles, "stairs": build_stairs}


def build(name: str, scene=None):
    """Build sample scene ``name`` into ``scene`` (default: a new empty scene file)."""
    if name not in BUILDERS:
        raise ValueError(f"no sample scene {name!r}; choose from {', '.join(SCENES)}")
    if scene is None:
        bpy.ops.wm.read_homefile(use_empty=True)
        scene = bpy.context.scene
        scene.name = name.capitalize()
    BUILDERS[name](scene)
    return scene
