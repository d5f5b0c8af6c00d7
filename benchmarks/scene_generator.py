"""Scenes nobody tuned the planner for, built by seeded code (issue 15).

A scene is pure numpy data (``Scene``): traversable plates (level quads, or ramps rising
along x or y), obstacle boxes, a start (position and the Start empty's Z rotation: 0
faces -Y, as in Blender) and a goal, and whether the goal is meant to be reachable.
``planner_inputs`` turns one into the planner's ground, obstacles, start footprints and
goal without a Blender scene (the ground queries on ``mathutils`` BVH trees, as a real
scene has them); ``cmu_character`` reads the CMU subject-16 library once (bpy imports
the BVH files) and gives its steps, forward and foot.

``benchmark_scenes()`` are the thirty scenes of ``bench_planner.py``: platforms with
bends and a gap that needs a run-up, corridors 1 to 3 m wide (starting inside, facing
along and across, and outside), stairs and ramps, islands (unreachable goals), pillars
and clutter, a bridge over a floor, paths of 10 to 40 m. ``held_out_scenes()`` are kinds
the planner was never tuned on (issue 28): stepping stones 0.5 m wide with gaps of 20 to
40 cm (straight, and round a bend), slabs with gaps between them, a gutter across a floor,
and real stairs (17 cm risers, 28 cm treads) with a landing and a 90-degree turn, up and
down.
"""

from __future__ import annotations

import functools
import os
import sys
from dataclasses import dataclass, field

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


@dataclass
class Scene:
    """A generated scene. ``plates`` rows: x0, x1, y0, y1, z0, z1, axis (0: the plate
    rises from z0 to z1 along x, 1: along y; level when z0 == z1). ``boxes`` rows: the
    obstacles' lo (3) and hi (3)."""

    name: str
    kind: str
    plates: list = field(default_factory=list)
    boxes: list = field(default_factory=list)
    start: tuple = (0.0, 0.0, 0.0)
    start_rotation: float = 0.0  # the Start empty's Z rotation (0 faces -Y)
    goal: tuple = (0.0, 0.0, 0.0)
    reachable: bool = True

    def plate(self, x0, x1, y0, y1, z0=0.0, z1=None, axis=0):
        self.plates.append((min(x0, x1), max(x0, x1), min(y0, y1), max(y0, y1), z0,
                            z0 if z1 is None else z1, axis))
        return self

    def box(self, lo, hi):
        self.boxes.append((*lo, *hi))
        return self


# --------------------------------------------------------------------- meshes

def plates_mesh(plates) -> tuple[np.ndarray, np.ndarray]:
    """(verts (4P, 3), tris (2P, 3)) of the plates' top quads."""
    p = np.asarray(plates, float).reshape(-1, 7)
    x0, x1, y0, y1, z0, z1, ax = p.T
    # corners (x0,y0) (x1,y0) (x1,y1) (x0,y1); along x: z0 at x0, z1 at x1; along y: at y0 / y1
    zc = np.stack([z0, np.where(ax == 0, z1, z0), z1, np.where(ax == 0, z0, z1)], axis=1)
    v = np.stack([np.c_[x0, y0], np.c_[x1, y0], np.c_[x1, y1], np.c_[x0, y1]], axis=1)
    verts = np.concatenate([v, zc[..., None]], axis=2).reshape(-1, 3)
    base = 4 * np.arange(len(p))[:, None]
    tris = np.concatenate([base + [0, 1, 2], base + [0, 2, 3]], axis=1).reshape(-1, 3)
    return verts, tris


def boxes_mesh(boxes) -> tuple[np.ndarray, np.ndarray]:
    """(verts (8B, 3), tris (12B, 3)) of closed axis-aligned boxes (rows lo, hi)."""
    b = np.asarray(boxes, float).reshape(-1, 6)
    bits = np.array([[x, y, z] for z in (0, 1) for y in (0, 1) for x in (0, 1)])
    verts = (b[:, None, :3] + bits[None] * (b[:, None, 3:] - b[:, None, :3])).reshape(-1, 3)
    quads = np.array([(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)])
    one = np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]])
    tris = (8 * np.arange(len(b))[:, None, None] + one[None]).reshape(-1, 3)
    return verts, tris


def _trimesh(verts, tris, name):
    from footstep_planner.core.plan.surface import TriMesh

    return TriMesh(verts, tris.astype(np.int64), np.zeros(len(tris), np.int64), (name,) if len(tris) else ())


# --------------------------------------------------------------------- the character

@dataclass
class Character:
    steps: object  # core.clips.steps.StepSet
    forward: np.ndarray
    foot: object  # core.plan.surface.FootShape


@functools.lru_cache(maxsize=None)
def cmu_character(package: str = "footstep_planner") -> Character:
    """The CMU subject-16 library (``benchmarks/library.py``), imported and analysed once
    in an empty Blender file: its steps, forward and foot shape. ``package`` is the
    add-on's module (the tests' enabled add-on is ``bl_ext.dev.footstep_planner``; the
    plain package is registered here)."""
    from importlib import import_module

    sys.path.insert(0, os.path.join(ROOT, "benchmarks"))
    from library import cmu_files

    return _analysed(package, lambda scene: import_module(package + ".blender.read.clips").import_clips(
        cmu_files(), name="CMU")[0])


@functools.lru_cache(maxsize=None)
def sample_character(package: str = "footstep_planner") -> Character:
    """The sample character (the mannequin and its generated clips), built, analysed and
    planned with as ``cmu_character`` does the CMU library, once per process."""
    from importlib import import_module

    return _analysed(package, lambda scene: import_module(package + ".blender.sample.mannequin").add_to_scene(scene)[0])


#: The add-on packages registered in this process (``_analysed``).
_REGISTERED: set = set()


def _analysed(package: str, make) -> Character:
    """The character ``make(scene)`` puts in an empty Blender file (30 fps), analysed with
    its mirrors and turned into the planner's steps, forward and foot shape."""
    from importlib import import_module

    import bpy

    from footstep_planner.core.base.settings import Settings
    from footstep_planner.core.clips.steps import library_steps
    from footstep_planner.core.plan.setup import foot_shape

    if package == "footstep_planner" and package not in _REGISTERED:
        from footstep_planner import register

        register()
        _REGISTERED.add(package)
    planning = import_module(package + ".blender.planning")
    character = import_module(package + ".blender.read.character")
    bpy.ops.wm.read_homefile(use_empty=True)
    bpy.context.scene.render.fps = 30
    ob = make(bpy.context.scene)
    settings = Settings()
    clips = character.analyze_character(ob, settings, mirrors=True)
    steps = library_steps(character.library_for(ob, clips), clips.analyses, bend_curvature=settings.bend_curvature,
                          stride=(settings.stride_min, settings.stride_max),
                          straighten=settings.straightens)
    return Character(steps, np.asarray(planning.world_forward(ob, clips.analyses)),
                     foot_shape(clips.analyses, clips.rig))


def planner_inputs(scene: Scene, forward) -> tuple:
    """(ground, obstacles, start footprints, goal (3,)) of a scene: BVH ground queries on
    its meshes, both feet standing 0.1 m either side of the start facing the way the Start
    empty faces (heading = rotation - pi/2 - the forward's yaw), dropped onto the ground."""
    from footstep_planner.blender.read.surfaces import BvhGround
    from footstep_planner.core.footprint import PathFootprint

    ground = BvhGround(_trimesh(*plates_mesh(scene.plates), "ground"))
    obstacles = BvhGround(_trimesh(*boxes_mesh(scene.boxes), "obstacles"))
    heading = scene.start_rotation - np.pi / 2 - float(np.arctan2(forward[1], forward[0]))
    ang = heading + np.arctan2(forward[1], forward[0])
    left = np.array([-np.sin(ang), np.cos(ang)])
    feet = np.asarray(scene.start, float)[:2] + np.array([[0.1], [-0.1]]) * left
    z = ground.ray_down(np.c_[feet, np.full(2, scene.start[2] + 0.5)], 3.0).z
    start = [PathFootprint(k, np.array([feet[k, 0], feet[k, 1], z[k]]), heading, 0.0, "start", "walk")
             for k in (0, 1)]
    return ground, obstacles, start, np.asarray(scene.goal, float)


def make_planner(scene: Scene, character: Character, settings=None):
    """(Planner, start footprints, goal) for a scene and a character."""
    from footstep_planner.core.plan.navgraph import Planner
    from footstep_planner.core.base.settings import Settings

    ground, obstacles, start, goal = planner_inputs(scene, character.forward)
    pl = Planner(ground, obstacles, character.steps, character.forward, foot=character.foot,
                 settings=settings or Settings())
    return pl, start, goal


def plan_scene(scene: Scene, character: Character, **settings):
    """(Planner, PlanResult) of a scene planned with a character and ``settings``
    (Settings fields); PlanError where it has no path."""
    from footstep_planner.core.base.settings import Settings

    pl, start, goal = make_planner(scene, character, Settings(**settings))
    return pl, pl.plan(start, goal)


# --------------------------------------------------------------------- scene kinds

def _facing(d) -> float:
    """The Start empty's Z rotation that faces direction ``d`` (x, y)."""
    return float(np.arctan2(d[0], -d[1]))


def zigzag(rng, name: str) -> Scene:
    """Platforms 1.2 to 2 m wide along a zig-zag of 3 to 5 segments with 90 degree bends;
    one long segment has a gap (0.6 to 1.0 m) with room for a run-up before it."""
    w = rng.uniform(1.2, 2.0)
    n = int(rng.integers(3, 6))
    gap_seg = int(rng.integers(1, n))
    sc, p, d = Scene(name, "zigzag"), np.zeros(2), np.array([1.0, 0.0])
    for k in range(n):
        length = rng.uniform(6.0, 8.0) if k == gap_seg else rng.uniform(3.0, 5.5)
        q = p + length * d
        lo, hi = np.minimum(p, q) - w / 2, np.maximum(p, q) + w / 2
        if k == gap_seg:
            g, at = rng.uniform(0.6, 1.0), rng.uniform(4.0, length - 1.5)
            a, b = p + at * d, p + (at + g) * d
            for u, v in ((p, a), (b, q)):
                ulo, uhi = np.minimum(u, v) - w / 2 * (1 - np.abs(d)), np.maximum(u, v) + w / 2 * (1 - np.abs(d))
                sc.plate(ulo[0], uhi[0], ulo[1], uhi[1])
            # the corners either end
            for c in (p, q):
                sc.plate(c[0] - w / 2, c[0] + w / 2, c[1] - w / 2, c[1] + w / 2)
        else:
            sc.plate(lo[0], hi[0], lo[1], hi[1])
        p = q
        d = np.array([-d[1], d[0]]) * (1 if (k % 2 == 0) else -1)
    sc.start, sc.start_rotation = (0.0, 0.0, 0.0), _facing((1, 0))
    sc.goal = (p[0], p[1], 0.0)
    return sc


def corridor(rng, name: str, width: float, facing: str, outside: bool = False) -> Scene:
    """A corridor ``width`` m wide between walls, 15 to 20 m long along x; the start
    inside it facing ``facing`` ("along" or "across"), or outside in a hall before it."""
    length = rng.uniform(15.0, 20.0)
    sc = Scene(name, "corridor")
    sc.plate(0.0, length, -width / 2 - 0.3, width / 2 + 0.3)
    for s in (-1, 1):
        sc.box((0.0, min(s * width / 2, s * (width / 2 + 0.2)), 0.0),
               (length, max(s * width / 2, s * (width / 2 + 0.2)), 2.5))
    if outside:
        sc.plate(-5.0, 0.0, -4.0, 4.0)
        sc.start, sc.start_rotation = (-3.5, rng.uniform(-2.5, 2.5), 0.0), _facing((0, 1))
    else:
        sc.start = (1.2, 0.0, 0.0)
        sc.start_rotation = _facing((1, 0)) if facing == "along" else _facing((0, -1))
    sc.goal = (length - 1.0, 0.0, 0.0)
    return sc


def stairs(rng, name: str, rise: float, tread: float, n: int) -> Scene:
    """A floor, ``n`` steps of ``rise`` up with treads ``tread`` m deep along x, a landing."""
    w = rng.uniform(1.5, 2.5)
    sc = Scene(name, "stairs")
    sc.plate(0.0, 6.0, -w / 2, w / 2)
    x = 6.0
    for k in range(1, n + 1):
        sc.plate(x, x + tread, -w / 2, w / 2, k * rise)
        x += tread
    sc.plate(x, x + 6.0, -w / 2, w / 2, n * rise)
    sc.start, sc.start_rotation = (1.0, 0.0, 0.0), _facing((1, 0))
    sc.goal = (x + 4.5, 0.0, n * rise)
    return sc


def ramps(rng, name: str) -> Scene:
    """A floor, a ramp up (8 to 18 degrees) to a platform, a ramp down, a floor; with a
    bend on the platform."""
    slope = np.radians(rng.uniform(8.0, 18.0))
    h = rng.uniform(0.8, 1.6)
    run = h / np.tan(slope)
    w = rng.uniform(1.5, 2.5)
    sc = Scene(name, "ramp")
    sc.plate(0.0, 5.0, -w / 2, w / 2)
    sc.plate(5.0, 5.0 + run, -w / 2, w / 2, 0.0, h, axis=0)
    x = 5.0 + run
    sc.plate(x, x + 4.0, -w / 2, 4.0 + w / 2, h)
    sc.plate(x + 4.0, x + 4.0 + run, 4.0 - w / 2, 4.0 + w / 2, h, 0.0, axis=0)
    sc.plate(x + 4.0 + run, x + 9.0 + run, 4.0 - w / 2, 4.0 + w / 2)
    sc.start, sc.start_rotation = (1.0, 0.0, 0.0), _facing((1, 0))
    sc.goal = (x + 7.5 + run, 4.0, 0.0)
    return sc


def island(rng, name: str, gap: float) -> Scene:
    """A floor and an island ``gap`` m beyond its edge with the goal on it (a jump's reach
    is about 1.5 m: wider gaps are unreachable)."""
    size = rng.uniform(8.0, 14.0)
    sc = Scene(name, "island", reachable=gap < 1.1)
    sc.plate(0.0, size, 0.0, size)
    sc.plate(size + gap, size + gap + 4.0, size / 2 - 2.0, size / 2 + 2.0)
    sc.start, sc.start_rotation = (1.5, rng.uniform(1.5, size - 1.5), 0.0), _facing((1, 0))
    sc.goal = (size + gap + 2.0, size / 2, 0.0)
    return sc


def clutter(rng, name: str, size: float, pillars: int, crates: int) -> Scene:
    """An open floor ``size`` m square with ``pillars`` pillars and ``crates`` low boxes
    scattered, corner to corner (the corners kept clear)."""
    sc = Scene(name, "clutter")
    sc.plate(0.0, size, 0.0, size)
    a, b = np.array([1.5, 1.5]), np.array([size - 1.5, size - 1.5])
    xy = rng.uniform(1.0, size - 1.0, (4 * (pillars + crates), 2))
    xy = xy[(np.linalg.norm(xy - a, axis=1) > 2.5) & (np.linalg.norm(xy - b, axis=1) > 2.5)]
    for k, (x, y) in enumerate(xy[:pillars + crates]):
        r = rng.uniform(0.2, 0.35) if k < pillars else rng.uniform(0.3, 0.8)
        top = 2.5 if k < pillars else rng.uniform(0.4, 0.9)
        sc.box((x - r, y - r, 0.0), (x + r, y + r, top))
    sc.start, sc.start_rotation = (*a, 0.0), _facing((0, 1))
    sc.goal = (*b, 0.0)
    return sc


def bridge(rng, name: str, goal_on: str) -> Scene:
    """A floor with a bridge 1.5 m over it, reached by a ramp round the side: start on the
    floor and the goal beyond the bridge's far end ("top"), or the reverse ("floor")."""
    h = rng.uniform(1.3, 1.7)
    sc = Scene(name, "bridge")
    sc.plate(-2.0, 16.0, 0.0, 12.0)  # the floor
    sc.plate(-2.0, 0.0, 12.0, 14.5)  # to the ramp's foot
    sc.plate(0.0, 10.0, 13.0, 14.5, 0.0, h, axis=0)  # the ramp
    sc.plate(10.0, 12.0, 6.0, 14.5, h)  # the landing, partly over the floor
    sc.plate(10.0, 11.5, -6.0, 6.0, h)  # the bridge, over the floor and beyond it
    top, floor = (10.75, -5.0, h), (rng.uniform(3.0, 6.0), rng.uniform(2.0, 4.0), 0.0)
    if goal_on == "top":
        sc.start, sc.goal, sc.start_rotation = floor, top, _facing((1, 0))
    else:
        sc.start, sc.goal, sc.start_rotation = top, floor, _facing((0, 1))
    return sc


def rooms(rng, name: str, nx: int, ny: int) -> Scene:
    """A floor of ``nx`` x ``ny`` rooms (5 to 8 m) with walls between them, each wall with a
    doorway 1.0 to 1.4 m wide at a random place; corner room to corner room."""
    wx, wy = rng.uniform(5.0, 8.0), rng.uniform(5.0, 8.0)
    sc = Scene(name, "rooms")
    sc.plate(0.0, nx * wx, 0.0, ny * wy)
    for i in range(1, nx):  # walls along y at x = i wx, with a door each row
        for j in range(ny):
            d, at = rng.uniform(1.0, 1.4), rng.uniform(j * wy + 1.0, (j + 1) * wy - 2.4)
            sc.box((i * wx - 0.1, j * wy, 0.0), (i * wx + 0.1, at, 2.5))
            sc.box((i * wx - 0.1, at + d, 0.0), (i * wx + 0.1, (j + 1) * wy, 2.5))
    for j in range(1, ny):
        for i in range(nx):
            if rng.random() < 0.5 and i != nx - 1:
                sc.box((i * wx, j * wy - 0.1, 0.0), ((i + 1) * wx, j * wy + 0.1, 2.5))  # no door
                continue
            d, at = rng.uniform(1.0, 1.4), rng.uniform(i * wx + 1.0, (i + 1) * wx - 2.4)
            sc.box((i * wx, j * wy - 0.1, 0.0), (at, j * wy + 0.1, 2.5))
            sc.box((at + d, j * wy - 0.1, 0.0), ((i + 1) * wx, j * wy + 0.1, 2.5))
    sc.start, sc.start_rotation = (1.5, 1.5, 0.0), _facing((0, 1))
    sc.goal = (nx * wx - 1.5, ny * wy - 1.5, 0.0)
    return sc


def stones(rng, name: str, n: int, turn_after: int = 0, gaps: tuple = (0.2, 0.4)) -> Scene:
    """A floor, ``n`` stepping stones 0.5 m square with gaps of ``gaps`` m (20 to 40 cm)
    between them (no ground below: water) along x, turning 90 degrees left (on along y)
    after the ``turn_after``-th stone when given, and a floor beyond; start on the near
    floor facing the stones."""
    sc = Scene(name, "stones")
    sc.plate(-4.0, 0.0, -1.0, 1.0)
    edge, d = np.array([0.0, 0.0]), np.array([1.0, 0.0])  # the last stone's far edge's middle
    for k in range(n):
        c = edge + (rng.uniform(*gaps) + 0.25) * d  # the stone's centre
        sc.plate(c[0] - 0.25, c[0] + 0.25, c[1] - 0.25, c[1] + 0.25)
        if turn_after and k + 1 == turn_after:
            d = np.array([0.0, 1.0])
        edge = c + 0.25 * d
    q = edge + rng.uniform(*gaps) * d  # the far floor's near edge
    far = q + 4.0 * d
    across = np.array([d[1], d[0]])
    lo, hi = np.minimum(q, far) - across, np.maximum(q, far) + across
    sc.plate(lo[0], hi[0], lo[1], hi[1])
    sc.start, sc.start_rotation = (-2.5, 0.0, 0.0), _facing((1, 0))
    g = q + 2.5 * d
    sc.goal = (g[0], g[1], 0.0)
    return sc


def slabs(rng, name: str, n: int) -> Scene:
    """``n`` slabs 1.2 to 2 m long and 1.5 m wide in a row, with gaps of 20 to 35 cm between
    them (no ground below)."""
    sc = Scene(name, "slabs")
    x = 0.0
    for k in range(n):
        length = rng.uniform(1.2, 2.0) if 0 < k < n - 1 else 3.0
        sc.plate(x, x + length, -0.75, 0.75)
        x += length + (rng.uniform(0.2, 0.35) if k < n - 1 else 0.0)
    sc.start, sc.start_rotation = (1.0, 0.0, 0.0), _facing((1, 0))
    sc.goal = (x - 1.0, 0.0, 0.0)
    return sc


def gutter(rng, name: str, width: float) -> Scene:
    """A floor with a gutter ``width`` m wide and 0.5 m deep across the way, and a corner to
    turn after it."""
    sc = Scene(name, "gutter")
    at = rng.uniform(4.0, 6.0)
    sc.plate(0.0, at, -1.5, 1.5)
    sc.plate(at, at + width, -1.5, 1.5, -0.5)  # its bottom
    sc.plate(at + width, at + width + 4.0, -1.5, 6.0)
    sc.start, sc.start_rotation = (1.0, 0.0, 0.0), _facing((1, 0))
    sc.goal = (at + width + 2.0, 4.5, 0.0)
    return sc


#: m: real stairs' riser and tread (``stairs_turn``).
RISER, TREAD = 0.17, 0.28


def stairs_turn(rng, name: str, n: int, down: bool = False) -> Scene:
    """Real stairs: a floor, a flight of ``n`` risers of 17 cm with 28 cm treads up along x
    to a landing (its top the n-th riser's) as deep as the stairs are wide, a 90-degree
    turn left, a second flight of ``n`` risers up along y and a floor at the top; start at
    the foot and the goal at the top, or (``down``) the reverse."""
    w = rng.uniform(1.1, 1.5)
    sc = Scene(name, "stairs")
    sc.plate(-4.0, 0.0, -w / 2, w / 2)
    for k in range(1, n):
        sc.plate((k - 1) * TREAD, k * TREAD, -w / 2, w / 2, k * RISER)
    xl = (n - 1) * TREAD
    sc.plate(xl, xl + w, -w / 2, w / 2, n * RISER)  # the landing
    for k in range(1, n):
        y = w / 2 + (k - 1) * TREAD
        sc.plate(xl, xl + w, y, y + TREAD, (n + k) * RISER)
    yt = w / 2 + (n - 1) * TREAD
    sc.plate(xl, xl + w, yt, yt + 4.0, 2 * n * RISER)
    foot, top = (-3.0, 0.0, 0.0), (xl + w / 2, yt + 2.5, 2 * n * RISER)
    if down:
        sc.start, sc.start_rotation, sc.goal = top, _facing((0, -1)), foot
    else:
        sc.start, sc.start_rotation, sc.goal = foot, _facing((1, 0)), top
    return sc


def held_out_scenes(seed: int = 28) -> list[Scene]:
    """Scenes of kinds the planner was never tuned on (issue 28), the same for the same seed."""
    rng = np.random.default_rng(seed)
    return [stones(rng, "stones_straight", 8), stones(rng, "stones_bend", 9, turn_after=5),
            slabs(rng, "slabs", 5), gutter(rng, "gutter", 0.3),
            stairs_turn(rng, "stairs_turn_up", 6), stairs_turn(rng, "stairs_turn_down", 6, down=True)]


def benchmark_scenes(seed: int = 15) -> list[Scene]:
    """The thirty scenes of the planner benchmark, the same for the same seed."""
    rng = np.random.default_rng(seed)
    out = [zigzag(rng, f"zigzag{k}") for k in range(1, 6)]
    out += [corridor(rng, "corridor2_along", 2.0, "along"), corridor(rng, "corridor2_across", 2.0, "across"),
            corridor(rng, "corridor1.2_along", 1.2, "along"), corridor(rng, "corridor3_across", 3.0, "across"),
            corridor(rng, "corridor1_outside", 1.0, "along", outside=True),
            corridor(rng, "corridor1.2_across", 1.2, "across")]
    out[-1].reachable = False  # the wall 0.6 m ahead: no step of the CMU library fits before it
    out += [stairs(rng, "steps3_12cm", 0.12, 0.3, 3), stairs(rng, "stairs_wide", 0.15, 0.6, 5),
            ramps(rng, "ramp1"), ramps(rng, "ramp2")]
    out += [island(rng, "island_far", 3.0), island(rng, "island_wide", 2.2), island(rng, "island_jump", 0.8)]
    out += [clutter(rng, "pillars12", 12.0, 6, 0), clutter(rng, "pillars20", 20.0, 16, 0),
            clutter(rng, "clutter15", 15.0, 4, 12), clutter(rng, "clutter25", 25.0, 10, 20),
            clutter(rng, "clutter10", 10.0, 3, 8)]
    out += [bridge(rng, "bridge_up", "top"), bridge(rng, "bridge_down", "floor"), bridge(rng, "bridge_up2", "top")]
    out += [rooms(rng, "rooms2x1", 2, 1), rooms(rng, "rooms2x2", 2, 2), rooms(rng, "rooms3x2", 3, 2),
            rooms(rng, "rooms3x3", 3, 3)]
    return out
