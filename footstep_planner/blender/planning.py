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
from collections import OrderedDict
from dataclasses import dataclass, replace

import bpy
import numpy as np

from ..core.base.settings import Settings
from ..core.base.timing import StageTimer
from ..core.clips.body import body_scale, leg_length, scaled_points
from ..core.clips.steps import library_steps, shortest_stride
from ..core.footprint import PathFootprint
from ..core.perform import turn_in_place
from ..core.perform.run import Planned, StartedRoute, perform_plan, synthesize_plan, waypoint_rows
from ..core.plan.navgraph import HIPS_HEIGHT, FootprintCache, PlanError, PlanResult, Planner
from ..core.plan.others import BODY_RADIUS, OUTLINE_STEP, Others, fit_clock, outline_points
from ..core.plan import stands
from ..core.plan.setup import PlanSetup, check_size, foot_shape, standing_footprints
from ..core.plan.surface import FootShape
from ..core.clips.rig import RigError
from ..core.report import crowd
from ..core.report import document as report
from ..core.solve.frames import Solved, solve, toe_tips, walk_motion
from ..core.synth.pipeline import Synthesis, stage_row, standing_body
from . import rigify
from .read.character import analyze_character, library_for
from .read.scene import facing_rotation, object_scale, rig_from_armature, rotation_heading, scene_fps
from .read.surfaces import BvhGround, local_mesh, scene_surfaces, tagged_objects
from .ui import overlay
from .write import bake as baking
from .write import rebake
from .write.owned import RANGE_PROP, ROUND_OTHERS_PROP

#: Support answers per scene, foot and gap rule, reused while the scene's tagged geometry
#: is unchanged: the CACHED_SCENES used last (a session that plans in many scenes, or
#: many feet, keeps the latest, not every one it ever planned).
_CACHES: OrderedDict[tuple[str, FootShape, bool], FootprintCache] = OrderedDict()
CACHED_SCENES = 4


def _support_cache(key: tuple[str, FootShape, bool], margin: float) -> FootprintCache:
    cache = _CACHES.pop(key, None)
    _CACHES[key] = cache = FootprintCache(margin=margin) if cache is None else cache  # (the latest last)
    while len(_CACHES) > CACHED_SCENES:
        _CACHES.popitem(last=False)
    return cache


def forget_support_caches() -> None:
    """Every scene's kept support answers dropped (a worker between jobs: a job plans as it
    would in a fresh Blender)."""
    _CACHES.clear()


def world_forward(ob, analyses) -> np.ndarray:
    """The character's heading-0 direction in the world, checking its object transform
    (its own one: a bake of the planner's animates the object, and does not count)."""
    m = baking.own_frame(ob)  # (an even scale is the rig's, read in world units: ``scene.object_scale``)
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


def plan_setup(scene, ob, settings=None, traversable=(), obstacles=(), others: Others | None = None) -> PlanSetup:
    """What a plan needs from the scene: the tagged surfaces, the character's clips
    analysed, its library and steps, its forward, and the Planner built from them (around
    ``others``, the characters already in the shot, when given: ``others_in_time``; the
    obstacles among them that move are avoided in time, not where they stand now)."""
    settings = settings or Settings()
    depsgraph = bpy.context.evaluated_depsgraph_get()
    ground, obst = scene_surfaces(scene, depsgraph, traversable, obstacles,
                                  leave_out=others.movers if others is not None else ())
    clips = analyze_character(ob, settings, mirrors=True)
    if not clips.analyses:
        why = "; ".join(clips.errors.values()) or "it has no actions"
        raise PlanError(f"character {ob.name!r} has no usable clips ({why})")
    check_size(ground, leg_length(clips.rig), f"character {ob.name!r}")
    settings = settings.for_body(body_scale(clips.rig))  # (a human's lengths, for this character's size)
    library = library_for(ob, clips)
    steps = library_steps(library, clips.analyses, bend_curvature=settings.bend_curvature,
                          stride=(shortest_stride(settings, library, clips.analyses), settings.stride_max),
                          straighten=settings.straightens, scale=settings.body_scale)
    forward = world_forward(ob, clips.analyses)
    foot = foot_shape(clips.analyses, clips.rig, settings.body_scale)
    cache = _support_cache((scene.name, foot, settings.cross_gaps),  # (its answers mean what the rules say)
                           margin=settings.length(0.6))  # (a foot's own)
    cache.update(object_geometry(ground, obst))
    planner = Planner(ground, obst, steps, forward, foot=foot,
                      settings=settings, cache=cache, others=others)
    return PlanSetup(planner, clips.analyses, library, forward, clips.rig)


def character_footprints(ob, setup: PlanSetup) -> list[PathFootprint]:
    """Both feet standing where the character stands: under its hips at rest, placed by
    its object's own transform (not the one a bake of the planner's animates it to, nor
    the pose its active clip has at the current frame), facing its forward. The same
    scene gives the same start, so re-baking gives the same footprints."""
    m = baking.own_frame(ob)  # (the rig is in world units)
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
        return object_goal(ob)
    return np.array(scene.cursor.location), None


def object_goal(ob) -> tuple:
    """(position (3,), Z rotation or None) of an object to walk to: its location and, for
    an empty, the way it faces (``goal_of``)."""
    return np.array(ob.matrix_world.translation), (facing_rotation(ob) if ob.type == "EMPTY" else None)


def plan(scene, ob, goal, goal_heading=None, start_marker=None, settings=None,
         traversable=(), obstacles=(), route=None, frame_start: float | None = None,
         not_around=(), shot=None, setup: PlanSetup | None = None) -> tuple[PlanResult, PlanSetup]:
    """The footprints from the start (``start_marker``, else where the character stands) to
    ``goal``, arriving facing ``goal_heading`` (a Z rotation, rad, see ``FACING``) when
    one is given; or, with ``route``, ``route(setup, start footprints, goal heading in the
    planner's frame)``'s (an edited plan, a way through waypoints). With
    ``Settings.avoid_characters``, around the other characters the planner baked in the
    scene (but those named in ``not_around``) as they play from ``frame_start`` (default:
    the current frame) on: ``others_in_time`` (in ``shot``'s space and time, a
    ``together.Shot``, when given). A ``setup`` made before by ``plan_setup`` for this
    character, scene and settings (nothing of them changed since: the live re-plan's,
    ``ui.live``) is used again, round the others as they are now."""
    settings = settings or Settings()
    others = None
    if settings.avoid_characters:
        first = scene.frame_current if frame_start is None else frame_start
        others = others_in_time(scene, ob, int(round(first)), not_around, obstacles, shot)
        if shot is not None and shot.clock is not None:  # (the clock the shot's last synthesis kept)
            others = others.on_clock(*shot.clock)
    if setup is None:
        setup = plan_setup(scene, ob, settings, traversable, obstacles, others)
    else:
        setup.planner = replace(setup.planner, others=others)
    if start_marker is not None:
        start = marker_footprints(start_marker, setup)
    elif isinstance(route, StartedRoute):  # (an edited plan leaves from where its bake did)
        start = route.standing(setup)
    else:
        start = character_footprints(ob, setup)
    heading = None if goal_heading is None else rotation_heading(goal_heading, setup.forward)
    setup.start = start
    return _search(setup, goal, heading, route), setup


def _search(setup: PlanSetup, goal, heading, route) -> PlanResult:
    """The plan's search from ``setup.start`` (``heading`` in the planner's frame): ``route``'s
    or, without one, the footprints' (turning in place where the way turns back)."""
    if route is not None:
        return route(setup, setup.start, heading)
    body = standing_body(setup.library, setup.analyses)
    return stands.plan_round(setup.planner, setup.start,
                             lambda planner, start: turn_in_place.plan(planner, start, goal, heading, body))


#: Plans made again round other characters: on the clock their synthesis kept
#: (``core.plan.others.fit_clock``) where it moved by more than CLOCK_MOVED s at the
#: path's end, or with the time slack doubled where the synthesized body still came within
#: the clearance of another's; at most CLOCK_TRIES times.
CLOCK_TRIES = 3
CLOCK_MOVED = 0.1


def synthesize(scene, result: PlanResult, setup: PlanSetup, settings=None, goal=None,
               goal_heading: float | None = None) -> Synthesis:
    """``core.perform.run.synthesize_plan`` at the scene's frame rate."""
    return synthesize_plan(result, setup, settings or Settings(), scene_fps(scene), goal, goal_heading)


def plan_and_synthesize(scene, ob, goal, goal_heading=None, start_marker=None, settings=None,
                        traversable=(), obstacles=(), route=None, frame_start: float | None = None,
                        not_around=(), shot=None, setup: PlanSetup | None = None) -> Planned:
    """Plan the footprints to ``goal`` and perform them (``core.perform.run.perform_plan``:
    a route through waypoints, ``directing.ViaRoute``, that stops at some or has arrival
    frames, scene frames from ``frame_start``, default the current one, is performed leg by
    leg; with ``Settings.avoid_characters`` around the other characters baked in the scene
    but ``not_around``, in ``shot``'s when given: ``plan``); the overlay shows the result."""
    settings = settings or Settings()
    result, setup = plan(scene, ob, goal, goal_heading, start_marker, settings, traversable, obstacles, route,
                         frame_start, not_around, shot, setup)
    heading = None if goal_heading is None else rotation_heading(goal_heading, setup.forward)
    first = float(scene.frame_current if frame_start is None else frame_start)
    planned = perform_plan(result, setup, settings, scene_fps(scene), goal, heading, route, first)
    tried = [(planned, setup.planner.others)]
    for _ in range(CLOCK_TRIES):
        others = _again(setup, result, planned)
        if others is None:
            break
        kept, setup.planner.others = setup.planner.others, others
        try:
            again = _search(setup, goal, heading, route)
        except PlanError:  # (no way on that clock, or that wide: the plan made stands, its report says how near)
            setup.planner.others = kept
            break
        result = again
        planned = perform_plan(result, setup, settings, scene_fps(scene), goal, heading, route, first)
        tried.append((planned, others))
    else:  # (never settled, the last unchecked: the clocks of two plans can send each to the other)
        if len(tried) > 1:
            planned, setup.planner.others = max(tried, key=lambda t: _synthesized_gap(setup, t[0], t[1]))
    syn = planned.synthesis
    if shot is not None:  # (a later job of the shot starts its search on this clock: fewer searched again)
        shot.clock = fit_clock(planned.result.footprints, syn.plan, syn.planted()) or shot.clock
    overlay.remember(scene, ob, planned.result.footprints, *syn.footprints, setup.forward, setup.planner.foot,
                     syn.body_position, planned.result.explored_positions if planned.result.explored else None)
    return planned


def _again(setup: PlanSetup, result: PlanResult, planned: Planned):
    """The others to plan round again (``CLOCK_TRIES``), None when the plan stands: the
    search timed its steps on its own clock, and the synthesis played them later (the stand
    and the start clip first) and at its pace, so the search goes again on that clock; where
    the clock held but the synthesized body still meets another's, with a wider slack."""
    others = setup.planner.others
    if others is None or others.empty:
        return None
    syn = planned.synthesis
    clock = fit_clock(result.footprints, syn.plan, syn.planted())
    end = max(f.time for f in result.footprints)
    old = others.clock
    if clock is not None and abs((clock[0] + clock[1] * end) - (old[0] + old[1] * end)) > CLOCK_MOVED:
        return others.on_clock(*clock)
    if _synthesized_gap(setup, planned, others) < setup.planner.settings.character_clearance:
        return others.widened()
    return None


def _synthesized_gap(setup: PlanSetup, planned: Planned, others: Others) -> float:
    """m: how near the synthesized body comes to another's, less both radii
    (``Others.least_gap``, on the synthesis's own times: no clock in it)."""
    if others is None or others.empty:
        return np.inf
    cfg, syn = setup.planner.settings, planned.synthesis  # (the character's: its lengths for its size)
    hips = syn.body_position + [0.0, 0.0, cfg.length(HIPS_HEIGHT)]
    return others.least_gap(syn.t, hips, cfg.length(BODY_RADIUS), cfg.body_scale)


#: mm: a re-bake whose splice lets a planted foot slide more than this is baked whole
SPLICE_SKATE_MM = 1.0


def measure(scene, ob, planned: Planned, solved: Solved, timing: report.BakeTiming, goal,
            body_on: str = "OBJECT", played: dict | None = None, obstacles=(), shot=None) -> dict:
    """The quality of the scene as Blender plays it (``bake.evaluate_played``: the bake
    with every other track and the active action as they are) over the bake's ``timing``
    (its ``planted`` when the bake's timing is not the synthesis's: a re-bake's splice),
    measured by ``core.report.document.measure_bake`` against ``goal`` and the plan's goal
    heading; the body as keyed (``body_on``) stands for the body. With ``played`` (a dict),
    its ``"body"`` is set to the body's positions (F, 3) as played and its ``"world"`` to
    the rig's world bone matrices (F, B, 4, 4) as played (one evaluation for the caller's
    own checks too). Where other characters in the scene were baked by the planner
    (``other_characters``), they play in the same frames, and the quality's ``"others"``
    gives, for each, how near the two bodies come and how many frames their feet stand on
    one footprint (``core.report.crowd.pair_figures``); where an obstacle (tagged, or named
    in ``obstacles`` for this run) moves over the bake (its transform: keys, a parent,
    constraints, drivers), its ``"moving_obstacles"`` gives how near the body comes to it
    (``crowd.obstacle_figures``). In a closed ``together.Shot`` the frames are read from
    its one pass, with every character of the shot in it."""
    setup, syn, rig = planned.setup, planned.synthesis, planned.setup.rig
    frames, fps = timing.frames, timing.fps
    root = None
    if body_on == "ROOT":  # (a Rigify rig's torso carries the body: its hips stand for it)
        root = rig.role_index("hips") if rigify.is_rigify(ob) else baking.root_bone(ob, rig)
    others = other_characters(scene, ob)
    obstacles = tagged_objects(scene, (), obstacles)[1]
    played_all, moved = _passes(shot)(scene, [(ob, rig), *others], timing.frame_start, frames, obstacles)
    world, body_pos, body_yaw, bone_rot = baking.played_pose(rig, *played_all[0], root)
    if played is not None:  # (for the caller: the body and the bones as played)
        played["body"], played["world"] = body_pos, world
    sched = syn.final.schedule
    walk = walk_motion(setup.analyses)
    stances = report.planted_stances(sched.feet, syn.planted() if timing.planted is None else timing.planted,
                                     *syn.footprints, fps, frames)
    allowance = report.source_steps(syn.tracks, sched.clips, sched.weights, fps)
    pose = report.PlayedPose(world, bone_rot, body_pos, body_yaw - solved.spin, rig.names,
                             toe_tips(rig, world, walk.heel_local, walk.toe_local))
    feet = report.FootPoints([rig.foot_chain(x)[0] for x in ("l", "r")], walk.heel_local, walk.toe_local)
    quality = report.measure_bake(pose, feet, setup.planner.ground, stances, goal, planned.goal_heading, allowance)
    movers = [(o, m) for o, m in zip(obstacles, moved) if crowd.moves(m)]
    if others or movers:
        me = crowd.body_of(ob.name, rig, world, fps)
    if others:  # (the other characters baked in the scene, played in the same frames)
        quality["others"] = [crowd.pair_figures(me, crowd.body_of(o.name, r, _world_of(shot, o, timing.frame_start, m),
                                                                 fps), timing.frame_start)
                             for (o, r), m in zip(others, played_all[1:])]
    if movers:  # (obstacles whose transform changes over the bake: planned where they stood)
        depsgraph = bpy.context.evaluated_depsgraph_get()
        quality["moving_obstacles"] = [
            crowd.obstacle_figures(me, o.name, BvhGround(local_mesh(o.name, o.evaluated_get(depsgraph))), m,
                                   timing.frame_start) for o, m in movers]
    return quality


def _world_of(shot, ob, frame_start: int, m) -> np.ndarray:
    """(F, B, 4, 4) the world matrices of ``ob``'s bones as played in ``m`` (its
    ``played_matrices`` from ``frame_start``); in a ``together.Shot``, its own (once closed,
    made once from its one pass for every job measured against ``ob``)."""
    return baking.played_world(*m) if shot is None else shot.played_world(ob, frame_start, m)


def other_characters(scene, ob) -> list:
    """(object, Rig) of every other character in the view layer that the planner baked
    (found by its tracks' tag, ``bake.owned_tracks``), in name order; one whose rig has no
    legs the planner reads is left out."""
    out = []
    # (an object removed since the view layer was last updated, a handle remade: listed as None)
    for o in sorted((o for o in bpy.context.view_layer.objects if o is not None), key=lambda o: o.name):
        if o.type != "ARMATURE" or o == ob or not baking.owned_tracks(o):
            continue
        try:
            r = rig_from_armature(o)
            r.require_legs()
        except RigError:
            continue
        out.append((o, r))
    return out


def others_in_time(scene, ob, frame_start: int, not_around=(), obstacles=(), shot=None) -> Others:
    """The other characters the planner baked in the scene (``other_characters``, but those
    named in ``not_around``) as Blender plays them from ``frame_start`` to the last frame of
    their tracks or the scene's (one pass of ``scene.frame_set``; after it each stands as it
    ends), on the clock of a plan starting there (``core.plan.others.Others``: their bodies,
    and the footprints their feet stand on and when); and the tagged obstacles (and those
    named in ``obstacles``) whose transform changes over those frames (keys, a parent,
    constraints, drivers), as points along their outline (``outline_points``) in time. In a
    ``together.Shot``, those it baked are as their IK solved them, and the pass of the rest
    is the shot's (played once for all its jobs)."""
    chars = [(o, r) for o, r in other_characters(scene, ob) if o.name not in set(not_around)]
    fps = scene_fps(scene)
    movable = movable_obstacles(scene, obstacles)
    if not chars and not movable:
        return crowd.others_of([], 1, fps)
    last = max([st.frame_end for o, _ in chars for tr in baking.owned_tracks(o) for st in tr.strips]
               + [scene.frame_end])
    frames = max(int(np.ceil(last)) - int(frame_start) + 1, 1)
    known = {} if shot is None else shot.bodies(chars, frame_start, frames)
    play = [c for c in chars if c[0].as_pointer() not in known]
    played, moved = [], []
    if play or movable:
        played, moved = _passes(shot)(scene, play, frame_start, frames, movable)
    bodies = iter(crowd.body_of(o.name, r, baking.played_world(*m), fps) for (o, r), m in zip(play, played))
    others = crowd.others_of([known[o.as_pointer()] if o.as_pointer() in known else next(bodies)
                              for o, _ in chars], frames, fps)
    depsgraph = bpy.context.evaluated_depsgraph_get()
    for o, m in zip(movable, moved):
        if not crowd.moves(m):
            continue
        mesh = local_mesh(o.name, o.evaluated_get(depsgraph))
        pts = outline_points(mesh.verts, mesh.tris)
        world = np.einsum("fij,pj->pfi", m[:, :3, :3], pts) + m[None, :, :3, 3]
        others = others.with_movers([o.name] * len(pts), world, 0.5 * OUTLINE_STEP)
    return others


def _passes(shot):
    """What plays the scene's frames for a read: ``bake.played_matrices``, or in a
    ``together.Shot`` its own (its passes kept, its one pass once closed)."""
    return baking.played_matrices if shot is None else shot.played_matrices


def movable_obstacles(scene, obstacles=()) -> list:
    """The tagged obstacles (and those named in ``obstacles``) that may move: animated or
    constrained, or under a parent that is (``_might_move``)."""
    return [o for o in tagged_objects(scene, (), obstacles)[1] if _might_move(o)]


def _might_move(ob) -> bool:
    """Whether an object or a parent of it is animated or constrained (else it stands)."""
    while ob is not None:
        ad = ob.animation_data
        if ob.constraints or (ad is not None and (ad.action is not None or len(ad.drivers) or len(ad.nla_tracks))):
            return True
        ob = ob.parent
    return False


@dataclass
class BakeRequest:
    """What a bake is asked for (``run``, ``run_steps``; the fields in the order the old
    positional calls gave them): walk to ``goal`` (arriving facing ``goal_heading``, a Z
    rotation, when given) from ``start_marker`` (else where the character stands), over the
    ``traversable`` and around the ``obstacles`` named (default: the tagged ones), with
    ``settings``; bake it as ``name`` from ``frame_start`` (default: the current frame),
    with timeline ``markers``, the body keyed on the object or the root bone (``body_on``),
    the frame range grown (``frame_range``). ``route`` replaces the search (an edited plan,
    waypoints: see ``plan``); a re-bake's ``splice`` (``directing.Splice``) re-keys only
    what changed; ``force`` bakes over an earlier bake of this name whose keys were edited,
    ``new_track`` beside it under a new name (``bake.new_track_name``). With
    ``Settings.avoid_characters`` the plan goes round the other characters the planner baked
    in the scene, but those named in ``not_around`` (a job list's later jobs, with
    ``--together``); in ``shot`` (a ``together.Shot``), round its earlier jobs as solved, and
    measured in its one pass once it is closed: ``bake_steps``."""

    goal: np.ndarray
    goal_heading: float | None = None
    start_marker: object = None
    settings: Settings | None = None
    traversable: tuple = ()
    obstacles: tuple = ()
    name: str | None = None
    frame_start: int | None = None
    markers: bool = False
    body_on: str = "OBJECT"
    frame_range: bool = True
    route: object = None
    splice: object = None
    force: bool = False
    new_track: bool = False
    not_around: tuple = ()
    shot: object = None

    def options(self, ob, scene, settings: Settings) -> baking.BakeOptions:
        """What ``bake.bake`` writes for this request on ``ob`` in ``scene``: its name (default
        "<character> to goal"; with ``new_track``, a new name, made beside that one), its
        first frame (default: the scene's current one) and the ``settings``' Rigify feet."""
        name, beside = self.name or f"{ob.name} to goal", None
        if self.new_track:
            name, beside = baking.new_track_name(ob, name), name
        frame_start = int(scene.frame_current if self.frame_start is None else self.frame_start)
        return baking.BakeOptions(name, frame_start, self.markers, self.body_on, self.frame_range,
                                  settings.rigify_ik_feet, self.force, beside)


def run(scene, ob, *args, progress=None, **options) -> dict:
    """Plan, synthesize, IK and bake ``ob`` as asked (``BakeRequest(*args, **options)``);
    returns the report (plan, stage times in the layout of thesis Table 4.1, quality of the
    baked result). ``progress(fraction, stage)`` is called between stages."""
    return run_to_end(run_steps(scene, ob, *args, **options), progress)


def run_to_end(steps, progress=None):
    """What a stage generator (``run_steps``, ``directing.rebake_steps``) returns, run to its
    end; ``progress(fraction, next stage)`` is called between its stages."""
    while True:
        try:
            fraction, stage = next(steps)
        except StopIteration as done:
            return done.value
        if progress is not None:
            progress(fraction, stage)


def run_steps(scene, ob, *args, **options):
    """``run`` one stage at a time: a generator yielding (fraction done, next stage) and
    returning the report (``bake_steps`` of ``BakeRequest(*args, **options)``)."""
    return bake_steps(scene, ob, BakeRequest(*args, **options))


def bake_steps(scene, ob, req: BakeRequest):
    """The bake one stage at a time. Nothing in the scene changes before the bake stage, and
    the bake is taken back unless its quality, measured as Blender plays it, passes; so a
    caller may stop it at any yield (close it) and leave the scene as it was. What would
    make the bake play elsewhere than planned (``bake.check_scene``, a constraint on the
    legs) is refused before planning; a bake whose measured goal or skate is beyond
    ``report.tolerances`` is taken back and refused (BakeError naming the figure), the
    earlier bake of its name kept. A re-bake's ``splice`` gets ``splice.before_ik(planned)``
    (it may pin footprints) and ``splice.after_bake(action, track, planted, frames,
    frame_start, fps)``: it may change the baked keys before they are measured and returns
    the timing they then have. Every bake records its footprints and their frames
    (``rebake.record``). In a ``together.Shot`` (``req.shot``) the bake joins the shot before
    the "quality" stage, and its driver stops there until every job has baked and the shot
    is closed: each is then measured in the shot's one pass."""
    job = _Job(scene, ob, req)
    baking.check_scene(scene, ob, req.body_on)
    yield 0.0, "planning"
    job.planned = planned = plan_and_synthesize(scene, ob, req.goal, req.goal_heading, req.start_marker, job.settings,
                                                req.traversable, req.obstacles, req.route, job.opts.frame_start,
                                                req.not_around, req.shot)
    baking.check_leg_constraints(ob, planned.setup.rig)
    yield 0.5, "inverse kinematics"
    if req.splice is not None:
        req.splice.before_ik(planned)
    job.solved = (planned.solved if planned.solved is not None and req.splice is None
                  else solve(planned.synthesis, planned.setup, job.settings))
    yield 0.7, "bake"
    job.bake(req.splice is not None)
    if req.shot is not None:
        req.shot.add(ob, planned.setup.rig, job.solved, job.opts.frame_start, job.fps, req.obstacles)
    try:
        yield 0.85, "quality"
        qual = job.measured()
    except BaseException:  # (a wrong bake, a failure, or the caller stopping here: the bake taken back)
        job.take_back()
        raise
    baking.settle(ob, scene, job.replaced)
    return job.report(qual)


class _Job:
    """One bake's state between ``bake_steps``' stages: what it bakes as (``opts``: its name,
    the one it is made beside, its first frame; and the scene's rate), the plan and IK once
    made, and the bake once written (its action, track, ``timing``, and the earlier bake it
    mutes)."""

    def __init__(self, scene, ob, req: BakeRequest):
        self.scene, self.ob, self.req = scene, ob, req
        self.settings = req.settings or Settings()
        self.fps = scene_fps(scene)
        self.opts = req.options(ob, scene, self.settings)
        self.timer, self.replaced, self.track, self.played = StageTimer(), [], None, {}
        self.planned = self.solved = None

    def bake(self, spliced: bool) -> None:
        """Bake (splicing into the old bake's keys, with ``spliced``) and record its timing."""
        planned, solved, syn, first = self.planned, self.solved, self.planned.synthesis, self.opts.frame_start
        self._remember_range()
        with self.timer("bake"):
            self.act, self.track = baking.bake(self.ob, self.scene, planned.setup.rig, solved.ik, solved.spin,
                                               self.opts, planned.result.footprints, syn.planted(), self.replaced)
            self.act[ROUND_OTHERS_PROP] = bool(self.settings.avoid_characters)
        self._grown = (self.scene.frame_start, self.scene.frame_end)
        try:
            planted, frames = syn.planted(), solved.ik.frames
            if spliced:
                planted, frames = self.req.splice.after_bake(self.act, self.track, planted, frames, first, self.fps)
            self.timing = report.BakeTiming(first, frames, self.fps, planted)
            rebake.record(self.act, planted, syn.footprints, first, self.fps)
            baking.record_keys(self.act)
        except BaseException:
            self.take_back()
            raise

    def _remember_range(self) -> None:
        """The scene's frame range and the range records on the character's bakes, as they
        are before this bake grows them (``take_back`` gives them back)."""
        self._range = (self.scene.frame_start, self.scene.frame_end)
        acts = {st.action for tr in baking.owned_tracks(self.ob) for st in tr.strips if st.action is not None}
        self._records = {a: (list(a[RANGE_PROP]) if RANGE_PROP in a else None) for a in acts}

    def take_back(self) -> None:
        """The bake taken back: its track and action removed, the earlier bake of its name as
        it was, and the frame range and the other bakes' records as before it."""
        if self.track is None:
            return
        baking.discard(self.ob, self.scene, self.track, self.replaced)
        self.track = None
        if self.req.shot is not None:
            self.req.shot.drop(self.ob)
        now = (self.scene.frame_start, self.scene.frame_end)
        if now != self._range and now == self._grown:  # (not when a later bake of a shot grew it since)
            self.scene.frame_start, self.scene.frame_end = self._range
        for act, rng in self._records.items():
            try:
                act.name  # (an action removed meanwhile has nothing to give back)
            except ReferenceError:
                continue
            if rng is None:
                act.pop(RANGE_PROP, None)
            else:
                act[RANGE_PROP] = rng

    def _measure(self) -> dict:
        self.played = {}
        return measure(self.scene, self.ob, self.planned, self.solved, self.timing, self.req.goal, self.opts.body_on,
                       self.played, self.req.obstacles, self.req.shot)

    def measured(self) -> dict:
        """The bake's quality as Blender plays it; a splice that slides a foot is re-baked
        whole; BakeError when a figure is beyond the report's tolerances."""
        qual, splice = self._measure(), self.req.splice
        if splice is not None and splice.span is not None and qual["foot_skate"]["max_mm"] > SPLICE_SKATE_MM:
            # the edit turned the walk too far round the kept footprints for their keys to mix
            # without a foot sliding: the whole path is baked instead
            splice.slid_mm, splice.span = float(qual["foot_skate"]["max_mm"]), None
            self.take_back()
            self.bake(False)
            qual = self._measure()
        pl = self.planned.setup.planner
        limits = report.tolerances(pl.settings.goal_radius, pl.settings.body_scale)
        qual["tolerances"] = limits
        faults = report.played_faults(qual, limits)
        if faults:
            raise baking.BakeError(f"the bake of {self.ob.name!r} is wrong: {'; '.join(faults)}: something in the "
                                   "scene moves the character besides its bake (a parent, a constraint, a driver, an "
                                   "NLA track, a time remap); nothing was baked")
        return qual

    def report(self, qual: dict) -> dict:
        """The bake's report: the plan, the stage times, the quality, the feet's points."""
        planned, solved, act = self.planned, self.solved, self.act
        result, syn = planned.result, planned.synthesis
        stages = stage_row(len(result.footprints), result.seconds, syn, pose_blend=solved.pose_seconds,
                           ik=solved.ik_seconds, bake=self.timer.seconds["bake"])
        baked = report.BakeIdentity(self.ob.name, self.opts.name, act.name, self.track.name)
        doc = report.bake_report(result, syn, baked, self.timing, goal=self.req.goal, forward=planned.setup.forward,
                                 stages=stages, quality=qual)
        doc["stashed_action"] = act.get(baking.STASH_PROP)
        if planned.performance is not None:
            doc["waypoints"] = waypoint_rows(planned, self.opts.frame_start, self.fps, self.played.get("body"))
        walk, rig = walk_motion(planned.setup.analyses), planned.setup.rig
        own = 1.0 / object_scale(self.ob)  # (in the armature's own units: as an independent read of the file has them)
        doc["feet"] = report.feet_points([rig.names[rig.foot_chain(x)[0]] for x in ("l", "r")],
                                         scaled_points(walk.heel_local, own), scaled_points(walk.toe_local, own))
        return doc

