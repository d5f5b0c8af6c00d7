"""A job list baked as Ray tasks (issue 13), on a local Ray instance with two workers:
each job in a worker process on its own copy of the scene, its files written atomically
by the driver, a failing job reported and the others baked, a worker that dies retried
once, then reported. About 40 s on a 2-core machine (Ray's start is 5 s of it)."""

import json
import os
import tempfile
from importlib import import_module

import pytest

ray = pytest.importorskip("ray", reason="Ray is not installed: pip install ray==2.60.0 (make venv installs "
                                        "requirements.txt, which has it)")

CHAR = "Footstep Mannequin"
COMMON = {"markers": False, "keep_frame_range": False, "body_on": "object", "traversable": None,
          "obstacles": None, "set": []}


@pytest.fixture(scope="module")
def rb(fp):
    return import_module(fp.__name__ + ".blender.command.ray_batch")


@pytest.fixture(scope="module")
def batch(tmp_path_factory, fp):
    """The benchmark's scene file and its 8 jobs, checked and normalised as the command
    line passes them: (scene path, [(number, label, job)])."""
    from benchmarks.bench_ray_batch import build_batch

    jobs = import_module(fp.__name__ + ".core.jobs")
    scene, _, raw = build_batch(str(tmp_path_factory.mktemp("ray_scene")), fp.__name__)
    return scene, [(n, jobs.job_label(n, job), jobs.normalised(job)) for n, job in enumerate(raw, 1)]


@pytest.fixture(scope="module")
def ray_up(rb):
    """A local Ray instance with 2 workers kept for the tests that inject a task (run_on_ray
    uses it and leaves it running, as it does any instance it did not start)."""
    started = not ray.is_initialized()
    if started:
        ray.init(**rb._init_args("local:2"))
    yield
    if started:
        ray.shutdown()


def bake(fp, rb, scene, jobs, folder, address="local:2", **kw):
    """run_on_ray as the command line calls it: every job's scene and report claimed in
    ``folder``, committed at the end. Returns (outcomes, the outcomes as progress saw them)."""
    files = import_module(fp.__name__ + ".core.base.files")
    seen = []
    with files.Outputs([scene]) as outs:
        dest = {n: {"out": outs.claim(str(folder / f"job_{n}.blend"), f"scene of job {n}"),
                    "report": outs.claim(str(folder / f"job_{n}.json"), f"report of job {n}")} for n, _, _ in jobs}
        outcomes = rb.run_on_ray(address, scene, jobs, COMMON, dest, outs, progress=seen.append, **kw)
        outs.commit()
    return outcomes, seen


def reported_folders(rb, monkeypatch) -> list:
    """The temporary folders this run's tasks report working in (each result's ``tmp``),
    as the driver receives them: the run's own folders, by what its workers said, never
    by a name another run's worker could share."""
    seen, outcome = [], rb._Batch.outcome

    def recording(self, number, label, result, tries):
        seen.append(result["tmp"])
        return outcome(self, number, label, result, tries)

    monkeypatch.setattr(rb._Batch, "outcome", recording)
    return seen


def written(folder) -> list:
    return sorted(os.listdir(folder))


# -- before any instance is up: the messages ------------------------------------------------

def test_without_ray_one_message_says_how_to_install_it(fp, rb, batch, tmp_path, monkeypatch):
    errors = import_module(fp.__name__ + ".core.base.errors")
    monkeypatch.setitem(__import__("sys").modules, "ray", None)
    with pytest.raises(errors.FootstepError, match=r"pip install 'ray=="):
        rb.run_on_ray("local", batch[0], batch[1], COMMON, {}, None)


@pytest.mark.parametrize("address, words", [("local:0", "a whole number from 1"), ("local:two", "whole number"),
                                            ("auto", "ray start --head")])
def test_a_bad_or_absent_cluster_is_one_message(fp, rb, batch, address, words):
    if ray.is_initialized():
        pytest.skip("a Ray instance is up in this process: run_on_ray would use it")
    if address == "auto" and os.path.exists(os.path.join(tempfile.gettempdir(), "ray", "ray_current_cluster")):
        pytest.skip("a Ray cluster runs on this machine (ray start): 'auto' would join it")
    errors = import_module(fp.__name__ + ".core.base.errors")
    env = {k: os.environ.pop(k) for k in ("RAY_ADDRESS",) if k in os.environ}
    try:
        with pytest.raises(errors.FootstepError, match=words):
            rb.run_on_ray(address, batch[0], batch[1], COMMON, {}, None)
    finally:
        os.environ.update(env)
    assert not ray.is_initialized()


# -- on a local instance with 2 workers ----------------------------------------------------

def test_eight_jobs_on_two_workers_one_fails_seven_baked(fp, rb, batch, tmp_path, capfd, monkeypatch):
    scene, jobs = batch
    folders, was_up = reported_folders(rb, monkeypatch), ray.is_initialized()
    outcomes, seen = bake(fp, rb, scene, jobs, tmp_path)
    out, err = capfd.readouterr()
    assert out == "", "stdout must stay clean for the command's results"
    assert ray.is_initialized() == was_up, "run_on_ray shuts down the instance it started, and only that"
    assert [o.number for o in outcomes] == list(range(1, 9)) and len(seen) == 8
    status = {o.number: o.status for o in outcomes}
    assert status == {**{n: "baked" for n in range(1, 8)}, 8: "failed"}, outcomes
    failed = outcomes[7]
    assert "Island" in failed.label and "off every traversable surface" in failed.error
    assert "footstep-ray-" not in failed.error and failed.outputs == []
    for o in outcomes[:7]:
        doc = json.loads((tmp_path / f"job_{o.number}.json").read_text())
        assert o.frames == doc["frame_end"] - doc["frame_start"] + 1 and o.skate_mm < 1.0 and o.attempts == 1
        assert o.outputs == [str(tmp_path / f"job_{o.number}.json"), str(tmp_path / f"job_{o.number}.blend")]
    assert written(tmp_path) == sorted([f"job_{n}.{e}" for n in range(1, 8) for e in ("blend", "json")]), \
        "the failing job wrote nothing, and no temporary file is left"
    assert len(folders) == 8 and all("footstep-ray-" in f for f in folders), folders
    assert not [f for f in folders if os.path.exists(f)], "each worker removes its temporary folder"
    _baked_scene_has_its_track(tmp_path / "job_3.blend", outcomes[2].frames)


def _baked_scene_has_its_track(path, frames):
    """The scene a worker saved: the shipped scene, with the job's bake in its NLA track."""
    import bpy

    bpy.ops.wm.open_mainfile(filepath=str(path), load_ui=False)
    ob = bpy.data.objects[CHAR]
    tracks = [t for t in ob.animation_data.nla_tracks if t.name.startswith("Footstep")]
    assert len(tracks) == 1 and tracks[0].name == "Footstep: west"
    strip = tracks[0].strips[0]
    assert round(strip.frame_end - strip.frame_start) + 1 == frames
    bpy.ops.wm.read_homefile(use_empty=True)


def dies_once(rb, marker_dir, victim):
    """A task that kills its worker process the first time it gets job ``victim``."""
    real = rb.default_task()

    def task(scene, name, job, common, want_out):
        import os

        marker = os.path.join(marker_dir, "died")
        if job.get("name") == victim and not os.path.exists(marker):
            open(marker, "w").close()
            os._exit(3)
        return real(scene, name, job, common, want_out)

    return task


def always_dies(rb, victim):
    real = rb.default_task()

    def task(scene, name, job, common, want_out):
        import os

        if job.get("name") == victim:
            os._exit(4)
        return real(scene, name, job, common, want_out)

    return task


def test_a_worker_dying_once_is_retried_and_the_job_bakes(fp, rb, batch, ray_up, tmp_path):
    scene, jobs = batch
    outcomes, _ = bake(fp, rb, scene, jobs[:2], tmp_path, task=dies_once(rb, str(tmp_path), "nearwall"))
    assert (tmp_path / "died").exists(), "the task did kill its worker"
    assert [(o.status, o.attempts) for o in outcomes] == [("baked", 1), ("baked", 2)], outcomes
    assert {"job_1.blend", "job_2.blend", "job_2.json"} <= set(written(tmp_path))


def test_a_worker_dying_twice_fails_that_job_only(fp, rb, batch, ray_up, tmp_path):
    scene, jobs = batch
    outcomes, seen = bake(fp, rb, scene, jobs[1:4], tmp_path, task=always_dies(rb, "west"))
    status = {o.label.split("'")[1]: (o.status, o.attempts) for o in outcomes}
    assert status == {"nearwall": ("baked", 1), "west": ("failed", 2), "centre": ("baked", 1)}, outcomes
    west = outcomes[1]
    assert west.error.startswith("the Ray worker died twice (") and len(seen) == 3
    assert written(tmp_path) == ["job_2.blend", "job_2.json", "job_4.blend", "job_4.json"]


def test_a_task_that_raises_is_one_failed_job_never_retried(fp, rb, batch, ray_up, tmp_path):
    scene, jobs = batch

    def task(scene, name, job, common, want_out):
        return 1 / 0

    outcomes, _ = bake(fp, rb, scene, jobs[:2], tmp_path, task=task)
    assert [(o.status, o.attempts, o.error) for o in outcomes] == \
        [("failed", 1, "internal error: ZeroDivisionError: division by zero")] * 2
    assert written(tmp_path) == []


def test_a_failed_bake_names_the_users_files_not_the_workers_copies(rb):
    tmp = "/tmp/footstep-ray-abc"
    result = {"status": 2, "tmp": tmp, "seconds": 0.1,
              "stderr": f"Read blend: {tmp}/scene/shot.blend\nfootstep: error: no object named 'Hero' in "
                        f"{tmp}/scene/shot.blend\n"}
    assert rb._error_line(result, "/work/shot.blend", {"out": None}) == "no object named 'Hero' in /work/shot.blend"
    bug = {"status": 70, "tmp": tmp, "seconds": 0.1, "stderr": "Traceback (most recent call last):\n  File x\n"
           "KeyError: 'feet'\nfootstep: this is a bug in Footstep Planner, not a problem with your files\n"}
    assert rb._error_line(bug, "/work/shot.blend", {}) == "internal error: KeyError: 'feet'"
