"""The animator directs (issue 16): moving one footprint of a baked Turns path and
re-baking re-keys only the span between its neighbouring locks (every other frame, as
Blender plays the scene, identical); paths through waypoints; plans as data through the
command line."""

import json
import shutil
from importlib import import_module

import numpy as np
import pytest

from conftest import needs_cmu, scene_with_cmu

CHAR = "Footstep Mannequin"


def _turns_scene(fp, name: str = "turns"):
    """The Turns (or another) sample scene at 30 fps with the sample character at Start:
    (scene, the character, the planning module, the goal, its heading)."""
    mannequin = import_module(fp.__name__ + ".blender.sample.mannequin")
    sample = import_module(fp.__name__ + ".blender.sample.sample_scenes")
    planning = import_module(fp.__name__ + ".blender.planning")
    scene = sample.build(name)
    scene.render.fps, scene.render.fps_base = 30, 1.0
    ob, _ = mannequin.add_to_scene(scene, "Start")
    return (scene, ob, planning, *planning.goal_of(scene, "Goal"))


@pytest.fixture
def turns(fp, empty_scene):
    """The Turns sample scene with the sample character, baked once from frame 1."""
    handles = import_module(fp.__name__ + ".blender.ui.handles")
    scene, ob, planning, goal, heading = _turns_scene(fp)
    planned = planning.plan_and_synthesize(scene, ob, goal, heading, scene.objects["Start"])
    doc = planning.run(scene, ob, goal, heading, scene.objects["Start"], name="turns", frame_start=1)
    handles.make_handles(scene, ob, planned.result.footprints, planned.setup.forward, goal, planned.goal_heading)
    return scene, ob, doc


def _played(fp, scene, ob, first, last):
    """World matrices of every bone and the object, frame by frame, as Blender plays."""
    import bpy

    out = []
    dg = bpy.context.evaluated_depsgraph_get()
    for f in range(first, last + 1):
        scene.frame_set(f)
        ev = ob.evaluated_get(dg)
        m = np.array(ev.matrix_world)
        out.append(np.stack([m @ np.array(pb.matrix) for pb in ev.pose.bones]))
    return np.array(out)


def _move_middle_footprint(fp, ob, dy: float):
    """Lock the footprints three either side of the middle one and move it ``dy`` m in y:
    (its index, where it now stands)."""
    handles = import_module(fp.__name__ + ".blender.ui.handles")
    hs = handles.handles(ob)
    k = len(hs) // 2
    handles.set_locked([hs[k - 3], hs[k + 3]], True)
    hs[k].location.y += dy
    return k, np.array(hs[k].location)


def test_moving_one_footprint_rebakes_only_its_span(fp, turns):
    import bpy

    scene, ob, doc = turns
    handles = import_module(fp.__name__ + ".blender.ui.handles")
    directing = import_module(fp.__name__ + ".blender.ui.directing")
    k, target = _move_middle_footprint(fp, ob, 0.12)
    first, last = doc["frame_start"], doc["frame_end"]
    before = _played(fp, scene, ob, first, last)

    doc2, route, splice = directing.rebake_handles(scene, ob)
    span = splice.span
    assert route.edited.spans and route.edited.spans[0][0] == k - 3
    assert doc2["frame_end"] == last + span.delta
    after = _played(fp, scene, ob, first, doc2["frame_end"])
    lo, hi = span.changed()
    frames = np.arange(first, doc2["frame_end"] + 1)
    same = frames < lo
    assert np.abs(after[same] - before[frames[same] - first]).max() < 1e-6
    later = frames > hi
    assert np.abs(after[later] - before[frames[later] - span.delta - first]).max() < 1e-6
    # the span itself changed, and the moved footprint is where it was put
    assert np.abs(after[~same & ~later] - before[np.clip(frames[~same & ~later] - first, 0, len(before) - 1)]).max() > 1e-3
    assert sum(np.allclose(f.position, target, atol=1e-6) for f in route.edited.result.footprints) == 1
    q = doc2["quality"]
    assert q["foot_skate"]["max_mm"] < 10 and q["goal"]["distance_m"] < 0.05
    # the handles show the new path, the locks kept
    plan, touched = handles.read_plan(ob)
    assert not touched.any() and plan.locked.sum() == 3
    assert bpy.data.actions[doc2["action"]]["footstep_planted_frames"]


def test_a_character_baked_from_a_start_elsewhere_is_replanned_from_its_plans_first_footprint(fp, empty_scene):
    """A character standing off every floor (as an import at the origin does), baked from
    the scene's Start: Re-plan leaves from the plan's first footprint, not from where the
    object stands, and keeps the plan's start exactly."""
    import bpy

    handles = import_module(fp.__name__ + ".blender.ui.handles")
    directing = import_module(fp.__name__ + ".blender.ui.directing")
    mannequin = import_module(fp.__name__ + ".blender.sample.mannequin")
    sample = import_module(fp.__name__ + ".blender.sample.sample_scenes")
    planning = import_module(fp.__name__ + ".blender.planning")
    scene = sample.build("turns")
    scene.render.fps, scene.render.fps_base = 30, 1.0
    off = bpy.data.objects.new("Off", None)
    off.location = (60.0, 60.0, 0.0)
    scene.collection.objects.link(off)
    ob, _ = mannequin.add_to_scene(scene, "Off")
    goal, heading = planning.goal_of(scene, "Goal")
    planned = planning.plan_and_synthesize(scene, ob, goal, heading, scene.objects["Start"])
    planning.run(scene, ob, goal, heading, scene.objects["Start"], name="turns", frame_start=1)
    handles.make_handles(scene, ob, planned.result.footprints, planned.setup.forward, goal, planned.goal_heading)
    k, target = _move_middle_footprint(fp, ob, 0.12)
    doc, route, _ = directing.rebake_handles(scene, ob)
    fps = route.edited.result.footprints
    assert np.array_equal(fps[0].position, planned.result.footprints[0].position)
    assert sum(np.allclose(f.position, target, atol=1e-6) for f in fps) == 1
    assert doc["quality"]["goal"]["distance_m"] < 0.05


def test_an_edited_plan_that_turns_in_place_rebakes_with_its_turn(fp, empty_scene):
    """Turns with the Start turned round: the bake turns in place at the start. Move a
    footprint of the walk after it in the viewport and re-bake from the handles: the
    turn is played again, on the spot, the moved footprint stands where it was put and
    the goal is reached without a sliding foot."""
    import math

    handles = import_module(fp.__name__ + ".blender.ui.handles")
    directing = import_module(fp.__name__ + ".blender.ui.directing")
    scene, ob, planning, goal, heading = _turns_scene(fp)
    start = scene.objects["Start"]
    start.rotation_euler.z += math.pi
    ob.rotation_euler.z = start.rotation_euler.z
    scene.view_layers[0].update()
    planned = planning.plan_and_synthesize(scene, ob, goal, heading, start)
    doc = planning.run(scene, ob, goal, heading, start, name="turned", frame_start=1)
    assert [t["where"] for t in doc["turns_in_place"]] == ["start"]
    handles.make_handles(scene, ob, planned.result.footprints, planned.setup.forward, goal, planned.goal_heading)
    k, target = _move_middle_footprint(fp, ob, 0.1)
    doc2, route, _ = directing.rebake_handles(scene, ob)
    assert [t["where"] for t in doc2["turns_in_place"]] == ["start"]
    assert abs(doc2["turns_in_place"][0]["degrees"]) >= 150
    assert sum(np.allclose(f.position, target, atol=1e-6) for f in route.edited.result.footprints) == 1
    q = doc2["quality"]
    assert q["foot_skate"]["max_mm"] < 1.0 and q["goal"]["distance_m"] < 0.05
    assert q["pops"]["introduced"]["count"] <= 5 and q["pops"]["introduced"]["max_excess_deg"] <= 5.0


def test_an_edit_too_big_to_splice_without_a_slide_is_baked_whole(fp, turns):
    """Moved 40 cm, the kept footprints' neighbours walk so differently that mixing the
    two bakes' keys slides the planted foot (by 56 mm; at 35 cm by 1.0 mm, the threshold's
    edge; 50 cm is more than a step reaches): the re-bake keys the whole path, says so,
    and no foot slides."""
    scene, ob, doc = turns
    directing = import_module(fp.__name__ + ".blender.ui.directing")
    _move_middle_footprint(fp, ob, 0.40)
    doc2, route, splice = directing.rebake_handles(scene, ob)
    assert splice.span is None and "the whole path was re-baked" in doc2["rebaked_whole"]
    assert "rebaked_frames" not in doc2 and doc2["quality"]["foot_skate"]["max_mm"] < 1.0


def test_the_panels_edit_lock_replan_and_undo(fp, empty_scene):
    """As in the viewport: Bake makes the handles; select two and Lock them, move one
    between them, Re-plan: only its span is re-keyed; Undo gives the bake back; an edit
    that can't be honoured (a locked footprint moved off the floor) is refused with the
    reason in the panel and nothing baked."""
    import bpy

    handles = import_module(fp.__name__ + ".blender.ui.handles")
    scene, ob, *_ = _turns_scene(fp, "obstacles")
    fs = scene.footstep
    fs.character, fs.goal, fs.start = ob, scene.objects["Goal"], scene.objects["Start"]
    assert bpy.ops.footstep.bake() == {"FINISHED"}
    hs = handles.handles(ob)
    assert len(hs) == len(json.loads(fs.plan_json)["footprints"])
    k = len(hs) // 2
    for o in scene.objects:
        o.select_set(False)
    hs[k - 3].select_set(True)
    hs[k + 3].select_set(True)
    assert bpy.ops.footstep.lock_footprints(lock=True) == {"FINISHED"}
    hs[k].location.x += 0.1
    name = ob.name
    bpy.ops.ed.undo_push(message="before re-plan")
    baked = lambda o: list(o.animation_data.nla_tracks[-1].strips[0].action["footstep_footprints"])  # noqa: E731
    action = baked(ob)
    assert bpy.ops.footstep.replan() == {"FINISHED"}
    assert baked(ob) != action
    assert "re-keyed frames" in fs.last_report and fs.edit_problem == ""
    bpy.ops.ed.undo_push(message="Re-plan")
    bpy.ops.ed.undo()
    ob = bpy.data.objects[name]
    assert baked(ob) == action
    hs = handles.handles(ob)
    hs[k].location.z -= 3.0  # (locked, as moved): off every surface
    with pytest.raises(RuntimeError, match="is locked but it is off surface"):
        bpy.ops.footstep.replan()
    assert "off surface" in bpy.context.scene.footstep.edit_problem
    assert baked(ob) == action  # nothing baked


@pytest.fixture(scope="module")
def shot_file(fp, tmp_path_factory):
    """The Turns scene with the sample character saved, and two waypoint empties A and B
    near the direct path's thirds: made once for the module (``shot`` copies it)."""
    import bpy

    bpy.ops.wm.read_homefile(use_empty=True)
    scene, ob, planning, goal, heading = _turns_scene(fp)
    fps = planning.plan(scene, ob, goal, heading, scene.objects["Start"])[0].footprints
    for name, i in (("A", len(fps) // 3), ("B", 2 * len(fps) // 3)):
        e = bpy.data.objects.new(name, None)
        e.location = fps[i].position
        scene.collection.objects.link(e)
    path = str(tmp_path_factory.mktemp("shot") / "shot.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path)
    return path


@pytest.fixture
def shot(shot_file, empty_scene, tmp_path):
    """(a folder of the test's own, the shot's file in it): a copy of ``shot_file``."""
    path = tmp_path / "shot.blend"
    shutil.copyfile(shot_file, path)
    return tmp_path, str(path)


def test_a_bake_through_waypoints_visits_them_in_order(fp, shot, capsys):
    cli = import_module(fp.__name__ + ".blender.command.cli").cli_main
    folder, path = shot
    assert cli(["bake", path, "--character", CHAR, "--start", "Start", "--goal", "Goal", "--via", "A,B",
                "--report", str(folder / "r.json")]) == 0
    doc = json.loads((folder / "r.json").read_text())
    wps = doc["waypoints"]
    assert [w["name"] for w in wps] == ["A", "B", "Goal"]
    assert wps[0]["frame"] < wps[1]["frame"] < wps[2]["frame"]
    import bpy

    body = np.array(doc["synthesis"]["body"]["position"])
    for w in wps[:2]:
        target = np.array(bpy.data.objects[w["name"]].location)
        planned = np.array(doc["synthesis"]["footprints"][w["footprint"]]["planned"])
        assert np.linalg.norm(planned[:2] - target[:2]) <= 0.35  # the goal radius
        assert np.linalg.norm(body[:, :2] - target[:2], axis=1).min() < 0.6  # (radius + half a stance)
    assert doc["quality"]["goal"]["distance_m"] < 0.05


def test_an_edited_plan_round_trips_through_bake_plan(fp, shot, capsys):
    """plan --out-plan writes the footprints; unedited, bake --plan bakes exactly them;
    edited (one footprint moved, two locked), bake --plan keeps the edit and re-plans only
    between the locks, re-keying only that span of the earlier bake."""
    cli = import_module(fp.__name__ + ".blender.command.cli").cli_main
    folder, path = shot
    plan_path = folder / "plan.json"
    common = [path, "--character", CHAR, "--start", "Start", "--goal", "Goal"]
    assert cli(["plan", *common, "--out-plan", str(plan_path)]) == 0
    doc = json.loads(plan_path.read_text())
    assert doc["format"] == "footstep-plan" and not any(f["locked"] for f in doc["footprints"])
    assert cli(["bake", *common, "--out", str(folder / "direct.blend"), "--report", str(folder / "direct.json")]) == 0
    assert cli(["bake", path, "--plan", str(plan_path), "--out", str(folder / "planned.blend"),
                "--report", str(folder / "planned.json")]) == 0
    direct, planned = (json.loads((folder / n).read_text()) for n in ("direct.json", "planned.json"))
    assert [f["position"] for f in planned["footprints"]] == [f["position"] for f in direct["footprints"]]
    assert planned["replanned"] == []
    k = len(doc["footprints"]) // 2
    doc["footprints"][k]["position"][0] += 0.1
    for i in (k - 3, k + 3):
        doc["footprints"][i]["locked"] = True
    plan_path.write_text(json.dumps(doc))
    assert cli(["bake", str(folder / "planned.blend"), "--plan", str(plan_path), "--report",
                str(folder / "edited.json")]) == 0
    edited = json.loads((folder / "edited.json").read_text())
    assert edited["replanned"][0][0] == k - 3 and edited["rebaked_frames"]
    lo, hi = edited["rebaked_frames"]
    assert direct["frame_start"] < lo < hi < edited["frame_end"]
    assert edited["quality"]["foot_skate"]["max_mm"] < 10 and edited["quality"]["goal"]["distance_m"] < 0.05


def test_a_bad_plan_file_is_one_message(fp, shot, capsys):
    cli = import_module(fp.__name__ + ".blender.command.cli").cli_main
    folder, path = shot
    (folder / "bad.json").write_text(json.dumps({"format": "footstep-plan", "version": 1, "character": CHAR,
                                                  "forward": [0, -1, 0], "footprints": [{"foot": "L"}]}))
    assert cli(["bake", path, "--plan", str(folder / "bad.json")]) == 2
    err = capsys.readouterr().err
    assert "at least two footprints" in err and "Traceback" not in err


def test_waypoints_from_a_collection_and_a_curve_in_the_panel(fp, shot):
    """The panel's Waypoints collection: its objects in name order, a curve's points in
    their order; the plan passes each within the goal radius, in order."""
    import bpy

    folder, path = shot
    bpy.ops.wm.open_mainfile(filepath=path)
    scene = bpy.context.scene
    coll = bpy.data.collections.new("Way")
    scene.collection.children.link(coll)
    a, b = bpy.data.objects["A"], bpy.data.objects["B"]
    curve = bpy.data.curves.new("Route", "CURVE")
    spline = curve.splines.new("POLY")
    spline.points.add(1)
    spline.points[0].co = (*a.location, 1.0)
    spline.points[1].co = (*b.location, 1.0)
    route_ob = bpy.data.objects.new("Route", curve)
    coll.objects.link(route_ob)
    fs = scene.footstep
    fs.character, fs.goal, fs.start, fs.waypoints = (bpy.data.objects[CHAR], scene.objects["Goal"],
                                                     scene.objects["Start"], coll)
    assert bpy.ops.footstep.plan() == {"FINISHED"}
    doc = json.loads(fs.plan_json)
    pos = np.array([f["position"] for f in doc["footprints"]])[:, :2]
    hits = [int(np.argmin(np.linalg.norm(pos - np.array(o.location[:2]), axis=1))) for o in (a, b)]
    assert hits[0] < hits[1]
    for o, i in zip((a, b), hits):
        assert np.linalg.norm(pos[i] - np.array(o.location[:2])) <= 0.35


def _played_body(fp, path, doc):
    """The body's positions (F, 3) as Blender plays the saved scene ``path``."""
    import bpy

    bpy.ops.wm.open_mainfile(filepath=str(path))
    scene, ob = bpy.context.scene, bpy.data.objects[CHAR]
    out = []
    for f in range(doc["frame_start"], doc["frame_end"] + 1):
        scene.frame_set(f)
        out.append(np.array(ob.evaluated_get(bpy.context.evaluated_depsgraph_get()).matrix_world.translation))
    return np.array(out)


def test_arrival_frames_are_met_and_a_pause_stands_still(fp, shot, capsys):
    """Three waypoints: A with a 1.5 s pause, B on frame 560 and the goal on frame 800 (the
    walk paced to them): each met within one frame as Blender plays the saved scene,
    read independently of the report; at A the body stands still for the pause."""
    cli = import_module(fp.__name__ + ".blender.command.cli").cli_main
    directed = import_module(fp.__name__ + ".core.perform.directed")
    folder, path = shot
    out = folder / "timed.blend"
    assert cli(["bake", path, "--character", CHAR, "--start", "Start", "--goal", "Goal", "--via", "A,B",
                "--pause", "A=1.5", "--arrive", "B=560,Goal=800", "--out", str(out),
                "--report", str(folder / "t.json")]) == 0
    text = capsys.readouterr().out
    assert "waypoints (frames" in text and "asked" in text
    doc = json.loads((folder / "t.json").read_text())
    rows = {r["name"]: r for r in doc["waypoints"]}
    assert list(rows) == ["A", "B", "Goal"]
    body = _played_body(fp, out, doc)
    import bpy

    marks = [directed.Mark(n, 0, np.array(bpy.data.objects[n].location), stop=n != "B") for n in rows]
    windows = [(rows[n]["planned"] - 60 - doc["frame_start"], rows[n]["planned"] + 60 - doc["frame_start"])
               for n in rows]
    windows = [(max(int(a), 0), min(int(b), len(body) - 1)) for a, b in windows]
    windows[-1] = (windows[-1][0], len(body) - 1)
    windows[0] = (windows[0][0], int(rows["A"]["planned"] - doc["frame_start"] + 1.2 * 30))  # (into the pause)
    got = doc["frame_start"] + directed.arrival_frames(body, marks, windows)
    assert abs(got[1] - 560) <= 1.0 and abs(got[2] - 800) <= 1.0
    for n, g in zip(rows, got):
        assert abs(rows[n]["achieved"] - g) <= 0.5  # the report reads the played scene
    # at A: stands still (under 2 mm a frame) for the pause, then walks on
    a = int(round(rows["A"]["achieved"])) - doc["frame_start"]
    speed = np.linalg.norm(np.diff(body[:, :2], axis=0), axis=1)
    still = np.flatnonzero(speed[a:a + 150] < 0.002)
    assert still[-1] - still[0] + 1 >= 1.5 * 30 - 2 and speed[a + 150:].max() > 0.02
    assert np.linalg.norm(body[a + still[0], :2] - np.array(bpy.data.objects["A"].location[:2])) < 0.1
    q = doc["quality"]
    assert q["foot_skate"]["max_mm"] < 5 and q["goal"]["distance_m"] < 0.05
    assert q["pops"]["introduced"]["count"] <= 5


def test_a_frame_too_soon_is_refused_with_the_earliest_which_is_then_met(fp, shot, capsys):
    cli = import_module(fp.__name__ + ".blender.command.cli").cli_main
    folder, path = shot
    common = [path, "--character", CHAR, "--start", "Start", "--goal", "Goal", "--via", "A,B"]
    assert cli(["bake", *common, "--arrive", "B=200", "--out", str(folder / "x.blend")]) == 2
    err = capsys.readouterr().err
    import re

    m = re.search(r"waypoint 'B' can't be reached by frame 200: the earliest is frame (\d+)", err)
    assert m and "Traceback" not in err and not (folder / "x.blend").exists()
    earliest = int(m.group(1))
    assert cli(["bake", *common, "--arrive", f"B={earliest}", "--report", str(folder / "e.json")]) == 0
    row = json.loads((folder / "e.json").read_text())["waypoints"][1]
    assert abs(row["achieved"] - earliest) <= 1.0
    # (the earliest is the soonest way tried: a jog at about the run's blend here, or the fastest pace)
    assert (row["met_by"] == "jog" and row["blend"] > 0.95) or row["pace"] > 1.2


def test_a_frame_too_soon_for_walking_is_met_running(fp, shot, capsys):
    """B on a frame the walk can't make at its fastest pace, with the jog off: the way to
    it is planned again, running where that is quicker (the library's run), and the
    frame is met."""
    cli = import_module(fp.__name__ + ".blender.command.cli").cli_main
    folder, path = shot
    assert cli(["bake", path, "--character", CHAR, "--start", "Start", "--goal", "Goal", "--via", "A,B",
                "--arrive", "B=380", "--set", "jog_to_arrive=false", "--report", str(folder / "run.json")]) == 0
    doc = json.loads((folder / "run.json").read_text())
    row = doc["waypoints"][1]
    assert abs(row["achieved"] - 380) <= 1.0 and row["met_by"] == "run" and row["jog_speed"] is None
    gaits = [f["gait"] for f in doc["footprints"][:row["footprint"]]]
    assert gaits.count("run") >= 5
    assert max(doc["synthesis"]["curves"]["s"]) > 0.99  # (the blend groups run there too)
    q = doc["quality"]
    assert q["foot_skate"]["max_mm"] < 5 and q["goal"]["distance_m"] < 0.05


def test_early_with_nowhere_to_wait_stops_at_the_waypoint_before(fp, shot, capsys):
    """A on frame 300, B much later than the slowest walk from A gets there: the path
    stops at A (it had no pause) and waits there."""
    cli = import_module(fp.__name__ + ".blender.command.cli").cli_main
    folder, path = shot
    assert cli(["bake", path, "--character", CHAR, "--start", "Start", "--goal", "Goal", "--via", "A,B",
                "--arrive", "A=300,B=900", "--report", str(folder / "stop.json")]) == 0
    a, b, _ = json.loads((folder / "stop.json").read_text())["waypoints"]
    assert abs(a["achieved"] - 300) <= 1.0 and abs(b["achieved"] - 900) <= 1.0
    assert a["stops"] and a["pause"] == 0 and b["waited"] > 3.0


def test_early_arrival_waits_standing_at_the_start(fp, shot, capsys):
    """A goal frame later than the slowest pace reaches it: the character waits at the
    start, standing, and leaves in time."""
    cli = import_module(fp.__name__ + ".blender.command.cli").cli_main
    folder, path = shot
    assert cli(["bake", path, "--character", CHAR, "--start", "Start", "--goal", "Goal", "--arrive", "Goal=1300",
                "--report", str(folder / "w.json")]) == 0
    doc = json.loads((folder / "w.json").read_text())
    (row,) = doc["waypoints"]
    assert abs(row["achieved"] - 1300) <= 1.0 and row["waited"] > 1.0 and abs(row["pace"] - 0.8) < 1e-6
    first_lift = min(f["planted_frames"][1] for f in doc["footprints"][:2])
    assert first_lift - doc["frame_start"] >= row["waited"] * 30


@pytest.mark.parametrize("args, says", [
    (["--pause", "Nowhere=1"], "a pause (--pause) names 'Nowhere', which is not a waypoint"),
    (["--arrive", "B=soon"], "--arrive: 'B=soon' is not NAME=NUMBER"),
    (["--pause", "A=-2"], "--pause A=-2: must be 0 to 600 seconds"),
    (["--arrive", "Goal=200000"], "would wait 6"),
])
def test_bad_timing_options_are_one_message(fp, shot, capsys, args, says):
    cli = import_module(fp.__name__ + ".blender.command.cli").cli_main
    folder, path = shot
    assert cli(["bake", path, "--character", CHAR, "--start", "Start", "--goal", "Goal", "--via", "A,B",
                *args]) == 2
    err = capsys.readouterr().err
    assert says in err and "Traceback" not in err


def test_the_panel_takes_a_pause_and_an_arrival_frame(fp, shot):
    """A waypoint's pause and the goal's arrival frame set on the objects (the panel's
    fields) are what the panel's Bake honours; its report lists the frames."""
    import bpy

    folder, path = shot
    bpy.ops.wm.open_mainfile(filepath=path)
    scene = bpy.context.scene
    coll = bpy.data.collections.new("Way")
    scene.collection.children.link(coll)
    coll.objects.link(bpy.data.objects["A"])
    a, goal = bpy.data.objects["A"], scene.objects["Goal"]
    a.footstep.pause = 1.0
    goal.footstep.use_arrive, goal.footstep.arrive = True, 900
    fs = scene.footstep
    fs.character, fs.goal, fs.start, fs.waypoints = bpy.data.objects[CHAR], goal, scene.objects["Start"], coll
    assert bpy.ops.footstep.bake() == {"FINISHED"}
    rows = {w["name"]: w for w in json.loads(fs.plan_json)["waypoints"]}
    assert rows["A"]["pause"] == 1.0 and rows["A"]["stops"]
    assert abs(rows["Goal"]["achieved"] - 900) <= 1.0
    overlay = import_module(fp.__name__ + ".blender.ui.overlay")
    labels = [text for _, text in overlay.LAST[scene.name]["labels"]]
    assert labels[0].startswith("A: frame ") and "stands 1 s" in labels[0]
    assert labels[-1].startswith("Goal: frame ") and labels[-1].endswith("(asked 900)")


@needs_cmu
def test_real_capture_pauses_and_meets_its_frames(fp, empty_scene):
    """The CMU subject-16 library (no idle clip: its standing is made from its walk) on
    the Turns scene: a pause at a waypoint and the goal on a frame, met within a frame
    as played, with the feet planted and the goal reached."""
    import bpy

    scene, ob = scene_with_cmu(fp, "turns")
    planning = import_module(fp.__name__ + ".blender.planning")
    directing = import_module(fp.__name__ + ".blender.ui.directing")
    goal, heading = planning.goal_of(scene, "Goal")
    direct = planning.plan(scene, ob, goal, heading, scene.objects["Start"])[0].footprints
    e = bpy.data.objects.new("A", None)
    e.location = direct[len(direct) // 2].position
    scene.collection.objects.link(e)
    bpy.context.view_layer.update()
    free = planning.run(scene, ob, goal, heading, scene.objects["Start"], name="free", frame_start=1,
                        route=directing.via_route(scene, ["A"], "Goal", goal, heading, {"A": 1.0}))
    target = int(free["waypoints"][-1]["achieved"]) + 40  # (slower than its own pace: it slows down)
    doc = planning.run(scene, ob, goal, heading, scene.objects["Start"], name="free", frame_start=1,  # (a retake)
                       route=directing.via_route(scene, ["A"], "Goal", goal, heading, {"A": 1.0}, {"Goal": target}))
    a, g = doc["waypoints"]
    assert a["stops"] and a["pause"] == 1.0 and abs(g["achieved"] - target) <= 1.0 and g["pace"] < 1.0
    q = doc["quality"]
    assert q["foot_skate"]["max_mm"] < 5 and q["footprint_error"]["max_mm"] < 10 and q["goal"]["distance_m"] < 0.05
