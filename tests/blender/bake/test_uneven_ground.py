"""Feet above uneven ground (issue 14): a walk across rolling hills (sine waves up to 25
degrees of slope), planned, solved and baked, then measured as Blender plays the scene
(``bake.evaluate_played``): the swinging foot's heel, ball and toe tip never dip into the
surface, the planted foot lies on it. And the hips: on the Turns scene's sharp turns the
IK lowers them at most 3 cm below the blended clips' height for reach."""

import math
from importlib import import_module

import numpy as np

from conftest import cmu_armature, needs_cmu

#: the hills: z = AMP sin(2 pi x / WAVE) cos(2 pi y / ACROSS), steepest 25 degrees
WAVE, ACROSS, MAX_SLOPE = 3.0, 9.0, math.radians(25.0)
#: m the swinging foot may dip (the mesh's facets, rounding) and the planted foot may miss
SWING_TOL, PLANTED_TOL = 0.005, 0.01


def _amplitude() -> float:
    """The amplitude whose steepest slope is MAX_SLOPE (the gradient's largest norm)."""
    x, y = np.meshgrid(np.linspace(0, WAVE, 301), np.linspace(0, ACROSS, 301))
    gx = 2 * np.pi / WAVE * np.cos(2 * np.pi * x / WAVE) * np.cos(2 * np.pi * y / ACROSS)
    gy = -2 * np.pi / ACROSS * np.sin(2 * np.pi * x / WAVE) * np.sin(2 * np.pi * y / ACROSS)
    return math.tan(MAX_SLOPE) / float(np.hypot(gx, gy).max())


def height(x, y):
    """The hills' height (m) at x, y (arrays)."""
    return _amplitude() * np.sin(2 * np.pi * np.asarray(x) / WAVE) * np.cos(2 * np.pi * np.asarray(y) / ACROSS)


def rolling_scene(fp):
    """A new scene: a traversable heightfield mesh of the hills (10 cm facets) over
    x in [-1.5, 13], y in [-2.5, 2.5], a Start and a Goal facing +X on two crests three
    waves apart (x = 0.75 and 9.75: level ground to stand on; the walk crosses the slopes)."""
    import bpy

    bpy.ops.wm.read_homefile(use_empty=True)
    scene = bpy.context.scene
    scene.render.fps = 30
    xs, ys = np.arange(-1.5, 13.0001, 0.1), np.arange(-2.5, 2.5001, 0.1)
    gx, gy = np.meshgrid(xs, ys, indexing="ij")
    verts = np.c_[gx.ravel(), gy.ravel(), height(gx, gy).ravel()]
    n = len(ys)
    i, j = np.meshgrid(np.arange(len(xs) - 1), np.arange(n - 1), indexing="ij")
    a = (i * n + j).ravel()
    faces = np.c_[a, a + n, a + n + 1, a + 1]
    coll = bpy.data.collections.new("Traversable")
    scene.collection.children.link(coll)
    coll.footstep.surface = "TRAVERSABLE"
    me = bpy.data.meshes.new("Hills")
    me.from_pydata(verts.tolist(), [], faces.tolist())
    me.validate()
    coll.objects.link(bpy.data.objects.new("Hills", me))
    for name, x in (("Start", WAVE / 4), ("Goal", WAVE / 4 + 3 * WAVE)):
        ob = bpy.data.objects.new(name, None)
        ob.location = (x, 0.0, float(height(x, 0.0)))
        ob.rotation_euler.z = math.pi / 2  # facing +X
        scene.collection.objects.link(ob)
    return scene


def _bake(fp, scene, ob):
    """Plan, synthesize, solve and bake ``ob`` from Start to Goal: (the report, its rig,
    the scene as Blender plays it: world bone matrices (F, B, 4, 4))."""
    planning = import_module(fp.__name__ + ".blender.planning")
    bake = import_module(fp.__name__ + ".blender.write.bake")
    scene_mod = import_module(fp.__name__ + ".blender.read.scene")
    goal, heading = planning.goal_of(scene, "Goal")
    doc = planning.run(scene, ob, goal, heading, scene.objects["Start"], name="hills", frame_start=1)
    rig = scene_mod.rig_from_armature(ob)
    frames = doc["frame_end"] - doc["frame_start"] + 1
    world = bake.evaluate_played(scene, ob, rig, doc["frame_start"], frames)[0]
    return doc, rig, world


def _sole(fp, doc, rig, world):
    """(3, 2, F, 3) world heel, ball and toe tip of each foot as played: the report's heel
    and ball points in the foot bones, and the tip ahead of the ball by the toe's length,
    bent with the toe (``ik.toe_tip``)."""
    ik = import_module(fp.__name__ + ".core.solve.ik")
    heel_l, ball_l = np.asarray(doc["feet"]["heel_local"]), np.asarray(doc["feet"]["toe_local"])
    out = np.zeros((3, 2, len(world), 3))
    for k, side in enumerate("lr"):
        foot, toe = rig.foot_chain(side)
        wf = world[:, foot]
        tip = ik.toe_tip(rig, side, wf, world[:, toe] if toe is not None else None, heel_l[k, :3], ball_l[k, :3])
        out[0, k] = (wf @ heel_l[k])[:, :3]
        out[1, k] = (wf @ ball_l[k])[:, :3]
        out[2, k] = (wf @ np.c_[tip, np.ones(len(tip))][..., None])[:, :3, 0]
    return out


def _planted(doc, frames):
    """(2, F) bool: each foot from its footprints' strike to liftoff frames."""
    on = np.zeros((2, frames), bool)
    for f in doc["footprints"]:
        a, b = (np.asarray(f["planted_frames"]) - doc["frame_start"]).clip(0, frames - 1)
        on["LR".index(f["foot"]) if isinstance(f["foot"], str) else int(f["foot"]), a:b + 1] = True
    return on


def _check_feet_above_hills(fp, doc, rig, world, tip_own=False):
    """The swinging foot's heel, ball and toe tip never more than SWING_TOL under the
    hills, the planted foot's lower end within PLANTED_TOL of them and no end deeper.
    ``tip_own``: a library whose clips sink their own toe tips (CMU's, 2 cm on flat
    ground) has its swinging toe tip held only to no deeper than the planted one went
    (the swing adds no dip of its own). Returns (the swing's deepest dip, the planted
    foot's largest miss), m."""
    pts = _sole(fp, doc, rig, world)
    depth = height(pts[..., 0], pts[..., 1]) - pts[..., 2]  # (3, 2, F) m below the surface
    planted = _planted(doc, len(world))
    ends = depth[:2]
    swing = ends[:, ~planted]
    assert swing.max() < SWING_TOL, f"a swinging heel or ball dips {swing.max() * 1000:.1f} mm"
    tip = depth[2][~planted].max()
    allowed = SWING_TOL + (max(depth[2][planted].max(), 0.0) if tip_own else 0.0)
    assert tip < allowed, f"a swinging toe tip dips {tip * 1000:.1f} mm"
    contact = np.minimum(pts[0, ..., 2] - height(pts[0, ..., 0], pts[0, ..., 1]),
                         pts[1, ..., 2] - height(pts[1, ..., 0], pts[1, ..., 1]))  # (2, F) the lower end
    assert np.abs(contact[planted]).max() < PLANTED_TOL, f"planted foot off by {np.abs(contact[planted]).max()} m"
    deep = (ends if tip_own else depth)[:, planted].max()
    assert deep < PLANTED_TOL, f"a planted foot's end {deep * 1000:.1f} mm deep"
    return max(swing.max(), tip), np.abs(contact[planted]).max()


def test_the_hills_are_as_steep_as_the_issue_says(fp):
    scene = rolling_scene(fp)
    me = scene.objects["Hills"].data
    normals = np.array([p.normal[:] for p in me.polygons])
    steepest = np.degrees(np.arccos(normals[:, 2].min()))
    assert 23.5 < steepest < 25.5


def test_sample_character_walks_the_hills_with_feet_above_the_surface(fp):
    mannequin = import_module(fp.__name__ + ".blender.sample.mannequin")
    scene = rolling_scene(fp)
    ob = mannequin.add_to_scene(scene, "Start")[0]
    doc, rig, world = _bake(fp, scene, ob)
    assert doc["quality"]["goal"]["distance_m"] < 0.1
    dip, off = _check_feet_above_hills(fp, doc, rig, world)
    print(f"sample character on the hills: swing dips {dip * 1000:.1f} mm at most, planted {off * 1000:.1f} mm")


@needs_cmu
def test_cmu_library_walks_the_hills_with_feet_above_the_surface(fp):
    scene = rolling_scene(fp)
    ob = cmu_armature(fp)
    doc, rig, world = _bake(fp, scene, ob)
    dip, off = _check_feet_above_hills(fp, doc, rig, world, tip_own=True)
    print(f"CMU on the hills: swing dips {dip * 1000:.1f} mm at most, planted {off * 1000:.1f} mm")


def test_sharp_turns_lower_the_hips_at_most_3_cm(fp):
    """Turns, level everywhere, with the sample character: the hips (the body, which
    carries them) never more than 3 cm under the blended clips' own height."""
    planning = import_module(fp.__name__ + ".blender.planning")
    mannequin = import_module(fp.__name__ + ".blender.sample.mannequin")
    sample_scenes = import_module(fp.__name__ + ".blender.sample.sample_scenes")
    settings = import_module(fp.__name__ + ".core.base.settings")
    scene = sample_scenes.build("turns")
    scene.render.fps = 30
    ob = mannequin.add_to_scene(scene, "Start")[0]
    goal, heading = planning.goal_of(scene, "Goal")
    planned = planning.plan_and_synthesize(scene, ob, goal, heading, scene.objects["Start"])
    solved = import_module(fp.__name__ + ".core.solve.frames").solve(planned.synthesis, planned.setup,
                                                                     settings.Settings())
    lowered = planned.synthesis.body_position[:, 2] - solved.ik.body_pos[:, 2]
    assert lowered.max() <= 0.03 + 1e-6, f"hips lowered {lowered.max() * 100:.2f} cm"
