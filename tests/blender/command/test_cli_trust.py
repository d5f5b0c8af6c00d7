"""A command line to trust with a studio's files (issue 13): nothing lost, jobs isolated,
one message and never a traceback, clean streams. Each case of the issue's "Why" is here."""

import hashlib
import json
import os
import signal
import subprocess
import sys
from importlib import import_module

import pytest

from conftest import HANG_SECONDS, ROOT


@pytest.fixture
def cli(fp, empty_scene):
    return import_module(fp.__name__ + ".blender.command.cli").cli_main


@pytest.fixture(scope="module")
def scene_file(tmp_path_factory, fp):
    """The Turns sample scene with the sample character, saved: the input of every case."""
    import bpy

    mannequin = import_module(fp.__name__ + ".blender.sample.mannequin")
    sample = import_module(fp.__name__ + ".blender.sample.sample_scenes")
    bpy.ops.wm.read_homefile(use_empty=True)
    scene = sample.build("turns")
    scene.render.fps = 30
    mannequin.add_to_scene(scene, "Start")
    path = str(tmp_path_factory.mktemp("scene") / "shot.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path, compress=True)
    return path


CHAR = "Footstep Mannequin"


def digest(folder) -> dict:
    """Every file under ``folder`` (hidden ones too) and its content's hash."""
    out = {}
    for root, _, files in os.walk(folder):
        for f in files:
            p = os.path.join(root, f)
            with open(p, "rb") as fh:
                out[os.path.relpath(p, folder)] = hashlib.sha256(fh.read()).hexdigest()
    return out


def bake_args(scene, *more):
    return ["bake", scene, "--character", CHAR, "--goal", "Goal", *more]


@pytest.fixture
def shot(tmp_path, scene_file):
    """A folder holding a copy of the scene, a previous good result and its report."""
    import shutil

    shutil.copy(scene_file, tmp_path / "shot.blend")
    shutil.copy(scene_file, tmp_path / "previous.blend")
    (tmp_path / "previous.json").write_text('{"good": true}')
    return tmp_path


def one_error_line(err: str) -> str:
    lines = [ln for ln in err.splitlines() if ln.startswith("footstep: error:")]
    assert "Traceback" not in err
    assert len(lines) == 1, err
    return lines[0]


# -- nothing lost --------------------------------------------------------------------------

@pytest.mark.parametrize("flag", ["--report", "--out"])
def test_an_output_over_the_input_scene_is_refused_before_any_work(cli, capsys, shot, flag):
    before = digest(shot)
    scene = str(shot / "shot.blend")
    assert cli(bake_args(scene, flag, scene if flag == "--report" else scene)) == 2
    line = one_error_line(capsys.readouterr().err)
    assert "one of the inputs" in line and "shot.blend" in line
    assert digest(shot) == before


def test_an_output_through_a_link_to_the_input_is_refused(cli, capsys, shot):
    os.symlink(shot / "shot.blend", shot / "link.blend")
    os.link(shot / "shot.blend", shot / "hard.blend")
    before = digest(shot)
    for link in ("link.blend", "hard.blend"):
        assert cli(bake_args(str(shot / "shot.blend"), "--out", str(shot / link))) == 2
        assert "one of the inputs" in one_error_line(capsys.readouterr().err)
    assert digest(shot) == before


def test_a_job_report_over_the_scene_fails_that_job_only(cli, capsys, shot):
    jobs = shot / "jobs.json"
    jobs.write_text(json.dumps([{"character": CHAR, "goal": "Goal", "report": str(shot / "shot.blend")},
                                {"character": CHAR, "goal": "Goal", "name": "ok", "report": str(shot / "ok.json")}]))
    before = digest(shot)
    assert cli(["bake", str(shot / "shot.blend"), "--job", str(jobs)]) == 1
    captured = capsys.readouterr()
    assert "one of the inputs" in captured.err and "Traceback" not in captured.err
    after = digest(shot)
    assert after.pop("ok.json") and after == before


def test_import_clips_never_writes_over_a_clip(cli, capsys, tmp_path):
    from bvh_files import legless

    clip = legless(tmp_path / "X.bvh")
    before = digest(tmp_path)
    assert cli(["import-clips", "--out", str(clip), str(clip)]) == 2
    assert "must be a .blend" in one_error_line(capsys.readouterr().err)
    assert digest(tmp_path) == before


def test_report_and_out_at_one_path_are_refused(cli, capsys, shot):
    before = digest(shot)
    same = str(shot / "both.blend")
    assert cli(bake_args(str(shot / "shot.blend"), "--out", same, "--report", same)) == 2
    assert "give each its own path" in one_error_line(capsys.readouterr().err)
    assert digest(shot) == before


def test_a_failed_bake_writes_nothing_and_keeps_the_previous_result(cli, capsys, shot):
    before = digest(shot)
    args = ["bake", str(shot / "shot.blend"), "--character", CHAR, "--goal", "Goal", "--set", "max_expansions=3",
            "--out", str(shot / "previous.blend"), "--report", str(shot / "previous.json")]
    assert cli(args) == 2
    one_error_line(capsys.readouterr().err)
    assert digest(shot) == before  # no litter either: no temporary file is left


def test_a_good_bake_replaces_the_previous_result_whole(cli, capsys, shot):
    assert cli(bake_args(str(shot / "shot.blend"), "--out", str(shot / "previous.blend"),
                         "--report", str(shot / "previous.json"))) == 0
    assert json.loads((shot / "previous.json").read_text())["character"] == CHAR
    assert sorted(os.listdir(shot)) == ["previous.blend", "previous.json", "shot.blend"]


def test_an_unwritable_folder_is_one_message_before_any_work(cli, capsys, shot):
    target = "/sys/kernel/out.blend"  # (refused even to root)
    if os.access("/sys/kernel", os.W_OK) and not os.path.isdir("/sys/kernel"):
        pytest.skip("no folder here refuses root's writes")
    before = digest(shot)
    assert cli(bake_args(str(shot / "shot.blend"), "--report", str(shot / "r.json"), "--out", target)) == 2
    line = one_error_line(capsys.readouterr().err)
    assert "/sys/kernel" in line and "ermission denied" in line
    assert digest(shot) == before


def test_a_write_failing_midway_leaves_everything_as_it_was(cli, capsys, shot, monkeypatch, fp):
    """The report is written, then the scene can't be (a full disk): neither lands."""
    cli_mod = import_module(fp.__name__ + ".blender.command.cli")

    def full_disk(final):
        def write(tmp):
            raise OSError(28, "No space left on device", tmp)
        return write

    monkeypatch.setattr(cli_mod, "blend_writer", full_disk)
    before = digest(shot)
    assert cli(bake_args(str(shot / "shot.blend"), "--out", str(shot / "previous.blend"),
                         "--report", str(shot / "previous.json"))) == 2
    assert "no space left" in one_error_line(capsys.readouterr().err)
    assert digest(shot) == before


# -- one message, never a traceback ---------------------------------------------------------

def test_ctrl_c_is_exit_130_and_nothing_written(cli, capsys, shot, monkeypatch, fp):
    batch = import_module(fp.__name__ + ".blender.command.batch")

    def interrupted(*a, **k):
        raise KeyboardInterrupt

    monkeypatch.setattr(batch, "bake_job", interrupted)
    before = digest(shot)
    assert cli(bake_args(str(shot / "shot.blend"), "--out", str(shot / "previous.blend"))) == 130
    err = capsys.readouterr().err
    assert "interrupted, nothing written" in err and "Traceback" not in err
    assert digest(shot) == before


def test_ctrl_c_of_a_real_process(shot):
    """SIGINT to ``python -m footstep_planner bake --job`` after its first job: status 130,
    one line, and neither the scene nor any report written."""
    jobs = shot / "jobs.json"
    jobs.write_text(json.dumps([{"character": CHAR, "goal": "Goal", "name": f"j{i}", "frame_start": 1 + 1000 * i}
                                for i in range(6)]))
    args = [sys.executable, "-m", "footstep_planner", "bake", str(shot / "shot.blend"), "--job", str(jobs),
            "--out", str(shot / "previous.blend"), "--report", str(shot / "r.json")]
    before = digest(shot)
    p = subprocess.Popen(args, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                         start_new_session=True)
    seen = ""
    while "jobs 1/6" not in seen:  # (progress lines are flushed as each job ends)
        line = p.stderr.readline()
        assert line, "the command ended before its first job did"
        seen += line
    p.send_signal(signal.SIGINT)
    out, err = p.communicate(timeout=HANG_SECONDS)
    if p.returncode == 0:
        pytest.skip("the jobs finished before the signal came")
    assert p.returncode == 130, seen + err
    assert "Traceback" not in err and err.strip().endswith("interrupted, nothing written")
    assert digest(shot) == before


def test_a_bug_shows_its_traceback_and_asks_to_be_reported(cli, capsys, shot, monkeypatch, fp):
    batch = import_module(fp.__name__ + ".blender.command.batch")
    monkeypatch.setattr(batch, "bake_job", lambda *a, **k: 1 / 0)
    before = digest(shot)
    assert cli(bake_args(str(shot / "shot.blend"), "--out", str(shot / "x.blend"))) == 70
    err = capsys.readouterr().err
    assert "ZeroDivisionError" in err and "please report it" in err
    assert digest(shot) == before


@pytest.mark.parametrize("args, words", [
    (["analyze", "{dir}/folder.bvh"], "is a folder"),
    (["import-clips", "--out", "{dir}/x.blend", "{dir}/folder.bvh"], "is a folder"),
    (["bake", "{scene}", "--character", CHAR, "--set", "goal_radius=-1"], "goal_radius"),
    (["bake", "{scene}", "--job", "{dir}/empty.json"], "is empty"),
    (["bake", "{scene}", "--job", "{dir}/garbage.json"], "not JSON"),
    (["bake", "{scene}", "--job", "{dir}/object.json"], "must be a JSON list"),
    (["bake", "{scene}", "--character", "Nobody"], "no object named 'Nobody'"),
    (["bake", "{dir}/missing.blend", "--character", CHAR], "no such file"),
    (["plot", "{dir}/garbage.json", "--out", "{dir}/plots"], "cannot read the plan report"),
    (["bake", "{scene}", "--character", CHAR, "--ray", "local"], "--ray runs a job list"),
])
def test_bad_input_is_one_line(cli, capsys, shot, args, words):
    (shot / "empty.json").write_text("[]")
    (shot / "garbage.json").write_text("{nope")
    (shot / "object.json").write_text('{"character": "x"}')
    (shot / "folder.bvh").mkdir()
    args = [a.format(dir=shot, scene=shot / "shot.blend") for a in args]
    before = digest(shot)
    assert cli(args) == 2
    assert words in one_error_line(capsys.readouterr().err)
    assert digest(shot) == before


@pytest.mark.parametrize("flag, value", [("--frame-start", "abc"), ("--goal-heading", "nan"),
                                         ("--frame-start", "99999999999")])
def test_bad_numbers_are_usage_errors(cli, capsys, shot, flag, value):
    assert cli(bake_args(str(shot / "shot.blend"), flag, value)) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and flag in err


# -- jobs isolated ----------------------------------------------------------------------------

BAD_JOBS = [
    {"character": CHAR, "goal": "Goal", "name": "first"},
    {"character": CHAR, "goal": "Goal", "goal_heading": "north"},
    {"character": CHAR, "goal": "Goal", "frame_start": "abc"},
    {"character": 5},
    {"character": CHAR, "goal": ["x", 1]},
    {"character": CHAR, "goal": "Goal", "settings": {"goal_radius": -1}},
    {"character": CHAR, "goal": "Goal", "unknown": 1},
    "not a job",
    {"character": CHAR, "goal": "Goal", "name": "last", "frame_start": 2000},
]


def test_bad_jobs_are_reported_and_the_good_ones_run(cli, capsys, shot):
    jobs = shot / "jobs.json"
    jobs.write_text(json.dumps(BAD_JOBS))
    out, report = shot / "out.blend", shot / "r.json"
    assert cli(["bake", str(shot / "shot.blend"), "--job", str(jobs), "--out", str(out), "--report", str(report)]) == 7
    captured = capsys.readouterr()
    assert "Traceback" not in captured.err
    for n in range(2, 9):
        assert f"footstep: error: job {n}" in captured.err
    table = captured.out.splitlines()
    assert "2 of 9 jobs baked, 7 failed" in table[-1]
    assert sum(" invalid " in row for row in table) == 7 and sum(" baked " in row for row in table) == 2
    assert out.is_file() and (shot / "r_1.json").is_file() and (shot / "r_9.json").is_file()
    assert not (shot / "r_2.json").exists()


def test_a_job_failing_at_run_time_is_rolled_back_and_the_rest_run(cli, capsys, shot, monkeypatch, fp):
    import bpy

    batch = import_module(fp.__name__ + ".blender.command.batch")
    real = batch.bake_job

    def flaky(scene, job, common, settings):
        doc = real(scene, job, common, settings)
        if job.get("name") == "breaks":  # fails after its bake: the bake must go
            raise RuntimeError("boom")
        return doc

    monkeypatch.setattr(batch, "bake_job", flaky)
    jobs = shot / "jobs.json"
    jobs.write_text(json.dumps([{"character": CHAR, "goal": "Goal", "name": "breaks"},
                                {"character": CHAR, "goal": "Goal", "name": "fine", "frame_start": 40}]))
    assert cli(["bake", str(shot / "shot.blend"), "--job", str(jobs)]) == 1
    captured = capsys.readouterr()
    assert "RuntimeError: boom" in captured.err and "please report it" in captured.err
    assert "1 of 2 jobs baked" in captured.out
    assert [a.name for a in bpy.data.actions if "breaks" in a.name] == []
    assert any("fine" in a.name for a in bpy.data.actions)


# -- clean streams ---------------------------------------------------------------------------

def test_json_on_stdout_is_exactly_one_document(shot):
    """``plan --json | jq`` works: Blender's "Read blend" line goes to stderr."""
    run = subprocess.run([sys.executable, "-m", "footstep_planner", "plan", str(shot / "shot.blend"),
                          "--character", CHAR, "--goal", "Goal", "--json"], cwd=ROOT, capture_output=True,
                         text=True, timeout=HANG_SECONDS)
    assert run.returncode == 0, run.stderr
    doc = json.loads(run.stdout)
    assert doc["character"] == CHAR
    assert "Read blend" in run.stderr


def test_a_job_list_prints_progress_on_stderr_and_the_table_on_stdout(cli, capfd, shot):
    jobs = shot / "jobs.json"
    jobs.write_text(json.dumps([{"character": CHAR, "goal": "Goal", "name": "a"},
                                {"character": CHAR, "goal": "Goal", "name": "b", "frame_start": 900}]))
    assert cli(["bake", str(shot / "shot.blend"), "--job", str(jobs)]) == 0
    out, err = capfd.readouterr()
    assert "footstep: jobs 2/2" in err and "jobs 2/2" not in out
    assert out.strip().splitlines()[-1].startswith("2 of 2 jobs baked, 0 failed")


def test_a_jobs_result_does_not_depend_on_the_jobs_before_it(cli, shot, fp):
    """Baked after other jobs in one Blender, a job plans the footprints it plans alone:
    what an earlier bake left in the pose does not reach the clips' analysis."""
    import bpy

    scene = str(shot / "shot.blend")
    bpy.ops.wm.open_mainfile(filepath=scene)
    planning = import_module(fp.__name__ + ".blender.planning")
    sc = bpy.context.scene
    goal, heading = planning.goal_of(sc, "Goal")
    fps = planning.plan(sc, bpy.data.objects[CHAR], goal, heading)[0].footprints
    for name, i in (("Mid", len(fps) // 2), ("Side", len(fps) // 4)):
        e = bpy.data.objects.new(name, bpy.data.meshes.new(name))  # (not an empty: no heading to arrive with)
        e.location = fps[i].position
        sc.collection.objects.link(e)
    bpy.ops.wm.save_as_mainfile(filepath=scene)
    jobs = shot / "jobs.json"
    jobs.write_text(json.dumps([{"character": CHAR, "goal": g, "name": g, "report": str(shot / f"{g}.json"),
                                 "frame_start": 1 + 2000 * i}  # (each bake of a character its own frames)
                                for i, g in enumerate(("Goal", "Side", "Mid"))]))
    assert cli(["bake", scene, "--job", str(jobs)]) == 0
    assert cli(["bake", scene, "--character", CHAR, "--goal", "Mid", "--report", str(shot / "alone.json")]) == 0
    serial, alone = (json.loads((shot / n).read_text()) for n in ("Mid.json", "alone.json"))
    assert [f["position"] for f in serial["footprints"]] == [f["position"] for f in alone["footprints"]]
