"""Corners slow a run (issue 30), measured on the scene as Blender plays it: a character
running free (``run_penalty`` 0) along a corridor 0.8 m wide that turns 90 degrees round a
1 m radius slows through the turn to at most the speed of its library's tightest run turn,
or, where no run clip turns that tightly (the sample character's runs turn at 4 m radius),
to a walk's turn, and runs again after it. With the sample character and CMU subject 16."""

import math
from importlib import import_module

import numpy as np
import pytest
from scipy.ndimage import uniform_filter1d

from conftest import cmu_armature, needs_cmu
from test_standing import FPS, _played

from footstep_planner.core.base.settings import Settings

#: m: the corner's radius (of the corridor's centre line) and the corridor's half width.
RADIUS, HALF_WIDTH = 1.0, 0.4
#: m: the straight before the corner and after it.
STRAIGHT = 8.0
#: The speeds measured are allowed this much over the clips' (a blend's, a frame's).
SLACK = 1.1


def _corner_scene():
    """An L-shaped corridor floor along +X, round the corner and on along +Y; the Start
    at its beginning facing +X, the Goal a metre short of its end."""
    import bpy

    from footstep_planner.blender.sample import sample_scenes as ss

    bpy.ops.wm.read_homefile(use_empty=True)
    scene = bpy.context.scene
    scene.render.fps = FPS
    t = ss._collection(scene, "Traversable", "TRAVERSABLE")
    a = np.linspace(0.0, math.pi / 2, 12)
    arc = np.c_[STRAIGHT + RADIUS * np.sin(a), RADIUS - RADIUS * np.cos(a)]
    line = np.r_[[[0.0, 0.0]], arc, [[STRAIGHT + RADIUS, RADIUS + STRAIGHT]]]
    ss._prism(t, "Corridor", np.array(ss._ribbon(line, HALF_WIDTH)), 0.0, -0.2)
    ss._marker(scene, "Start", (0.5, 0.0, 0.0), ss.EAST)
    ss._marker(scene, "Goal", (STRAIGHT + RADIUS, RADIUS + STRAIGHT - 1.0, 0.0), ss.NORTH)
    return scene


def _character(fp, scene, who):
    if who == "sample":
        return import_module(fp.__name__ + ".blender.sample.mannequin").add_to_scene(scene, "Start")[0]
    return cmu_armature(fp)


@pytest.mark.parametrize("who", ["sample", pytest.param("cmu", marks=needs_cmu)])
def test_a_run_slows_through_a_tight_corner_and_speeds_up_after_it(fp, who):
    scene = _corner_scene()
    ob = _character(fp, scene, who)
    planning = import_module(fp.__name__ + ".blender.planning")
    goal, heading = planning.goal_of(scene, "Goal")
    doc = planning.run(scene, ob, goal, heading, scene.objects["Start"], settings=Settings(run_penalty=0.0),
                       name="corner", frame_start=1)
    q = doc["quality"]
    assert q["goal"]["distance_m"] < 0.06 and q["foot_skate"]["max_mm"] < 1.0
    gaits = [f["gait"] for f in doc["footprints"]]
    xy = np.array([f["position"][:2] for f in doc["footprints"]])
    assert "run" in [g for g, p in zip(gaits, xy) if p[1] < 0.5 * HALF_WIDTH and p[0] < STRAIGHT - 1.0]
    assert "run" in [g for g, p in zip(gaits, xy) if p[1] > RADIUS + 2.0]

    _, _, body, _ = _played(fp, scene, ob, doc)
    smooth = uniform_filter1d(body[:, :2], int(0.5 * FPS), axis=0, mode="nearest")
    v = np.gradient(smooth, axis=0) * FPS
    speed = np.linalg.norm(v, axis=1)
    way = np.degrees(np.arctan2(v[:, 1], v[:, 0]))
    turning = (way > 25.0) & (way < 65.0) & (speed > 0.3)
    assert turning.sum() >= 5  # (it turns the corner)
    before = (smooth[:, 0] > 2.0) & (smooth[:, 0] < STRAIGHT - 2.0) & (smooth[:, 1] < HALF_WIDTH)
    after = (smooth[:, 1] > RADIUS + 2.0) & (smooth[:, 1] < RADIUS + STRAIGHT - 3.0)
    corner = float(speed[turning].max())

    library = planning.plan_setup(scene, ob).library
    walk, run = library.turn_groups["walk"], library.turn_groups["run"]
    tightest = max(run.clips, key=lambda c: c.tau)  # (the corner turns left)
    if tightest.tau >= 0.75 / RADIUS:  # (the library runs round such a corner: CMU's turn90 jog)
        bound = tightest.speed
    else:  # (its runs turn wider: a walk's turn)
        bound = max(c.speed for c in walk.clips)
    assert corner <= SLACK * bound, (corner, bound, tightest)
    assert speed[before].max() > corner + 0.3 and speed[after].max() > corner + 0.3, \
        (speed[before].max(), corner, speed[after].max())
