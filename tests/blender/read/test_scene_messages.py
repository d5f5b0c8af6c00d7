"""Messages that name the fault (issue 26): a curve tagged traversable is walked on by its
evaluated mesh, an empty tagged traversable is named; hidden floors and floors in an
excluded collection are not walked on unless named for the run; ``--scene NAME`` picks a
scene, and a character or goal in another scene than the active one says which."""

import json
from importlib import import_module

import pytest


@pytest.fixture
def surfaces(fp, empty_scene):
    return import_module(fp.__name__ + ".blender.read.surfaces"), import_module(fp.__name__ + ".core.base.errors")


def _floor(name="Floor", size=4.0, collection=None):
    import bpy

    me = bpy.data.meshes.new(name)
    h = size / 2
    me.from_pydata([(-h, -h, 0), (h, -h, 0), (h, h, 0), (-h, h, 0)], [], [(0, 1, 2, 3)])
    ob = bpy.data.objects.new(name, me)
    (collection or bpy.context.scene.collection).objects.link(ob)
    ob.footstep.surface = "TRAVERSABLE"
    return ob


def _ground(surf, scene, **kw):
    import bpy

    return surf.scene_surfaces(scene, bpy.context.evaluated_depsgraph_get(), **kw)[0]


def test_a_curve_tagged_traversable_is_walked_on(surfaces):
    import bpy

    surf, _ = surfaces
    cu = bpy.data.curves.new("Disc", "CURVE")
    cu.dimensions, cu.fill_mode = "2D", "BOTH"
    spline = cu.splines.new("POLY")
    spline.points.add(3)
    for p, (x, y) in zip(spline.points, ((-2, -2), (2, -2), (2, 2), (-2, 2))):
        p.co = (x, y, 0.0, 1.0)
    spline.use_cyclic_u = True
    ob = bpy.data.objects.new("Disc", cu)
    bpy.context.scene.collection.objects.link(ob)
    ob.footstep.surface = "TRAVERSABLE"
    hit = _ground(surf, bpy.context.scene).ray_down([[0.5, 0.5, 1.0]], 3.0)
    assert hit.hit[0] and abs(hit.z[0]) < 1e-6


def test_an_empty_tagged_traversable_is_named(surfaces):
    import bpy

    surf, errors = surfaces
    e = bpy.data.objects.new("Pad", None)
    bpy.context.scene.collection.objects.link(e)
    e.footstep.surface = "TRAVERSABLE"
    with pytest.raises(errors.FootstepError, match="'Pad', tagged, is a empty, with no surface"):
        _ground(surf, bpy.context.scene)


def test_hidden_and_excluded_floors_are_not_walked_on_unless_named(surfaces):
    import bpy

    surf, errors = surfaces
    scene = bpy.context.scene
    floor = _floor()
    floor.hide_set(True)
    with pytest.raises(errors.FootstepError, match="'Floor', tagged, is hidden.*--traversable Floor"):
        _ground(surf, scene)
    assert _ground(surf, scene, traversable=("Floor",)).ray_down([[0, 0, 1]], 3.0).hit[0]  # (asked for)
    floor.hide_set(False)
    coll = bpy.data.collections.new("Set")
    scene.collection.children.link(coll)
    coll.objects.link(floor)
    scene.collection.objects.unlink(floor)
    bpy.context.view_layer.layer_collection.children["Set"].exclude = True
    with pytest.raises(errors.FootstepError, match="'Floor', tagged, is in a collection excluded"):
        _ground(surf, scene)
    bpy.context.view_layer.layer_collection.children["Set"].exclude = False
    second = _floor("Shown", collection=None)
    second.location.x = 10.0
    floor.hide_set(True)  # (a hidden floor beside a shown one: only the shown one is walked on)
    bpy.context.view_layer.update()
    ground = _ground(surf, scene)
    assert not ground.ray_down([[0, 0, 1]], 3.0).hit[0] and ground.ray_down([[10, 0, 1]], 3.0).hit[0]


@pytest.fixture(scope="module")
def two_scenes(fp, tmp_path_factory):
    """The Turns sample scene with the sample character, and an empty scene made the
    active one, saved."""
    import bpy

    bpy.ops.wm.read_homefile(use_empty=True)
    scene = import_module(fp.__name__ + ".blender.sample.sample_scenes").build("turns")
    scene.render.fps = 30
    import_module(fp.__name__ + ".blender.sample.mannequin").add_to_scene(scene, "Start")
    bpy.context.window.scene = bpy.data.scenes.new("Layout")
    path = str(tmp_path_factory.mktemp("two") / "two.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path)
    return path, scene.name


def test_the_scene_at_fault_is_named_and_scene_picks_another(fp, two_scenes, capsys):
    cli = import_module(fp.__name__ + ".blender.command.cli").cli_main
    path, name = two_scenes
    args = ["plan", path, "--character", "Footstep Mannequin", "--goal", "Goal", "--json"]
    assert cli(args) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and f"is not in scene 'Layout' (it is in scene {name!r}" in err
    assert cli(["bake", path, "--character", "Footstep Mannequin", "--goal", "Goal"]) == 2
    assert "is not in scene 'Layout'" in capsys.readouterr().err
    assert cli(args + ["--scene", "Nowhere"]) == 2
    assert "no scene named 'Nowhere'" in capsys.readouterr().err
    assert cli(args + ["--scene", name]) == 0
    assert json.loads(capsys.readouterr().out)["character"] == "Footstep Mannequin"


def test_a_character_from_a_missing_library_is_named(fp, empty_scene, tmp_path, capsys):
    import os

    import bpy

    cli = import_module(fp.__name__ + ".blender.command.cli").cli_main
    ob = bpy.data.objects.new("Hero", bpy.data.armatures.new("Hero"))
    bpy.context.scene.collection.objects.link(ob)
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "lib.blend"))
    bpy.ops.wm.read_homefile(use_empty=True)
    with bpy.data.libraries.load(str(tmp_path / "lib.blend"), link=True) as (_, dst):
        dst.objects = ["Hero"]
    bpy.context.scene.collection.objects.link(dst.objects[0])
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "shot.blend"))
    os.rename(tmp_path / "lib.blend", tmp_path / "moved.blend")
    for verb in ("plan", "bake"):
        assert cli([verb, str(tmp_path / "shot.blend"), "--character", "Hero"]) == 2
        err = capsys.readouterr().err
        assert "Traceback" not in err and "comes from the library '//lib.blend', which is missing" in err


def test_a_file_from_a_newer_blender_is_refused(fp, two_scenes, monkeypatch, capsys):
    cli_mod = import_module(fp.__name__ + ".blender.command.cli")
    monkeypatch.setattr(import_module(fp.__name__ + ".blender.command.blend_io"), "file_version", lambda: (99, 1, 0))
    path, name = two_scenes
    assert cli_mod.cli_main(["bake", path, "--scene", name, "--character", "Footstep Mannequin"]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and "saved by a newer Blender (file version 99.1.0)" in err


def test_floors_reached_through_a_collection_instance_are_walked_on(surfaces):
    """A tagged floor in a collection the scene holds only as an instance (an empty
    instancing it, moved 10 m along X): walked on where the instance stands."""
    import bpy

    surf, _ = surfaces
    scene = bpy.context.scene
    kit = bpy.data.collections.new("Kit")  # (not linked into the scene)
    _floor(collection=kit)
    e = bpy.data.objects.new("Kit instance", None)
    e.instance_type, e.instance_collection = "COLLECTION", kit
    e.location.x = 10.0
    scene.collection.objects.link(e)
    bpy.context.view_layer.update()
    ground = _ground(surf, scene)
    assert ground.ray_down([[10.5, 0.0, 1.0]], 3.0).hit[0] and not ground.ray_down([[0.0, 0.0, 1.0]], 3.0).hit[0]
