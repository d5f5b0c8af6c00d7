"""Two characters baked into one shot (issue 29's figures per pair, measured as played):
the later bake's report says how near the two bodies come, on which frame, and how many
frames a foot of each stands on one footprint; a bake is measured against an obstacle
that moves; the same figures come from the saved file as Blender plays it."""

import math
from importlib import import_module

import numpy as np

from conftest import cmu_armature, needs_cmu
from crowd_scenes import crossing, played_bodies

FPS = 30


def _crossing(fp, cmu_b: bool = False):
    """The crossing (``crowd_scenes.crossing``): A east, B north, meeting in the middle."""
    return crossing(fp, cmu_b)


def _corridor(fp):
    """Two squares 6 m across joined by a passage 0.7 m wide and 4 m long (east to west, at
    y = 0), no way round it: A (the sample character) walks from the west square to the
    east one, B (CMU's real capture) from the east to the west, both setting off at once;
    alone they meet in the corridor's middle."""
    import bpy

    bpy.ops.wm.read_homefile(use_empty=True)
    scene = bpy.context.scene
    scene.render.fps = FPS
    ss = import_module(fp.__name__ + ".blender.sample.sample_scenes")
    floor = ss._collection(scene, "Traversable", "TRAVERSABLE")
    ss._box(floor, "West", -8.0, -2.0, -3.0, 3.0, -0.2, 0.0)
    ss._box(floor, "Corridor", -2.0, 2.0, -0.35, 0.35, -0.2, 0.0)
    ss._box(floor, "East", 2.0, 8.0, -3.0, 3.0, -0.2, 0.0)
    east, west = math.pi / 2, -math.pi / 2
    for name, at, heading in (("StartA", (-6.5, 1.0, 0.0), east), ("GoalA", (6.5, 1.0, 0.0), east),
                              ("StartB", (6.5, -1.0, 0.0), west), ("GoalB", (-6.5, -1.0, 0.0), west)):
        ss._marker(scene, name, at, heading)
    man = import_module(fp.__name__ + ".blender.sample.mannequin")
    a, _ = man.add_to_scene(scene, "StartA")
    return scene, a, cmu_armature(fp)


def _bake(fp, scene, ob, tag):
    planning = import_module(fp.__name__ + ".blender.planning")
    goal, heading = planning.goal_of(scene, f"Goal{tag}")
    return planning.run(scene, ob, goal, heading, scene.objects[f"Start{tag}"], name=f"walk {tag}", frame_start=1)


@needs_cmu
def test_two_characters_crossing_are_measured_against_each_other_as_played(fp, tmp_path, capsys):
    """A job list baking two characters into one shot, from the command line (the sample
    character, then CMU's real capture): the second job's report and summary name the
    first character, how near the bodies came and on which frame; the saved scene, as
    Blender plays it, gives the same figures; the panel's quality box names the other
    too."""
    import json

    import bpy

    from conftest import Recorder

    a, b, doc_a, doc_b, out, said = _job_list(fp, tmp_path, capsys)
    names = b, a
    assert "others" not in doc_a["quality"]  # (nobody else baked yet; B only stands there)
    (fig,) = doc_b["quality"]["others"]
    print("B against A as baked:", fig)
    assert fig["character"] == names[1]
    # they meet at the crossing: the bodies come within a shoulder's width of each other
    assert fig["least_distance_m"] < 0.3, fig
    # the job list's summary: job 2's nearest other character, and how near
    row = next(line for line in said.splitlines() if line.startswith("job 2"))
    assert row.rstrip().endswith(names[1]) and f"{fig['least_distance_m']:.2f}" in row.split()

    # the panel's quality box (the report as the Bake operator keeps it) names the other too
    fs = bpy.context.scene.footstep  # (the command line read the scene file anew)
    fs.plan_json = json.dumps({k: doc_b[k] for k in ("stages", "quality")})
    stub = Recorder()
    import_module(fp.__name__ + ".blender.ui.panel")._draw_report(stub, fs)
    texts = [kw.get("text") for name, _, kw in stub.log if name == "label"]
    assert f"nearest {names[1]}" in texts
    assert f"on {names[1]}'s footprints" in texts or not fig["frames_on_one_footprint"]

    # the saved scene, as Blender plays it: the same figures, from the bodies read there
    bodies, first = _played_pair(fp, out, doc_b, names)
    crowd = import_module(fp.__name__ + ".core.report.crowd")
    assert crowd.pair_figures(bodies[0], bodies[1], first) == fig
    # and the least distance is where the hips are nearest, a few frames at most apart
    hips = [bd.hips for bd in bodies]
    nearest = first + int(np.argmin(np.linalg.norm(hips[0][:, :2] - hips[1][:, :2], axis=1)))
    assert abs(nearest - fig["least_distance_frame"]) <= 5


def test_an_obstacle_that_moves_across_the_way_is_measured_as_played(fp, tmp_path):
    """A cart keyed to slide onto A's way and stay there (planned where it stood at the
    first frame, off the way) is measured against the body as played: A walks into it
    (how deep, on which frame, for how many frames); a post that never moves is not
    listed."""
    import bpy

    scene, a, b = _crossing(fp)
    bpy.data.objects.remove(b)  # (A alone)
    ss = import_module(fp.__name__ + ".blender.sample.sample_scenes")
    obst = ss._collection(scene, "Obstacles", "OBSTACLE")
    cart = ss._box(obst, "Cart", -0.5, 0.5, -0.5, 0.5, 0.0, 1.0)
    ss._box(obst, "Post", -0.2, 0.2, 6.0, 6.4, 0.0, 2.0)
    for frame, y in ((1, -3.0), (60, 0.0), (400, 0.0)):
        cart.location = (0.0, y, 0.0)
        cart.keyframe_insert("location", frame=frame)
    scene.frame_set(1)
    doc = _bake(fp, scene, a, "A")
    (fig,) = doc["quality"]["moving_obstacles"]
    print("A against the cart as baked:", fig)
    assert fig["obstacle"] == "Cart"
    assert fig["least_distance_m"] < -0.1 and fig["frames_touching"] > 5
    assert "with Cart (moving)" in import_module(fp.__name__ + ".core.report.tables").format_bake(doc)

    # the saved file as Blender plays it: the same figure
    me, moved, again = _played_obstacle(fp, str(tmp_path / "cart.blend"), a.name, "Cart", doc)
    assert again == fig
    # the deepest where the body passes the cart's middle (x = 0), the cart on the way
    at = fig["least_distance_frame"] - doc["frame_start"]
    assert abs(me.hips[at, 0]) < 0.35 and abs(moved[at, 1, 3]) < 1e-6


def test_a_door_that_slides_open_is_waited_for_and_a_cart_gone_round_in_time(fp, tmp_path):
    """Obstacles that move, avoided in time (``avoid_characters``): a door in a wall slides
    open between frames 200 and 230, and the only way is through it; the character stops
    before it, stands until it has opened and goes through, never touching it as Blender
    plays the saved scene. Planned where it stands on the first frame, the door is shut
    and the plan refused. A cart that slides onto the way (the test above) is kept clear
    of, in time, where alone the body walks into it."""
    import bpy

    scene, a, b = _crossing(fp)
    bpy.data.objects.remove(b)
    ss = import_module(fp.__name__ + ".blender.sample.sample_scenes")
    for name in ("Floor",):
        bpy.data.objects.remove(scene.objects[name])
    floor = next(c for c in bpy.data.collections if c.name.startswith("Traversable"))
    ss._box(floor, "Hall", -6.0, 6.0, -3.0, 3.0, -0.2, 0.0)
    obst = ss._collection(scene, "Obstacles", "OBSTACLE")
    ss._box(obst, "Wall south", -0.1, 0.1, -3.0, -0.5, 0.0, 2.5)
    ss._box(obst, "Wall north", -0.1, 0.1, 0.5, 3.0, 0.0, 2.5)
    door = ss._box(obst, "Door", -0.05, 0.05, -0.5, 0.5, 0.0, 2.2)
    for frame, y in ((1, 0.0), (200, 0.0), (230, 1.1)):
        door.location = (0.0, y, 0.0)
        door.keyframe_insert("location", frame=frame)
    scene.frame_set(1)
    planning = import_module(fp.__name__ + ".blender.planning")
    PlanError = import_module(fp.__name__ + ".core.plan.navgraph").PlanError
    Settings = import_module(fp.__name__ + ".core.base.settings").Settings
    goal, heading = planning.goal_of(scene, "GoalA")
    try:
        planning.plan(scene, a, goal, heading, scene.objects["StartA"], Settings(), frame_start=1)
    except PlanError:
        pass
    else:
        raise AssertionError("the door is shut on the first frame: planned where it stands, no way through")
    doc = planning.run(scene, a, goal, heading, scene.objects["StartA"], Settings(avoid_characters=True),
                       name="walk A", frame_start=1)
    (fig,) = doc["quality"]["moving_obstacles"]
    print("A against the door, avoided in time:", fig, doc.get("stands"), doc.get("waypoints"))
    assert fig["obstacle"] == "Door" and fig["least_distance_m"] > 0.05 and fig["frames_touching"] == 0, fig
    assert doc["stands"] and doc["quality"]["goal"]["distance_m"] <= 0.3
    # (it goes through once the door is open: the body crosses the wall after frame 200)
    body = np.array(doc["synthesis"]["body"]["position"])
    through = doc["frame_start"] + int(np.argmax(body[:, 0] > 0.0))
    assert through > 200, through

    # the saved file as Blender plays it: the same figure against the door
    assert _played_obstacle(fp, str(tmp_path / "door.blend"), a.name, "Door", doc)[2] == fig

    # the cart that slides onto the way, in time: kept clear of
    scene, a, b = _crossing(fp)
    bpy.data.objects.remove(b)
    obst = ss._collection(scene, "Obstacles", "OBSTACLE")
    cart = ss._box(obst, "Cart", -0.5, 0.5, -0.5, 0.5, 0.0, 1.0)
    for frame, y in ((1, -3.0), (60, 0.0), (400, 0.0)):
        cart.location = (0.0, y, 0.0)
        cart.keyframe_insert("location", frame=frame)
    scene.frame_set(1)
    goal, heading = planning.goal_of(scene, "GoalA")
    doc = planning.run(scene, a, goal, heading, scene.objects["StartA"], Settings(avoid_characters=True),
                       name="walk A", frame_start=1)
    (fig,) = doc["quality"]["moving_obstacles"]
    print("A against the cart, avoided in time:", fig)
    assert fig["least_distance_m"] > 0.05 and fig["frames_touching"] == 0, fig
    assert doc["quality"]["goal"]["distance_m"] <= 0.3


@needs_cmu
def test_a_job_list_planned_together_keeps_the_bodies_apart_as_played(fp, tmp_path):
    """The crossing as one shot (``bake --job --together``): CMU's real capture, planned
    after the sample character, goes round it in time. As Blender plays the saved scene the
    bodies never touch (they kept a clearance apart where they crossed: they met above) and
    no foot of either stands where the other's does; the first job is planned as alone
    (the same footprints as without ``--together``)."""
    import bpy

    a, b, doc_a, doc_b, out, _ = _job_list(fp, tmp_path, None, "--together")
    names = a, b
    alone = _bake(fp, _crossing(fp)[0], bpy.context.scene.objects[names[0]], "A")
    assert doc_a["footprints"] == alone["footprints"]
    (fig,) = doc_b["quality"]["others"]
    print("B against A, planned together:", fig, doc_b["plan"]["search"] if "plan" in doc_b else "")
    assert fig["character"] == names[0]
    # (planned a clearance apart, 0.15 m, with half a second's slack either way in time)
    assert fig["least_distance_m"] > 0.1 and fig["frames_overlapping"] == 0, fig
    assert fig["frames_on_one_footprint"] == 0, fig
    assert doc_b["quality"]["goal"]["distance_m"] <= 0.3
    # measured at the end in the shot's one pass: the first job against the later one too
    (back,) = doc_a["quality"]["others"]
    assert back["character"] == names[1]
    assert {k: v for k, v in back.items() if k != "character"} == {k: v for k, v in fig.items() if k != "character"}

    # the saved scene as Blender plays it: the same, from the bodies read there
    bodies, first = _played_pair(fp, out, doc_b, (names[1], names[0]))
    again = import_module(fp.__name__ + ".core.report.crowd").pair_figures(bodies[0], bodies[1], first)
    assert again == fig

    # the shot's review sheet: the top view has each character's footprints in its colour
    review = import_module(fp.__name__ + ".blender.command.review")
    scene = bpy.context.scene
    shot = [(scene.objects[names[0]], doc_a), (scene.objects[names[1]], doc_b)]
    sheet = review.crowd_sheet(scene, shot, str(tmp_path), "shot", [fig["least_distance_frame"]])
    for k, doc in enumerate((doc_a, doc_b)):  # (what the top view drew: its objects' colours)
        drawn = bpy.data.collections[f"Footprints (demo) {k + 1}"].objects
        prints = [o for o in drawn if o.name.startswith("footprint")]
        assert len(prints) == len(doc["footprints"])
        tint = np.array(review.PALETTE[k])
        for o, f in zip(sorted(prints, key=lambda o: o.name), doc["footprints"]):
            assert np.allclose(o.color[:3], tint * (0.65 if f["foot"] == "R" else 1.0), atol=1e-6)
    for png in ("shot_top.png", f"shot_frame{fig['least_distance_frame']:04d}.png", "shot_review.png"):
        assert (tmp_path / png).stat().st_size > 10_000, png
    assert sheet == str(tmp_path / "shot_review.png")


@needs_cmu
def test_head_on_in_a_corridor_one_stands_aside_and_lets_the_other_through(fp, tmp_path):
    """Head-on in a passage 0.7 m wide (no room to pass in it: two bodies need 0.55 m
    between their middles), planned together: CMU's capture, planned after the sample
    character, stands in its square (at its start, or on the way with the other foot
    brought beside) until the passage is clear, then goes through. As Blender plays the
    saved scene the bodies never touch and no foot stands on the other's footprint; both
    reach their goals."""
    a, b, doc_a, doc_b, out, _ = _job_list(fp, tmp_path, None, "--together", scene=_corridor)
    (fig,) = doc_b["quality"]["others"]
    print("B against A in the corridor:", fig, doc_b["search"], doc_b.get("waypoints"))
    assert fig["least_distance_m"] > 0.1 and fig["frames_overlapping"] == 0, fig
    assert fig["frames_on_one_footprint"] == 0, fig
    # (it stood: at the start, or on the way, a stop of the report's waypoints)
    (stand,) = doc_b["stands"]
    rows = doc_b["waypoints"]
    if stand["at_start"]:
        assert rows[0]["waited"] == stand["pause"] > 0, rows
    else:
        assert rows[0]["name"] == "stand 1" and rows[0]["stops"] and rows[0]["pause"] == stand["pause"] > 0, rows
    assert "stands" not in doc_a
    for doc in (doc_a, doc_b):
        assert doc["quality"]["goal"]["distance_m"] <= 0.3
    bodies, first = _played_pair(fp, out, doc_b, (b, a))
    again = import_module(fp.__name__ + ".core.report.crowd").pair_figures(bodies[0], bodies[1], first)
    assert again == fig


def _square(fp):
    """A square 12 m across; four characters set off at once from the middles of its four
    sides for the opposite ones, through its middle: three sample characters and, from
    the south, CMU's real capture; and a fifth (a sample character) on a floor of its own
    20 m off. (scene, the characters' names in job order)."""
    import bpy

    bpy.ops.wm.read_homefile(use_empty=True)
    scene = bpy.context.scene
    scene.render.fps = FPS
    ss = import_module(fp.__name__ + ".blender.sample.sample_scenes")
    man = import_module(fp.__name__ + ".blender.sample.mannequin")
    ss._box(ss._collection(scene, "Traversable", "TRAVERSABLE"), "Square", -6.0, 6.0, -6.0, 6.0, -0.2, 0.0)
    names = []
    for k in range(4):
        ang = k * math.pi / 2  # (from the west walking east, then south, east and north)
        d = np.array([math.cos(ang), math.sin(ang), 0.0])
        ss._marker(scene, f"Start{k}", tuple(-5.0 * d), ang + math.pi / 2)
        ss._marker(scene, f"Goal{k}", tuple(5.0 * d), ang + math.pi / 2)
        ob = cmu_armature(fp) if k == 1 else man.add_to_scene(scene, f"Start{k}")[0]
        names.append(ob.name)
    ss._box(bpy.data.collections["Traversable"], "Far", 20.0, 32.0, -2.0, 2.0, -0.2, 0.0)
    ss._marker(scene, "Start4", (21.0, 0.0, 0.0), math.pi / 2)
    ss._marker(scene, "Goal4", (31.0, 0.0, 0.0), math.pi / 2)
    names.append(man.add_to_scene(scene, "Start4")[0].name)
    return scene, names


@needs_cmu
def test_four_characters_crossing_a_square_through_its_middle_keep_apart_and_arrive(fp, tmp_path):
    """Four characters crossing a square from its four sides through its middle, planned
    together from the command line (three sample characters and CMU's capture): as
    Blender plays the saved scene every one reaches its goal within 5 cm, no two bodies
    come within the clearance of each other at any frame, and no foot stands on another's
    footprint. A fifth, far from them, bakes the footprints it bakes alone."""
    import json

    import bpy

    scene, names = _square(fp)
    path = str(tmp_path / "square.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path)
    jobs = [{"character": n, "goal": f"Goal{k}", "start": f"Start{k}", "name": f"cross {k}",
             "report": str(tmp_path / f"r{k}.json")} for k, n in enumerate(names)]
    (tmp_path / "jobs.json").write_text(json.dumps(jobs))
    cli = import_module(fp.__name__ + ".blender.command.cli").cli_main
    assert cli(["bake", path, "--job", str(tmp_path / "jobs.json"), "--together", "--out",
                str(tmp_path / "baked.blend")]) == 0
    docs = [json.loads((tmp_path / f"r{k}.json").read_text()) for k in range(5)]
    far = docs.pop()
    assert min(o["least_distance_m"] for o in far["quality"]["others"]) > 10.0
    pairs = [(d["character"], o) for d in docs for o in d["quality"].get("others", [])
             if o["character"] != far["character"]]
    print("the square's pairs:", [(a, o["character"], o["least_distance_m"], o["least_distance_frame"])
                                  for a, o in pairs])
    # (measured in the shot's one pass, each job against every other: every pair twice, alike)
    assert len(pairs) == 12
    seen = {}
    for who, o in pairs:
        seen.setdefault(frozenset((who, o["character"])), []).append({k: v for k, v in o.items() if k != "character"})
    assert len(seen) == 6 and all(a == b for a, b in seen.values())
    clearance = import_module(fp.__name__ + ".core.base.settings").Settings().character_clearance
    for who, o in pairs:
        assert o["least_distance_m"] >= clearance and o["frames_overlapping"] == 0, (who, o)
        assert o["frames_on_one_footprint"] == 0, (who, o)
    for d in docs:
        assert d["quality"]["goal"]["distance_m"] <= 0.05, (d["character"], d["quality"]["goal"])

    # the far one, baked again alone (round no one) over its bake: the same footprints
    bpy.ops.wm.open_mainfile(filepath=str(tmp_path / "baked.blend"))
    scene = bpy.context.scene
    planning = import_module(fp.__name__ + ".blender.planning")
    goal, heading = planning.goal_of(scene, "Goal4")
    alone = planning.run(scene, scene.objects[names[4]], goal, heading, scene.objects["Start4"], name="cross 4",
                         frame_start=1)
    assert far["footprints"] == alone["footprints"]


def _crossing_by_a_pillar(fp):
    """The crossing with two sample characters and a pillar off their ways, in a collection
    of its own and not tagged (a job list names it an obstacle)."""
    scene, a, b = _crossing(fp)
    ss = import_module(fp.__name__ + ".blender.sample.sample_scenes")
    props = ss._collection(scene, "Props", "NONE")
    ss._box(props, "Pillar", 5.5, 6.0, 5.5, 6.0, 0.0, 2.0)
    return scene, a, b


def test_a_job_list_together_with_an_obstacle_named_for_the_run_bakes_and_measures_each_pair(fp, tmp_path):
    """``--together --obstacles Pillar``: an object named an obstacle for the run (not
    tagged) stands in the shot's one measure like a tagged one; both jobs bake, and each
    report has the other character's figures."""
    a, b, doc_a, doc_b, _, _ = _job_list(fp, tmp_path, None, "--together", "--obstacles", "Pillar",
                                         scene=_crossing_by_a_pillar)
    assert [o["character"] for o in doc_a["quality"]["others"]] == [b]
    assert [o["character"] for o in doc_b["quality"]["others"]] == [a]
    assert doc_b["quality"]["others"][0]["frames_overlapping"] == 0
    assert "moving_obstacles" not in doc_a["quality"]  # (the pillar stands)


def _played_obstacle(fp, path: str, name: str, obstacle: str, doc: dict):
    """(the body of character ``name``, the obstacle's world matrices (F, 4, 4), its
    ``crowd.obstacle_figures``) as Blender plays the scene saved (a copy) at ``path`` over
    the frames of the report ``doc``."""
    import bpy

    bpy.ops.wm.save_as_mainfile(filepath=path, copy=True)
    bpy.ops.wm.open_mainfile(filepath=path)
    scene = bpy.context.scene
    bake = import_module(fp.__name__ + ".blender.write.bake")
    crowd = import_module(fp.__name__ + ".core.report.crowd")
    read = import_module(fp.__name__ + ".blender.read.scene")
    surfaces = import_module(fp.__name__ + ".blender.read.surfaces")
    first, n = doc["frame_start"], doc["frame_end"] - doc["frame_start"] + 1
    ob, thing = scene.objects[name], scene.objects[obstacle]
    rig = read.rig_from_armature(ob)
    (played,), (moved,) = bake.played_matrices(scene, [(ob, rig)], first, n, [thing])
    me = crowd.body_of(name, rig, bake.played_world(*played), FPS)
    local = surfaces.BvhGround(surfaces.local_mesh(obstacle, thing.evaluated_get(bpy.context.evaluated_depsgraph_get())))
    return me, moved, crowd.obstacle_figures(me, obstacle, local, moved, first)


def _job_list(fp, tmp_path, capsys, *flags, scene=None):
    """The crossing (the sample character A, CMU's capture B), or ``scene`` (a function of
    ``fp`` giving the scene, A and B), saved and baked from the command line as a job list,
    A first: (A's name, B's, A's report, B's, the baked scene's path, what the command
    printed)."""
    import json

    import bpy

    scene, a, b = _crossing(fp, cmu_b=True) if scene is None else scene(fp)
    names = a.name, b.name  # (the objects go when the command line opens the file)
    path = str(tmp_path / "shot.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path)
    jobs = tmp_path / "jobs.json"
    jobs.write_text(json.dumps([
        {"character": names[0], "goal": "GoalA", "start": "StartA", "name": "walk A", "report": str(tmp_path / "a.json")},
        {"character": names[1], "goal": "GoalB", "start": "StartB", "name": "walk B", "report": str(tmp_path / "b.json")},
    ]))
    out = str(tmp_path / "baked.blend")
    cli = import_module(fp.__name__ + ".blender.command.cli").cli_main
    if capsys is not None:
        capsys.readouterr()
    assert cli(["bake", path, "--job", str(jobs), *flags, "--out", out]) == 0
    said = capsys.readouterr().out if capsys is not None else ""
    doc_a, doc_b = (json.loads((tmp_path / n).read_text()) for n in ("a.json", "b.json"))
    return *names, doc_a, doc_b, out, said


def _played_pair(fp, out: str, doc: dict, names) -> tuple[list, int]:
    """The bodies (``crowd.body_of``) of the two characters ``names`` as Blender plays the
    saved scene ``out`` over the frames of the report ``doc``, and its first frame."""
    import bpy

    bpy.ops.wm.open_mainfile(filepath=out)
    scene = bpy.context.scene
    first, n = doc["frame_start"], doc["frame_end"] - doc["frame_start"] + 1
    return played_bodies(fp, scene, [scene.objects[n_] for n_ in names], first, n), first
