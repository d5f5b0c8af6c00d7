"""Tagged meshes read from the scene, and BVH ground queries equal to the numpy ones."""

from importlib import import_module

import numpy as np
import pytest


def _mods(fp):
    return (import_module(fp.__name__ + ".blender.read.surfaces"), import_module(fp.__name__ + ".core.plan.surface"))


def _mesh_object(scene, name, verts, faces, collection=None):
    import bpy

    me = bpy.data.meshes.new(name)
    me.from_pydata([tuple(v) for v in verts], [], [tuple(f) for f in faces])
    ob = bpy.data.objects.new(name, me)
    (collection or scene.collection).objects.link(ob)
    return ob


def _quad(scene, name, x0, x1, y0, y1, z=0.0, collection=None):
    return _mesh_object(scene, name, [(x0, y0, z), (x1, y0, z), (x1, y1, z), (x0, y1, z)],
                        [(0, 1, 2, 3)], collection)


def test_tags_and_their_inheritance(fp, empty_scene):
    import bpy

    surf, _ = _mods(fp)
    floors = bpy.data.collections.new("Floors")
    empty_scene.collection.children.link(floors)
    inner = bpy.data.collections.new("Inner")
    floors.children.link(inner)
    floors.footstep.surface = "TRAVERSABLE"
    a = _quad(empty_scene, "A", 0, 1, 0, 1, collection=inner)  # inherits from Floors
    b = _quad(empty_scene, "B", 0, 1, 0, 1, collection=inner)
    b.footstep.surface = "OBSTACLE"  # its own tag wins
    c = _quad(empty_scene, "C", 0, 1, 0, 1)  # untagged
    trav, obst = surf.tagged_objects(empty_scene)
    assert [o.name for o in trav] == ["A"] and [o.name for o in obst] == ["B"]
    trav, obst = surf.tagged_objects(empty_scene, traversable=["C"])
    assert [o.name for o in trav] == ["A", "C"]
    assert c.footstep.surface == "NONE"  # a run's tag is not written to the scene
    with pytest.raises(Exception, match="'Nope'"):
        surf.tagged_objects(empty_scene, obstacles=["Nope"])
    del a


def test_surfaces_are_read_in_world_space_with_modifiers(fp, empty_scene):
    import bpy

    surf, core = _mods(fp)
    ob = _quad(empty_scene, "Floor", 0, 1, 0, 1)
    ob.location = (10, 0, 2)
    ob.rotation_euler = (0, 0, np.pi / 2)
    arr = ob.modifiers.new("Array", "ARRAY")
    arr.count = 3
    ob.footstep.surface = "TRAVERSABLE"
    dg = bpy.context.evaluated_depsgraph_get()
    ground, obstacles = surf.scene_surfaces(empty_scene, dg)
    assert ground.mesh.n == 6 and obstacles.mesh.n == 0
    lo, hi = ground.mesh.bounds()
    # the array runs along local X (3 m), turned to world Y; moved to (10, 0, 2)
    assert lo == pytest.approx([9, 0, 2], abs=1e-6) and hi == pytest.approx([10, 3, 2], abs=1e-6)
    hit = ground.ray_down(np.array([[9.5, 2.5, 3.0], [9.5, 3.5, 3.0]]), 2.0)
    assert hit.hit.tolist() == [True, False] and hit.z[0] == pytest.approx(2.0)


def test_no_traversable_mesh_is_a_clear_error(fp, empty_scene):
    import bpy

    surf, core = _mods(fp)
    _quad(empty_scene, "Floor", 0, 1, 0, 1)
    with pytest.raises(core.SurfaceError, match="no traversable mesh"):
        surf.scene_surfaces(empty_scene, bpy.context.evaluated_depsgraph_get())


def test_bvh_ground_equals_numpy_ground(fp, empty_scene):
    """Both implementations of the ground queries give the same answers."""
    import bpy

    surf, core = _mods(fp)
    rng = np.random.default_rng(11)
    # a bumpy terrain, a tilted ramp, and a box of obstacles
    n = 12
    xs, ys = np.meshgrid(np.linspace(-3, 3, n), np.linspace(-3, 3, n))
    zs = 0.2 * rng.standard_normal((n, n))
    verts = np.c_[xs.ravel(), ys.ravel(), zs.ravel()]
    faces = [(i * n + j, i * n + j + 1, (i + 1) * n + j + 1, (i + 1) * n + j)
             for i in range(n - 1) for j in range(n - 1)]
    _mesh_object(empty_scene, "Terrain", verts, faces).footstep.surface = "TRAVERSABLE"
    ramp = _quad(empty_scene, "Ramp", 3, 5, -1, 1)
    ramp.rotation_euler = (0, -0.26, 0)
    ramp.footstep.surface = "TRAVERSABLE"
    bpy.ops.mesh.primitive_cube_add(size=1, location=(1, 1, 0.5))
    bpy.context.object.footstep.surface = "OBSTACLE"
    dg = bpy.context.evaluated_depsgraph_get()
    bvh, bvh_obst = surf.scene_surfaces(empty_scene, dg)
    ref, ref_obst = core.MeshGround(bvh.mesh), core.MeshGround(bvh_obst.mesh)
    pts = np.c_[rng.uniform(-3.5, 5.5, (400, 2)), rng.uniform(-0.5, 2.5, 400)]
    a, b = bvh.ray_down(pts, 3.0), ref.ray_down(pts, 3.0)
    assert (a.hit == b.hit).mean() > 0.99  # a ray exactly on a shared edge may go either way
    both = a.hit & b.hit
    assert np.abs(a.z[both] - b.z[both]).max() < 1e-5
    assert np.abs(np.abs((a.normal[both] * b.normal[both]).sum(1)) - 1).max() < 1e-5
    qa, da = bvh_obst.nearest(pts)
    qb, db = ref_obst.nearest(pts)
    assert np.abs(da - db).max() < 1e-5
    fwd = np.array([0.0, -1.0])
    heads = rng.uniform(-np.pi, np.pi, 400)
    foot = core.FootShape()
    sa = core.footprint_support(bvh, bvh_obst, pts, heads, fwd, foot)
    sb = core.footprint_support(ref, ref_obst, pts, heads, fwd, foot)
    assert (sa.ok == sb.ok).mean() > 0.99 and sa.ok.any() and (~sa.ok).any()


def test_object_panel_draws(fp, empty_scene):
    import bpy

    from conftest import Recorder

    panel = import_module(fp.__name__ + ".blender.ui.panel").FOOTSTEP_PT_object_surface
    coll = bpy.data.collections.new("Ground")
    empty_scene.collection.children.link(coll)
    coll.footstep.surface = "TRAVERSABLE"
    ob = _quad(empty_scene, "Floor", 0, 1, 0, 1, collection=coll)
    stub = Recorder()
    with bpy.context.temp_override(object=ob):
        panel.draw(type("P", (), {"layout": stub})(), bpy.context)
    labels = [kw.get("text") for name, _, kw in stub.log if name == "label"]
    assert "Traversable by its collection" in labels
