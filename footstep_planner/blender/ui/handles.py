"""Footprints you can edit in the viewport: after a plan, each footprint is a small empty
(a handle) in a collection the planner owns, ``Footprints: <character>``. Move or rotate
a handle (G, R, or the gizmo), lock or unlock it (``footstep_locked``, the Lock and
Unlock operators); ``read_plan`` turns the handles back into a plan
(``core.plan.plan_file.PlanFile``) for ``core.plan.plan_edit.edited_path`` to make whole.

A handle faces the way its footprint does (``read.scene.FACING``: its local -Y axis, as the
Start and Goal empties). Each keeps its planned pose in custom properties at full
precision, so an untouched footprint reads back exactly as it was planned (object
transforms are single precision). The planner owns the collection and its handles
(``OWNED``) and removes them with Clear or a new plan; nothing else is touched.
"""

from __future__ import annotations

import bpy
import numpy as np

from ...core.footprint import PathFootprint
from ...core.plan.plan_file import PlanFile
from ...core.base.angles import yaw

OWNED = "footstep_handles"  # on the collection and each handle: the character's name
INDEX, FOOT, LOCKED = "footstep_index", "footstep_foot", "footstep_locked"
PLANNED = "footstep_planned"  # [x, y, z, heading, time] as planned (doubles)
STEP = "footstep_step"  # [label, gait, "1" if jump, "1" if on a tread, a jog's walk/run blend or ""]
META = "footstep_plan"  # on the collection: [forward x, y, z, goal x, y, z, goal heading] (nan: none)
#: on the handle of a footprint that reaches a waypoint: the waypoint (the object itself,
#: an ID property: found by identity), and where it stood when the footprint was planned
WAYPOINT, WAYPOINT_AT = "footstep_waypoint", "footstep_waypoint_at"
#: m and rad a handle may differ from its planned pose and still count as untouched
TOUCH = 1e-4
SIZE = 0.08


def collection_name(ob) -> str:
    """The name the planner gives the character's handles' collection (Blender suffixes
    it, ``.001``, when a collection of the user's has it: the planner's is found by its
    owner tag, ``owned_collection``, never by name)."""
    return f"Footprints: {ob.name}"


def owned_collection(ob):
    """The planner's collection of ``ob``'s handles: the one carrying its owner tag."""
    return next((c for c in bpy.data.collections if c.get(OWNED) == ob.name and c.get(META) is not None), None)


def clear_handles(ob) -> int:
    """Remove the character's handles and their collection (only what the planner made)."""
    n = 0
    while (coll := owned_collection(ob)) is not None:
        for h in [o for o in coll.objects if o.get(OWNED) == ob.name and o.get(INDEX) is not None]:
            bpy.data.objects.remove(h)
            n += 1
        if coll.objects or coll.children:  # (the user put things of theirs in it: it stays, untagged)
            del coll[OWNED]
            continue
        bpy.data.collections.remove(coll)
    return n


def make_handles(scene, ob, footprints: list[PathFootprint], forward, goal=None, goal_heading=None,
                 locked=None, waypoints: dict | None = None) -> list:
    """A handle per footprint (replacing the character's earlier ones), locked as
    ``locked`` (N,) says (default: none); ``waypoints`` (footprint index -> the waypoint
    object it reaches): those handles are locked too and follow their waypoint when it
    moves (``read_plan``)."""
    clear_handles(ob)
    coll = bpy.data.collections.new(collection_name(ob))
    coll[OWNED] = ob.name
    nan = float("nan")
    g = list(np.asarray(goal, float)) if goal is not None else [nan] * 3
    f3 = [float(forward[0]), float(forward[1]), 0.0]  # (the planner's forward is (x, y))
    coll[META] = [*f3, *map(float, g), nan if goal_heading is None else float(goal_heading)]
    scene.collection.children.link(coll)
    locked = np.zeros(len(footprints), bool) if locked is None else np.array(locked, bool)
    waypoints = {int(i): w for i, w in (waypoints or {}).items() if 0 < int(i) < len(footprints) and w is not None}
    locked[list(waypoints)] = True
    out = [_handle(coll, ob, i, f, forward, bool(lk)) for i, (f, lk) in enumerate(zip(footprints, locked))]
    for i, w in waypoints.items():
        out[i][WAYPOINT] = w
        out[i][WAYPOINT_AT] = [float(v) for v in w.matrix_world.translation]
    return out


def _handle(coll, ob, i: int, f: PathFootprint, forward, locked: bool):
    h = bpy.data.objects.new(f"FP {i:03d} {'LR'[f.foot]}", None)
    h.empty_display_type = "SINGLE_ARROW"
    h.empty_display_size = SIZE
    h.location = [float(v) for v in f.position]
    # a handle faces its footprint's way with its -Y axis: Z rotation = yaw + pi/2
    h.rotation_euler = (0.0, 0.0, float(f.heading + yaw(forward) + np.pi / 2))
    h[OWNED], h[INDEX], h[FOOT], h[LOCKED] = ob.name, i, "LR"[f.foot], locked
    h[PLANNED] = [*map(float, f.position), float(f.heading), float(f.time)]
    h[STEP] = [f.label, f.gait, "1" if f.jump else "", "1" if f.tread else "", "" if f.speed is None else repr(f.speed)]
    h.lock_rotation = (True, True, False)  # footprints turn about Z only
    coll.objects.link(h)
    return h


def handles(ob) -> list:
    """The character's handles, in path order."""
    coll = owned_collection(ob)
    if coll is None:
        return []
    return sorted((o for o in coll.objects if o.get(OWNED) == ob.name), key=lambda o: int(o[INDEX]))


def _pose(h, forward) -> tuple[np.ndarray, float, bool]:
    """(position, heading, touched) of a handle: its planned pose, exactly, unless it was
    moved or turned."""
    planned = list(h[PLANNED])
    m = h.matrix_world if h.parent is not None else h.matrix_basis  # (no depsgraph update needed)
    pos, heading = np.array(m.translation, float), float(m.to_euler().z) - np.pi / 2 - yaw(forward)
    turn = abs((heading - planned[3] + np.pi) % (2 * np.pi) - np.pi)
    if np.abs(pos - planned[:3]).max() <= TOUCH and turn <= TOUCH:
        return np.array(planned[:3], float), float(planned[3]), False
    return pos, heading, True


def read_plan(ob) -> tuple[PlanFile, np.ndarray]:
    """The handles as a plan, and which of them were moved or turned (N,) bool; a moved
    handle counts as locked (the animator put it there)."""
    hs = handles(ob)
    meta = list(owned_collection(ob)[META]) if hs else []
    forward = np.array(meta[:3], float) if meta else np.array([0.0, -1.0, 0.0])
    fps, locked, touched = [], [], []
    for h in hs:
        pos, heading, moved = _pose(h, forward)
        shift = waypoint_shift(h)
        if shift is not None:  # (its waypoint moved: it goes with it)
            pos, moved = pos + shift, True
        label, gait, jump, tread, blend = (list(h[STEP]) + ["", ""])[:5]  # (handles made before the tread and blend)
        fps.append(PathFootprint("LR".index(h[FOOT]), pos, heading, float(h[PLANNED][4]), label, gait, bool(jump),
                                 bool(tread), float(blend) if blend else None))
        locked.append(bool(h[LOCKED]) or moved)
        touched.append(moved)
    goal = np.array(meta[3:6], float) if meta and np.isfinite(meta[3]) else None
    gh = float(meta[6]) if meta and np.isfinite(meta[6]) else None
    touched = np.array(touched, bool)
    return PlanFile(ob.name, forward, fps, np.array(locked, bool), goal, gh, touched), touched


def waypoint_shift(h) -> np.ndarray | None:
    """(3,) how far the waypoint a handle reaches (``WAYPOINT``) moved since its footprint
    was planned; None where it has none, it is gone from every scene, or it moved less
    than TOUCH."""
    w, at = h.get(WAYPOINT), h.get(WAYPOINT_AT)
    if not isinstance(w, bpy.types.Object) or at is None or not w.users_scene:
        return None
    d = np.array(w.matrix_world.translation, float) - np.array(list(at), float)
    return d if np.abs(d).max() > TOUCH else None


def waypoints_reached(ob) -> list:
    """[(the footprint's position now (3,), its waypoint)] of the character's handles that
    reach a waypoint (``WAYPOINT``), the footprint moved with it (``read_plan``)."""
    plan, _ = read_plan(ob)
    return [(f.position, h[WAYPOINT]) for h, f in zip(handles(ob), plan.footprints)
            if isinstance(h.get(WAYPOINT), bpy.types.Object)]


def characters_reaching(obj) -> list:
    """The names of the characters one of whose handles reaches the waypoint ``obj``."""
    out = []
    for c in bpy.data.collections:
        owner = c.get(OWNED)
        if owner is None or c.get(META) is None or owner in out:
            continue
        if any(h.get(WAYPOINT) == obj for h in c.objects if h.get(INDEX) is not None):
            out.append(owner)
    return out


def set_locked(objs, state: bool) -> int:
    """Lock (or unlock) the handles among ``objs``; returns how many."""
    n = 0
    for o in objs:
        if o.get(OWNED) is not None and o.get(INDEX) is not None:
            o[LOCKED] = bool(state)
            n += 1
    return n


__all__ = ["clear_handles", "handles", "make_handles", "owned_collection", "read_plan", "set_locked"]
