"""Two characters baked into one shot (issue 29's figures per pair, measured as played):
the later bake's report says how near the two bodies come, on which frame, and how many
frames a foot of each stands on one footprint; the same figures come from the saved file
as Blender plays it."""

import math
from importlib import import_module

import numpy as np

FPS = 30


def _crossing(fp):
    """An open floor where A walks east along y = 0 and B north along x = 0, both 5 m
    from the crossing: at one pace they meet there."""
    import bpy

    bpy.ops.wm.read_homefile(use_empty=True)
    scene = bpy.context.scene
    scene.render.fps = FPS
    ss = import_module(fp.__name__ + ".blender.sample.sample_scenes")
    floor = ss._collection(scene, "Traversable", "TRAVERSABLE")
    ss._box(floor, "Floor", -8.0, 8.0, -8.0, 8.0, -0.2, 0.0)
    east, north = math.pi / 2, math.pi
    for name, at, heading in (("StartA", (-5.0, 0.0, 0.0), east), ("GoalA", (5.0, 0.0, 0.0), east),
                              ("StartB", (0.0, -5.0, 0.0), north), ("GoalB", (0.0, 5.0, 0.0), north)):
        ss._marker(scene, name, at, heading)
    man = import_module(fp.__name__ + ".blender.sample.mannequin")
    a, _ = man.add_to_scene(scene, "StartA")
    b, _ = man.add_to_scene(scene, "StartB")
    return scene, a, b


def _bake(fp, scene, ob, tag):
    planning = import_module(fp.__name__ + ".blender.planning")
    goal, heading = planning.goal_of(scene, f"Goal{tag}")
    return planning.run(scene, ob, goal, heading, scene.objects[f"Start{tag}"], name=f"walk {tag}", frame_start=1)


def test_two_characters_crossing_are_measured_against_each_other_as_played(fp, tmp_path):
    import bpy

    scene, a, b = _crossing(fp)
    doc_a = _bake(fp, scene, a, "A")
    assert "others" not in doc_a["quality"]  # (nobody else baked yet; B only stands there)
    doc_b = _bake(fp, scene, b, "B")
    (fig,) = doc_b["quality"]["others"]
    print("B against A as baked:", fig)
    assert fig["character"] == a.name
    # they meet at the crossing: the bodies come within a shoulder's width of each other
    assert fig["least_distance_m"] < 0.3, fig
    lines = import_module(fp.__name__ + ".core.report.tables").format_bake(doc_b)
    assert f"with {a.name}: bodies" in lines
    # the panel's quality box (the report as the Bake operator keeps it) names the other too
    import json

    from conftest import Recorder

    scene.footstep.plan_json = json.dumps({k: doc_b[k] for k in ("stages", "quality")})
    stub = Recorder()
    import_module(fp.__name__ + ".blender.ui.panel")._draw_report(stub, scene.footstep)
    texts = [kw.get("text") for name, _, kw in stub.log if name == "label"]
    assert f"nearest {a.name}" in texts and f"on {a.name}'s footprints" in texts

    # the saved file, as Blender plays it: the same figures, from the bodies read there
    names = b.name, a.name
    path = str(tmp_path / "shot.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path, copy=True)
    bpy.ops.wm.open_mainfile(filepath=path)
    scene = bpy.context.scene
    bake = import_module(fp.__name__ + ".blender.write.bake")
    crowd = import_module(fp.__name__ + ".core.report.crowd")
    read = import_module(fp.__name__ + ".blender.read.scene")
    first, n = doc_b["frame_start"], doc_b["frame_end"] - doc_b["frame_start"] + 1
    obs = [scene.objects[n_] for n_ in names]
    rigs = [read.rig_from_armature(o) for o in obs]
    played = bake.played_matrices(scene, list(zip(obs, rigs)), first, n)
    bodies = [crowd.body_of(o.name, r, bake.played_world(*m), FPS) for o, r, m in zip(obs, rigs, played)]
    again = crowd.pair_figures(bodies[0], bodies[1], first)
    assert again == fig
    # and the least distance is where the hips are nearest, a few frames at most apart
    hips = [bd.hips for bd in bodies]
    nearest = first + int(np.argmin(np.linalg.norm(hips[0][:, :2] - hips[1][:, :2], axis=1)))
    assert abs(nearest - fig["least_distance_frame"]) <= 5
