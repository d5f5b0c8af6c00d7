"""Tagged meshes -> world-space triangles, and ground queries on mathutils.bvhtree.

A mesh object (or a curve, surface, metaball or text, by its evaluated mesh) is
traversable or an obstacle by its own tag (``obj.footstep.surface``), or else by the tag
of the nearest tagged collection it belongs to (collections inherit from their parents);
an object instanced through a collection instance is walked on where the instance stands.
Objects hidden in the viewport or in an excluded collection are left out unless named.
Headless runs can add tags for one run by name.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from itertools import repeat

import bpy
import numpy as np
from mathutils.bvhtree import BVHTree

from ...core.plan.rays import RayGrid
from ...core.plan.surface import GroundHit, SurfaceError, TriMesh

TAGS = ("NONE", "TRAVERSABLE", "OBSTACLE")


def _collection_tag(coll, parents) -> str:
    seen = set()
    while coll is not None and coll.name not in seen:
        seen.add(coll.name)
        tag = coll.footstep.surface
        if tag != "NONE":
            return tag
        coll = parents.get(coll.name)
    return "NONE"


def _parents(scene) -> dict:
    out = {}

    def walk(c):
        for ch in c.children:
            out.setdefault(ch.name, c)
            walk(ch)
    walk(scene.collection)
    return out


def effective_tag(ob, scene=None, parents=None) -> str:
    """The object's own tag, else the first tag found up its collections."""
    own = ob.footstep.surface
    if own != "NONE":
        return own
    parents = parents if parents is not None else _parents(scene or bpy.context.scene)
    for coll in ob.users_collection:
        tag = _collection_tag(coll, parents)
        if tag != "NONE":
            return tag
    return "NONE"


#: Object types with a surface (their evaluated mesh is walked on or avoided).
SURFACE_TYPES = {"MESH", "CURVE", "SURFACE", "META", "FONT"}


def tagged_objects(scene, traversable=(), obstacles=(), skipped=None) -> tuple[list, list]:
    """(traversable, obstacle) objects of ``scene`` with a surface (meshes, and curves,
    surfaces, metaballs and texts by their evaluated mesh), with ``traversable`` and
    ``obstacles`` naming extra objects tagged for this run only. A tagged object hidden
    in the viewport or in a collection excluded from the view layer is left out, unless
    named for this run; ``skipped`` (a list) gets (name, why) for each tagged object left
    out (hidden, excluded, no surface). Unknown names, and named objects without a
    surface, raise SurfaceError naming them."""
    extra = {}
    for names, tag in ((traversable, "TRAVERSABLE"), (obstacles, "OBSTACLE")):
        for name in names:
            ob = scene.objects.get(name)
            if ob is None:
                raise SurfaceError(f"no object named {name!r} in scene {scene.name!r}")
            if ob.type not in SURFACE_TYPES:
                raise SurfaceError(f"object {name!r} is a {ob.type.lower()}, not a mesh; "
                                   "only meshes can be walked on or avoided")
            extra[name] = tag
    parents = _parents(scene)
    trav, obst = [], []
    skipped = [] if skipped is None else skipped
    layer = scene.view_layers[0] if bpy.context.scene != scene and len(scene.view_layers) else None
    for ob in scene.objects:
        tag = extra.get(ob.name) or effective_tag(ob, scene, parents)
        if tag == "NONE":
            continue
        if ob.type not in SURFACE_TYPES:
            if ob.footstep.surface != "NONE":  # (its own tag: named when nothing else is walked on)
                skipped.append((ob.name, f"is a {ob.type.lower()}, with no surface to walk on"))
            continue
        if ob.name not in extra:
            why = _hidden(ob, layer)
            if why:
                skipped.append((ob.name, why))
                continue
        if tag == "TRAVERSABLE":
            trav.append(ob)
        elif tag == "OBSTACLE":
            obst.append(ob)
    return sorted(trav, key=lambda o: o.name), sorted(obst, key=lambda o: o.name)


def _hidden(ob, layer=None) -> str | None:
    """Why a tagged object is not walked on: hidden in the viewport, or in a collection
    excluded from the view layer (None: it is visible)."""
    if ob.hide_viewport:
        return "is disabled in viewports"
    try:
        visible = ob.visible_get(view_layer=layer) if layer is not None else ob.visible_get()
    except (RuntimeError, TypeError):
        return None
    if visible:
        return None
    vl = layer or bpy.context.view_layer
    if ob.name not in vl.objects:
        return "is in a collection excluded from the view layer"
    return "is hidden"


def instanced(scene, depsgraph) -> dict:
    """Tag -> [(name, evaluated object, world matrix)] of the tagged surfaces that stand in
    the scene as instances (a collection instanced by an empty): tagged by their own tag,
    their collection's, or the instancing empty's own."""
    out = {"TRAVERSABLE": [], "OBSTACLE": []}
    if not any(o.instance_type == "COLLECTION" and o.instance_collection is not None for o in scene.objects):
        return out  # (no collection instance: nothing to look through, however many particles)
    parents = _parents(scene)
    for inst in depsgraph.object_instances:
        if not inst.is_instance or inst.object is None or inst.object.type not in SURFACE_TYPES:
            continue
        ob = inst.object.original
        tag = effective_tag(ob, scene, parents)
        if tag == "NONE" and inst.parent is not None:
            tag = inst.parent.original.footstep.surface
        if tag in out:
            who = inst.parent.original.name if inst.parent is not None else "?"
            out[tag].append((f"{who}/{ob.name}", inst.object, np.array(inst.matrix_world)))
    return out


def mesh_of(objects, depsgraph, placed=()) -> TriMesh:
    """World-space triangles of the objects as evaluated (modifiers applied), and of the
    ``placed`` ones ((name, evaluated object, world matrix): instances)."""
    parts = []
    items = [(ob.name, ob.evaluated_get(depsgraph), None) for ob in objects] + list(placed)
    for name, ev, matrix in items:
        local = local_mesh(name, ev)
        m = np.array(ev.matrix_world) if matrix is None else matrix
        parts.append(TriMesh(local.verts @ m[:3, :3].T + m[:3, 3], local.tris, local.owner, local.names))
    return TriMesh.concat(parts)


def local_mesh(name: str, ev) -> TriMesh:
    """The triangles of evaluated object ``ev`` (modifiers applied) in its own space."""
    me = ev.to_mesh()
    try:
        me.calc_loop_triangles()
        nv, nt = len(me.vertices), len(me.loop_triangles)
        # (in the types Blender holds them in, read at once; other types are converted
        # one value at a time)
        co = np.empty(nv * 3, np.float32)
        me.vertices.foreach_get("co", co)
        tri = np.empty(nt * 3, dtype=np.int32)
        me.loop_triangles.foreach_get("vertices", tri)
    finally:
        ev.to_mesh_clear()
    return TriMesh(co.astype(np.float64).reshape(-1, 3), tri.astype(np.int64).reshape(-1, 3),
                   np.zeros(nt, np.int64), (name,))


#: Points from which a batch of rays is cast by ``core.plan.rays.RayGrid`` rather than one
#: C call a point: a grid's batch costs about 0.25 ms however small (its few dozen array
#: operations), then about 0.2 us a ray, against 0.7 to 1.5 us a ray for the tree
#: (measured on the planner benchmark's scenes: even at 512 points).
GRID_RAYS = 512


@dataclass
class BvhGround:
    """Ground queries (core.plan.surface.Ground) on a mathutils BVH tree: one C call a point,
    or for a batch of ``GRID_RAYS`` rays or more, all at once on ``RayGrid`` (made on the
    first such batch; exact, where the tree holds its vertices in float32: the heights
    agree to 1e-6 m). A ray's normal (facing up) is read from a table of the triangles'
    made once, by the triangle hit, not from the tree's vector point by point."""

    mesh: TriMesh
    tree: BVHTree = field(init=False, repr=False)
    _normal: np.ndarray = field(init=False, repr=False)  # (T, 3): each triangle's unit normal, facing up

    def __post_init__(self):
        if self.mesh.n:
            self.tree = BVHTree.FromPolygons(self.mesh.verts.tolist(), self.mesh.tris.tolist(),
                                             all_triangles=True)
            self._normal = self.mesh.up_normals()  # (the grid's own table: one answer either way)
        else:
            self.tree = None
            self._normal = np.zeros((0, 3))

    @cached_property
    def _grid(self) -> RayGrid:
        return RayGrid(self.mesh)

    def ray_down(self, points, max_dist: float) -> GroundHit:
        p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        n = len(p)
        if n >= GRID_RAYS:
            return self._grid.ray_down(p, max_dist)
        face = np.full(n, -1, np.int64)
        z = np.full(n, np.nan)
        if self.tree is not None and n:
            cast, down, dist = self.tree.ray_cast, repeat((0.0, 0.0, -1.0)), repeat(max_dist + 1e-9)
            res = list(map(cast, p.tolist(), down, dist))  # mathutils takes plain sequences
            got = [i for i, r in enumerate(res) if r[2] is not None]
            if got:
                face[got] = [res[i][2] for i in got]
                z[got] = [res[i][0][2] for i in got]
        nor = np.full((n, 3), np.nan)
        hit = face >= 0
        nor[hit] = self._normal[face[hit]]
        owner = np.where(hit, self.mesh.owner[np.maximum(face, 0)], -1) if self.mesh.n else face.copy()
        return GroundHit(hit, z, nor, owner, face)

    def nearest(self, points, max_dist: float = np.inf):
        p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        out = np.empty((len(p), 3))
        out.fill(np.nan)
        dist = np.empty(len(p))
        dist.fill(np.inf)
        if self.tree is not None and len(p):
            lim = 1e30 if not np.isfinite(max_dist) else float(max_dist)
            res = list(map(self.tree.find_nearest, p.tolist(), repeat(lim)))
            got = [i for i, r in enumerate(res) if r[3] is not None]
            if got:
                out[got] = [res[i][0][:] for i in got]
                dist[got] = [res[i][3] for i in got]
        return out, dist


def scene_surfaces(scene, depsgraph, traversable=(), obstacles=(), leave_out=()):
    """(ground, obstacles) ground queries for a scene, but for the obstacles named in
    ``leave_out`` (ones that move, avoided in time instead); SurfaceError when nothing is
    traversable."""
    skipped = []
    trav, obst = tagged_objects(scene, traversable, obstacles, skipped)
    obst = [o for o in obst if o.name not in set(leave_out)]
    inst = instanced(scene, depsgraph)
    if not trav and not inst["TRAVERSABLE"]:
        if skipped:
            name, why = skipped[0]
            more = f" (and {len(skipped) - 1} more)" if len(skipped) > 1 else ""
            raise SurfaceError(f"scene {scene.name!r} has nothing traversable to walk on: {name!r}, tagged, {why}"
                               f"{more}; show it, or name it for this run (--traversable {name})")
        raise SurfaceError(f"scene {scene.name!r} has no traversable mesh: tag the floors "
                           "in Object Properties > Footstep, or pass --traversable NAME")
    return (BvhGround(mesh_of(trav, depsgraph, inst["TRAVERSABLE"]).without_undersides()),
            BvhGround(mesh_of(obst, depsgraph, inst["OBSTACLE"])))
