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
from ..core.navgraph import FootprintCache, Footstep, PlanError, PlanResult, Planner
from ..core.pipeline import Synthesis, surface_snap
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


def world_forward(ob, analyses) -> np.ndarray:
    """The character's heading-0 direction in the world, checking its object transform."""
    m = np.array(ob.matrix_world)
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
                      turn_penalty=st.turn_penalty, jump_penalty=st.jump_penalty,
                      run_penalty=st.run_penalty, gait_change_penalty=st.gait_change_penalty,
                      heuristic_weight=st.heuristic_weight, goal_radius=st.goal_radius)
    return PlanSetup(planner, clips.analyses, library, forward)


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


def synthesize(scene, result: PlanResult, s: PlanSetup, settings=None) -> Synthesis:
    """Thesis 3.3 to 3.7 on a planned path: the body trajectory and every clip's weight
    and time per scene frame, footprints kept on the tagged surfaces."""
    pl = s.planner
    snap = surface_snap(pl.ground, pl.obstacles, s.forward, pl.foot, clearance=pl.clearance,
                        step_height=pl.max_step_height)
    return _synthesize(result.footsteps, s.library, s.analyses, settings or Settings(),
                       fps=scene_rate(scene), forward=s.forward, snap=snap)
