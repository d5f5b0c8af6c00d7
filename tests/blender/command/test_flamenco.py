"""The Flamenco job type (issue 13): ``flamenco/footstep_bake.js`` compiled with node
against stand-ins for the Manager's ``author`` API (``flamenco/check_job_type.js``). One
job list becomes one ``blender-render`` task per job whose arguments are exactly those
``core.jobs.job_argv`` builds, so a job bakes on Flamenco as it bakes anywhere else."""

import json
import os
import shutil
import subprocess

import pytest

from conftest import HANG_SECONDS, ROOT
from footstep_planner.core.jobs import check_job, job_argv, normalised
from footstep_planner.core.base.settings import Settings

NODE = shutil.which("node") or shutil.which("nodejs")
pytestmark = pytest.mark.skipif(NODE is None, reason="node (Node.js) is not installed: the Flamenco job type is "
                                                     "JavaScript, checked with node (apt-get install nodejs)")

JOB_TYPE = os.path.join(ROOT, "flamenco", "footstep_bake.js")
CHECKER = os.path.join(ROOT, "flamenco", "check_job_type.js")

#: a job list using every field, and values whose text Python and JavaScript write differently
JOBS = [
    {"character": "Hero", "goal": "Door", "name": "hero walk", "frame_start": 101, "goal_heading": 90,
     "settings": {"turn_penalty": 3, "smoothing_keep_arcs": False, "max_expansions": 50000, "goal_radius": 1e-05}},
    {"character": "Extra", "body_on": "ROOT", "out": "crowd/extra.blend", "report": "/abs/extra.json",
     "goal_heading": -0.5, "start": "Bench", "frame_start": -20},
    {"character": "Hero", "goal": "Window", "goal_heading": 0.1 + 0.2, "name": "", "settings": {},
     "via": ["Door", "Stairs"]},
    {"character": "Hero", "goal_heading": 1e-7, "frame_start": 1000000.0, "body_on": "object"},
]
SETTINGS = {"blendfile": "/shots/sh010/sh010.flamenco.blend", "output_folder": "/bakes/sh010",
            "markers": True, "keep_frame_range": False, "body_on": "object", "traversable": "Floor,Ramp",
            "obstacles": "", "set": "heuristic_weight=3 rest_time=0.5"}
COMMON = {"markers": True, "keep_frame_range": False, "body_on": "object", "traversable": "Floor,Ramp",
          "obstacles": "", "set": ["heuristic_weight=3", "rest_time=0.5"]}


def compile_job(tmp_path, jobs, **settings) -> tuple[int, dict]:
    """(exit status, what check_job_type.js printed) for a job of this job type."""
    path = tmp_path / "settings.json"
    path.write_text(json.dumps({**SETTINGS, **settings, "jobs": jobs if isinstance(jobs, str) else json.dumps(jobs)}))
    p = subprocess.run([NODE, CHECKER, JOB_TYPE, str(path)], capture_output=True, text=True, timeout=HANG_SECONDS)
    assert p.stdout.strip(), p.stderr
    return p.returncode, json.loads(p.stdout)


def expected_paths(n: int, job: dict) -> tuple[str, str]:
    out, report = job.get("out"), job.get("report")
    out = out if out and out.startswith("/") else f"/bakes/sh010/{out or f'sh010_{n}.blend'}"
    report = report if report and report.startswith("/") else f"/bakes/sh010/{report or f'sh010_{n}.json'}"
    return out, report


def same_command(js: list, py: list) -> bool:
    """The same arguments, a ``--set`` value compared by what it sets (JavaScript writes the
    float setting 3.0 as 3)."""
    if len(js) != len(py):
        return False
    for i, (a, b) in enumerate(zip(js, py)):
        if a != b and not (i > 0 and js[i - 1] == "--set" and a.split("=")[0] == b.split("=")[0]
                           and Settings.parse(*a.split("=", 1)) == Settings.parse(*b.split("=", 1))):
            return False
    return True


def test_each_job_is_one_blender_task_running_job_argvs_command(tmp_path):
    assert all(check_job(n, job) == [] for n, job in enumerate(JOBS, 1)), "the sample jobs are valid"
    status, done = compile_job(tmp_path, JOBS)
    assert status == 0, done
    names = [t["name"] for t in done["tasks"]]
    assert names[:2] == ["job 1 'hero walk' (Hero to Door)", "job 2 (Extra to the 3D cursor)"]
    assert len(done["tasks"]) == len(JOBS)
    for n, (task, job) in enumerate(zip(done["tasks"], JOBS), 1):
        assert task["type"] == "blender" and task["dependencies"] == [] and len(task["commands"]) == 1
        cmd = task["commands"][0]
        assert cmd["type"] == "blender-render"
        params = cmd["parameters"]
        assert (params["exe"], params["exeArgs"], params["argsBefore"], params["blendfile"]) == \
            ("{blender}", "{blenderArgs}", [], SETTINGS["blendfile"])
        out, report = expected_paths(n, job)
        assert params["args"][:2] == ["-c", "footstep"]
        args = params["args"][2:]
        assert args == job_argv(job, out=out, report=report, common=COMMON), f"job {n}"
        assert same_command(args, job_argv(normalised(job), out=out, report=report, common=COMMON)), f"job {n}"


def test_python_and_javascript_write_numbers_alike(tmp_path):
    values = [90, -0.5, 1e-05, 0.1 + 0.2, 1e-7, 123.456, -0.0, 359.99999999999994, 5e-324, 0.0001, 999999.5]
    jobs = [{"character": "Hero", "goal_heading": v, "frame_start": int(v)} for v in values]
    status, done = compile_job(tmp_path, jobs)
    assert status == 0, done
    for task, v in zip(done["tasks"], values):
        args = task["commands"][0]["parameters"]["args"]
        assert args[args.index("--goal-heading") + 1] == repr(float(v))
        assert args[args.index("--frame-start") + 1] == str(int(v))


@pytest.mark.parametrize("jobs, words", [
    ("[{\"character\": ", "not JSON"),
    ("[]", "non-empty JSON list"),
    ({"character": "Hero"}, "non-empty JSON list"),
    ([{"character": "Hero", "gaol": "Door"}], "job 1: unknown field 'gaol'"),
    ([{"character": "Hero"}, {"goal": "Door"}], "job 2: 'character' must be"),
    ([{"character": "Hero", "frame_start": 1.5}], "'frame_start' must be a whole number"),
    ([{"character": "Hero", "body_on": "hips"}], "'body_on' must be"),
    ([{"character": "Hero", "settings": [1]}], "'settings' must be an object"),
])
def test_an_invalid_job_list_is_refused_saying_why(tmp_path, jobs, words):
    status, done = compile_job(tmp_path, jobs)
    assert status == 1 and "tasks" not in done
    assert words in done["error"]


def test_the_job_type_declares_its_settings(tmp_path):
    with open(JOB_TYPE, encoding="utf-8") as fh:
        source = fh.read()
    assert "const JOB_TYPE = {" in source and "function compileJob(job)" in source
    status, done = compile_job(tmp_path, [{"character": "Hero"}])
    assert status == 0 and done["label"] == "Footstep Bake"
    keys = {s["key"]: s for s in done["settings"]}
    assert {"blendfile", "jobs", "jobs_file", "output_folder", "markers", "keep_frame_range", "body_on",
            "traversable", "obstacles", "set"} == set(keys)
    assert all(s["type"] in ("string", "bool", "int32", "float") for s in done["settings"])
    assert all(s.get("visible", "submission") in ("submission", "web", "hidden", "none") for s in done["settings"])
    assert keys["body_on"]["choices"] == ["object", "root"]
