"""Planning in a Blender scene: the character's footprints and clips, the tagged
surfaces, the goal -> core.navgraph.Planner -> a footstep path.

Headings in the result are yaws (radians) relative to the character's rest-pose forward
as it stands in the world (its armature's rest forward turned by the object's rotation).
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass

import bpy
import numpy as np

from ..core.analysis import ClipAnalysis
from ..core.library import Library
from ..core.rig import Rig
from ..core.navgraph import FootprintCache, Footstep, PlanError, PlanResult, Planner
from ..core.pipeline import Synthesis, stage_row, surface_snap
from ..core.pipeline import synthesize as _synthesize
from ..core.settings import Settings
from ..core.steps import library_steps
from ..core.surface import FootShape
from .character import analyze_character, library_for
from .surfaces import scene_surfaces

#: Support answers per scene, reused while its tagged geometry is unchanged.
_CACHES: dict[str, FootprintCache] = {}


@dataclass
class PlanSetup:
    planner: Planner
    analyses: list[ClipAnalysis]
    library: Library
    forward: np.ndarray  # world (x, y) of heading 0
    rig: Rig | None = None


def world_forward(ob, analyses) -> np.ndarray:
    """The character's heading-0 direction in the world, checking its object transform
    (its own one: a bake of the planner's animates the object, and does not count)."""
    from .bake import own_matrix_world

    m = own_matrix_world(ob)
    scale = np.linalg.norm(m[:3, :3], axis=0)
    if np.abs(scale - 1).max() > 1e-3:
        raise PlanError(f"character {ob.name!r} is scaled ({', '.join(f'{v:.3g}' for v in scale)}) in "
                        "object mode; apply its scale (Object > Apply > Scale) so its clips "
                        "fit the world")
    if abs(m[2, 2] - 1) > 1e-3:
        raise PlanError(f"character {ob.name!r} is tilted in object mode; only a turn about Z "
                        "is allowed: clear its X and Y rotation")
    f = analyses[0].motion.rest_forward
    w = m[:2, :2] @ f
    return w / np.linalg.norm(w)


def foot_shape(analyses) -> FootShape:
    """The foot's rectangle from the clips' heel and toe points (ball of the foot), with
    room for the heel behind the ankle and the toes ahead of the ball."""
    lengths = [np.linalg.norm(f.toe[:2] - f.heel[:2]) for a in analyses for f in a.footprints()]
    half = 0.5 * float(np.median(lengths)) if lengths else 0.08
    return FootShape(back=half + 0.04, front=half + 0.07, half_width=0.05)


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


def setup(scene, ob, settings=None, traversable=(), obstacles=()) -> PlanSetup:
    depsgraph = bpy.context.evaluated_depsgraph_get()
    ground, obst = scene_surfaces(scene, depsgraph, traversable, obstacles)
    clips = analyze_character(ob, settings)
    if not clips.analyses:
        why = "; ".join(clips.errors.values()) or "it has no actions"
        raise PlanError(f"character {ob.name!r} has no usable clips ({why})")
    library = library_for(ob, clips)
    steps = library_steps(library, clips.analyses)
    forward = world_forward(ob, clips.analyses)
    cache = _CACHES.setdefault(scene.name, FootprintCache())
    cache.update(object_geometry(ground, obst))
    st = settings or Settings()
    planner = Planner(ground, obst, steps, forward, foot=foot_shape(clips.analyses), cache=cache,
                      **{k: getattr(st, k) for k in Planner.FROM_SETTINGS})
    return PlanSetup(planner, clips.analyses, library, forward, clips.rig)


def _heading(vec_xy, forward) -> float:
    return float(np.arctan2(vec_xy[1], vec_xy[0]) - np.arctan2(forward[1], forward[0]))


def character_footprints(ob, s: PlanSetup) -> list[Footstep]:
    """Where the character's feet are now (the evaluated pose at the current frame),
    dropped onto the ground."""
    from .scene import rig_from_armature

    rig = rig_from_armature(ob)
    ev = ob.evaluated_get(bpy.context.evaluated_depsgraph_get())
    m = np.array(ev.matrix_world)
    out = []
    for k, side in enumerate("lr"):
        foot, toe = rig.foot_chain(side)
        pb = ev.pose.bones[rig.names[foot]]
        ankle = m @ np.append(np.array(pb.head), 1.0)
        ball = m @ np.append(np.array(ev.pose.bones[rig.names[toe]].head if toe is not None else pb.tail), 1.0)
        mid = 0.5 * (ankle[:3] + ball[:3])
        hit = s.planner.ground.ray_down(np.array([[mid[0], mid[1], mid[2] + 0.5]]), 3.0)
        if not hit.hit[0]:
            raise PlanError(f"character {ob.name!r}: its {'left' if k == 0 else 'right'} foot "
                            f"({mid[0]:.2f}, {mid[1]:.2f}) is not above a traversable surface")
        pos = np.array([mid[0], mid[1], hit.z[0]])
        out.append(Footstep(k, pos, _heading(ball[:2] - ankle[:2], s.forward), 0.0, "start", "walk"))
    return out


def marker_footprints(marker, s: PlanSetup, width: float = 0.1) -> list[Footstep]:
    """Both feet standing at an object (an empty), facing along its -Y axis turned by its
    Z rotation like the character (heading = its Z rotation)."""
    m = np.array(marker.matrix_world)
    p = m[:3, 3]
    psi = float(marker.matrix_world.to_euler().z)
    ang = psi + np.arctan2(s.forward[1], s.forward[0])
    left = np.array([-np.sin(ang), np.cos(ang), 0.0])
    out = []
    for k, sign in ((0, 1), (1, -1)):
        q = p + sign * width * left
        hit = s.planner.ground.ray_down(np.array([[q[0], q[1], q[2] + 0.5]]), 3.0)
        if not hit.hit[0]:
            raise PlanError(f"start {marker.name!r} is not above a traversable surface")
        out.append(Footstep(k, np.array([q[0], q[1], hit.z[0]]), psi, 0.0, "start", "walk"))
    return out


def goal_of(scene, name: str | None):
    """(position, heading or None): an object's location (and Z rotation as heading when
    it is an empty arrow), or the 3D cursor."""
    if name:
        ob = scene.objects.get(name)
        if ob is None:
            raise PlanError(f"no object named {name!r} in scene {scene.name!r} to walk to")
        return np.array(ob.matrix_world.translation), None
    return np.array(scene.cursor.location), None


def plan(scene, ob, goal, goal_heading=None, start_marker=None, settings=None,
         traversable=(), obstacles=()) -> tuple[PlanResult, PlanSetup]:
    s = setup(scene, ob, settings, traversable, obstacles)
    start = marker_footprints(start_marker, s) if start_marker is not None else character_footprints(ob, s)
    return s.planner.plan(start, goal, goal_heading), s


def scene_rate(scene) -> float:
    return float(scene.render.fps) / float(scene.render.fps_base or 1.0)


def synthesize(scene, result: PlanResult, s: PlanSetup, settings=None, goal=None) -> Synthesis:
    """Thesis 3.3 to 3.7 on a planned path: the body trajectory and every clip's weight
    and time per scene frame, footprints kept on the tagged surfaces."""
    pl = s.planner
    snap = surface_snap(pl.ground, pl.obstacles, s.forward, pl.foot, clearance=pl.clearance,
                        step_height=pl.max_step_height)
    return _synthesize(result.footsteps, s.library, s.analyses, settings or Settings(),
                       fps=scene_rate(scene), forward=s.forward, snap=snap, goal=goal)


def _spin(forward, analyses) -> float:
    """World yaw of heading 0 minus the rig's rest forward's yaw: the armature object's
    yaw is this plus the body heading."""
    rest = analyses[0].motion.rest_forward
    return float(np.arctan2(forward[1], forward[0]) - np.arctan2(rest[1], rest[0]))


def source_steps(tracks, schedule, fps: float) -> np.ndarray:
    """(B,) the largest rotation step (rad) each bone takes between two frames at ``fps``
    in any clip the schedule plays."""
    from ..core.metrics import rotation_steps

    out = None
    for c, name in enumerate(schedule.clips):
        if not (schedule.weights[:, c] > 0).any():
            continue
        tr = tracks[name]
        step = rotation_steps(tr.quat).max(axis=0) * tr.pose_rate / fps  # per sample -> per frame
        out = step if out is None else np.maximum(out, step)
    return out


def run(scene, ob, goal, goal_heading=None, start_marker=None, settings=None, traversable=(),
        obstacles=(), name: str | None = None, frame_start: int | None = None, markers: bool = False,
        progress=None, body_on: str = "OBJECT") -> dict:
    """Plan, synthesize, IK and bake ``ob`` walking to ``goal``; returns the report
    (plan, stage times in the layout of thesis Table 4.1, quality of the baked result).
    ``progress(fraction, stage)`` is called between stages."""
    steps = run_steps(scene, ob, goal, goal_heading, start_marker, settings, traversable, obstacles,
                      name, frame_start, markers, body_on)
    while True:
        try:
            fraction, stage = next(steps)
        except StopIteration as done:
            return done.value
        if progress is not None:
            progress(fraction, stage)


def run_steps(scene, ob, goal, goal_heading=None, start_marker=None, settings=None, traversable=(),
              obstacles=(), name: str | None = None, frame_start: int | None = None, markers: bool = False,
              body_on: str = "OBJECT"):
    """``run`` one stage at a time: a generator yielding (fraction done, next stage) and
    returning the report. Nothing in the scene changes before the last stage (the bake),
    so a caller may stop it at any yield and leave the scene as it was."""
    import time

    from ..core.ik import solve_ik
    from ..core.metrics import introduced_pops, quality
    from ..core.pose import blend_pose, pose_bases
    from ..core.surface import footprint_support
    from . import bake as baking

    st = settings or Settings()
    fps_scene = scene_rate(scene)
    name = name or f"{ob.name} to goal"
    frame_start = int(scene.frame_current if frame_start is None else frame_start)
    yield 0.0, "planning"
    result, s = plan(scene, ob, goal, goal_heading, start_marker, st, traversable, obstacles)
    yield 0.3, "synthesis"
    syn = synthesize(scene, result, s, st, goal=goal)
    from . import overlay

    overlay.remember(scene, result.footsteps, *syn.footprints, s.forward, s.planner.foot, syn.body_position,
                     np.array([n[2] for n in s.planner.explored]) if s.planner.explored else None)
    sched = syn.final.schedule
    tracks = syn.tracks
    yield 0.5, "inverse kinematics"
    t0 = time.perf_counter()
    quat, hips = blend_pose(sched, tracks)
    basis = pose_bases(s.rig, quat, hips)
    t_pose = time.perf_counter() - t0
    pl = s.planner
    pos, head = syn.footprints
    sup = footprint_support(pl.ground, pl.obstacles, pos, head, s.forward, pl.foot, clearance=pl.clearance)
    normal = np.where(np.isfinite(sup.normal), sup.normal, [0.0, 0.0, 1.0])
    walk = next((a for a in s.analyses if a.kind == "cycle"), s.analyses[0]).motion
    spin = _spin(s.forward, s.analyses)
    planted = syn.planted()

    def ground_z(points):
        hit = pl.ground.ray_down(np.asarray(points, float) + [0.0, 0.0, 0.3], 0.6)
        return np.where(hit.hit, hit.z, np.nan)

    t_ik0 = time.perf_counter()
    ik = solve_ik(s.rig, basis, sched.t, syn.body_position, syn.body_heading, spin, walk.heel_local,
                  walk.toe_local, sched.feet, planted, pos, head, normal, s.forward, st, ground_z=ground_z)
    t_ik = time.perf_counter() - t_ik0
    yield 0.7, "bake"
    t1 = time.perf_counter()
    act, track = baking.bake(ob, scene, s.rig, ik, spin, name, frame_start, result.footsteps, planted, markers,
                             body_on)
    t_bake = time.perf_counter() - t1
    yield 0.85, "quality"
    world, body_pos, body_yaw, bone_rot = baking.evaluate(ob, s.rig, act, frame_start, ik.frames)
    feet = [s.rig.foot_chain(x)[0] for x in ("l", "r")]
    heel = np.stack([(world[:, f] @ walk.heel_local[k])[:, :3] for k, f in enumerate(feet)])
    toe = np.stack([(world[:, f] @ walk.toe_local[k])[:, :3] for k, f in enumerate(feet)])
    ground_z = np.full((2, ik.frames, 2), np.nan)
    for k in range(2):
        for i, p in enumerate((heel[k], toe[k])):
            hit = pl.ground.ray_down(p + [0.0, 0.0, 0.5], 1.5)
            ground_z[k, :, i] = np.where(hit.hit, hit.z, np.nan)
    idx = lambda t: int(np.clip(round(t * fps_scene), 0, ik.frames - 1))  # noqa: E731
    stances = [{"foot": int(sched.feet[i]), "start": idx(a), "end": idx(b), "stance": idx(m),
                "position": pos[i], "heading": float(head[i])} for i, (a, m, b) in enumerate(planted)]
    qual = quality(heel, toe, ground_z, stances, world[..., :3, 3], bone_rot, body_pos,
                   body_yaw - spin, np.asarray(goal, float), goal_heading)
    allowance = source_steps(tracks, sched, fps_scene)
    qual["pops"]["introduced"] = introduced_pops(bone_rot, allowance)
    for key in ("rotation_bone", "offset_bone"):
        if qual["pops"].get(key) is not None:
            qual["pops"][key] = s.rig.names[qual["pops"][key]]
    if qual["pops"]["introduced"]["bone"] is not None:
        qual["pops"]["introduced"]["bone"] = s.rig.names[qual["pops"]["introduced"]["bone"]]
    stages = stage_row(len(result.footsteps), result.seconds, syn, pose_blend=t_pose, ik=t_ik, bake=t_bake)
    doc = result.to_dict()
    doc.update({"character": ob.name, "goal": [round(float(v), 4) for v in goal], "name": name,
                "forward": [round(float(v), 6) for v in s.forward],
                "frame_start": frame_start, "frame_end": frame_start + ik.frames - 1,
                "action": act.name, "track": track.name,
                "stages": stages,
                "quality": qual,
                "footprints": [{**f, "planted_frames": [frame_start + idx(a), frame_start + idx(b)],
                                "frame": frame_start + idx(m), "position": [round(float(v), 4) for v in pos[i]],
                                "heading": round(float(head[i]), 4)}
                               for i, (f, (a, m, b)) in enumerate(zip(doc["footprints"], planted))]})
    doc["synthesis"] = syn.to_dict(frame0=float(frame_start))
    return doc
