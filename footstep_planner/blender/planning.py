"""Planning in a Blender scene: the character's footprints and clips, the tagged
surfaces, the goal -> core.navgraph.Planner -> a footstep path.

Headings in the result are yaws (radians) relative to the character's rest-pose forward
as it stands in the world (its armature's rest forward turned by the object's rotation).
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, replace

import bpy
import numpy as np
from scipy.spatial.transform import Rotation

from ..core import report, turn_in_place
from ..core.analysis import ClipAnalysis
from ..core.body import body_scale
from ..core.directed import Performance, TimingError, arrival_frames, arrival_times, perform
from ..core.ik import IKResult, solve_ik
from ..core.library import Library
from ..core.rig import Rig, forward_kinematics
from ..core.navgraph import FootprintCache, PathFootprint, PlanError, PlanResult, Planner
from ..core.pipeline import Synthesis, stage_row, standing_body, surface_snap
from ..core.pipeline import synthesize as _synthesize
from ..core.settings import Settings
from ..core.steps import library_steps
from ..core.pose import blend_pose, pose_bases
from ..core.surface import FootShape, footprint_support
from ..core.timing import StageTimer
from .character import analyze_character, library_for
from .scene import scene_fps
from .surfaces import scene_surfaces

#: Support answers per scene, reused while its tagged geometry is unchanged.
_CACHES: dict[tuple[str, FootShape], FootprintCache] = {}
#: m of toes the foot's rectangle reaches ahead of the ball; a longer toe bone's tip is
#: ``FootShape.tip``.
TOE_ROOM = 0.07


@dataclass
class PlanSetup:
    planner: Planner
    analyses: list[ClipAnalysis]
    library: Library
    forward: np.ndarray  # world (x, y) of heading 0
    rig: Rig | None = None
    start: list | None = None  # the standing footprints the plan left from


def world_forward(ob, analyses) -> np.ndarray:
    """The character's heading-0 direction in the world, checking its object transform
    (its own one: a bake of the planner's animates the object, and does not count)."""
    from .bake import own_frame

    m = own_frame(ob)  # (an even scale is the rig's, read in world units: ``scene.object_scale``)
    if abs(m[2, 2] - 1) > 1e-3:
        raise PlanError(f"character {ob.name!r} is tilted in object mode; only a turn about Z "
                        "is allowed: clear its X and Y rotation")
    f = analyses[0].motion.rest_forward
    w = m[:2, :2] @ f
    return w / np.linalg.norm(w)


def foot_shape(analyses, rig: Rig | None = None, scale: float = 1.0) -> FootShape:
    """The foot's rectangle from the clips' heel and toe points (ball of the foot), with
    room for the heel behind the ankle and the toes ahead of the ball; with the ``rig``,
    the toe tip where its toe bones reach further (``FootShape.tip``: a long toe that
    must stay out of a riser). The room and the width are a human's times the body's
    ``scale`` (``Settings.body_scale``)."""
    lengths = [np.linalg.norm(f.toe[:2] - f.heel[:2]) for a in analyses for f in a.footprints()]
    half = 0.5 * float(np.median(lengths)) if lengths else 0.08 * scale
    toes = [float(np.linalg.norm(rig.tails[t] - rig.rest[t, :3, 3])) for t in
            (rig.foot_chain(side)[1] for side in "lr") if t is not None] if rig is not None else []
    room = TOE_ROOM * scale
    tip = half + max(toes) if toes and max(toes) > room else 0.0
    sole = getattr(rig, "sole", None)
    if sole is not None:  # (the mesh's own heel and toe tip: the rectangle is the foot's, and a little room)
        along = sole.ball - sole.heel
        reach = max(float(np.max(np.einsum("ki,ki->k", sole.tip - sole.ball, along)
                                  / np.maximum(np.linalg.norm(along, axis=1), 1e-9))), 0.0)
        front = min(reach, room)  # (the toes beyond that may hang over a nosing, going down: ``tip``)
        return FootShape(back=half + 0.01 * scale, front=half + front, half_width=0.05 * scale,
                         tip=half + reach if reach > room else 0.0, scale=scale)
    return FootShape(back=half + 0.04 * scale, front=half + room, half_width=0.05 * scale, tip=tip, scale=scale)


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
    cache = _CACHES.setdefault((scene.name, foot), FootprintCache(margin=settings.length(0.6)))  # (a foot's own)
    cache.update(object_geometry(ground, obst))
    planner = Planner(ground, obst, steps, forward, foot=foot,
                      settings=settings, cache=cache)
    return PlanSetup(planner, clips.analyses, library, forward, clips.rig)


#: m (a human's): the shortest step a walk is shortened to is at most this long, whatever
#: its clip's stride (one stair tread, 28 cm, a step): ``Settings.stride_min`` of a
#: long-striding game walk (0.9 m a step) would still skip treads.
SHORTEST_STEP = 0.28


def shortest_stride(settings: Settings, library: Library, analyses) -> float:
    """The least share of its clip's stride a walking step may be shortened to:
    ``Settings.stride_min``, or less for a library whose straightest walk steps so far
    that that share is well longer than SHORTEST_STEP (at the character's size: a 0.9 m
    game walk step, not a human's 0.72 m)."""
    if settings.stride_min >= 1.0:  # (the clips' own strides only, as asked)
        return settings.stride_min
    by = {a.name: a for a in analyses}
    walk = library.turn_groups.get("walk") or library.turn_groups.get("run")
    if walk is None or not walk.clips:
        return settings.stride_min
    straight = min(walk.clips, key=lambda c: abs(c.tau))
    a = by.get(straight.clip)
    step = 0.5 * a.stride if a is not None and a.stride else 0.0
    if step <= 0:
        return settings.stride_min
    share = settings.length(SHORTEST_STEP) / step
    return settings.stride_min if share >= 0.8 * settings.stride_min else float(max(share, 0.05))


def character_footprints(ob, setup: PlanSetup) -> list[PathFootprint]:
    """Both feet standing where the character stands: under its hips at rest, placed by
    its object's own transform (not the one a bake of the planner's animates it to, nor
    the pose its active clip has at the current frame), facing its forward. The same
    scene gives the same start, so re-baking gives the same footprints."""
    from .bake import own_frame

    m = own_frame(ob)  # (the rig is in world units)
    hips = setup.rig.rest[setup.rig.role_index("hips")][:, 3]
    return standing_footprints(m @ hips, 0.0, setup, f"character {ob.name!r}")


#: m: the standing feet's distance either side of the body, and with
#: ``Settings.straightens`` (the default) the least and most of it as the walk's stance
#: width sets it.
STAND_HALF_WIDTH = 0.1
STAND_HALF_WIDTH_RANGE = (0.05, 0.15)


def standing_footprints(position, heading: float, setup: PlanSetup, what: str,
                        width: float | None = None) -> list[PathFootprint]:
    """Both feet side by side, ``width`` either side of ``position`` (3,), turned
    ``heading`` (the planner's frame), dropped onto the ground; PlanError naming ``what``
    when there is no traversable surface under a foot. The width is STAND_HALF_WIDTH,
    or with ``Settings.straightens`` (the default) half the walk's stance width
    (``StepSet.stance_width``, within STAND_HALF_WIDTH_RANGE) and each foot turned out as
    the walk turns it out (``StepSet.toe_out``): the first step then leaves straight, not
    askew, along the line through ``position``, not beside it."""
    ang = heading + np.arctan2(setup.forward[1], setup.forward[0])
    left = np.array([-np.sin(ang), np.cos(ang), 0.0])
    p = np.asarray(position, float)[:3]
    cfg = setup.planner.settings
    straight = cfg.straightens
    toe = setup.planner.steps.toe_out() if straight else 0.0
    if width is None:
        width = cfg.length(STAND_HALF_WIDTH)
        if straight and setup.planner.steps.stance_width() > 0:
            lo, hi = (cfg.length(w) for w in STAND_HALF_WIDTH_RANGE)
            width = float(np.clip(0.5 * setup.planner.steps.stance_width(), lo, hi))
    out = []
    for k, sign in ((0, 1), (1, -1)):
        q = p + sign * width * left
        hit = setup.planner.ground.ray_down(np.array([[q[0], q[1], q[2] + cfg.length(0.5)]]), cfg.length(3.0))
        if not hit.hit[0]:
            raise PlanError(f"{what} stands at ({p[0]:.2f}, {p[1]:.2f}, {p[2]:.2f}), not above a traversable "
                            "surface: move it onto a traversable mesh, or pick a Start")
        out.append(PathFootprint(k, np.array([q[0], q[1], hit.z[0]]), heading + sign * toe, 0.0, "start", "walk"))
    return out


#: Empties (Start, Goal) and the character face their local -Y axis, as Blender's
#: characters do: an empty turned by ``z`` about Z faces the way a character at rest
#: turned by ``z`` faces.
FACING = "-Y"


def facing_rotation(ob) -> float:
    """The Z rotation (rad) of the way ``ob`` faces: the yaw of its local -Y axis in the
    world, plus a quarter turn (0 when it faces -Y, pi/2 facing +X)."""
    m = ob.matrix_world
    if abs(m[2][2] - 1.0) < 1e-6:  # upright: its Z rotation as it was set
        return float(m.to_euler().z)
    return float(np.arctan2(-m[1][1], -m[0][1]) + np.pi / 2)


def rotation_heading(z_rotation: float, forward) -> float:
    """The planner's heading (rad, from the character's ``forward``) of the way something
    turned ``z_rotation`` about Z from facing -Y faces."""
    return float(z_rotation) - np.pi / 2 - float(np.arctan2(forward[1], forward[0]))


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
    """Thesis 3.3 to 3.7 on a planned path: the body trajectory and every clip's weight
    and time per scene frame, footprints kept on the tagged surfaces. The character starts
    from standing on its start footprints and stops to standing at the goal, turned to
    ``goal_heading`` (the planner's heading, rad) when given; the synthesis's path
    (``Synthesis.plan``) holds both standing feet at either end. A path that turns in
    place (``core.turn_in_place``) plays each turn as a leg of its own."""
    path = result.footprints
    other = next((f for f in setup.start or () if f.foot != path[0].foot), None)
    return legs_of(scene, setup, settings or Settings())(path, other, goal, goal_heading, None, None, None)


def legs_of(scene, setup: PlanSetup, settings: Settings):
    """``core.directed.SynthFn`` on this scene: a leg from standing to standing (a path
    that turns in place: its turns and walk, ``core.turn_in_place.synthesize``)."""
    pl = setup.planner
    settings = settings.for_body(pl.settings.body_scale)  # (a human's lengths, for this character)
    snap = surface_snap(pl.ground, pl.obstacles, setup.forward, pl.foot, clearance=pl.clearance,
                        step_height=pl.max_step_height)
    fps = scene_fps(scene)
    body = standing_body(setup.library, setup.analyses)

    def leg(path, other, goal, heading, lead, hold, pace):
        if other is None:
            other = next((f for f in setup.start or () if f.foot != path[0].foot), None)
        return _synthesize(path, setup.library, setup.analyses, settings, fps=fps, forward=setup.forward, snap=snap,
                           goal=goal, standing=True, start_other=other, goal_heading=heading, pace=pace, lead=lead,
                           hold=hold)

    def turning(path, other, goal, heading, lead, hold, pace):
        if any(f.label == turn_in_place.PIVOT for f in path):
            return turn_in_place.synthesize(path, leg, other, goal, heading, lead, hold, pace, setup.forward, pl.foot,
                                            settings.turn_step_angle, body)
        return leg(path, other, goal, heading, lead, hold, pace)

    return turning


@dataclass
class Planned:
    """A plan and its synthesized motion."""

    result: PlanResult
    setup: PlanSetup
    synthesis: Synthesis
    goal_heading: float | None  # the planner's heading to arrive with (rad), if any
    performance: Performance | None = None  # through waypoints: when each is reached
    solved: Solved | None = None  # the IK of ``synthesis``, when timing it needed one already


def plan_and_synthesize(scene, ob, goal, goal_heading=None, start_marker=None, settings=None,
                        traversable=(), obstacles=(), route=None, frame_start: float | None = None) -> Planned:
    """Plan the footprints to ``goal`` and synthesize the motion along them; the overlay
    shows the result. A route through waypoints (``directing.ViaRoute``) that stops at
    some or has arrival frames (scene frames, the first frame being ``frame_start``,
    default the current one) is performed leg by leg (``core.directed.perform``)."""
    from . import overlay

    settings = settings or Settings()
    result, setup = plan(scene, ob, goal, goal_heading, start_marker, settings, traversable, obstacles, route)
    heading = None if goal_heading is None else rotation_heading(goal_heading, setup.forward)
    performance, ik = None, _LastSolve(setup, heading, settings)
    if callable(getattr(route, "marks", None)):
        fps = scene_fps(scene)
        first = float(scene.frame_current if frame_start is None else frame_start)
        marks = route.marks(fps, first)
        if route.directed:
            can_run = bool(setup.library.turn_groups.get("run"))
            while True:  # (a frame too soon: run on the way to it; early with nowhere to wait: stop before)
                try:
                    performance = _perform(scene, result, setup, settings, marks, goal, heading, first, ik.body)
                    break
                except TimingError as ex:
                    if not route.retime(ex, can_run):
                        raise
                    result = route(setup, setup.start, heading)
                    marks = route.marks(fps, first)
            syn = performance.synthesis
        else:
            syn = synthesize(scene, result, setup, settings, goal=goal, goal_heading=heading)
            times, windows = arrival_times(syn, [syn], marks, ik.body(syn))
            performance = Performance(syn, marks, times, np.ones(len(marks)), np.zeros(len(marks)), windows)
    else:
        syn = synthesize(scene, result, setup, settings, goal=goal, goal_heading=heading)
    result = replace(result, footprints=list(syn.plan))  # with both standing feet at either end
    overlay.remember(scene, result.footprints, *syn.footprints, setup.forward, setup.planner.foot, syn.body_position,
                     result.explored_positions if result.explored else None)
    return Planned(result, setup, syn, heading, performance, ik.of(syn))


class _LastSolve:
    """The IK of syntheses whose arrival frames are read on the baked body (``body``),
    the last one kept for the bake (``of``)."""

    def __init__(self, setup: PlanSetup, heading, settings: Settings):
        self.setup, self.heading, self.settings, self.last = setup, heading, settings, None

    def body(self, syn: Synthesis) -> np.ndarray:
        solved = solve(Planned(None, self.setup, syn, self.heading), self.settings)
        self.last = (syn, solved)
        return solved.ik.body_pos

    def of(self, syn: Synthesis) -> "Solved | None":
        return self.last[1] if self.last is not None and self.last[0] is syn else None


def _perform(scene, result: PlanResult, setup: PlanSetup, settings: Settings, marks, goal, heading,
             frame_start: float, body) -> Performance:
    """The path through its marks leg by leg, stopping where they stop, their frames met
    (read on ``body(synthesis)``: the body the bake will have, after the IK)."""
    return perform(result.footprints, marks, legs_of(scene, setup, settings), goal, heading,
                   pace_range=(settings.pace_min, settings.pace_max), frame_start=frame_start, body=body)


def waypoint_rows(planned: Planned, frame_start: int, fps: float, played_body=None) -> list[dict]:
    """Per waypoint (the goal last): the frame asked for, the frame the plan reaches it on
    and, with the played body positions (F, 3), the frame the played scene does; the
    pause, the pace of the walk to it, the seconds waited before."""
    perf = planned.performance
    if perf is None:
        return []
    played = None if played_body is None else arrival_frames(played_body, perf.marks, perf.windows)
    rows = []
    for k, m in enumerate(perf.marks):
        rows.append({"name": m.name, "arrive": None if m.arrive is None else round(frame_start + m.arrive * fps, 2),
                     "planned": round(float(frame_start + perf.times[k] * fps), 2),
                     "achieved": None if played is None else round(float(frame_start + played[k]), 2),
                     "stops": bool(m.stop), "pause": round(float(m.pause), 3), "pace": round(float(perf.pace[k]), 4),
                     "waited": round(float(perf.waited[k]), 3)})
    return rows


def body_spin(forward, analyses) -> float:
    """World yaw of heading 0 minus the rig's rest forward's yaw: the armature object's
    yaw is this plus the body heading."""
    rest = analyses[0].motion.rest_forward
    return float(np.arctan2(forward[1], forward[0]) - np.arctan2(rest[1], rest[0]))


def _walk_motion(setup: PlanSetup):
    """The clip whose heel and toe points stand for the character's (its first cycle)."""
    return next((a for a in setup.analyses if a.kind == "cycle"), setup.analyses[0]).motion


#: mm: a re-bake whose splice lets a planted foot slide more than this is baked whole
SPLICE_SKATE_MM = 1.0


@dataclass
class Solved:
    """The IK's result, with the seconds of the pose blend and of the IK."""

    ik: IKResult
    spin: float
    pose_seconds: float
    ik_seconds: float


def flat_feet(rig: Rig, basis: np.ndarray, weight: np.ndarray, heel_local: np.ndarray,
              toe_local: np.ndarray) -> np.ndarray:
    """Pose bases (F, B, 4, 4) with each foot turned about its ankle, as far as ``weight``
    (F,) 0..1 (the standing clip's), until its heel and ball (``heel_local``, ``toe_local``
    (2, 4) in the foot bones' frames) lie level: a standing character stands on flat feet
    (the IK keeps a planted foot's own pitch)."""
    on = np.flatnonzero(np.asarray(weight) > 1e-6)
    if not len(on):
        return basis
    basis = np.array(basis, float, copy=True)
    feet = [rig.foot_chain(side)[0] for side in ("l", "r")]
    world = forward_kinematics(rig, basis[on], bones=feet)
    for k, f in enumerate(feet):
        W = world[:, f, :3, :3]
        d = W @ (np.asarray(toe_local[k][:3], float) - np.asarray(heel_local[k][:3], float))  # heel to ball
        level = d * [1.0, 1.0, 0.0]
        axis = np.cross(d, level)
        norm = np.linalg.norm(axis, axis=1, keepdims=True)
        axis = np.where(norm > 1e-12, axis / np.maximum(norm, 1e-12), [1.0, 0.0, 0.0])
        pitch = np.abs(np.arctan2(d[:, 2], np.linalg.norm(level, axis=1)))
        turn = Rotation.from_rotvec(axis * (pitch * weight[on])[:, None]).as_matrix()
        basis[on, f, :3, :3] = basis[on, f, :3, :3] @ (W.transpose(0, 2, 1) @ turn @ W)
    return basis


def solve(planned: Planned, settings: Settings) -> Solved:
    """Thesis 3.8: the clips' bone rotations blended per frame, then the feet pinned to
    the footprints (on the surface, along its normal) by the IK."""
    syn, setup = planned.synthesis, planned.setup
    timer = StageTimer()
    walk = _walk_motion(setup)
    with timer("pose_blend"):
        quat, hips = blend_pose(syn.posed_schedule(), syn.tracks)
        basis = flat_feet(setup.rig, pose_bases(setup.rig, quat, hips), syn.stand_weight(), walk.heel_local,
                          walk.toe_local)
    pl = setup.planner
    pos, head = syn.footprints
    sup = footprint_support(pl.ground, pl.obstacles, pos, head, setup.forward, pl.foot, clearance=pl.clearance)
    normal = np.where(np.isfinite(sup.normal), sup.normal, [0.0, 0.0, 1.0])
    spin = body_spin(setup.forward, setup.analyses)

    look = pl.settings.length(0.3)

    def ground_z(points):
        hit = pl.ground.ray_down(np.asarray(points, float) + [0.0, 0.0, look], 2 * look)
        return np.where(hit.hit, hit.z, np.nan)

    with timer("ik"):
        ik = solve_ik(setup.rig, basis, syn.final.schedule.t, syn.body_position, syn.body_heading, spin,
                      walk.heel_local, walk.toe_local, syn.final.schedule.feet, syn.planted(), pos, head, normal,
                      setup.forward, settings.for_body(pl.settings.body_scale), ground_z=ground_z, still=syn.flat)
    return Solved(ik, spin, timer.seconds["pose_blend"], timer.seconds["ik"])


def measure(scene, ob, planned: Planned, solved: Solved, frame_start: int, goal, goal_heading, fps: float,
            body_on: str = "OBJECT", planted=None, frames: int | None = None, played: dict | None = None) -> dict:
    """The quality of the scene as Blender plays it (``bake.evaluate_played``: the bake
    with every other track and the active action as they are), measured by
    ``core.report.measure_bake``; ``planted`` and ``frames`` when the bake's timing is
    not the synthesis's (a re-bake's splice)."""
    from . import bake as baking

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
    walk = _walk_motion(setup)
    stances = report.planted_stances(sched.feet, syn.planted() if planted is None else planted, *syn.footprints,
                                     fps, frames)
    allowance = report.source_steps(syn.tracks, sched.clips, sched.weights, fps)
    return report.measure_bake(world, bone_rot, body_pos, body_yaw - solved.spin,
                               [setup.rig.foot_chain(x)[0] for x in ("l", "r")], walk.heel_local, walk.toe_local,
                               setup.planner.ground, stances, goal, goal_heading, allowance, setup.rig.names,
                               tips=toe_tips(setup.rig, world, walk.heel_local, walk.toe_local))


def toe_tips(rig: Rig, world: np.ndarray, heel_local: np.ndarray, toe_local: np.ndarray) -> np.ndarray:
    """(2, F, 3) each foot's toe tip in the world (``core.ik.toe_tip``: the toe bone's end,
    bent as it is, or the mesh's tip) of bone matrices ``world`` (F, B, 4, 4)."""
    from ..core.ik import toe_tip

    out = []
    for k, side in enumerate(("l", "r")):
        foot, toe = rig.foot_chain(side)
        local = toe_tip(rig, side, world[:, foot], world[:, toe] if toe is not None else None,
                        heel_local[k, :3], toe_local[k, :3])
        out.append(np.einsum("fij,fj->fi", world[:, foot, :3, :3], local) + world[:, foot, :3, 3])
    return np.stack(out)


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
    from . import bake as baking
    from . import rebake

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
    solved = planned.solved if planned.solved is not None and splice is None else solve(planned, settings)
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
    walk, rig = _walk_motion(planned.setup), planned.setup.rig
    from ..core.body import scaled_points
    from .scene import object_scale

    own = 1.0 / object_scale(ob)  # (in the armature's own units: as an independent read of the file has them)
    doc["feet"] = report.feet_points([rig.names[rig.foot_chain(x)[0]] for x in ("l", "r")],
                                     scaled_points(walk.heel_local, own), scaled_points(walk.toe_local, own))
    return doc

