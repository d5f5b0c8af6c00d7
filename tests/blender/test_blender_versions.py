"""One add-on for Blender 4.5 LTS and 5.x: the key-writing helper on either API, the
command line's own exit status (4.5 crashes at exit with the add-on still registered), and
the manifest and test venv pins that say which Blender versions it runs on."""

import os
import re
import subprocess
import sys
import tomllib
from importlib import import_module
from pathlib import Path

import pytest

from conftest import HANG_SECONDS, ROOT

MANIFEST = tomllib.loads((Path(ROOT) / "blender_manifest.toml").read_text(encoding="utf-8"))


@pytest.fixture
def keys(fp):
    return import_module(fp.__name__ + ".blender.write.keys")


@pytest.fixture(params=["this Blender's API", "the 4.5 API"])
def api(request, keys, monkeypatch):
    """Each test runs on this Blender's ``new`` and, on 5.x, on the 4.5 path as well
    (curve made, then its group set), so both are checked whichever bpy runs the tests."""
    if request.param == "the 4.5 API":
        monkeypatch.setattr(keys, "NEW_TAKES_GROUP", False)
    return keys


def _channelbag():
    import bpy

    act = bpy.data.actions.new("keys test")
    slot = act.slots.new(id_type="OBJECT", name="keys test")
    return act.layers.new("L").strips.new(type="KEYFRAME").channelbag(slot, ensure=True)


def test_curves_land_in_their_named_groups(api, empty_scene):
    cb = _channelbag()
    loc = [api.new_fcurve(cb, 'pose.bones["hips"].location', i, "hips") for i in range(3)]
    rot = api.new_fcurve(cb, 'pose.bones["shin.L"].rotation_quaternion', 2, "shin.L")
    bare = api.new_fcurve(cb, "location", 1)
    assert [(fc.data_path, fc.array_index) for fc in loc] == [('pose.bones["hips"].location', i) for i in range(3)]
    assert rot.array_index == 2 and bare.array_index == 1
    # one group per name, made once, holding its curves in order
    assert sorted(g.name for g in cb.groups) == ["hips", "shin.L"]
    by = {g.name: [(c.data_path, c.array_index) for c in g.channels] for g in cb.groups}
    assert by["hips"] == [('pose.bones["hips"].location', i) for i in range(3)]
    assert by["shin.L"] == [('pose.bones["shin.L"].rotation_quaternion', 2)]
    assert bare.group is None
    assert len(cb.fcurves) == 5


def test_an_existing_group_is_reused(api, empty_scene):
    cb = _channelbag()
    made = cb.groups.new("torso")
    fc = api.new_fcurve(cb, 'pose.bones["torso"].location', 0, "torso")
    assert len(cb.groups) == 1 and fc.group == made


def test_a_curve_made_twice_is_refused_as_blender_refuses_it(api, empty_scene):
    cb = _channelbag()
    api.new_fcurve(cb, "location", 0, "Object Transforms")
    with pytest.raises(RuntimeError):
        api.new_fcurve(cb, "location", 0, "Object Transforms")
    assert len(cb.fcurves) == 1


def test_the_helper_reads_the_api_this_blender_has(keys):
    import bpy

    assert keys.NEW_TAKES_GROUP == (bpy.app.version >= (5, 0, 0))


def test_no_call_site_passes_the_5_0_only_argument():
    """Every F-Curve is made through the helper: ``group_name=`` (5.0 only) appears
    nowhere else in the add-on or the tests."""
    hits = []
    for folder in ("footstep_planner", "tests", "benchmarks", "tools"):
        for path in Path(ROOT, folder).rglob("*.py"):
            if path.name in ("keys.py", Path(__file__).name):
                continue
            for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
                if "group_name=" in line:
                    hits.append(f"{path.relative_to(ROOT)}:{n}")
    assert not hits, hits


def test_python_dash_m_exits_with_the_verbs_own_status(tmp_path):
    """A verb's exit status is its own (2: bad input), not a crash at exit: on Blender 4.5
    the process segfaults (139) unless the add-on is unregistered first."""
    env = dict(os.environ, PYTHONPATH=ROOT, BLENDER_USER_RESOURCES=str(tmp_path / "res"))
    missing = str(tmp_path / "missing.blend")
    run = subprocess.run([sys.executable, "-m", "footstep_planner", "plan", missing, "--character", "Hero"],
                         cwd=ROOT, env=env, capture_output=True, text=True, timeout=HANG_SECONDS)
    assert run.returncode == 2, (run.returncode, run.stderr[-2000:])
    assert "missing.blend" in run.stderr and "Traceback" not in run.stderr
    ok = subprocess.run([sys.executable, "-m", "footstep_planner", "--help"], cwd=ROOT, env=env,
                        capture_output=True, text=True, timeout=HANG_SECONDS)
    assert ok.returncode == 0 and "usage: footstep" in ok.stdout, (ok.returncode, ok.stderr[-2000:])


def test_this_blender_meets_the_manifest_minimum():
    import bpy

    low = tuple(int(x) for x in MANIFEST["blender_version_min"].split("."))
    assert low <= (4, 5, 0), "the add-on runs on Blender 4.5 LTS: the manifest must not ask for more"
    assert bpy.app.version >= low


def _pins(name: str) -> dict:
    pins = {}
    for line in (Path(ROOT) / name).read_text(encoding="utf-8").splitlines():
        m = re.match(r"\s*([A-Za-z0-9_.-]+)==(\S+)", line)
        if m:
            pins[m.group(1).lower()] = m.group(2)
    return pins


def test_the_lts_venv_pins_the_same_packages_but_bpy():
    main, lts = _pins("requirements.txt"), _pins("requirements-lts.txt")
    assert main["bpy"].startswith("5.") and lts["bpy"].startswith("4.5.")
    shared = set(main) & set(lts) - {"bpy"}
    assert {"numpy", "scipy", "pytest", "hypothesis"} <= shared
    assert {k: lts[k] for k in shared} == {k: main[k] for k in shared}
    assert set(lts) <= set(main), "the LTS venv installs nothing the main one lacks"
