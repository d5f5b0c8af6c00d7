"""The command line: verbs, --help, JSON, and bad input (one clear line, no traceback)."""

import json
import os
import subprocess
import sys
from importlib import import_module

import numpy as np
import pytest

from bvh_files import broken_variants, edit_frames, legless
from conftest import HANG_SECONDS, ROOT, cmu, needs_cmu


@pytest.fixture
def cli(fp, empty_scene):
    return import_module(fp.__name__ + ".blender.command.cli").cli_main


@pytest.mark.parametrize("verb", [[], ["import-clips"], ["analyze"], ["demo"]])
def test_help_on_every_verb(cli, capsys, verb):
    assert cli(verb + ["--help"]) == 0
    out = capsys.readouterr().out
    assert "usage: footstep" in out and "--help" in out


def test_unknown_verb_is_a_usage_error(cli, capsys):
    assert cli(["fly"]) == 2
    assert "invalid choice" in capsys.readouterr().err


@needs_cmu
def test_import_then_analyze_a_library_blend(cli, capsys, tmp_path):
    lib = str(tmp_path / "lib.blend")
    assert cli(["import-clips", "--out", lib, "--name", "Subject16", cmu("16_16"), cmu("16_35")]) == 0
    assert os.path.isfile(lib)
    capsys.readouterr()
    assert cli(["analyze", lib, "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    (char,) = doc["characters"]
    assert char["armature"] == "Subject16"
    clips = {c["name"]: c for c in char["clips"]}
    assert set(clips) == {"cmu_16_16_walk", "cmu_16_35_run_jog"}
    walk = clips["cmu_16_16_walk"]
    for key in ("fps", "frames", "gait", "speed", "stride", "cycle", "tau", "feet", "footprints"):
        assert key in walk
    # the file's scene took the first file's rate: contact intervals are in its frames
    assert walk["fps"] == 120 and walk["frames"] == 510
    contacts = walk["feet"]["L"]["contacts"]
    assert all(1 <= a < b <= 510 for a, b in contacts) and len(contacts) >= 3
    fp0 = walk["footprints"][1]
    assert {"foot", "position", "heading", "time", "frame", "heel", "toe", "strike"} <= set(fp0)
    assert char["library"]["turn_groups"]["walk"]["clips"][0]["clip"] == "cmu_16_16_walk"


@needs_cmu
def test_analyze_at_another_rate_and_with_a_setting(cli, capsys):
    assert cli(["analyze", cmu("16_16"), "--fps", "30", "--set", "contact_height=0.07", "--json"]) == 0
    (walk,) = json.loads(capsys.readouterr().out)["clips"]
    assert walk["fps"] == 30 and walk["frames"] == 128
    assert walk["gait"] == "walk" and walk["speed"] == pytest.approx(1.02, rel=0.05)


@needs_cmu
def test_the_table(cli, capsys):
    assert cli(["analyze", cmu("16_16"), cmu("49_05")]) == 0
    out = capsys.readouterr().out
    assert "cmu_16_16_walk" in out and "cmu_49_05_run_leap_run" in out and "jump" in out


@needs_cmu
def test_plots(cli, tmp_path):
    pytest.importorskip("matplotlib")
    assert cli(["analyze", cmu("16_35"), "--plot", str(tmp_path)]) == 0
    assert os.path.getsize(tmp_path / "cmu_16_35_run_jog.png") > 10_000


def _one_error_line(capsys):
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("footstep: error: "), err
    assert "Traceback" not in err[0]
    return err[0]


@needs_cmu
@pytest.mark.parametrize("kind", ["not_bvh", "bad_channels", "truncated_motion", "not_a_number",
                                  "short_line", "unclosed", "empty"])
def test_malformed_bvh(cli, capsys, tmp_path, kind):
    path = broken_variants(cmu("16_35"), str(tmp_path))[kind]
    assert cli(["analyze", path]) == 2
    assert os.path.basename(path) in _one_error_line(capsys)


def test_missing_file(cli, capsys, tmp_path):
    assert cli(["analyze", str(tmp_path / "nope.bvh")]) == 2
    line = _one_error_line(capsys)
    assert "nope.bvh" in line and "no such file" in line
    assert cli(["analyze", str(tmp_path / "nope.blend")]) == 2
    assert "nope.blend" in _one_error_line(capsys)


def test_skeleton_without_legs(cli, capsys, tmp_path):
    path = legless(str(tmp_path / "armsonly.bvh"))
    assert cli(["analyze", path]) == 2
    line = _one_error_line(capsys)
    assert "armsonly.bvh" in line and "thigh_l" in line and "foot_r" in line


@needs_cmu
def test_clip_with_no_foot_on_the_ground(cli, capsys, tmp_path):
    path = edit_frames(cmu("16_16"), str(tmp_path / "floating.bvh"),
                       lambda d: d + np.r_[0, 60.0, 0, np.zeros(d.shape[1] - 3)])
    assert cli(["analyze", path]) == 1
    line = _one_error_line(capsys)
    assert "'floating'" in line and "no foot ever touches the ground" in line


@needs_cmu
def test_clip_too_short_for_a_cycle(cli, capsys, tmp_path):
    path = edit_frames(cmu("16_16"), str(tmp_path / "snippet.bvh"), lambda d: d[150:230])
    assert cli(["analyze", path]) == 1
    line = _one_error_line(capsys)
    assert "'snippet'" in line and "too short" in line


@needs_cmu
def test_a_refused_file_among_good_ones_is_named_and_the_others_saved(cli, capsys, tmp_path):
    """import-clips imports every file it can: the refused one is named on stderr with its
    reason, the exit status counts it, the input file is left as it was; a run that
    imports nothing saves nothing."""
    import bpy

    lib = str(tmp_path / "lib.blend")
    assert cli(["import-clips", "--out", lib, "--name", "Hero", cmu("16_16")]) == 0
    size = os.path.getsize(lib)
    out = str(tmp_path / "out.blend")
    capsys.readouterr()
    assert cli(["import-clips", "--blend", lib, "--into", "Hero", "--out", out, cmu("16_35"),
                legless(str(tmp_path / "armsonly.bvh"))]) == 1
    assert "armsonly.bvh" in _one_error_line(capsys)
    assert os.path.getsize(lib) == size
    assert sorted(a.name for a in bpy.data.actions) == ["cmu_16_16_walk", "cmu_16_35_run_jog"]
    bpy.ops.wm.open_mainfile(filepath=out)
    assert sorted(a.name for a in bpy.data.actions) == ["cmu_16_16_walk", "cmu_16_35_run_jog"]
    nothing = str(tmp_path / "nothing.blend")
    assert cli(["import-clips", "--blend", lib, "--into", "Hero", "--out", nothing,
                legless(str(tmp_path / "armsonly.bvh"))]) == 2
    assert "armsonly.bvh" in _one_error_line(capsys)
    assert not os.path.exists(nothing) and os.path.getsize(lib) == size
    assert cli(["import-clips", "--blend", lib, "--into", "Nobody", "--out", nothing, cmu("16_35")]) == 2
    assert "'Nobody'" in _one_error_line(capsys)


@needs_cmu
def test_python_dash_m_runs_the_same_verbs(tmp_path):
    """The real entry point, in its own process: clean JSON on stdout, exit codes."""
    env = dict(os.environ, PYTHONPATH=ROOT)
    env.pop("BLENDER_USER_RESOURCES", None)
    env["BLENDER_USER_RESOURCES"] = str(tmp_path / "res")
    run = lambda *a: subprocess.run([sys.executable, "-m", "footstep_planner", *a], cwd=ROOT,  # noqa: E731
                                    env=env, capture_output=True, text=True, timeout=HANG_SECONDS)
    ok = run("analyze", cmu("16_35"), "--json")
    assert ok.returncode == 0, ok.stderr
    (clip,) = json.loads(ok.stdout)["clips"]
    assert clip["gait"] == "run"
    bad = run("analyze", str(tmp_path / "missing.bvh"))
    assert bad.returncode == 2 and "Traceback" not in bad.stderr and "missing.bvh" in bad.stderr


def test_demo_runs_the_whole_tool_on_built_in_content(cli, capsys, tmp_path):
    # no outside data: the scene, the character and its clips are generated
    assert cli(["demo", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "the Footstep Mannequin and its 12 generated clips" in out and "blend groups (proposed)" in out
    assert "baked 'jumps demo' into NLA track" in out and "foot skate per stance" in out
    assert "stage times" in out and "per_frame" in out
    doc = json.load(open(tmp_path / "jumps_report.json"))
    q = doc["quality"]
    assert sum(f["jump"] for f in doc["footprints"]) >= 2  # both gaps of the Jumps scene
    assert q["goal"]["distance_m"] < 0.05 and q["foot_skate"]["max_mm"] < 1.0
    assert q["footprint_error"]["max_mm"] < 5.0 and q["penetration"]["max_mm"] < 5.0
    assert {c["name"] for c in doc["clips"]} >= {"walk", "run", "run_jump"}
    for name in ("jumps_baked.blend", "jumps_review.png", "jumps_top.png", "jumps_tau.png"):
        assert (tmp_path / name).stat().st_size > 1000, name
    import bpy

    # the renders show something: not one flat colour
    shots = sorted(tmp_path.glob("jumps_frame*.png"))
    assert len(shots) >= 3
    for png in shots + [tmp_path / "jumps_review.png"]:
        im = bpy.data.images.load(str(png))
        px = np.empty(im.size[0] * im.size[1] * 4, np.float32)
        im.pixels.foreach_get(px)
        assert px.reshape(-1, 4)[:, :3].std() > 0.05, png.name
    # the saved scene holds the bake, on the mannequin
    bpy.ops.wm.open_mainfile(filepath=str(tmp_path / "jumps_baked.blend"))
    ob = bpy.data.objects["Footstep Mannequin"]
    assert [t.name for t in ob.animation_data.nla_tracks] == ["Footstep: jumps demo"]


def test_demo_names_the_sample_scenes_when_given_another(cli, capsys, tmp_path):
    assert cli(["demo", "--scene", "moon", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "moon" in err and "jumps, turns, obstacles" in err and "Traceback" not in err


@pytest.mark.parametrize("scale", ["1e30", "1e-9", "0", "nan"])
def test_an_absurd_import_scale_is_refused_in_one_line(cli, capsys, tmp_path, scale):
    """``--scale`` outside a micrometre to a kilometre per unit (fuzz case import_clips-2-9:
    1e30 was a traceback) is a usage error naming the option, and nothing is written."""
    from bvh_files import walker

    bvh = walker(str(tmp_path / "walk.bvh"))
    out = tmp_path / "lib.blend"
    assert cli(["import-clips", "--out", str(out), "--scale", scale, str(bvh)]) == 2
    err = capsys.readouterr().err
    assert "--scale" in err and "Traceback" not in err and not out.exists()
