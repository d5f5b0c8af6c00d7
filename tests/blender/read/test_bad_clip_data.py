"""Bad clip data refused at the door, and long clips read without holding them whole
(issue 13).

A BVH file whose motion holds a value that is not a finite number, whose skeleton has a
bone of no length, or whose frame time is absurd; an FBX file with a key that is not a
finite number; a folder given as a clip: each is refused by the command line with exit
status 2 and one line naming the file and the line, frame and channel (or joint, or
value) at fault, and nothing is written. Long clips take other paths (F-curves kept as
samples, clips read a chunk at a time): made short here by lowering their thresholds,
they give what the ordinary paths give.
"""

import os
from importlib import import_module

import numpy as np
import pytest

from bvh_files import bad_data_variants, walker
from conftest import cmu, needs_cmu

BAD_BVH = ("nan_motion", "inf_motion", "overflow_motion", "zero_length", "joint_named_twice", "frame_time_zero",
           "frame_time_negative", "frame_time_nan", "frame_time_tiny", "frame_time_huge")


@pytest.fixture
def cli(fp, empty_scene):
    return import_module(fp.__name__ + ".blender.command.cli").cli_main


@pytest.fixture(scope="module")
def bad_bvh(tmp_path_factory):
    return bad_data_variants(str(tmp_path_factory.mktemp("bad_bvh")))


def _one_error_line(capsys) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("footstep: error: "), err
    assert "Traceback" not in err[0]
    return err[0]


@pytest.mark.parametrize("verb", ["import-clips", "analyze"])
@pytest.mark.parametrize("kind", BAD_BVH)
def test_bad_bvh_data_is_refused_at_the_door(cli, capsys, tmp_path, bad_bvh, kind, verb):
    path, words = bad_bvh[kind]
    out = tmp_path / "lib.blend"
    argv = ["import-clips", path, "--out", str(out)] if verb == "import-clips" else ["analyze", path, "--json"]
    assert cli(argv) == 2
    line = _one_error_line(capsys)
    missing = [w for w in words if w not in line]
    assert not missing, (missing, line)
    assert not out.exists() and os.listdir(tmp_path) == []


def test_a_clip_name_no_file_has_is_said_and_a_refused_file_still_named(cli, capsys, tmp_path, bad_bvh):
    """``analyze --clip NAME`` where no clip is so named says so (it said nothing, exit 2);
    a file refused as a whole is named whatever ``--clip`` asks (its clips are unknown)."""
    good = walker(str(tmp_path / "good.bvh"), frames=30)
    assert cli(["analyze", good, "--json", "--clip", "walk"]) == 1  # (one problem)
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["footstep: error: --clip 'walk': no clip of that name (the clips: good)"], err
    path, words = bad_bvh["frame_time_nan"]
    assert cli(["analyze", path, "--clip", "walk"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 2 and all(w in err[0] for w in words) and "'walk'" in err[1], err


def test_a_folder_given_as_a_clip_is_named_a_folder(fp, cli, capsys, tmp_path):
    clips = import_module(fp.__name__ + ".blender.read.clips")
    for name in ("walk.bvh", "walk.fbx"):
        folder = tmp_path / name
        folder.mkdir()
        with pytest.raises(clips.ClipImportError, match=f"{name}: is a folder, not an? (BVH|FBX) file"):
            clips.import_clips([str(folder)])
        assert cli(["analyze", str(folder)]) == 2
        assert "is a folder" in _one_error_line(capsys)


# -- FBX ------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def nan_fbx(fp, tmp_path_factory):
    """An FBX file written by Blender's exporter from the mannequin's walk, one of the
    hips' location keys made NaN before the export."""
    import bpy

    from benchmarks import mixamo_like

    mannequin = import_module(fp.__name__ + ".blender.sample.mannequin")
    bpy.ops.wm.read_homefile(use_empty=True)
    ob, _ = mannequin.build()
    (act,) = mannequin.generate_clips(ob, names=["walk"])
    fc = next(fc for fc in mixamo_like.curves(act) if fc.data_path == 'pose.bones["spine"].location')
    fc.keyframe_points[5].co[1] = float("nan")
    path = mixamo_like.export(str(tmp_path_factory.mktemp("fbx") / "nan_walk.fbx"), [ob], act, (1, 20))
    bpy.ops.wm.read_homefile(use_empty=True)
    return path


def test_an_fbx_key_that_is_not_a_number_is_refused(cli, capsys, tmp_path, nan_fbx):
    out = tmp_path / "lib.blend"
    assert cli(["import-clips", nan_fbx, "--out", str(out)]) == 2
    line = _one_error_line(capsys)
    for word in ("nan_walk.fbx", "bone 'spine'", "channel location X", "frame ", "not a finite number"):
        assert word in line, (word, line)
    assert not out.exists() and os.listdir(tmp_path) == []
    assert cli(["analyze", nan_fbx]) == 2
    assert "nan_walk.fbx" in _one_error_line(capsys)


def test_a_refused_fbx_leaves_the_users_scene_as_it_was(fp, empty_scene, nan_fbx):
    import bpy

    clips = import_module(fp.__name__ + ".blender.read.clips")
    mine = bpy.data.objects.new("Mine", None)
    empty_scene.collection.objects.link(mine)
    bpy.context.view_layer.objects.active = mine
    mine.select_set(True)
    ids = lambda: {attr: sorted(i.name for i in getattr(bpy.data, attr))  # noqa: E731
                   for attr in ("objects", "armatures", "meshes", "actions", "materials", "collections")}
    before = ids()
    with pytest.raises(clips.ClipImportError, match="not a finite number"):
        clips.import_clips([nan_fbx])
    assert ids() == before and bpy.context.view_layer.objects.active == mine and mine.select_get()
    assert empty_scene.render.fps == 24


# -- long clips -----------------------------------------------------------------------

def _curves(act):
    return [fc for layer in act.layers for strip in layer.strips for cb in strip.channelbags for fc in cb.fcurves]


@pytest.mark.parametrize("fps", [120, 24])
def test_a_long_clip_is_kept_as_samples_that_play_as_its_keys(fp, empty_scene, tmp_path, monkeypatch, fps):
    import bpy

    clips = import_module(fp.__name__ + ".blender.read.clips")
    scene_mod = import_module(fp.__name__ + ".blender.read.scene")
    empty_scene.render.fps = fps
    path = walker(str(tmp_path / "walker.bvh"), frames=240)
    ob, (keyed,) = clips.import_clips([path])
    monkeypatch.setattr(import_module(fp.__name__ + ".blender.read.clip_keys"), "SAMPLED_FRAMES", 100)
    _, (sampled,) = clips.import_clips([path], name="Sampled")
    curves = _curves(sampled)
    still = [fc for fc in curves if len(fc.keyframe_points)]
    assert all(len(fc.keyframe_points) == 2 and not len(fc.sampled_points) for fc in still)
    last = 1 + 239 * fps // 120
    assert {len(fc.sampled_points) for fc in curves if fc not in still} == {last}
    assert 0 < len(still) < len(curves) and tuple(sampled.frame_range) == (1, last)
    frames = np.arange(1, last + 1, dtype=float)  # (the samples are the keys at the whole frames)
    a, b = (scene_mod.sample_basis(ob, act, frames) for act in (keyed, sampled))
    assert np.abs(a - b).max() < 1e-5
    name, sampled.name = ob.name, "kept"
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "long.blend"))
    bpy.ops.wm.open_mainfile(filepath=str(tmp_path / "long.blend"))
    c = scene_mod.sample_basis(bpy.data.objects[name], bpy.data.actions["kept"], frames)
    assert np.abs(a - c).max() < 1e-5


@needs_cmu
def test_a_long_clip_read_in_chunks_analyses_as_it_does_whole(fp, empty_scene, monkeypatch):
    clips = import_module(fp.__name__ + ".blender.read.clips")
    character = import_module(fp.__name__ + ".blender.read.character")
    scene_mod = import_module(fp.__name__ + ".blender.read.scene")
    analysis = import_module(fp.__name__ + ".core.clips.analysis")
    empty_scene.render.fps = 120
    ob, (act,) = clips.import_clips([cmu("16_35")])
    rig = scene_mod.rig_from_armature(ob)
    for fps in (None, 30):
        whole = scene_mod.clip_from_action(ob, act, rig, fps=fps)
        monkeypatch.setattr(character, "CHUNK", 37)
        chunked = character.read_clip(ob, act, rig, fps=fps)
        monkeypatch.undo()
        assert chunked.n == whole.n and chunked.local_rot.dtype == np.float32
        for field in ("times", "root_pos", "root_heading", "hips_in_root", "heel", "toe", "heel_local",
                      "toe_local"):
            assert np.abs(getattr(chunked, field) - getattr(whole, field)).max() < 1e-9, field
        assert np.abs(chunked.local_rot - whole.local_rot).max() < 1e-6
        assert analysis.analyze_clip(chunked).to_dict() == analysis.analyze_clip(whole).to_dict()


@needs_cmu
def test_the_bvh_import_gives_what_blenders_importer_gives(fp, empty_scene):
    """The import reads and keys BVH files itself (whole F-curves at once); its armature
    and keys are those of Blender's own BVH importer."""
    import contextlib
    import io

    import bpy

    clips = import_module(fp.__name__ + ".blender.read.clips")
    scene_mod = import_module(fp.__name__ + ".blender.read.scene")
    empty_scene.render.fps = 120
    with contextlib.redirect_stdout(io.StringIO()):
        bpy.ops.import_anim.bvh(filepath=cmu("49_05"), global_scale=0.01, use_fps_scale=True,
                                rotate_mode="QUATERNION", axis_forward="-Z", axis_up="Y")
    (theirs,) = [o for o in bpy.data.objects if o.type == "ARMATURE"]
    ours, (act,) = clips.import_clips([cmu("49_05")], scale=0.01)
    bones = lambda o: [(b.name, b.parent.name if b.parent else None, b.use_connect) for b in o.data.bones]  # noqa: E731
    assert bones(ours) == bones(theirs)
    for attr in ("matrix_local", "tail_local"):
        a, b = (np.array([np.array(getattr(bone, attr)) for bone in o.data.bones]) for o in (ours, theirs))
        assert np.abs(a - b).max() < 1e-5, attr
    keys = lambda act: {(fc.data_path, fc.array_index): _co(fc) for fc in _curves(act)}  # noqa: E731
    mine, blenders = keys(act), keys(theirs.animation_data.action)
    assert list(mine) == list(blenders)
    for curve, co in mine.items():
        assert np.abs(co[:, 0] - blenders[curve][:, 0]).max() < 1e-2  # (their 120.0005 fps drifts)
        assert np.abs(co[:, 1] - blenders[curve][:, 1]).max() < 1e-5, curve
    assert scene_mod.SOURCE_FPS_PROP in act


def _co(fc) -> np.ndarray:
    co = np.empty(2 * len(fc.keyframe_points))
    fc.keyframe_points.foreach_get("co", co)
    return co.reshape(-1, 2)
