"""Turning in place as Blender plays it (issue 14): a goal behind the start is reached after
a turn on the spot (the body stays over the start while it turns round, then walks
away, no loop), a goal facing back the way the walk came ends with a turn on the spot,
and a start facing a corridor's wall turns to walk along it. Baked through the command
line, saved, reopened and read frame by frame through the depsgraph; with the sample
character and the CMU library."""

import json
import math
from importlib import import_module

import numpy as np
import pytest

from conftest import needs_cmu, scene_with_cmu

CHAR = "Footstep Mannequin"
FPS = 30


def _turns_saved(fp, tmp_path, char: str = "mannequin", start_turn: float = 0.0, goal_turn: float = 0.0):
    """The Turns sample scene, its Start (and Goal) turned by these angles (rad), with the
    sample character (or the CMU library) at Start, saved: (path, character name)."""
    import bpy

    if char == "mannequin":
        bpy.ops.wm.read_homefile(use_empty=True)
        scene = import_module(fp.__name__ + ".blender.sample.sample_scenes").build("turns")
        scene.render.fps, scene.render.fps_base = FPS, 1.0
        ob, _ = import_module(fp.__name__ + ".blender.sample.mannequin").add_to_scene(scene, "Start")
    else:
        scene, ob = scene_with_cmu(fp, "turns", FPS)
    scene.objects["Start"].rotation_euler.z += start_turn
    scene.objects["Goal"].rotation_euler.z += goal_turn
    bpy.context.view_layer.update()
    path = str(tmp_path / "turn.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path)
    return path, ob.name


def _bake(fp, path, char, tmp_path, *extra):
    cli = import_module(fp.__name__ + ".blender.command.cli").cli_main
    out, rep = str(tmp_path / "baked.blend"), str(tmp_path / "baked.json")
    assert cli(["bake", path, "--character", char, "--start", "Start", "--goal", "Goal", "--out", out,
                "--report", rep, *extra]) == 0
    with open(rep) as fh:
        return out, json.load(fh)


def _played(fp, out, doc):
    """The saved bake reopened and played through the depsgraph: (body (F, 3), body yaw
    (F,) rad, unwrapped, foot skate figures of the report's stances (``metrics.foot_skate``),
    the heel and toe points (2, F, 3) each)."""
    import bpy

    metrics = import_module(fp.__name__ + ".core.report.metrics")
    bpy.ops.wm.open_mainfile(filepath=out)
    scene = bpy.context.scene
    ob = scene.objects[doc["character"]]
    feet = doc["feet"]
    heel_local, toe_local = np.array(feet["heel_local"]), np.array(feet["toe_local"])
    first, n = doc["frame_start"], doc["frame_end"] - doc["frame_start"] + 1
    body, yaw = np.empty((n, 3)), np.empty(n)
    heel, toe = np.empty((2, n, 3)), np.empty((2, n, 3))
    dg = bpy.context.evaluated_depsgraph_get()
    for i in range(n):
        scene.frame_set(first + i)
        ev = ob.evaluated_get(dg)
        mw = np.array(ev.matrix_world)
        body[i], yaw[i] = mw[:3, 3], math.atan2(mw[1, 0], mw[0, 0])
        for k, name in enumerate(feet["bones"]):
            m = mw @ np.array(ev.pose.bones[name].matrix)
            heel[k, i], toe[k, i] = (m @ heel_local[k])[:3], (m @ toe_local[k])[:3]
    stances = [{"foot": "LR".index(f["foot"]), "start": f["planted_frames"][0] - first,
                "end": f["planted_frames"][1] - first, "stance": f["frame"] - first,
                "position": np.array(f["position"]), "heading": f["heading"]} for f in doc["footprints"]]
    return body, np.unwrap(yaw), stances, metrics.foot_skate(heel, toe, stances)


def _check_start_turn(fp, out, doc, skate_mm: float):
    turns = doc["turns_in_place"]
    assert [t["where"] for t in turns] == ["start"] and abs(turns[0]["degrees"]) >= 150
    assert all(f["clip"] == "pivot" for f in doc["footprints"][2:2 + turns[0]["steps"]])
    body, yaw, stances, skate = _played(fp, out, doc)
    a, b = (f - doc["frame_start"] for f in turns[0]["frames"])
    start = body[0, :2]
    # the body stays over the start while it turns round, by at least 150 degrees ...
    assert np.linalg.norm(body[a:b + 1, :2] - start, axis=1).max() < 0.03
    assert abs(yaw[b] - yaw[a]) >= math.radians(150)
    # the turn's length in animation frames (the motion's, not the machine's time): quick
    # short steps (PIVOT_PACE), as a person turns round in 2 to 3 s of motion
    assert b - a < 4.5 * FPS
    # ... then walks away: never behind the start (a walking U-turn swings 0.9 m behind it)
    ahead = np.array([math.cos(yaw[b] + math.pi / 2), math.sin(yaw[b] + math.pi / 2)])  # (the rig faces -Y)
    assert ((body[b:, :2] - start) @ -ahead).min() > -0.1
    # the planted feet stay put through the turn as through the walk
    turning = [k for k, s in enumerate(stances) if s["start"] <= b]
    assert max(skate["per_stance_mm"][k] for k in turning) < 1.0 and skate["max_mm"] < skate_mm
    q = doc["quality"]
    assert q["goal"]["distance_m"] < 0.05 and abs(q["goal"]["heading_deg"]) < 5.0
    intro = q["pops"]["introduced"]
    assert intro["count"] <= 5 and intro["max_excess_deg"] <= 5.0


def test_a_goal_behind_the_start_is_reached_after_a_turn_in_place(fp, empty_scene, tmp_path, capsys):
    path, char = _turns_saved(fp, tmp_path, start_turn=math.pi)
    out, doc = _bake(fp, path, char, tmp_path)
    assert "turns in place at the start" in capsys.readouterr().out
    _check_start_turn(fp, out, doc, 1.0)


@needs_cmu
def test_the_cmu_library_turns_in_place_too(fp, empty_scene, tmp_path):
    path, char = _turns_saved(fp, tmp_path, "cmu", start_turn=math.pi)
    out, doc = _bake(fp, path, char, tmp_path)
    _check_start_turn(fp, out, doc, 5.0)


def test_a_goal_facing_back_ends_with_a_turn_in_place(fp, empty_scene, tmp_path):
    """The Goal turned round: the walk arrives facing its way and turns on the spot to the
    goal's heading (instead of a loop to arrive facing it), standing still at the goal."""
    path, char = _turns_saved(fp, tmp_path, goal_turn=math.pi)
    out, doc = _bake(fp, path, char, tmp_path)
    turns = doc["turns_in_place"]
    assert [t["where"] for t in turns] == ["end"] and abs(turns[0]["degrees"]) >= 120
    body, yaw, stances, skate = _played(fp, out, doc)
    a = turns[0]["frames"][0] - doc["frame_start"]
    assert np.linalg.norm(body[a:, :2] - body[-1, :2], axis=1).max() < 0.03
    assert skate["max_mm"] < 1.0
    q = doc["quality"]
    assert q["goal"]["distance_m"] < 0.05 and abs(q["goal"]["heading_deg"]) < 5.0
    intro = q["pops"]["introduced"]
    assert intro["count"] <= 5 and intro["max_excess_deg"] <= 5.0


def test_turning_in_place_off_has_no_room_to_walk_round(fp, empty_scene, tmp_path):
    """``turn_in_place_angle=0`` plans as before: facing the end of the Turns path, half a
    metre from it, the walking turn has no room, and the plan is refused; turning in
    place, it is not (its first steps leave the way the path goes)."""
    import bpy

    path, char = _turns_saved(fp, tmp_path, start_turn=math.pi)
    planning = import_module(fp.__name__ + ".blender.planning")
    navgraph = import_module(fp.__name__ + ".core.plan.navgraph")
    settings = import_module(fp.__name__ + ".core.base.settings").Settings(turn_in_place_angle=0.0)
    scene = bpy.context.scene
    goal, heading = planning.goal_of(scene, "Goal")
    with pytest.raises(navgraph.PlanError, match="cannot be reached"):
        planning.plan(scene, bpy.data.objects[char], goal, heading, scene.objects["Start"], settings)
    result, _ = planning.plan(scene, bpy.data.objects[char], goal, heading, scene.objects["Start"])
    assert sum(f.label == "pivot" for f in result.footprints) >= 4


def test_a_turning_plan_saved_and_baked_turns_again(fp, empty_scene, tmp_path):
    """``plan --out-plan`` keeps the pivot steps; ``bake --plan`` plays them as a turn."""
    cli = import_module(fp.__name__ + ".blender.command.cli").cli_main
    path, char = _turns_saved(fp, tmp_path, start_turn=math.pi)
    plan = str(tmp_path / "plan.json")
    assert cli(["plan", path, "--character", char, "--start", "Start", "--goal", "Goal", "--out-plan", plan]) == 0
    with open(plan) as fh:
        labels = [f["clip"] for f in json.load(fh)["footprints"]]
    assert labels.count("pivot") >= 4
    rep = str(tmp_path / "again.json")
    assert cli(["bake", path, "--plan", plan, "--out", str(tmp_path / "again.blend"), "--report", rep]) == 0
    with open(rep) as fh:
        doc = json.load(fh)
    assert [t["where"] for t in doc["turns_in_place"]] == ["start"]
    assert doc["quality"]["foot_skate"]["max_mm"] < 1.0


def test_a_job_back_to_the_start_turns_at_both_ends_and_the_panel_says_so(fp, empty_scene, tmp_path):
    """A job list's return from the Goal to the Start (the Turns scene's U-turn): it turns
    in place to face the way back, and at the Start to face the Start's way; the panel's
    Plan reports the same turns."""
    import bpy

    path, char = _turns_saved(fp, tmp_path)
    jobs = tmp_path / "jobs.json"
    rep = tmp_path / "back.json"
    jobs.write_text(json.dumps([{"character": char, "goal": "Start", "start": "Goal", "name": "back",
                                 "report": str(rep)}]))
    cli = import_module(fp.__name__ + ".blender.command.cli").cli_main
    assert cli(["bake", path, "--job", str(jobs), "--out", str(tmp_path / "jobs.blend")]) == 0
    doc = json.loads(rep.read_text())
    assert [t["where"] for t in doc["turns_in_place"]] == ["start", "end"]
    assert all(abs(t["degrees"]) >= 90 for t in doc["turns_in_place"])
    q = doc["quality"]
    assert q["goal"]["distance_m"] < 0.05 and abs(q["goal"]["heading_deg"]) < 5.0
    assert q["foot_skate"]["max_mm"] < 1.0 and q["pops"]["introduced"]["count"] <= 5
    bpy.ops.wm.open_mainfile(filepath=path)
    scene = bpy.context.scene
    fs = scene.footstep
    fs.character, fs.goal, fs.start = bpy.data.objects[char], scene.objects["Start"], scene.objects["Goal"]
    assert bpy.ops.footstep.plan() == {"FINISHED"}
    planned = json.loads(fs.plan_json)
    assert [t["where"] for t in planned["turns_in_place"]] == ["start", "end"]


def test_a_pause_where_the_way_turns_back_turns_in_place_there(fp, empty_scene, tmp_path):
    """Out along the Turns path to A, pause, and back past the start's way: the path stops
    at A and turns on the spot there toward the way back; the arrival frame asked for the
    goal is still met as Blender plays the saved scene."""
    import bpy

    path, char = _turns_saved(fp, tmp_path)
    bpy.ops.wm.open_mainfile(filepath=path)
    scene = bpy.context.scene
    for name, at in (("A", (5.0, 0.0, 0.0)), ("Back", (1.5, 0.0, 0.0))):
        e = bpy.data.objects.new(name, None)
        e.location = at
        scene.collection.objects.link(e)
    bpy.ops.wm.save_as_mainfile(filepath=path)
    cli = import_module(fp.__name__ + ".blender.command.cli").cli_main
    out, rep = str(tmp_path / "via.blend"), str(tmp_path / "via.json")
    assert cli(["bake", path, "--character", char, "--start", "Start", "--goal", "Back", "--via", "A",
                "--pause", "A=0.5", "--arrive", "Back=440", "--out", out, "--report", rep]) == 0
    with open(rep) as fh:
        doc = json.load(fh)
    turns = doc["turns_in_place"]
    assert [t["where"] for t in turns] == ["waypoint"] and abs(turns[0]["degrees"]) >= 60
    rows = {r["name"]: r for r in doc["waypoints"]}
    assert abs(rows["Back"]["achieved"] - 440) <= 1.0
    assert rows["A"]["achieved"] < turns[0]["frames"][0]
    body, yaw, stances, skate = _played(fp, out, doc)
    a, b = (f - doc["frame_start"] for f in turns[0]["frames"])
    assert np.linalg.norm(body[a:b + 1, :2] - body[a, :2], axis=1).max() < 0.03
    assert skate["max_mm"] < 1.0


def _hairpin_saved(fp, tmp_path, char: str = "mannequin"):
    """A hairpin bend nobody tuned the planner for: two walkways 0.8 m wide side by side,
    a wall between them, joined at their far end by a landing 1 m deep; Start at the
    near end of one, Goal at the near end of the other, facing back. Saved: (path,
    character name)."""
    import bpy

    ss = import_module(fp.__name__ + ".blender.sample.sample_scenes")
    if char == "mannequin":
        bpy.ops.wm.read_homefile(use_empty=True)
        scene = bpy.context.scene
    else:
        scene, ob = scene_with_cmu(fp, "turns", FPS)
        for o in [o for o in scene.objects if o is not ob and o.type != "ARMATURE"]:
            bpy.data.objects.remove(o)
    scene.name, scene.render.fps, scene.render.fps_base = "Hairpin", FPS, 1.0
    t = ss._collection(scene, "Hairpin Traversable", "TRAVERSABLE")
    o = ss._collection(scene, "Hairpin Obstacles", "OBSTACLE")
    ss._box(t, "Walk A", -1.0, 6.0, -0.4, 0.4, -0.3, 0.0)
    ss._box(t, "Walk B", -1.0, 6.0, 0.6, 1.4, -0.3, 0.0)
    ss._box(t, "Landing", 6.0, 7.0, -0.4, 1.4, -0.3, 0.0)
    ss._box(o, "Wall", -1.0, 6.0, 0.4, 0.6, 0.0, 1.2)
    ss._marker(scene, "Start", (0.0, 0.0, 0.0), ss.EAST)
    ss._marker(scene, "Goal", (0.0, 1.0, 0.0), ss.WEST)
    if char == "mannequin":
        ob, _ = import_module(fp.__name__ + ".blender.sample.mannequin").add_to_scene(scene, "Start")
    else:
        ob.location, ob.rotation_euler.z = (0.0, 0.0, 0.0), ss.EAST
    bpy.context.view_layer.update()
    path = str(tmp_path / "hairpin.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path)
    return path, ob.name


@pytest.mark.parametrize("char", ["mannequin", pytest.param("cmu", marks=needs_cmu)])
def test_a_hairpin_bend_is_turned_in_place(fp, empty_scene, tmp_path, char):
    """Where the way turns back on a landing too small to walk round comfortably, the walk
    goes onto the landing, stops, turns on the spot (what the walk in has not turned
    already) and walks back along the other walkway: the report says it turned in place
    at the hairpin, the body stays over its spot while it turns, no planted foot slides,
    and the goal is reached with its heading. With turning in place off, the same scene
    is walked round in a U-turn (or refused)."""
    path, name = _hairpin_saved(fp, tmp_path, char)
    out, doc = _bake(fp, path, name, tmp_path)
    turns = doc["turns_in_place"]
    assert [t["where"] for t in turns] == ["hairpin"] and abs(turns[0]["degrees"]) >= 45, turns
    body, yaw, stances, skate = _played(fp, out, doc)
    a, b = (f - doc["frame_start"] for f in turns[0]["frames"])
    assert body[a, 0] > 6.0  # (on the landing, past the wall's end)
    assert np.linalg.norm(body[a:b + 1, :2] - body[a, :2], axis=1).max() < 0.1  # (on the spot)
    assert abs(yaw[b] - yaw[a]) >= math.radians(45)
    assert abs(yaw[-1] - yaw[0]) >= math.radians(170)  # (turned back, by walking in and turning on the spot)
    assert skate["max_mm"] < (1.0 if char == "mannequin" else 5.0)
    q = doc["quality"]
    assert q["goal"]["distance_m"] < 0.05 and abs(q["goal"]["heading_deg"]) < 5.0
    intro = q["pops"]["introduced"]
    assert intro["count"] <= 5 and intro["max_excess_deg"] <= 5.0
    cli = import_module(fp.__name__ + ".blender.command.cli").cli_main
    rep = str(tmp_path / "walked.json")
    rc = cli(["bake", path, "--character", name, "--start", "Start", "--goal", "Goal", "--out",
              str(tmp_path / "walked.blend"), "--report", rep, "--set", "turn_in_place_angle=0"])
    if rc == 0:  # (walked round: a U-turn on the landing; or no room for one at all)
        with open(rep) as fh:
            assert not json.load(fh)["turns_in_place"]
    print(char, "turning in place off:", "walked round" if rc == 0 else "refused")


def test_a_hairpin_on_the_way_to_a_waypoint_is_turned_in_place(fp, empty_scene, tmp_path):
    """The hairpin scene through a waypoint on the far walkway (``--via``): the leg to it
    turns in place at the hairpin as a plain walk does, and the route reaches the
    waypoint and the goal."""
    import bpy

    path, name = _hairpin_saved(fp, tmp_path)
    bpy.ops.wm.open_mainfile(filepath=path)
    scene = bpy.context.scene
    ss = import_module(fp.__name__ + ".blender.sample.sample_scenes")
    ss._marker(scene, "Via", (3.0, 1.0, 0.0), ss.WEST)
    bpy.ops.wm.save_as_mainfile(filepath=path)
    out, doc = _bake(fp, path, name, tmp_path, "--via", "Via")
    assert [t["where"] for t in doc["turns_in_place"]] == ["hairpin"], doc["turns_in_place"]
    q = doc["quality"]
    assert q["goal"]["distance_m"] < 0.05 and q["foot_skate"]["max_mm"] < 1.0
    intro = q["pops"]["introduced"]
    assert intro["count"] <= 5 and intro["max_excess_deg"] <= 5.0
