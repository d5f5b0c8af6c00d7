"""A bake in a Blender scene: the scene read into a plan's setup (the tagged surfaces,
the character's clips analysed, its start and goal), the core's stages called (the search,
``core.perform.run.perform_plan``, ``core.solve.frames.solve``), the keys written
(``write.bake``) and the scene measured as Blender plays it (``measure``); ``run_steps``
holds the order.

Headings in the result are yaws (radians) relative to the character's rest-pose forward
as it stands in the world (its armature's rest forward turned by the object's rotation).
"""

from __future__ import annotations

import hashlib

import bpy
import numpy as np

from ..core.base.settings import Settings
from ..core.base.timing import StageTimer
from ..core.clips.body import body_scale, scaled_points
from ..core.clips.steps import library_steps, shortest_stride
from ..core.footprint import PathFootprint
from ..core.perform import turn_in_place
from ..core.perform.run import Planned, perform_plan, synthesize_plan, waypoint_rows
from ..core.plan.navgraph import FootprintCache, PlanError, PlanResult, Planner
from ..core.plan.setup import PlanSetup, foot_shape, standing_footprints
from ..core.plan.surface import FootShape
from ..core.report import document as report
from ..core.solve.frames import Solved, solve, toe_tips, walk_motion
from ..core.synth.pipeline import Synthesis, stage_row, standing_body
from .read.character import analyze_character, library_for
from .read.scene import facing_rotation, object_scale, rotation_heading, scene_fps
from .read.surfaces import scene_surfaces
from .ui import overlay

#: Support answers per scene, reused while its tagged geometry is unchanged.
_CACHES: dict[tuple[str, FootShape, bool], FootprintCache] = {}


def world_forward(ob, analyses) -> np.ndarray:
    """The character's heading-0 direction in the world, checking its object transform
    (its own one: a bake of the planner's animates the object, and does not count)."""
    from .write.bake import own_frame

    m = own_frame(ob)  # (an even scale is the rig's, read in world units: ``scene.object_scale``)
    if abs(m[2, 2] - 1) > 1e-3:
        raise PlanError(f"character {ob.name!r} is tilted in object mode; only a turn about Z "
                        "is allowed: clear its X and Y rotation")
    f = analyses[0].motion.rest_forward
    w = m[:2, :2] @ f
    return w / np.linalg.norm(w)


def object_geometry(ground, obstacles) -> dict:
    """name -> (hash, lo, hi) of every tagged object's world-space triangles (and its
    role), for the support cache to drop answers only where something changed."""
    out = {}
    for role, g in (("T", ground), ("O", obstacles)):
        m = g.mesh
        for i, name in enumerate(m.names):
            sel = m.owner == i
            tris = m.tris[sel]
            v = m.verts[np.unique(tris)] if len(tris) else np.zeros((1, 3))
            h = hashlib.sha1(role.encode())
            h.update(np.ascontiguousarray(m.verts[tris], dtype=np.float32).tobytes())
            out[f"{role}:{name}"] = (h.hexdigest(), v.min(axis=0), v.max(axis=0))
    return out


def plan_setup(scene, ob, settings=None, traversable=(), obstacles=()) -> PlanSetup:
    """What a plan needs from the scene: the tagged surfaces, the character's clips
    analysed, its library and steps, its forward, and the Planner built from them."""
    settings = settings or Settings()
    depsgraph = bpy.context.evaluated_depsgraph_get()
    ground, obst = scene_surfaces(scene, depsgraph, traversable, obstacles)
    clips = analyze_character(ob, settings, mirrors=True)
    if not clips.analyses:
        why = "; ".join(clips.errors.values()) or "it has no actions"
        raise PlanError(f"character {ob.name!r} has no usable clips ({why})")
    settings = settings.for_body(body_scale(clips.rig))  # (a human's lengths, for this character's size)
    library = library_for(ob, clips)
    steps = library_steps(library, clips.analyses, bend_curvature=settings.bend_curvature,
                          stride=(shortest_stride(settings, library, clips.analyses), settings.stride_max),
                          straighten=settings.straightens, scale=settings.body_scale)
    forward = world_forward(ob, clips.analyses)
    foot = foot_shape(clips.analyses, clips.rig, settings.body_scale)
    cache = _CACHES.setdefault((scene.name, foot, settings.cross_gaps),  # (its answers mean what the rules say)
                               FootprintCache(margin=settings.length(0.6)))  # (a foot's own)
    cache.update(object_geometry(ground, obst))
    planner = Planner(ground, obst, steps, forward, foot=foot,
                      settings=settings, cache=cache)
    return PlanSetup(planner, clips.analyses, library, forward, clips.rig)


def character_footprints(ob, setup: PlanSetup) -> list[PathFootprint]:
    """Both feet standing where the character stands: under its hips at rest, placed by
    its object's own transform (not the one a bake of the planner's animates it to, nor
    the pose its active clip has at the current frame), facing its forward. The same
    scene gives the same start, so re-baking gives the same footprints."""
    from .write.bake import own_frame

    m = own_frame(ob)  # (the rig is in world units)
    hips = setup.rig.rest[setup.rig.role_index("hips")][:, 3]
    return standing_footprints(m @ hips, 0.0, setup, f"character {ob.name!r}")


def marker_footprints(marker, setup: PlanSetup) -> list[PathFootprint]:
    """Both feet standing at an object (an empty), side by side, facing the way it faces
    (see ``FACING``)."""
    return standing_footprints(np.array(marker.matrix_world.translation),
                               rotation_heading(facing_rotation(marker), setup.forward), setup,
                               f"start {marker.name!r}")


def goal_of(scene, name: str | None):
    """(position, heading or None): an object's location and, for an empty, the way it
    faces as a Z rotation (``facing_rotation``: the heading to arrive with); without a
    name the 3D cursor, with no heading."""
    if name:
        ob = scene.objects.get(name)
        if ob is None:
            raise PlanError(f"no object named {name!r} in scene {scene.name!r} to walk to")
        return np.array(ob.matrix_world.translation), (facing_rotation(ob) if ob.type == "EMPTY" else None)
    return np.array(scene.cursor.location), None


def plan(scene, ob, goal, goal_heading=None, start_marker=None, settings=None,
         traversable=(), obstacles=(), route=None) -> tuple[PlanResult, PlanSetup]:
    """The footprints from the start (``start_marker``, else where the character stands) to
    ``goal``, arriving facing ``goal_heading`` (a Z rotation, rad, see ``FACING``) when
    one is given; or, with ``route``, ``route(setup, start footprints, goal heading in the
    planner's frame)``'s (an edited plan, a way through waypoints)."""
    setup = plan_setup(scene, ob, settings, traversable, obstacles)
    start = marker_footprints(start_marker, setup) if start_marker is not None else character_footprints(ob, setup)
    heading = None if goal_heading is None else rotation_heading(goal_heading, setup.forward)
    setup.start = start
    if route is not None:
        return route(setup, start, heading), setup
    return turn_in_place.plan(setup.planner, start, goal, heading, standing_body(setup.library, setup.analyses)), setup


def synthesize(scene, result: PlanResult, setup: PlanSetup, settings=None, goal=None,
               goal_heading: float | None = None) -> Synthesis:
    """``core.perform.run.synthesize_plan`` at the scene's frame rate."""
    return synthesize_plan(result, setup, settings or Settings(), scene_fps(scene), goal, goal_heading)


def plan_and_synthesize(scene, ob, goal, goal_heading=None, start_marker=None, settings=None,
                        traversable=(), obstacles=(), route=None, frame_start: float | None = None) -> Planned:
    """Plan the footprints to ``goal`` and perform them (``core.perform.run.perform_plan``:
    a route through waypoints, ``directing.ViaRoute``, that stops at some or has arrival
    frames, scene frames from ``frame_start``, default the current one, is performed leg by
    leg); the overlay shows the result."""
    settings = settings or Settings()
    result, setup = plan(scene, ob, goal, goal_heading, start_marker, settings, traversable, obstacles, route)
    heading = None if goal_heading is None else rotation_heading(goal_heading, setup.forward)
    first = float(scene.frame_current if frame_start is None else frame_start)
    planned = perform_plan(result, setup, settings, scene_fps(scene), goal, heading, route, first)
    syn = planned.synthesis
    overlay.remember(scene, planned.result.footprints, *syn.footprints, setup.forward, setup.planner.foot,
                     syn.body_position, planned.result.explored_positions if planned.result.explored else None)
    return planned


#: mm: a re-bake whose splice lets a planted foot slide more than this is baked whole
SPLICE_SKATE_MM = 1.0


def measure(scene, ob, planned: Planned, solved: Solved, frame_start: int, goal, goal_heading, fps: float,
            body_on: str = "OBJECT", planted=None, frames: int | None = None, played: dict | None = None) -> dict:
    """The quality of the scene as Blender plays it (``bake.evaluate_played``: the bake
    with every other track and the active action as they are), measured by
    ``core.report.document.measure_bake``; ``planted`` and ``frames`` when the bake's timing is
    not the synthesis's (a re-bake's splice)."""
    from .write import bake as baking

    setup, syn = planned.setup, planned.synthesis
    frames = solved.ik.frames if frames is None else frames
    root = None
    if body_on == "ROOT":  # (a Rigify rig's torso carries the body: its hips stand for it)
        from . import rigify

        root = setup.rig.role_index("hips") if rigify.is_rigify(ob) else baking.root_bone(ob, setup.rig)
    world, body_pos, body_yaw, bone_rot = baking.evaluate_played(scene, ob, setup.rig, frame_start, frames, root)
    if played is not None:  # (for the caller: the body as played)
        played["body"] = body_pos
    sched = syn.final.schedule
    walk = walk_motion(setup.analyses)
    stances = report.planted_stances(sched.feet, syn.planted() if planted is None else planted, *syn.footprints,
                                     fps, frames)
    allowance = report.source_steps(syn.tracks, sched.clips, sched.weights, fps)
    return report.measure_bake(world, bone_rot, body_pos, body_yaw - solved.spin,
                               [setup.rig.foot_chain(x)[0] for x in ("l", "r")], walk.heel_local, walk.toe_local,
                               setup.planner.ground, stances, goal, goal_heading, allowance, setup.rig.names,
                               tips=toe_tips(setup.rig, world, walk.heel_local, walk.toe_local))


def run(scene, ob, goal, goal_heading=None, start_marker=None, settings=None, traversable=(),
        obstacles=(), name: str | None = None, frame_start: int | None = None, markers: bool = False,
        progress=None, body_on: str = "OBJECT", frame_range: bool = True, route=None, splice=None,
        force: bool = False, new_track: bool = False) -> dict:
    """Plan, synthesize, IK and bake ``ob`` walking to ``goal``; returns the report
    (plan, stage times in the layout of thesis Table 4.1, quality of the baked result).
    ``progress(fraction, stage)`` is called between stages; ``route``, ``splice``,
    ``force`` and ``new_track`` as for ``run_steps``."""
    steps = run_steps(scene, ob, goal, goal_heading, start_marker, settings, traversable, obstacles,
                      name, frame_start, markers, body_on, frame_range, route, splice, force, new_track)
    while True:
        try:
            fraction, stage = next(steps)
        except StopIteration as done:
            return done.value
        if progress is not None:
            progress(fraction, stage)


def run_steps(scene, ob, goal, goal_heading=None, start_marker=None, settings=None, traversable=(),
              obstacles=(), name: str | None = None, frame_start: int | None = None, markers: bool = False,
              body_on: str = "OBJECT", frame_range: bool = True, route=None, splice=None, force: bool = False,
              new_track: bool = False):
    """``run`` one stage at a time: a generator yielding (fraction done, next stage) and
    returning the report. Nothing in the scene changes before the last stage (the bake),
    so a caller may stop it at any yield and leave the scene as it was. ``route``
    replaces the search (see ``plan``). A re-bake's ``splice`` (``directing.Splice``)
    gets ``splice.before_ik(planned)`` (it may pin footprints) and
    ``splice.after_bake(action, track, planted, frames, frame_start, fps)``: it may change
    the baked keys before they are measured and returns the timing they then have
    ((strike, stance, liftoff) s per footprint from ``frame_start``, and the number of
    frames). Every bake records its footprints and their frames (``rebake.record``).
    What would make the bake play elsewhere than planned (``bake.check_scene``, a
    constraint on the legs) is refused before planning; a bake whose measured goal or
    skate is beyond ``report.tolerances`` is taken back and refused (BakeError naming
    the figure), the earlier bake of its name kept. ``force``: bake over an earlier bake
    of this name whose keys were edited; ``new_track``: bake beside it under a new name
    (``bake.new_track_name``)."""
    from .write import bake as baking
    from .write import rebake

    settings = settings or Settings()
    fps = scene_fps(scene)
    name = name or f"{ob.name} to goal"
    beside = None
    if new_track:
        name, beside = baking.new_track_name(ob, name), name
    frame_start = int(scene.frame_current if frame_start is None else frame_start)
    baking.check_scene(scene, ob, body_on)
    yield 0.0, "planning"
    planned = plan_and_synthesize(scene, ob, goal, goal_heading, start_marker, settings, traversable, obstacles,
                                  route, frame_start)
    result, syn = planned.result, planned.synthesis
    baking.check_leg_constraints(ob, planned.setup.rig)
    yield 0.5, "inverse kinematics"
    if splice is not None:
        splice.before_ik(planned)
    solved = planned.solved if planned.solved is not None and splice is None else solve(syn, planned.setup, settings)
    yield 0.7, "bake"
    timer = StageTimer()
    replaced = []  # (the earlier bake of this name: muted until the new one is measured)

    def bake_it(spliced):
        """Bake (splicing into the old bake's keys, with ``spliced``) and record its timing:
        (action, track, planted s per footprint, frames)."""
        with timer("bake"):
            act, track = baking.bake(ob, scene, planned.setup.rig, solved.ik, solved.spin, name, frame_start,
                                     result.footprints, syn.planted(), markers, body_on, frame_range,
                                     rigify_ik_feet=settings.rigify_ik_feet, replaced=replaced, force=force,
                                     beside=beside)
        try:
            planted, frames = syn.planted(), solved.ik.frames
            if spliced:
                planted, frames = splice.after_bake(act, track, planted, frames, frame_start, fps)
            rebake.record(act, planted, syn.footprints, frame_start, fps)
            baking.record_keys(act)
        except BaseException:
            baking.discard(ob, scene, track, replaced)
            raise
        return act, track, planted, frames

    act, track, planted, frames = bake_it(splice is not None)
    try:
        yield 0.85, "quality"
        played = {}
        qual = measure(scene, ob, planned, solved, frame_start, goal, planned.goal_heading, fps, body_on, planted,
                       frames, played)
        if splice is not None and splice.span is not None and qual["foot_skate"]["max_mm"] > SPLICE_SKATE_MM:
            # the edit turned the walk too far round the kept footprints for their keys to mix
            # without a foot sliding: the whole path is baked instead
            splice.slid_mm, splice.span = float(qual["foot_skate"]["max_mm"]), None
            baking.discard(ob, scene, track, replaced)
            act, track, planted, frames = bake_it(False)
            played = {}
            qual = measure(scene, ob, planned, solved, frame_start, goal, planned.goal_heading, fps, body_on, planted,
                           frames, played)
        pl = planned.setup.planner
        limits = report.tolerances(pl.settings.goal_radius, pl.settings.body_scale)
        qual["tolerances"] = limits
        faults = report.played_faults(qual, limits)
        if faults:
            raise baking.BakeError(f"the bake of {ob.name!r} is wrong: {'; '.join(faults)}: something in the scene "
                                   "moves the character besides its bake (a parent, a constraint, a driver, an NLA "
                                   "track, a time remap); nothing was baked")
    except BaseException:  # (a wrong bake, a failure, or the caller stopping here: the bake taken back)
        baking.discard(ob, scene, track, replaced)
        raise
    baking.settle(ob, scene, replaced)
    stages = stage_row(len(result.footprints), result.seconds, syn, pose_blend=solved.pose_seconds,
                       ik=solved.ik_seconds, bake=timer.seconds["bake"])
    doc = report.bake_report(result, syn, character=ob.name, goal=goal, name=name, forward=planned.setup.forward,
                             frame_start=frame_start, frames=frames, fps=fps, action=act.name,
                             track=track.name, stages=stages, quality=qual, planted=planted)
    doc["stashed_action"] = act.get(baking.STASH_PROP)
    if planned.performance is not None:
        doc["waypoints"] = waypoint_rows(planned, frame_start, fps, played.get("body"))
    walk, rig = walk_motion(planned.setup.analyses), planned.setup.rig
    own = 1.0 / object_scale(ob)  # (in the armature's own units: as an independent read of the file has them)
    doc["feet"] = report.feet_points([rig.names[rig.foot_chain(x)[0]] for x in ("l", "r")],
                                     scaled_points(walk.heel_local, own), scaled_points(walk.toe_local, own))
    return doc

