"""The cases of the fuzz campaign (``benchmarks/fuzz.py``, issue 13), generated from a seed.

A case is pure data (``Case``): a command line, the files to lay out before it runs
(``setup``, operations on paths relative to the case's working folder), and the outputs
the command owns (it may write them when it succeeds, and nothing else). The same
(kind, seed, index) always gives the same case: ``make_case("bake", 1, 42)``; its id is
``bake-1-42``.

Base scenes are built once per run by ``build_pool`` (in a Blender subprocess, see
``fuzz.py``) from ``scene_spec(seed, j)``: random floor plates, walls, gaps, steps,
islands, goal and start empties on and off the surfaces, the sample character scaled,
turned and moved. The pool also holds the Turns sample scene with the sample character
(``@sample``, a scene where plans succeed), a good BVH file (the mannequin's walk,
``@bvh``), and a good plan report (``@report``).

``materialise`` lays a case's files out. Paths in a case's ``argv`` and ``setup`` (and in
the text of files it writes) may hold ``{root}`` (the case folder) and ``{work}`` (its
working folder, the command's cwd); ``../other`` is a sibling folder inside the case
folder, so everything a case points at is inside it and compared.
"""

from __future__ import annotations

import json
import math
import os
import random
import re
import shutil
import stat
import subprocess
from dataclasses import asdict, dataclass, field

CHAR = "Footstep Mannequin"
#: bump when the scene builder changes: the pool is cached under this version
POOL_VERSION = 3


@dataclass
class Ctx:
    """What the generators may rely on: the run's seed (the scene pool's), the pool's
    size, whether ``chattr +i`` works here (else the variants needing it fall back)."""
    seed: int = 1
    pool: int = 20
    immutable: bool = True


@dataclass
class Case:
    id: str
    kind: str
    argv: list
    setup: list = field(default_factory=list)
    owned: list = field(default_factory=list)       # files the command may write on success
    owned_dirs: list = field(default_factory=list)  # folders it may fill on success
    job_owned: dict = field(default_factory=dict)   # job number -> its files (bake --job)
    note: str = ""
    timeout: float = 120.0
    expect: str = ""  # "ok": the command must succeed; "fail": it must not; "": either

    @property
    def batch(self) -> bool:
        return "--job" in self.argv

    def needs(self) -> set:
        """The pool items the setup copies (``@scene:SEED:J``, ``@sample``, ``@sacred:VARIANT``, ``@bvh``,
        ``@cmu``, ``@report``)."""
        return {op[1] for op in self.setup if op[0] in ("copy", "bvh") and op[1].startswith("@")}

    def to_dict(self) -> dict:
        return asdict(self)


def pick(rng: random.Random, options):
    return options[rng.randrange(len(options))]


def chance(rng: random.Random, p: float) -> bool:
    return rng.random() < p


# ============================================================== scene specs (pure)

def _plate(name, x0, x1, y0, y1, top, tag="TRAVERSABLE"):
    return {"name": name, "box": [x0, x1, y0, y1, top - 0.3, top], "tag": tag}


def _inside(rng, plate, z_extra=0.0):
    x0, x1, y0, y1, _, top = plate["box"]
    return [rng.uniform(x0 + 0.3, x1 - 0.3), rng.uniform(y0 + 0.3, y1 - 0.3), top + z_extra]


def _floors(rng) -> tuple[list, float, float, float]:
    """The floor, perhaps a plate beyond a gap (a step up or down), steps, an island and
    an untagged plate."""
    w, d, z0 = rng.uniform(3, 12), rng.uniform(3, 10), pick(rng, [0.0, 0.0, 0.0, 0.5, -1.0])
    plates = [_plate("Floor", -2, w, -d / 2, d / 2, z0)]
    if chance(rng, 0.6):
        gap, dz = rng.uniform(0.2, 2.5), pick(rng, [0.0, 0.0, 0.15, 0.3, -0.3, 0.6])
        plates.append(_plate("Far", w + gap, w + gap + rng.uniform(2, 6), -d / 4, d / 4, z0 + dz))
    for k in range(rng.randrange(3)):
        x, y = rng.uniform(0, w - 1), rng.uniform(-d / 2, d / 2 - 1)
        plates.append(_plate(f"Step{k}", x, x + 1, y, y + 1, z0 + rng.uniform(0.05, 0.45)))
    if chance(rng, 0.5):
        plates.append(_plate("Island", w + 15, w + 18, -1.5, 1.5, z0))
    if chance(rng, 0.3):
        plates.append(_plate("Untagged", -2, w, d / 2 + 0.1, d / 2 + 3, z0, tag=""))
    return plates, w, d, z0


def _walls(rng, w, d, z0) -> list:
    walls = []
    for k in range(rng.randrange(4)):
        x, y, length = rng.uniform(0.5, w), rng.uniform(-d / 2, d / 2), rng.uniform(1, 4)
        along_x = chance(rng, 0.5)
        x1, y1 = (x + length, y + 0.2) if along_x else (x + 0.2, y + length)
        walls.append({"name": f"Wall{k}", "box": [x, x1, y, y1, z0, z0 + rng.uniform(0.3, 2.5)]})
    return walls


def _markers(rng, plates, walls, w, d, z0) -> dict:
    """name -> [x, y, z, z rotation]: Start and Goal on surfaces, and extras on and off."""
    tagged = [p for p in plates if p["tag"] and p["name"] != "Island"]
    rot = lambda: rng.uniform(-math.pi, math.pi)  # noqa: E731
    m = {"Start": [0.0, 0.0, z0, rot()], "Goal": _inside(rng, pick(rng, tagged)) + [rot()]}
    extras = {
        "GoalOff": [w + 30.0, d, z0, rot()], "GoalAir": _inside(rng, plates[0], 3.0) + [rot()],
        "StartOff": [-6.0, 0.0, z0, rot()], "Ziel ✓ ü": _inside(rng, plates[0]) + [rot()],
        "Goal ": _inside(rng, plates[0]) + [0.0]}
    if any(p["name"] == "Island" for p in plates):
        extras["GoalIsland"] = [w + 16.5, 0.0, z0, rot()]
    if walls:
        x0, x1, y0, y1, _, _ = walls[0]["box"]
        extras["GoalWall"] = [(x0 + x1) / 2, (y0 + y1) / 2, z0, rot()]
    for name in sorted(extras):
        if chance(rng, 0.7):
            m[name] = extras[name]
    return m


def _character(rng) -> dict:
    """Mostly as the user leaves it (on Start, turned about Z); else one hostile transform."""
    c = {"scale": [1, 1, 1], "tilt": 0.0, "offset": [0, 0, 0],
         "bare_armature": chance(rng, 0.3), "cube": chance(rng, 0.5)}
    if chance(rng, 0.35):
        key, value = pick(rng, [("scale", [0.5] * 3), ("scale", [2] * 3), ("scale", [1, 1, 1.5]),
                                ("scale", [-1, 1, 1]), ("scale", [0.01] * 3), ("scale", [100] * 3),
                                ("tilt", 0.3), ("tilt", math.pi), ("offset", [0.3, 0, 0]),
                                ("offset", [0, 0, 1]), ("offset", [50, 50, 0])])
        c[key] = value
    return c


def scene_spec(seed: int, j: int) -> dict:
    """Base scene ``j`` of the pool of run ``seed`` (pure data; ``build_scene`` makes it)."""
    rng = random.Random(f"scene:{seed}:{j}")
    plates, w, d, z0 = _floors(rng)
    walls = _walls(rng, w, d, z0)
    return {"version": POOL_VERSION, "name": f"Fuzz {seed}.{j}", "fps": pick(rng, [24, 25, 30, 30, 60, 29.97]),
            "plates": plates, "walls": walls, "markers": _markers(rng, plates, walls, w, d, z0),
            "character": _character(rng)}


#: the Turns sample scene's names (``@sample``)
SAMPLE_SPEC = {"markers": {"Start": None, "Goal": None}, "plates": [{"name": "Path", "tag": "TRAVERSABLE"},
               {"name": "CurvedPlatform", "tag": "TRAVERSABLE"}], "walls": [],
               "character": {"cube": False, "bare_armature": False}}


# ============================================================== building the pool (bpy)

def _set_fps(scene, fps: float) -> None:
    scene.render.fps = max(1, int(round(fps)))
    scene.render.fps_base = scene.render.fps / fps


def build_scene(spec: dict, path: str) -> None:
    """Build ``spec`` in a new empty file and save it at ``path`` (needs the add-on
    registered)."""
    import bpy

    from footstep_planner.blender.sample import sample_scenes as ss
    bpy.ops.wm.read_homefile(use_empty=True)
    scene = bpy.context.scene
    scene.name = spec["name"]
    _set_fps(scene, spec["fps"])
    colls = {"TRAVERSABLE": ss._collection(scene, "Traversable", "TRAVERSABLE"),
             "OBSTACLE": ss._collection(scene, "Obstacles", "OBSTACLE")}
    colls[""] = bpy.data.collections.new("Props")
    scene.collection.children.link(colls[""])
    for p in spec["plates"]:
        ss._box(colls[p["tag"]], p["name"], *p["box"])
    for wall in spec["walls"]:
        ss._box(colls["OBSTACLE"], wall["name"], *wall["box"])
    for name, (x, y, z, rot) in spec["markers"].items():
        ss._marker(scene, name, (x, y, z), rot)
    _place_character(scene, spec["character"])
    bpy.ops.wm.save_as_mainfile(filepath=path, compress=True)


def _place_character(scene, c: dict) -> None:
    import bpy

    from footstep_planner.blender.sample import mannequin
    ob, _ = mannequin.add_to_scene(scene, "Start")
    ob.scale = c["scale"]
    ob.rotation_euler.x = c["tilt"]
    ob.location = [a + b for a, b in zip(ob.location, c["offset"])]
    if c["bare_armature"]:
        scene.collection.objects.link(bpy.data.objects.new("Bare", bpy.data.armatures.new("Bare")))
    if c["cube"]:
        me = bpy.data.meshes.new("Cube")
        me.from_pydata([(0, 0, 0), (1, 0, 0), (0, 1, 0)], [], [(0, 1, 2)])
        scene.collection.objects.link(bpy.data.objects.new("Cube", me))


def build_sample(path: str, report: str) -> None:
    """The Turns sample scene with the sample character, saved at ``path``, and a good plan
    report of it at ``report`` (made with the planner's API, not the CLI under test)."""
    import bpy

    from footstep_planner.blender.sample import mannequin, sample_scenes
    from footstep_planner.blender import planning
    from footstep_planner.core.report.document import plan_report
    from footstep_planner.core.base.settings import Settings

    bpy.ops.wm.read_homefile(use_empty=True)
    scene = sample_scenes.build("turns")
    _set_fps(scene, 30)
    ob, _ = mannequin.add_to_scene(scene, "Start")
    bpy.ops.wm.save_as_mainfile(filepath=path, compress=True)
    position, heading = planning.goal_of(scene, "Goal")
    planned = planning.plan_and_synthesize(scene, ob, position, heading, scene.objects["Start"], Settings())
    with open(report, "w", encoding="utf-8") as fh:
        json.dump(plan_report(planned.result, planned.synthesis, ob.name, position, scene.frame_current), fh)


def build_bvh(path: str) -> None:
    """The mannequin's walk clip exported as a BVH file (small, with feet: a good clip)."""
    import bpy

    from footstep_planner.blender.sample import mannequin
    bpy.ops.wm.read_homefile(use_empty=True)
    scene = bpy.context.scene
    _set_fps(scene, 30)
    ob, _ = mannequin.build(scene.collection)
    acts = mannequin.generate_clips(ob, names=["walk"])
    (ob.animation_data or ob.animation_data_create()).action = acts[0]
    start, end = (int(f) for f in acts[0].frame_range)
    bpy.context.view_layer.objects.active = ob
    ob.select_set(True)
    bpy.ops.export_anim.bvh(filepath=path, frame_start=start, frame_end=end, global_scale=100.0)


def _sacred_tweak(scene, ob) -> None:
    ad = ob.animation_data
    tr = ad.nla_tracks["User layer"]
    ad.nla_tracks.active = tr
    tr.strips[0].select = True
    ad.use_tweak_mode = True


def _sacred_parent(scene, ob) -> None:
    import bpy

    e = bpy.data.objects.new("Dolly", None)
    scene.collection.objects.link(e)
    ob.parent = e
    e.keyframe_insert("location", frame=1)
    e.location.x = 3.0
    e.keyframe_insert("location", frame=100)


def _sacred_constraint(kind, bone=None):
    def make(scene, ob):
        c = (ob.pose.bones[bone] if bone else ob).constraints.new(kind)
        c.target = scene.objects["Goal"]
    return make


def _sacred_driver(scene, ob) -> None:
    ob.driver_add("location", 0).driver.expression = "4.0"


def _sacred_collection(scene, ob) -> None:
    import bpy

    coll = bpy.data.collections.new(f"Footprints: {ob.name}")
    scene.collection.children.link(coll)
    coll.objects.link(bpy.data.objects.new("FP 000 L", None))


#: issue 26's scene states (``build_sacred``): variant -> (what it does to the sample
#: scene, what the bake must do: "ok" succeed, "fail" be refused)
SACRED = {
    "plain": (lambda scene, ob: None, "ok"),
    "user_fp_markers": (lambda scene, ob: None, "ok"),
    "user_collection": (_sacred_collection, "ok"),
    "beyond_360": (lambda scene, ob: setattr(ob.rotation_euler, "z", ob.rotation_euler.z + 4 * math.pi), "ok"),
    "tweak_mode": (_sacred_tweak, "fail"),
    "animated_parent": (_sacred_parent, "fail"),
    "copy_location": (_sacred_constraint("COPY_LOCATION"), "fail"),
    "child_of": (_sacred_constraint("CHILD_OF"), "fail"),
    "ik_on_shin": (_sacred_constraint("IK", "shin.L"), "fail"),
    "time_remap": (lambda scene, ob: setattr(scene.render, "frame_map_new", 200), "fail"),
    "solo_track": (lambda scene, ob: setattr(ob.animation_data.nla_tracks["User layer"], "is_solo", True), "fail"),
    "driven_location": (_sacred_driver, "fail"),
}


def lived_in(scene, ob) -> None:
    """The sample scene's character as an animator leaves it: its "idle" clip active, a
    muted NLA layer of their own ("User layer", the walk), markers of their own (one
    named like the planner's)."""
    import bpy

    ad = ob.animation_data_create()
    ad.action = bpy.data.actions["idle"]
    ad.action_slot = ad.action.slots[0]
    tr = ad.nla_tracks.new()
    tr.name = "User layer"
    tr.strips.new("wave", 1, bpy.data.actions["walk"]).action_slot = bpy.data.actions["walk"].slots[0]
    tr.mute = True
    scene.timeline_markers.new("FP review", frame=12)
    scene.timeline_markers.new("FP 0 L", frame=40)


def build_sacred(variant: str, path: str) -> None:
    """The sample scene as an animator leaves it (a clip active, a muted NLA layer of their
    own, markers of their own, one named like the planner's), then ``SACRED[variant]``."""
    import bpy

    from footstep_planner.blender.sample import mannequin, sample_scenes
    bpy.ops.wm.read_homefile(use_empty=True)
    scene = sample_scenes.build("turns")
    _set_fps(scene, 30)
    ob, _ = mannequin.add_to_scene(scene, "Start")
    lived_in(scene, ob)
    SACRED[variant][0](scene, ob)
    bpy.ops.wm.save_as_mainfile(filepath=path, compress=True)


def build_pool(items: list) -> None:
    """The pool worker: each item {"what": "scene"|"sample"|"sacred"|"bvh", "path", ...}."""
    from footstep_planner import register

    register()
    for it in items:
        if it["what"] == "scene":
            build_scene(it["spec"], it["path"])
        elif it["what"] == "sample":
            build_sample(it["path"], it["report"])
        elif it["what"] == "sacred":
            build_sacred(it["variant"], it["path"])
        else:
            build_bvh(it["path"])


# ============================================================== outputs and inputs

@dataclass
class Arg:
    """A path given to the command (``arg``), the files laid out for it (``ops``), and a
    note naming the variant."""
    arg: str
    ops: list = field(default_factory=list)
    note: str = ""
    timeout: float | None = None


def _locked_dir(ctx, ext):
    if not ctx.immutable:
        return Arg(f"blocker/out{ext}", [("text", "blocker", "a file in the way")], "under a file (no chattr)")
    return Arg(f"locked/out{ext}", [("dir", "locked"), ("immutable", "locked")], "in an immutable folder")


def _locked_file(ctx, ext):
    if not ctx.immutable:
        return Arg(f"blocker/a/b/out{ext}", [("text", "blocker", "x")], "deep under a file (no chattr)")
    return Arg(f"locked{ext}", [("text", f"locked{ext}", "old"), ("immutable", f"locked{ext}")],
                "over an immutable file")


#: hostile output paths: name -> (rng, ext, ctx) -> Arg
HOSTILE_OUTPUTS = {
    "unicode": lambda r, e, c: Arg(f"Ausgabe ✓ ü/ñame mit Leerzeichen{e}"),
    "dotdot": lambda r, e, c: Arg(f"../work/x/../out{e}"),
    "other_folder": lambda r, e, c: Arg(f"../other/out{e}", [("dir", "../other")]),
    "absolute": lambda r, e, c: Arg(f"{{work}}/abs{e}"),
    "name_250": lambda r, e, c: Arg("n" * (250 - len(e)) + e),
    "name_300": lambda r, e, c: Arg("n" * 300 + e),
    "path_5000": lambda r, e, c: Arg("/".join(["d" * 200] * 25) + f"/out{e}"),
    "under_file": lambda r, e, c: Arg(f"blocker/out{e}", [("text", "blocker", "a file in the way")]),
    "deep_under_file": lambda r, e, c: Arg(f"blocker/a/b/out{e}", [("text", "blocker", "x")]),
    "proc": lambda r, e, c: Arg(f"/proc/self/fuzz_out{e}"),
    "sys": lambda r, e, c: Arg(f"/sys/kernel/fuzz_out{e}"),
    "locked_dir": lambda r, e, c: _locked_dir(c, e),
    "locked_file": lambda r, e, c: _locked_file(c, e),
    "is_dir": lambda r, e, c: Arg(f"outdir{e}", [("dir", f"outdir{e}")]),
    "trailing_slash": lambda r, e, c: Arg("newdir/"),
    "fifo": lambda r, e, c: Arg(f"pipe{e}", [("fifo", f"pipe{e}")], timeout=30),
    "dev_null": lambda r, e, c: Arg(f"null{e}", [("device", f"null{e}")], timeout=30),
    "symlink_other": lambda r, e, c: Arg(f"link{e}", [("text", "target.txt", "keep me"),
                                                       ("symlink", "target.txt", f"link{e}")]),
    "symlink_dangling": lambda r, e, c: Arg(f"dangle{e}", [("symlink", "nowhere/x", f"dangle{e}")]),
    "symlink_loop": lambda r, e, c: Arg(f"loop{e}", [("symlink", f"loop{e}", f"loop{e}")]),
    "symlink_dir": lambda r, e, c: Arg(f"linkdir/out{e}", [("dir", "../other/real"),
                                                            ("symlink", "../other/real", "linkdir")]),
    "empty": lambda r, e, c: Arg(""),
    "wrong_ext": lambda r, e, c: Arg("out.txt"),
    "upper_ext": lambda r, e, c: Arg(f"OUT{e.upper()}"),
    "newline": lambda r, e, c: Arg(f"a\nb{e}"),
    "dash": lambda r, e, c: Arg(f"-o{e}"),
    "dot_dash": lambda r, e, c: Arg(f"./-o{e}"),
}

PLAIN_OUTPUTS = {
    "new": lambda r, e, c: Arg(f"out{e}", note="new"),
    "new_folders": lambda r, e, c: Arg(f"new/sub/out{e}", note="new_folders"),
    "existing": lambda r, e, c: Arg(f"previous{e}", [("copy", "@sample", f"previous{e}") if e == ".blend"
                                                      else ("text", f"previous{e}", '{"good": true}')], "existing"),
}


def output_path(rng, ext: str, ctx: Ctx, hostile: float = 0.5) -> Arg:
    """A path for an output file ending in ``ext``: plain, or (with probability
    ``hostile``) one of ``HOSTILE_OUTPUTS``."""
    table = HOSTILE_OUTPUTS if chance(rng, hostile) else PLAIN_OUTPUTS
    name = pick(rng, sorted(table))
    p = table[name](rng, ext, ctx)
    p.note = p.note or name
    return p


def alias(rng, target: str) -> Arg:
    """Another spelling of the existing input ``target`` (relative to the working folder):
    the same string, ./, absolute, through .., a symbolic link (or two), a hard link."""
    base = target.rsplit("/", 1)[-1]
    spellings = {
        "same": Arg(target),
        "dot": Arg(f"./{target}"),
        "absolute": Arg(f"{{work}}/{target}"),
        "dotdot": Arg(f"../work/sub/../{target}", [("dir", "sub")]),
        "symlink": Arg(f"alias_{base}", [("symlink", target, f"alias_{base}")]),
        "hardlink": Arg(f"hard_{base}", [("hardlink", target, f"hard_{base}")]),
        "symlink_chain": Arg(f"a2_{base}", [("symlink", target, f"a1_{base}"),
                                            ("symlink", f"a1_{base}", f"a2_{base}")]),
    }
    name = pick(rng, sorted(spellings))
    p = spellings[name]
    p.note = f"alias:{name}"
    return p


# ============================================================== scene options (plan, bake)

def pool_scene(rng, ctx: Ctx, sample: float = 0.25) -> tuple[str, dict]:
    """(pool key, spec): a random base scene, or the sample scene."""
    if chance(rng, sample):
        return "@sample", SAMPLE_SPEC
    j = rng.randrange(ctx.pool)
    return f"@scene:{ctx.seed}:{j}", scene_spec(ctx.seed, j)


def character_arg(rng, spec: dict, bad: bool) -> str:
    if not bad:
        return CHAR
    return pick(rng, ["Nobody", "Goal", "", CHAR.lower(), CHAR + " ", "Bare" if spec["character"]["bare_armature"]
                      else "Cube", "Cube" if spec["character"]["cube"] else "Floor"])


def goal_args(rng, spec: dict, bad: str) -> list:
    """--goal and --start (markers of the scene, or with ``bad`` == "goal"/"start" other
    names), and with ``bad`` == "heading"/"tags" a hostile --goal-heading or tag list."""
    markers = sorted(spec["markers"])
    goal = pick(rng, ["Goal"] * 4 + markers + [None])
    if bad == "goal":
        goal = pick(rng, ["Nowhere", "", "Start", CHAR, spec["plates"][0]["name"]])
    start = pick(rng, [None, "Start", "Start"] + [m for m in markers if "Start" in m])
    if bad == "start":
        start = pick(rng, ["Nowhere", "Goal", "", CHAR])
    args = ([] if goal is None else ["--goal", goal]) + ([] if start is None else ["--start", start])
    if chance(rng, 0.2) or bad == "heading":
        args += ["--goal-heading", pick(rng, ["90", "-180", "720", "-0"] if bad != "heading" else
                                        ["1e300", "nan", "inf", "abc", "1e-320", "", "1e400"])]
    if bad == "tags":
        flag = pick(rng, ["--traversable", "--obstacles"])
        args += [flag, pick(rng, ["Untagged", "Floor,Untagged", ",,", "Nowhere", "Ziel ✓ ü", "Cube", CHAR, "Floor",
                                  "Wall0", "Floor,Floor", "Path", ""])]
    return args


GOOD_SETTINGS = ["goal_radius=0.5", "max_expansions=5000", "turn_penalty=0.3", "smoothing_keep_arcs=false",
                 "heuristic_weight=3", "goal_heading_tolerance=1.0", "stand_hold=0", "refinement_iterations=0",
                 "smoothing_iterations=0", "tau_smoothing=0", "transition_time=0", "ik_iterations=0",
                 "speed_sigma=0.1", "contact_height=0.001", "bend_curvature=0", "goal_radius=100", "tau_dt=0.01",
                 "goal_heading_tolerance=0.01", "stand_hold=60", "heuristic_weight=100", "rigify_ik_feet=true",
                 "max_expansions=200000"]
BAD_SETTINGS = ["goal_radius=-1", "goal_radius=nan", "goal_radius=inf", "goal_radius=1e400", "goal_radius=",
                "goal_radius", "=", "=1", "nope=1", "max_expansions=0", "max_expansions=1", "max_expansions=1.5",
                "max_expansions=1e9", "smoothing_keep_arcs=maybe", "goal_radius=0.5=1", "GOAL_RADIUS=1",
                " goal_radius = 1 ", "goal_radius=1,5", "analysis_rate=1", "analysis_rate=10000",
                "goal_radius=\u0661", "ik_iterations=-1", "stand_hold=1e308", "refinement_iterations=1000"]


def setting_args(rng, bad: bool, p: float = 0.3) -> list:
    args = []
    while chance(rng, p) and len(args) < 6:
        args += ["--set", pick(rng, GOOD_SETTINGS)]
    if bad:
        args += ["--set", pick(rng, BAD_SETTINGS)]
    return args


def _with_output(case: Case, flag: str, p: Arg) -> None:
    """Add ``flag p.arg`` to the case, its files, its note and its ownership."""
    case.argv += [flag, p.arg]
    case.setup += p.ops
    case.owned.append(p.arg)
    case.note += f" {flag}:{p.note}"
    if p.timeout:
        case.timeout = min(case.timeout, p.timeout)


#: what is hostile in a plan or bake case (one thing at a time, or nothing)
ASPECTS = ["none", "none", "none", "character", "goal", "start", "heading", "settings", "tags", "output", "output",
           "options"]


def _scene_case(rng, ctx, cid, kind, verb) -> tuple[Case, str]:
    key, spec = pool_scene(rng, ctx)
    bad = pick(rng, ASPECTS if verb == "bake" else [a for a in ASPECTS if a != "options"])
    case = Case(cid, kind, [verb, "scene.blend", "--character", character_arg(rng, spec, bad == "character")],
                [("copy", key, "scene.blend")], note=f"{key} hostile:{bad}")
    case.argv += goal_args(rng, spec, bad) + setting_args(rng, bad == "settings")
    return case, bad


# ============================================================== the kinds

def gen_plan(rng, ctx, cid) -> Case:
    case, bad = _scene_case(rng, ctx, cid, "plan", "plan")
    if chance(rng, 0.5):
        case.argv.append("--json")
    if chance(rng, 0.5) or bad == "output":
        _with_output(case, "--report", output_path(rng, ".json", ctx, 0.9 if bad == "output" else 0.0))
    return case


def _bake_options(rng, bad: bool) -> list:
    values = {"--name": (["Walk ✓ ü", "x"], ["n" * 300, "", "a/b", "Footstep: x", "-", "\t"]),
              "--frame-start": (["1", "-100", "1000000", "0"], ["1000001", "abc", "1.5", "1e3"]),
              "--body-on": (["root", "object"], ["hips", "ROOT"])}
    args = []
    for flag, (good, hostile) in values.items():
        if chance(rng, 0.25):
            args += [flag, pick(rng, good)]
    if bad:
        flag = pick(rng, sorted(values))
        args += [flag, pick(rng, values[flag][1])]
    for flag, p in (("--markers", 0.3), ("--keep-frame-range", 0.2)):
        args += [flag] if chance(rng, p) else []
    return args


def gen_bake(rng, ctx, cid) -> Case:
    case, bad = _scene_case(rng, ctx, cid, "bake", "bake")
    case.argv += _bake_options(rng, bad == "options")
    hostile = 0.6 if bad == "output" else 0.0
    if chance(rng, 0.6):
        _with_output(case, "--out", output_path(rng, ".blend", ctx, hostile))
    if chance(rng, 0.5) or (bad == "output" and "--out" not in case.argv):
        _with_output(case, "--report", output_path(rng, ".json", ctx, hostile))
    return case


FAIL_CAUSES = [["--set", "max_expansions=1"], ["--goal", "Nowhere"], ["--start", "Nowhere"],
               ["--set", "goal_radius=-1"], ["--obstacles", "Path,CurvedPlatform"], ["--goal-heading", "nan"],
               ["--character", "Start"], ["--traversable", "Nowhere"], ["--frame-start", "1000001"]]


def gen_failed_bake(rng, ctx, cid) -> Case:
    """A plan or bake that fails (late or early) with --out and --report at previous good
    files: they must stay as they were."""
    verb = pick(rng, ["bake", "bake", "plan"])
    cause = pick(rng, FAIL_CAUSES if verb == "bake" else FAIL_CAUSES[:8])
    char = [] if "--character" in cause else ["--character", CHAR]
    case = Case(cid, "failed_bake", [verb, "scene.blend", *char, "--goal", "Goal", "--start", "Start", *cause],
                [("copy", "@sample", "scene.blend")], note=" ".join(cause))
    if verb == "bake":
        _with_output(case, "--out", PLAIN_OUTPUTS["existing"](rng, ".blend", ctx))
    _with_output(case, "--report", PLAIN_OUTPUTS["existing"](rng, ".json", ctx))
    return case


def _input_is_output_bake(rng, case) -> None:
    which = pick(rng, ["--out", "--report", "both_same", "job_report", "job_out", "job_file"])
    if not which.startswith("job"):
        case.argv += ["--character", CHAR, "--goal", "Goal"]
    if which in ("--out", "--report"):
        _with_output(case, which, alias(rng, "scene.blend"))
    elif which == "both_same":
        _with_output(case, "--out", Arg("same.blend", note="same"))
        _with_output(case, "--report", Arg(pick(rng, ["same.blend", "./same.blend", "{work}/same.blend"]), note="same"))
    else:
        target = alias(rng, "jobs.json" if which == "job_file" else "scene.blend")
        job = {"character": CHAR, "goal": "Goal", "start": "Start",
               "report" if which != "job_out" else "out": target.arg}
        case.setup += [("text", "jobs.json", json.dumps([job]))] + target.ops
        case.argv += ["--job", "jobs.json"]
        case.job_owned["1"] = [target.arg]
        case.note += f" {which}:{target.note}"


def gen_output_is_input(rng, ctx, cid) -> Case:
    """An output that is one of the inputs, however spelled: must be refused."""
    case = _output_is_input(rng, ctx, cid, pick(rng, ["plan", "bake", "bake", "import-clips", "import-clips", "plot"]))
    case.expect = "fail" if case.argv[0] != "plot" else ""
    return case


def _output_is_input(rng, ctx, cid, verb) -> Case:
    if verb == "import-clips":
        case = Case(cid, "output_is_input", ["import-clips", "clip.bvh"], [("bvh", "@bvh", "clip.bvh", "good")])
        if chance(rng, 0.5):
            case.setup.append(("copy", "@sample", "lib.blend"))
            case.argv += ["--blend", "lib.blend"]
            _with_output(case, "--out", alias(rng, "lib.blend"))
        else:
            _with_output(case, "--out", alias(rng, "clip.bvh"))
        return case
    if verb == "plot":
        case = Case(cid, "output_is_input", ["plot", "plots/r_tau.png", "--name", "r"],
                    [("dir", "plots"), ("copy", "@report", "plots/r_tau.png")], note="report named as a plot")
        _with_output(case, "--out", Arg(pick(rng, ["plots", "./plots/", "{work}/plots"])))
        case.owned_dirs, case.owned = case.owned, []
        return case
    case = Case(cid, "output_is_input", [verb, "scene.blend"], [("copy", "@sample", "scene.blend")])
    if verb == "plan":
        case.argv += ["--character", CHAR, "--goal", "Goal"]
        _with_output(case, "--report", alias(rng, "scene.blend"))
    else:
        _input_is_output_bake(rng, case)
    return case


UNWRITABLE = ["under_file", "deep_under_file", "proc", "sys", "locked_dir", "locked_file", "is_dir", "name_300",
              "path_5000", "fifo", "dev_null", "empty", "trailing_slash"]


def _unwritable(rng, ext, ctx) -> Arg:
    """A file (``ext``) or, without ``ext``, a folder that cannot be written ("" and a
    trailing slash are fine names for a folder, and a folder that is there already is
    written into: ``plot --out DIR`` and ``analyze --plot DIR`` take one)."""
    name = pick(rng, UNWRITABLE if ext else [u for u in UNWRITABLE if u not in ("empty", "trailing_slash", "is_dir")])
    p = HOSTILE_OUTPUTS[name](rng, ext, ctx)
    p.note = p.note or name
    return p


def gen_unwritable(rng, ctx, cid) -> Case:
    """Outputs that cannot be written (for root too): the command fails, the other outputs
    are not written either."""
    verb = pick(rng, ["plan", "bake", "bake", "import-clips", "analyze", "plot"])
    case = Case(cid, "unwritable", [verb], note=verb)
    if verb in ("plan", "bake"):
        case.argv += ["scene.blend", "--character", CHAR, "--goal", "Goal", "--start", "Start"]
        case.setup.append(("copy", "@sample", "scene.blend"))
        outs = [("--report", ".json")] + ([("--out", ".blend")] if verb == "bake" else [])
        bad = rng.randrange(len(outs))
        for k, (flag, ext) in enumerate(outs):
            _with_output(case, flag, _unwritable(rng, ext, ctx) if k == bad else PLAIN_OUTPUTS["new"](rng, ext, ctx))
    elif verb == "import-clips":
        case.argv.append("clip.bvh")
        case.setup.append(("bvh", "@bvh", "clip.bvh", "good"))
        _with_output(case, "--out", _unwritable(rng, ".blend", ctx))
    elif verb == "analyze":
        case.argv.append("clip.bvh")
        case.setup.append(("bvh", "@bvh", "clip.bvh", "good"))
        _with_output(case, "--plot", _unwritable(rng, "", ctx))
        case.owned_dirs, case.owned = case.owned, []
    else:
        case.argv.append("report.json")
        case.setup.append(("copy", "@report", "report.json"))
        _with_output(case, "--out", _unwritable(rng, "", ctx))
        case.owned_dirs, case.owned = case.owned, []
    case.expect = "fail"
    return case


# -- job lists

JOB_BAD = {
    "character": [5, "", "Nobody", "Goal", [CHAR], {"a": 1}, True, "Foot\u0000"],
    "goal": [["Goal"], [1, 2, 3], {"x": 1}, 5, "", "Nowhere", "Start"],
    "start": [3.5, "Nowhere", [], ""],
    "name": [5, "ü" * 300, "", "a/b", "\n", "\ud800"],
    "frame_start": ["abc", 1.5, float("inf"), 2000000, -5, True, "1"],
    "goal_heading": ["north", float("nan"), 1e7, [90], "90", True],
    "body_on": ["hips", 1, "ROOT", ""],
    "settings": [{"goal_radius": -1}, {"goal_radius": "abc"}, {"nope": 1}, [], "x", {"max_expansions": 1},
                 {"max_expansions": 1.5}, {"smoothing_keep_arcs": "yes"}, {"goal_radius": float("nan")},
                 {"goal_radius": None}, {"goal_radius": {"a": [1]}}],
    "colour": ["red"],
}

#: job "report"/"out" values that are not plain new files: (value, files laid out for it)
JOB_PATHS = [("", []), (5, []), ("scene.blend", []), ("jobs.json", []), ("blocker/r.json", [("text", "blocker", "x")]),
             ("/proc/self/r.json", []), ("x" * 300 + ".json", []), ("dup.json", []),
             ("../other/r.json", [("dir", "../other")]), ("out.blend", []), ("r.txt", [])]

JOB_FILES = ["not json", "", "[]", "{}", "null", "[1, 2]", "[[]]", "NaN", "[" * 100000 + "]" * 100000,
             "\ufeff[]", '[{"character": {"a": [1, {"b": [null, {"c": "\\ud800"}]}]}}]',
             json.dumps([{"character": 5}] * 2000), '[{"character": "Footstep Mannequin", "character": 5}]',
             '[{"character": "\\ud800"}]', '[{"name": "\\udcff", "character": 7}]']


def _good_job(rng, n: int) -> dict:
    """A good job; each of one character its own name and frames (two on one frame or of
    one name are refused as a list, issue 26: ``gen_sacred`` tries that)."""
    job = {"character": CHAR, "goal": "Goal", "start": "Start"}
    for key, value in (("name", f"hero {n} ✓"), ("frame_start", 3000 * n), ("goal_heading", 90),
                       ("body_on", "root"), ("settings", {"goal_radius": 0.5}), ("report", f"r{n}.json"),
                       ("out", f"o{n}.blend")):
        if chance(rng, 0.25) or key in ("name", "frame_start"):
            job[key] = value
    return job


def _spoil(rng, job: dict, case: Case) -> None:
    if chance(rng, 0.3):
        key = pick(rng, ["report", "out"])
        value, ops = pick(rng, JOB_PATHS)
        job[key] = value
        case.setup += ops
        return
    key = pick(rng, sorted(JOB_BAD))
    value = pick(rng, JOB_BAD[key])
    if value is None or (key == "character" and chance(rng, 0.1)):
        job.pop(key, None)
    else:
        job[key] = value


def _job_owned(case: Case, jobs: list, report: str | None) -> None:
    """Each job's files: its own report and out, or the report derived from --report."""
    for n, job in enumerate(jobs, 1):
        if not isinstance(job, dict):
            continue
        derived = (report if len(jobs) == 1 else f"{os.path.splitext(report)[0]}_{n}.json") if report else None
        own = [job.get("report") or derived, job.get("out")]
        case.job_owned[str(n)] = [p for p in own if isinstance(p, str) and p]


def gen_jobs(rng, ctx, cid) -> Case:
    """bake --job with job lists good and bad (fields of the wrong type, invalid JSON,
    outputs at inputs or at each other)."""
    case = Case(cid, "jobs", ["bake", "scene.blend", "--job", "jobs.json"], [("copy", "@sample", "scene.blend")])
    if chance(rng, 0.15):
        text = pick(rng, JOB_FILES)
        case.setup.append(("text", "jobs.json", text))
        case.note = f"job file: {text[:30]!r}"
        return case
    jobs = [_good_job(rng, n) for n in range(1, 1 + pick(rng, [1, 1, 2, 2, 3]))]
    for job in jobs:
        if chance(rng, 0.6):
            _spoil(rng, job, case)
    case.setup.append(("text", "jobs.json", json.dumps(jobs)))
    case.note = " | ".join(json.dumps(j, ensure_ascii=True)[:80] for j in jobs)
    report = None
    if chance(rng, 0.4):
        report = output_path(rng, ".json", ctx, 0.2)
        case.argv += ["--report", report.arg]
        case.setup += report.ops
        report = report.arg
    if chance(rng, 0.3):
        _with_output(case, "--out", output_path(rng, ".blend", ctx, 0.2))
    _job_owned(case, jobs, report)
    if chance(rng, 0.08):
        case.argv[case.argv.index("jobs.json")] = pick(rng, ["jobs_dir.json", "missing.json", "pipe.json",
                                                             "scene.blend"])
        case.setup += [("dir", "jobs_dir.json"), ("fifo", "pipe.json")]
        case.timeout = 30
    return case


# -- clip files

BVH_VARIANTS = ["good", "good", "good", "not_bvh", "bad_channels", "truncated_motion", "truncated_hierarchy",
                "not_a_number", "short_line", "unclosed", "empty", "nan_motion", "inf_motion", "big_motion",
                "nan_column", "nan_offset", "frames_too_many", "frames_negative", "frames_zero", "frame_time_zero",
                "frame_time_negative", "frame_time_nan", "frame_time_tiny", "one_frame", "crlf", "utf16", "bom",
                "binary", "latin1_name", "deep", "huge_channels", "dup_names", "no_motion", "zero_offsets",
                "huge_values", "long_line", "legless"]
#: clip "files" that are not BVH text: name -> files laid out for ``path``
SPECIAL_CLIPS = {"dir": lambda p: [("dir", p)], "missing": lambda p: [], "fifo": lambda p: [("fifo", p)],
                 "blend_as_bvh": lambda p: [("copy", "@sample", p)], "cmu": lambda p: [("copy", "@cmu", p)]}
CLIP_NAMES = ["clip{k}.bvh"] * 6 + ["Clip ✓ ü {k}.bvh", "clip{k}.BVH", "clip{k}.fbx", "clip{k}",
                                    "c{k}" + "n" * 240 + ".bvh", "sub dir/clip{k}.bvh"]


def clip_file(rng, k: int) -> Arg:
    """A clip file: good, broken (``BVH_VARIANTS``) or not a file at all."""
    name = pick(rng, CLIP_NAMES).format(k=k)
    ops = [("dir", "sub dir")] if name.startswith("sub dir/") else []
    if chance(rng, 0.12):
        special = pick(rng, sorted(SPECIAL_CLIPS))
        return Arg(name, ops + SPECIAL_CLIPS[special](name), special, 30 if special == "fifo" else None)
    variant = pick(rng, BVH_VARIANTS)
    return Arg(name, ops + [("bvh", "@bvh", name, variant)], variant)


def _clip_args(rng, case: Case, n_max: int = 3) -> list:
    clips = [clip_file(rng, k) for k in range(1 + rng.randrange(n_max))]
    for c in clips:
        case.argv.append(c.arg)
        case.setup += c.ops
        case.note += f" {c.note}"
        case.timeout = min(case.timeout, c.timeout or case.timeout)
    return clips


def gen_import_clips(rng, ctx, cid) -> Case:
    case = Case(cid, "import_clips", ["import-clips"])
    clips = _clip_args(rng, case)
    if chance(rng, 0.2):
        case.setup.append(("copy", "@sample", "lib.blend"))
        case.argv += ["--blend", "lib.blend"]
        if chance(rng, 0.5):
            case.argv += ["--into", pick(rng, [CHAR, "Nobody", "Goal", "Path"])]
    for flag, values in (("--name", ["Hero ✓", "", "n" * 300, CHAR]),
                         ("--fps", ["0", "-1", "nan", "1e-9", "1e9", "24", "119.88"]),
                         ("--scale", ["0.01", "0", "1e-30", "1e30", "inf"])):
        if chance(rng, 0.2):
            case.argv += [flag, pick(rng, values)]
    r = rng.random()
    out = Arg(clips[0].arg, note="out=clip") if r < 0.1 else Arg("lib.blend", note="out=--blend") if r < 0.2 \
        else output_path(rng, ".blend", ctx, 0.3)
    _with_output(case, "--out", out)
    return case


def gen_analyze(rng, ctx, cid) -> Case:
    case = Case(cid, "analyze", ["analyze"])
    if chance(rng, 0.7):
        _clip_args(rng, case, 2)
    if not case.argv[1:] or chance(rng, 0.15):
        key, spec = pool_scene(rng, ctx, 0.5)
        case.argv.append("scene.blend")
        case.setup.append(("copy", key, "scene.blend"))
        if chance(rng, 0.4):
            case.argv += ["--character", character_arg(rng, spec, chance(rng, 0.3))]
    if chance(rng, 0.5):
        case.argv.append("--json")
    if chance(rng, 0.2):
        case.argv += ["--clip", pick(rng, ["walk", "nope", "", "walk_turn_left_sharp"])]
    if chance(rng, 0.1):
        case.argv += ["--fps", pick(rng, ["1", "1e6", "24", "nan"])]
    case.argv += setting_args(rng, chance(rng, 0.15), 0.1)
    if chance(rng, 0.3):
        plots = pick(rng, [Arg("plots", note="new"),
                           Arg("plots", [("dir", "plots"), ("text", "plots/keep.txt", "keep")], "existing folder"),
                           Arg("Plöts ✓", note="unicode"), output_path(rng, "", ctx, 1.0)])
        _with_output(case, "--plot", plots)
        case.owned_dirs, case.owned = case.owned, []
    return case


# -- plot reports

REPORT_EDITS = ["good", "good", "not_json", "list", "empty_object", "no_synthesis", "null_synthesis", "drop_key",
                "null_key", "strings", "halve_lists", "nan_numbers", "empty_lists", "nested_garbage", "huge_numbers",
                "utf16", "binary", "deep"]


def gen_plot(rng, ctx, cid) -> Case:
    edit = pick(rng, REPORT_EDITS + ["dir", "missing", "fifo"])
    name = pick(rng, ["report.json"] * 4 + ["Bericht ✓.json", "report", "r" * 250 + ".json"])
    case = Case(cid, "plot", ["plot", name], note=edit)
    if edit in ("dir", "missing", "fifo"):
        case.setup += SPECIAL_CLIPS[edit](name)
        case.timeout = 30
    else:
        case.setup.append(("report", "@report", name, edit, rng.randrange(1000)))
    out = pick(rng, [Arg("plots", note="new"),
                     Arg("plots", [("dir", "plots"), ("garbage", "plots/report_tau.png", 100)],
                         "folder with an old plot"),
                     output_path(rng, "", ctx, 0.7)])
    _with_output(case, "--out", out)
    case.owned_dirs, case.owned = case.owned, []
    if chance(rng, 0.3):
        case.argv += ["--name", pick(rng, ["x", "Plan ✓", "../escape", "a" * 300, "", "-", "sub/x"])]
    return case


# -- paths and broken scenes

SCENE_PATHS = ["Szenen ✓/mit Leerzeichen ü.blend", "../other/scene.blend", "{work}/scene.blend", "sub/../scene.blend",
               "link.blend", "n" * 240 + ".blend", "./-scene.blend", "scene\nnewline.blend", "scene.BLEND", "scene",
               "hard.blend", ".hidden.blend", "deep/" * 40 + "scene.blend"]


def _scene_at(rng, case: Case) -> None:
    path = pick(rng, SCENE_PATHS)
    case.note += f" scene:{path[:40]!r}"
    if path in ("link.blend", "hard.blend"):
        case.setup += [("copy", "@sample", "real.blend"), ("symlink" if path == "link.blend" else "hardlink",
                                                           "real.blend", path)]
    else:
        case.setup += [("dir", "sub")] if path.startswith("sub/") else []
        case.setup.append(("copy", "@sample", path))
    case.argv[1] = path


VALID_HOSTILE = ["unicode", "dotdot", "other_folder", "absolute", "name_250", "symlink_other", "symlink_dangling",
                 "upper_ext", "newline", "dot_dash", "symlink_dir"]


def gen_paths(rng, ctx, cid) -> Case:
    """Valid but unusual names for the scene and the outputs: the command should work."""
    verb = pick(rng, ["plan", "plan", "bake"])
    case = Case(cid, "paths", [verb, "scene.blend", "--character", CHAR, "--goal", "Goal", "--start", "Start"],
                expect="ok")
    _scene_at(rng, case)
    outs = [("--report", ".json")] + ([("--out", ".blend")] if verb == "bake" else [])
    for flag, ext in outs:
        if chance(rng, 0.7):
            name = pick(rng, VALID_HOSTILE)
            p = HOSTILE_OUTPUTS[name](rng, ext, ctx)
            p.note = name
            _with_output(case, flag, p)
    return case


BROKEN_SCENES = {
    "missing": [], "dir": [("dir", "scene.blend")], "empty": [("text", "scene.blend", "")],
    "text": [("text", "scene.blend", "this is not a blend file\n")], "binary": [("garbage", "scene.blend", 5000)],
    "truncated_10": [("copy", "@sample", "scene.blend"), ("truncate", "scene.blend", 0.1)],
    "truncated_50": [("copy", "@sample", "scene.blend"), ("truncate", "scene.blend", 0.5)],
    "truncated_99": [("copy", "@sample", "scene.blend"), ("truncate", "scene.blend", 0.99)],
    "header_only": [("copy", "@sample", "scene.blend"), ("truncate", "scene.blend", 16)],
    "bvh": [("bvh", "@bvh", "scene.blend", "good")], "json": [("copy", "@report", "scene.blend")],
    "fifo": [("fifo", "scene.blend")], "loop": [("symlink", "scene.blend", "scene.blend")],
    "dangling": [("symlink", "gone.blend", "scene.blend")],
}


def gen_bad_scene(rng, ctx, cid) -> Case:
    """plan or bake of a scene file that is not one; previous results must stay."""
    broken = pick(rng, sorted(BROKEN_SCENES))
    verb = pick(rng, ["plan", "bake"])
    case = Case(cid, "bad_scene", [verb, "scene.blend", "--character", CHAR, "--goal", "Goal"],
                list(BROKEN_SCENES[broken]), note=broken, timeout=30 if broken == "fifo" else 120, expect="fail")
    _with_output(case, "--report", PLAIN_OUTPUTS["existing"](rng, ".json", ctx))
    if verb == "bake":
        _with_output(case, "--out", PLAIN_OUTPUTS["existing"](rng, ".blend", ctx))
    return case


def gen_sacred(rng, ctx, cid) -> Case:
    """Issue 26: a bake of the sample scene in a state animators leave scenes in; the ones
    that would bake wrong must be refused ("fail": never exit 0), the others bake; or a
    job list of two bakes of one character, at frames far apart (both bake) or on one
    frame (refused before any runs)."""
    variant = pick(rng, sorted(SACRED) + ["jobs_apart", "jobs_clash"])
    base = variant if variant in SACRED else "plain"
    case = Case(cid, "sacred", ["bake", "scene.blend"], [("copy", f"@sacred:{base}", "scene.blend")], note=variant,
                expect=SACRED[base][1] if variant in SACRED else ("ok" if variant == "jobs_apart" else "fail"))
    if variant.startswith("jobs"):
        second = 2000 if variant == "jobs_apart" else 1
        jobs = [{"character": CHAR, "goal": "Goal", "start": "Start", "name": "a", "frame_start": 1},
                {"character": CHAR, "goal": "Goal", "start": "Start", "name": "b", "frame_start": second}]
        case.setup.append(("text", "jobs.json", json.dumps(jobs)))
        case.argv += ["--job", "jobs.json"]
    else:
        case.argv += ["--character", CHAR, "--goal", "Goal", "--start", "Start"]
        case.argv += ["--markers"] if variant == "user_fp_markers" or chance(rng, 0.3) else []
    _with_output(case, "--out", PLAIN_OUTPUTS["existing"](rng, ".blend", ctx) if chance(rng, 0.5)
                 else Arg("baked.blend", note="new"))
    return case


KINDS = {"plan": gen_plan, "bake": gen_bake, "failed_bake": gen_failed_bake, "output_is_input": gen_output_is_input,
         "unwritable": gen_unwritable, "jobs": gen_jobs, "import_clips": gen_import_clips, "analyze": gen_analyze,
         "plot": gen_plot, "paths": gen_paths, "bad_scene": gen_bad_scene, "sacred": gen_sacred}


def make_case(kind: str, seed: int, index: int, ctx: Ctx | None = None) -> Case:
    """Case ``index`` of ``kind`` in run ``seed``: the same arguments, the same case."""
    ctx = ctx or Ctx(seed=seed)
    rng = random.Random(f"{kind}:{seed}:{index}")
    case = KINDS[kind](rng, ctx, f"{kind}-{seed}-{index}")
    case.note = case.note.strip()
    return case


def parse_id(cid: str) -> tuple[str, int, int]:
    kind, seed, index = cid.rsplit("-", 2)
    return kind, int(seed), int(index)


def generate(seed: int, n: int, kinds=None, ctx: Ctx | None = None) -> list[Case]:
    """``n`` cases, the kinds taken in turn."""
    kinds = list(kinds or KINDS)
    return [make_case(kinds[i % len(kinds)], seed, i // len(kinds), ctx) for i in range(n)]


# ============================================================== broken BVH text and reports

def _motion(text: str) -> tuple[str, list, list]:
    head, motion = text.split("MOTION", 1)
    lines = motion.strip().splitlines()
    return head, lines[:2], lines[2:]


def _with_rows(text: str, fn) -> str:
    """``text`` with its motion rows (lists of value strings) passed through ``fn``."""
    head, hdr, rows = _motion(text)
    rows = fn([r.split() for r in rows])
    hdr = [f"Frames: {len(rows)}", hdr[1]]
    return head + "MOTION\n" + "\n".join(hdr + [" ".join(r) for r in rows]) + "\n"


def _set_value(value: str):
    def fn(rows):
        rows[len(rows) // 2][len(rows[0]) // 2] = value
        return rows
    return fn


def _deep_bvh(depth: int = 3000) -> str:
    lines = ["HIERARCHY", "ROOT Hips", "{", "OFFSET 0 0 0",
             "CHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation"]
    for k in range(depth):
        lines += [f"JOINT J{k}", "{", "OFFSET 0 1 0", "CHANNELS 3 Zrotation Yrotation Xrotation"]
    lines += ["End Site", "{", "OFFSET 0 1 0", "}"] + ["}"] * (depth + 1)
    row = " ".join(["0"] * (6 + 3 * depth))
    return "\n".join(lines + ["MOTION", "Frames: 2", "Frame Time: 0.033333", row, row]) + "\n"


def _legless() -> str:
    joint = "JOINT {}\n{{\nOFFSET 0 10 0\nCHANNELS 3 Zrotation Yrotation Xrotation\n"
    joints = "".join(joint.format(n) for n in ("Spine", "Neck"))
    body = joints + "End Site\n{\nOFFSET 0 10 0\n}\n}\n}\n"
    row = " ".join(["0"] * 12)
    return ("HIERARCHY\nROOT Hips\n{\nOFFSET 0 0 0\nCHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation "
            f"Xrotation\n{body}}}\nMOTION\nFrames: 2\nFrame Time: 0.0333\n{row}\n{row}\n")


BVH_EDITS = {
    "good": lambda t: t,
    "not_bvh": lambda t: "hello\nworld\n",
    "bad_channels": lambda t: t.replace("CHANNELS 3", "CHANNELS 4", 1),
    "truncated_motion": lambda t: t[: t.index("MOTION") + 200],
    "truncated_hierarchy": lambda t: t[: t.index("MOTION") // 2],
    "not_a_number": lambda t: _with_rows(t, _set_value("x")),
    "short_line": lambda t: _with_rows(t, lambda rows: rows[:-1] + [rows[-1][:-2]]),
    "unclosed": lambda t: t[: t.index("MOTION")].rsplit("}", 1)[0] + "\nMOTION\nFrames: 1\nFrame Time: 0.01\n0\n",
    "empty": lambda t: "",
    "nan_motion": lambda t: _with_rows(t, _set_value("nan")),
    "inf_motion": lambda t: _with_rows(t, _set_value("-inf")),
    "big_motion": lambda t: _with_rows(t, _set_value("1e400")),
    "nan_column": lambda t: _with_rows(t, lambda rows: [["nan"] + r[1:] for r in rows]),
    "nan_offset": lambda t: re.sub(r"OFFSET \S+", "OFFSET nan", t, count=1),
    "frames_too_many": lambda t: re.sub(r"Frames: \d+", "Frames: 99999", t),
    "frames_negative": lambda t: re.sub(r"Frames: \d+", "Frames: -5", t),
    "frames_zero": lambda t: _with_rows(t, lambda rows: []),
    "frame_time_zero": lambda t: re.sub(r"Frame Time: \S+", "Frame Time: 0", t),
    "frame_time_negative": lambda t: re.sub(r"Frame Time: \S+", "Frame Time: -0.0333", t),
    "frame_time_nan": lambda t: re.sub(r"Frame Time: \S+", "Frame Time: nan", t),
    "frame_time_tiny": lambda t: re.sub(r"Frame Time: \S+", "Frame Time: 1e-300", t),
    "one_frame": lambda t: _with_rows(t, lambda rows: rows[:1]),
    "crlf": lambda t: t.replace("\n", "\r\n"),
    "utf16": lambda t: t.encode("utf-16"),
    "bom": lambda t: "\ufeff" + t,
    "binary": lambda t: random.Random(len(t)).randbytes(4000),
    "latin1_name": lambda t: t.replace("spine.001", "spïne").encode("latin-1", "replace"),
    "deep": lambda t: _deep_bvh(),
    "huge_channels": lambda t: t.replace("CHANNELS 3", "CHANNELS 99999", 1),
    "dup_names": lambda t: t.replace("JOINT thigh.R", "JOINT thigh.L"),
    "no_motion": lambda t: t[: t.index("MOTION")],
    "zero_offsets": lambda t: re.sub(r"OFFSET [^\n]+", "OFFSET 0 0 0", t),
    "huge_values": lambda t: _with_rows(t, lambda rows: [[f"{float(v) * 1e30:g}" for v in r] for r in rows]),
    "long_line": lambda t: _with_rows(t, lambda rows: rows[:-1] + [rows[-1] + ["0"] * 100000]),
    "legless": lambda t: _legless(),
}


def _edit_synthesis(fn):
    def edit(doc, k):
        syn = doc["synthesis"]
        keys = sorted(syn)
        fn(syn, keys[k % len(keys)])
        return doc
    return edit


def _map_lists(value, fn):
    if isinstance(value, list):
        return fn([_map_lists(v, fn) for v in value])
    if isinstance(value, dict):
        return {k: _map_lists(v, fn) for k, v in value.items()}
    return value


def _nan_numbers(values):
    return [float("nan") if isinstance(v, float) and i % 3 == 0 else v for i, v in enumerate(values)]


#: report edit -> (doc, k) -> doc or raw text/bytes
REPORT_EDITS_FN = {
    "good": lambda d, k: d,
    "not_json": lambda d, k: "{not json",
    "list": lambda d, k: [d],
    "empty_object": lambda d, k: {},
    "no_synthesis": lambda d, k: {x: v for x, v in d.items() if x != "synthesis"},
    "null_synthesis": lambda d, k: {**d, "synthesis": None},
    "drop_key": _edit_synthesis(lambda syn, key: syn.pop(key)),
    "null_key": _edit_synthesis(lambda syn, key: syn.__setitem__(key, None)),
    "strings": _edit_synthesis(lambda syn, key: syn.__setitem__(key, "abc")),
    "halve_lists": lambda d, k: _map_lists(d, lambda v: v[: len(v) // 2]),
    "nan_numbers": lambda d, k: _map_lists(d, _nan_numbers),
    "empty_lists": lambda d, k: _map_lists(d, lambda v: []),
    "nested_garbage": _edit_synthesis(lambda syn, key: syn.__setitem__(key, {"a": [1, {"b": [None, "x"]}]})),
    "huge_numbers": lambda d, k: _map_lists(d, lambda v: [1e308 if isinstance(x, float) else x for x in v]),
    "utf16": lambda d, k: json.dumps(d).encode("utf-16"),
    "binary": lambda d, k: random.Random(k).randbytes(3000),
    "deep": lambda d, k: '{"synthesis": ' + "[" * 100000 + "]" * 100000 + "}",
}


# ============================================================== laying out a case's files

def fill(text: str, root: str, work: str) -> str:
    return text.replace("{root}", root).replace("{work}", work)


def _write(path: str, data) -> None:
    os.makedirs(os.path.dirname(path) or ".", exist_ok=True)
    mode = "wb" if isinstance(data, bytes) else "w"
    with open(path, mode, **({} if mode == "wb" else {"encoding": "utf-8", "errors": "surrogatepass"})) as fh:
        fh.write(data)


def _op_copy(at, pool, locked, src, dst):
    source = pool[src] if src.startswith("@") else at(src)
    os.makedirs(os.path.dirname(at(dst)) or ".", exist_ok=True)
    shutil.copyfile(source, at(dst))


def _op_bvh(at, pool, locked, src, dst, variant):
    with open(pool[src], encoding="utf-8") as fh:
        _write(at(dst), BVH_EDITS[variant](fh.read()))


def _op_report(at, pool, locked, src, dst, edit, k):
    with open(pool[src], encoding="utf-8") as fh:
        doc = REPORT_EDITS_FN[edit](json.load(fh), k)
    _write(at(dst), doc if isinstance(doc, (str, bytes)) else json.dumps(doc))


def _op_truncate(at, pool, locked, dst, size):
    full = at(dst)
    os.truncate(full, int(size * os.path.getsize(full)) if size < 1 else int(size))


def _op_immutable(at, pool, locked, dst):
    subprocess.run(["chattr", "+i", at(dst)], check=True)
    locked.append(at(dst))


SETUP_OPS = {
    "copy": _op_copy, "bvh": _op_bvh, "report": _op_report, "truncate": _op_truncate, "immutable": _op_immutable,
    "text": lambda at, pool, locked, dst, text: _write(at(dst), fill(text, *at.places)),
    "garbage": lambda at, pool, locked, dst, n: _write(at(dst), random.Random(dst).randbytes(n)),
    "dir": lambda at, pool, locked, dst: os.makedirs(at(dst), exist_ok=True),
    "symlink": lambda at, pool, locked, target, dst: os.symlink(target, at(dst)),
    "hardlink": lambda at, pool, locked, src, dst: os.link(at(src), at(dst)),
    "fifo": lambda at, pool, locked, dst: os.mkfifo(at(dst)),
    "device": lambda at, pool, locked, dst: _null_device(at(dst)),
}


def _null_device(path: str) -> None:
    """A character device like /dev/null (1, 3) at ``path``; a FIFO where mknod is not
    allowed."""
    try:
        os.mknod(path, 0o666 | stat.S_IFCHR, os.makedev(1, 3))
    except PermissionError:
        os.mkfifo(path)


#: which argument of an operation is the file it makes
DEST_ARG = {"copy": 2, "bvh": 2, "report": 2, "text": 1, "garbage": 1, "dir": 1, "symlink": 2, "hardlink": 2, "fifo": 1,
            "device": 1}


def materialise(case: Case, root: str, pool: dict) -> list[str]:
    """Lay out the case's files under ``root``/work (its cwd); returns the paths made
    immutable (``unlock`` them before removing the folder)."""
    work = os.path.join(root, "work")
    os.makedirs(work)
    os.makedirs(os.path.join(root, "tmp"))
    locked = []

    def at(p):
        return os.path.normpath(os.path.join(work, fill(p, root, work)))
    at.places = (root, work)  # (a job list may name {work}/... too)

    for op in case.setup:
        dest = DEST_ARG.get(op[0])
        if dest and os.path.lexists(at(op[dest])):
            continue  # (two variants asking for one file: the first one's stays)
        SETUP_OPS[op[0]](at, pool, locked, *op[1:])
    return locked


def unlock(paths) -> None:
    for p in paths:
        subprocess.run(["chattr", "-i", p], check=False)


def immutable_works(folder: str) -> bool:
    """Whether ``chattr +i`` works here (root in a container may lack the capability)."""
    probe = os.path.join(folder, ".chattr-probe")
    open(probe, "w").close()
    ok = subprocess.run(["chattr", "+i", probe], capture_output=True).returncode == 0
    if ok:
        ok = not os.access(probe, os.W_OK) or _write_fails(probe)
        subprocess.run(["chattr", "-i", probe], capture_output=True)
    os.unlink(probe)
    return ok


def _write_fails(path: str) -> bool:
    try:
        with open(path, "w"):
            return False
    except OSError:
        return True
