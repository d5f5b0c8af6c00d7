"""Pace through speed and stride (issue 30): an arrival frame between the fastest walk and
the slowest run is met by a jog, the walk and the run blended, its footprints laid again
at the stride the clips take at that speed. With the sample character on the Obstacles
sample scene and with CMU subject 16 (real capture) on Turns and Obstacles (on Turns the
sample character's run turns too wide for its bends: it walks them, and such a frame is
met running, as docs/limits.md says), and with the CC0 game character of ../shared/clips as
downloaded (one-cycle in-place walk and run at 24 fps) on Obstacles, a waypoint B two
thirds along the way
is asked for on the frame a speed 30 % of the way from the walk at its fastest pace to
the run at its slowest would reach it. The bake is saved, opened again and played
(``scene.frame_set``): B is reached within one frame of it, nobody waited or ran, each
step's stride is within the library's, and within 15 % of the library's stride at that
step's speed (between the walk's and the run's speeds: the two blended as a straight way
plays them)."""

from importlib import import_module

import numpy as np
import pytest

from conftest import needs_cmu, needs_quaternius, scene_with_cmu
from test_feet_out_of_the_floor import _quaternius
from test_stride_speed import _library_strides

#: where between the walk's fastest speed and the run's slowest the frame asked for lies
SHARE = 0.3


def _scene(fp, who, name):
    """(scene, character) on the sample scene ``name`` at 30 fps, with a waypoint B two
    thirds along the direct path."""
    import bpy

    if who == "sample":
        bpy.ops.wm.read_homefile(use_empty=True)
        scene = import_module(fp.__name__ + ".blender.sample.sample_scenes").build(name)
        scene.render.fps, scene.render.fps_base = 30, 1.0
        ob, _ = import_module(fp.__name__ + ".blender.sample.mannequin").add_to_scene(scene, "Start")
    elif who == "quaternius":  # (the CC0 game character as downloaded: one-cycle in-place walk and run, 24 fps)
        bpy.ops.wm.read_homefile(use_empty=True)
        scene = import_module(fp.__name__ + ".blender.sample.sample_scenes").build(name)
        scene.render.fps, scene.render.fps_base = 30, 1.0
        ob = _quaternius(fp, scene)
        start = scene.objects["Start"]
        ob.location, ob.rotation_euler.z = start.location, start.rotation_euler.z
    else:
        scene, ob = scene_with_cmu(fp, name)
    planning = import_module(fp.__name__ + ".blender.planning")
    goal, heading = planning.goal_of(scene, "Goal")
    fps = planning.plan(scene, ob, goal, heading, scene.objects["Start"])[0].footprints
    b = bpy.data.objects.new("B", None)
    b.location = fps[2 * len(fps) // 3].position
    scene.collection.objects.link(b)
    bpy.context.view_layer.update()
    return scene, ob


def _played(path, name: str, first: int, last: int) -> np.ndarray:
    """The character's positions (F, 3) as Blender plays the saved file ``path``."""
    import bpy

    bpy.ops.wm.open_mainfile(filepath=str(path))
    scene, ob = bpy.context.scene, bpy.data.objects[name]
    out = []
    for f in range(first, last + 1):
        scene.frame_set(f)
        out.append(np.array(ob.evaluated_get(bpy.context.evaluated_depsgraph_get()).matrix_world.translation))
    return np.array(out)


@pytest.mark.parametrize("who, name", [("sample", "obstacles"), pytest.param("cmu", "turns", marks=needs_cmu),
                                       pytest.param("cmu", "obstacles", marks=needs_cmu),
                                       pytest.param("quaternius", "obstacles", marks=needs_quaternius)])
def test_a_frame_between_the_walk_and_the_run_is_met_jogging(fp, empty_scene, tmp_path, who, name):
    import bpy

    planning = import_module(fp.__name__ + ".blender.planning")
    directing = import_module(fp.__name__ + ".blender.ui.directing")
    directed = import_module(fp.__name__ + ".core.perform.directed")
    settings = import_module(fp.__name__ + ".core.base.settings").Settings()
    scene, ob = _scene(fp, who, name)
    goal, heading = planning.goal_of(scene, "Goal")
    start = scene.objects["Start"]
    free = planning.run(scene, ob, goal, heading, start, name="b", frame_start=1,
                        route=directing.via_route(scene, ["B"], "Goal", goal, heading))
    setup = planning.plan(scene, ob, goal, heading, start)[1]
    lib = _blended_strides(setup.planner.steps, setup.library)  # (speed, step length) per clip, by speed, and between
    walk = [v for v, g in _clip_speeds(setup.planner.steps) if g == "walk"]
    run = [v for v, g in _clip_speeds(setup.planner.steps) if g == "run"]
    fastest_walk = settings.pace_max * max(walk)
    slowest_run = settings.pace_min * min(run)
    assert fastest_walk < slowest_run
    v = fastest_walk + SHARE * (slowest_run - fastest_walk)
    t_free = free["waypoints"][0]["achieved"] - 1
    own = float(np.median(walk))  # (the free walk goes at about its clips' own speed)
    target = int(round(1 + t_free * own / v))
    assert target < 1 + t_free / settings.pace_max  # (sooner than the fastest walk...)

    doc = planning.run(scene, ob, goal, heading, start, name="b", frame_start=1,
                       route=directing.via_route(scene, ["B"], "Goal", goal, heading, None, {"B": target}))
    row = doc["waypoints"][0]
    assert row["met_by"] == "jog" and 0.0 < row["blend"] < 1.0 and row["waited"] == 0.0, row
    assert not any(f["gait"] == "run" for f in doc["footprints"])  # (... and not run)
    name = ob.name
    path = tmp_path / "jog.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    body = _played(path, name, doc["frame_start"], doc["frame_end"])
    b = np.array(bpy.data.objects["B"].location)
    marks = [directed.Mark("B", 0, b), directed.Mark("Goal", 0, np.asarray(goal, float), stop=True)]
    k = int(np.argmin(np.linalg.norm(body[:, :2] - b[:2], axis=1)))  # (the body passes B about here, once:
    windows = [(max(k - 15, 0), min(k + 15, len(body) - 1)), (0, len(body) - 1)]  # the way turns back further on)
    got = doc["frame_start"] + directed.arrival_frames(body, marks, windows)[0]
    assert abs(got - target) <= 1.0, (got, target)

    # each step to B: within the library's strides, and as long as its clips step at its speed
    fps = np.array([f["position"] for f in doc["footprints"]])
    stance = np.array([np.mean(f["planted_frames"]) for f in doc["footprints"]]) / bpy.context.scene.render.fps
    last = int(np.argmin(np.linalg.norm(fps[:, :2] - b[:2], axis=1)))  # (the footprint reaching B)
    length = np.linalg.norm(np.diff(fps[:last + 1, :2], axis=0), axis=1)
    speed = length / np.maximum(np.diff(stance[:last + 1]), 1e-6)
    jogged = np.array(["blend" in f for f in doc["footprints"][1:last + 1]])  # (the steps the jog laid)
    assert jogged.sum() >= 0.6 * len(length)
    # (within the library's speeds, and not the first two steps from standing: the start's, gathering speed)
    jogged &= (speed >= 0.95 * lib[0, 0]) & (speed <= 1.05 * lib[-1, 0]) & (np.arange(len(length)) >= 3)
    assert jogged.sum() >= 0.5 * len(length)
    assert length[jogged].min() >= 0.85 * lib[:, 1].min() and length[jogged].max() <= 1.15 * lib[:, 1].max()
    off = np.abs(length / np.interp(speed, lib[:, 0], lib[:, 1]) - 1.0)[jogged]
    assert np.mean(off <= 0.15) >= 0.9 and off.max() <= 0.35, np.round(np.sort(off)[-5:], 2)
    q = doc["quality"]
    assert q["foot_skate"]["max_mm"] < 5 and q["goal"]["distance_m"] < 0.05
    assert q["pops"]["introduced"]["count"] <= max(5, free["quality"]["pops"]["introduced"]["count"])


def _blended_strides(steps, library) -> np.ndarray:
    """(K, 2) the library's stride against speed: per clip at its own stride
    (``_library_strides``) outside the speeds between its walk and its run, and there
    the walk and the run blended as a straight way plays them (the turning groups'
    clips of least curvature, each blend taking its share of both the step's length and
    its duration: the blend groups weigh the clips' durations so), at nineteen blends."""
    rows = _library_strides(steps)
    ends = []
    cyc = ~steps.jump & (steps.stride == 1.0)
    for gait in ("walk", "run"):  # (a clip's or a blend's label: the one of the gait that turns least)
        labels = [lab for lab in set(steps.label[cyc & (steps.gait == gait)].tolist())
                  if library.label_tau(lab) is not None]
        m = cyc & (steps.label == min(labels, key=lambda lab: abs(library.label_tau(lab))))
        ends.append((np.hypot(steps.fwd[m], steps.left[m]).mean(), steps.duration[m].mean()))
    (lw, dw), (lr, dr) = ends
    s = np.linspace(0.05, 0.95, 19)
    between = np.c_[((1 - s) * lw + s * lr) / ((1 - s) * dw + s * dr), (1 - s) * lw + s * lr]
    rows = rows[(rows[:, 0] < between[0, 0]) | (rows[:, 0] > between[-1, 0])]
    return np.array(sorted([tuple(r) for r in rows] + [tuple(r) for r in between]))


def _clip_speeds(steps) -> list[tuple[float, str]]:
    """(speed m/s, gait) of each cyclic clip or blend of the library at its own stride
    (as ``_library_strides`` reads them)."""
    cyc = ~steps.jump & (steps.stride == 1.0)
    out = []
    for lab in sorted(set(steps.label[cyc].tolist())):
        m = cyc & (steps.label == lab)
        out.append((float(np.hypot(steps.fwd[m], steps.left[m]).mean() / steps.duration[m].mean()), str(steps.gait[m][0])))
    return out
