"""Build the extension zip for this platform, then install and enable it in Blender.

The build runs tools/build_extension.py in a subprocess (restricted to the current
platform, so only one scipy wheel is needed), once with bpy and once in a fresh venv that
has only pip. Installation runs in another subprocess with its own
BLENDER_USER_RESOURCES, so neither the user's preferences nor this pytest process (which
loads the add-on from a dev repository) are touched.
"""

import hashlib
import importlib.util
import json
import os
import subprocess
import sys
import textwrap
import tomllib
import zipfile
from pathlib import Path

import pytest

from conftest import HANG_SECONDS

ROOT = Path(__file__).resolve().parents[3]
BUILD_SCRIPT = ROOT / "tools" / "build_extension.py"
MANIFEST = tomllib.loads((ROOT / "blender_manifest.toml").read_text(encoding="utf-8"))
EXIT_DOWNLOAD_FAILED = 3  # tools/build_extension.py's code for "wheel could not be downloaded"


def _load_build_tool():
    spec = importlib.util.spec_from_file_location("_fp_build_extension", BUILD_SCRIPT)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


_BUILD = _load_build_tool()
_BLENDER_EXT = _BUILD.load_blender_ext()
PLATFORM = _BUILD.platform_from_this_system()  # e.g. "linux-x64", Blender's spelling


def _wheel_for_this_platform():
    by_platform = _BUILD.wheels_by_platform(MANIFEST)
    wheels = by_platform.get(PLATFORM, [])
    assert len(wheels) == 1, f"expected one scipy wheel for {PLATFORM}, manifest gives {wheels}"
    return Path(wheels[0]).name


@pytest.fixture(scope="module")
def built_zip(tmp_path_factory):
    if PLATFORM not in MANIFEST.get("platforms", []):
        pytest.skip(f"this platform ({PLATFORM}) is not one the extension is built for")
    out = tmp_path_factory.mktemp("dist")
    proc = _build(sys.executable, out)
    assert "validated with Blender's extension tool" in proc.stdout, proc.stdout
    return _the_zip(out, proc)


def _build(python, out, *extra):
    proc = subprocess.run(
        [str(python), str(BUILD_SCRIPT), "--platforms", PLATFORM, "--output-dir", str(out), *extra],
        cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=HANG_SECONDS,
    )
    if proc.returncode == EXIT_DOWNLOAD_FAILED:
        pytest.skip(f"the scipy wheel for {PLATFORM} could not be downloaded (no network?):\n"
                    + proc.stdout[-2000:])
    assert proc.returncode == 0, proc.stdout
    return proc


def _the_zip(out, proc):
    """The one zip a build made in ``out``, its checksum file checked."""
    zips = sorted(out.glob("*.zip"))
    expected = out / f"{MANIFEST['id']}-{MANIFEST['version']}-{PLATFORM.replace('-', '_')}.zip"
    assert zips == [expected], (zips, proc.stdout)
    digest, name = (out / (expected.name + ".sha256")).read_text().split()
    assert name == expected.name and digest == hashlib.sha256(expected.read_bytes()).hexdigest()
    return expected


def test_build_needs_only_python_and_pip(built_zip, tmp_path):
    """A fresh venv with pip and no bpy builds the same zip (byte for byte) and says it
    could not run Blender's validator; the zip then passes that validator."""
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True, timeout=HANG_SECONDS)
    python = venv / "bin" / "python"
    probe = subprocess.run([str(python), "-c", "import importlib.util as u; print(u.find_spec('bpy'))"],
                           capture_output=True, text=True, timeout=HANG_SECONDS)
    assert probe.stdout.strip() == "None", "the fresh venv must not see bpy"
    out = tmp_path / "dist"
    # its own wheel folder: the wheel is fetched with the venv's pip
    proc = _build(python, out, "--wheels-dir", str(tmp_path / "wheels"))
    assert "not validated with Blender's extension tool" in proc.stdout, proc.stdout
    assert (tmp_path / "wheels" / _wheel_for_this_platform()).is_file()
    z = _the_zip(out, proc)
    assert z.read_bytes() == built_zip.read_bytes()
    run = subprocess.run([sys.executable, str(_BUILD.blender_ext_path()), "validate",
                          "--valid-tags", str(_BUILD.valid_tags_path()), str(z)],
                         stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=HANG_SECONDS)
    assert run.returncode == 0, run.stdout


@pytest.mark.parametrize("tag", ["win_amd64", "win_arm64", "win32", "macosx_12_0_arm64", "macosx_10_14_x86_64",
                                 "macosx_10_9_universal2", "manylinux_2_27_x86_64", "manylinux2014_aarch64",
                                 "musllinux_1_2_x86_64", "linux_x86_64"])
def test_wheel_platforms_read_as_blender_reads_them(tag):
    assert _BUILD.blender_platforms_from_wheel_platform(tag) == _BLENDER_EXT.blender_platforms_from_wheel_platform(tag)


def test_the_manifest_excludes_what_blender_excludes():
    patterns = MANIFEST["build"]["paths_exclude_pattern"]
    blender = _BLENDER_EXT.PathPatternMatch(patterns)
    paths = ["__init__.py", "core/solve/ik.py", "core/__pycache__", "a/b/x.pyc", "tests", "tests/t.py", "core/tests",
             "dist", "x.zip", "core/y.zip", "s.blend1", "s.blend", ".git", ".venv", "benchmarks", "core/benchmarks",
             ".pytest_cache", "core/.hypothesis", "build", "wheels", "LICENSE"]
    for p in paths:
        for is_dir in (False, True):
            ours = _BUILD.excluded(p, is_dir, patterns)
            assert ours == blender.test_path(p + ("/" if is_dir else "")), (p, is_dir, ours)


def test_zip_validates(built_zip):
    proc = subprocess.run(
        [sys.executable, str(_BUILD.blender_ext_path()), "validate",
         "--valid-tags", str(_BUILD.valid_tags_path()), str(built_zip)],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=HANG_SECONDS,
    )
    assert proc.returncode == 0, proc.stdout


def test_zip_contents(built_zip):
    with zipfile.ZipFile(built_zip) as zf:
        names = set(zf.namelist())
        manifest = tomllib.loads(zf.read("blender_manifest.toml").decode("utf-8"))
    assert "blender_manifest.toml" in names
    assert "__init__.py" in names
    assert "core/__init__.py" in names
    wheel = _wheel_for_this_platform()
    assert f"wheels/{wheel}" in names
    # Only this platform's wheel goes into a split-platform zip.
    assert [n for n in names if n.endswith(".whl")] == [f"wheels/{wheel}"]
    assert not [n for n in names if "__pycache__" in n or n.endswith(".pyc")]
    assert not [n for n in names if n.startswith("tests/")]
    assert "LICENSE" in names
    assert manifest["id"] == "footstep_planner"
    assert manifest["platforms"] == [PLATFORM]
    assert manifest["wheels"] == [f"./wheels/{wheel}"]


# Runs in a fresh Python with bpy. The scipy installed in the venv is hidden so that the
# import must be served by the wheel Blender unpacked from the zip.
_INSTALL_SCRIPT = textwrap.dedent(
    r"""
    import importlib.machinery, json, os, sys, sysconfig

    VENV_SITE = {os.path.realpath(sysconfig.get_paths()["purelib"]),
                 os.path.realpath(sysconfig.get_paths()["platlib"])}

    class OnlyBundledScipy:
        # Find top-level "scipy" anywhere on sys.path except the venv's site-packages.
        def find_spec(self, name, path=None, target=None):
            if name != "scipy":
                return None
            paths = [p for p in sys.path if os.path.realpath(p) not in VENV_SITE]
            spec = importlib.machinery.PathFinder.find_spec(name, paths)
            if spec is None:
                raise ModuleNotFoundError("scipy is not installed outside the venv", name=name)
            return spec

    sys.meta_path.insert(0, OnlyBundledScipy())

    import bpy, addon_utils

    zip_path = sys.argv[1]
    result = bpy.ops.extensions.package_install_files(
        filepath=zip_path, repo="user_default", enable_on_install=True)
    mod_name = "bl_ext.user_default.footstep_planner"
    loaded_default, loaded_state = addon_utils.check(mod_name)
    mod = sys.modules.get(mod_name)
    in_prefs = mod_name in bpy.context.preferences.addons

    import scipy
    from scipy.spatial import cKDTree
    import numpy as np
    d, i = cKDTree(np.eye(3)).query([1.0, 0.1, 0.0])

    # the installed add-on at work: bake the sample character on a sample scene
    from importlib import import_module
    bake_ok = None
    if mod is not None:
        import_module(mod_name + ".blender.sample.sample_scenes").build("jumps")
        scene = bpy.context.scene
        ob, _ = import_module(mod_name + ".blender.sample.mannequin").add_to_scene(scene, "Start")
        fs = scene.footstep
        fs.character, fs.goal, fs.start = ob, scene.objects["Goal"], scene.objects["Start"]
        bake_ok = sorted(bpy.ops.footstep.bake())
        tracks = [t.name for t in ob.animation_data.nla_tracks]
        report = fs.last_report
    addon_utils.disable(mod_name, default_set=True)
    left = sorted(n for n in dir(bpy.types) if n.startswith(("FOOTSTEP_", "footstep_")))
    left += [f"Scene.footstep"] if hasattr(bpy.types.Scene, "footstep") else []
    left += [h.__name__ for h in bpy.app.handlers.load_post if "footstep" in (h.__module__ or "")]
    left += [f.__name__ for f in bpy.types.VIEW3D_MT_object_animation._dyn_ui_initialize()
             if "footstep" in (getattr(f, "__module__", "") or "")]

    print("RESULT " + json.dumps({
        "bake": bake_ok, "tracks": tracks if bake_ok else [], "report": report if bake_ok else "",
        "left_registered": left, "enabled_after": mod_name in bpy.context.preferences.addons,
        "op": sorted(result),
        "in_prefs": in_prefs,
        "loaded_default": loaded_default,
        "loaded_state": loaded_state,
        "module_file": getattr(mod, "__file__", None),
        "extensions_dir": bpy.utils.user_resource("EXTENSIONS"),
        "scipy_version": scipy.__version__,
        "scipy_file": scipy.__file__,
        "kdtree_index": int(i),
    }))
    """
)


def test_install_enable_bake_and_disable_in_blender(built_zip, tmp_path):
    user_resources = tmp_path / "blender_user"
    user_resources.mkdir()
    env = dict(os.environ, BLENDER_USER_RESOURCES=str(user_resources))
    proc = subprocess.run(
        [sys.executable, "-c", _INSTALL_SCRIPT, str(built_zip)],
        cwd=tmp_path, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
        timeout=HANG_SECONDS,
    )
    lines = [ln for ln in proc.stdout.splitlines() if ln.startswith("RESULT ")]
    assert proc.returncode == 0 and lines, proc.stdout
    res = json.loads(lines[-1][len("RESULT "):])

    assert res["op"] == ["FINISHED"], proc.stdout
    assert res["in_prefs"] and res["loaded_default"] and res["loaded_state"], proc.stdout
    # The enabled add-on is the installed copy, under the isolated user resources.
    ext_dir = Path(res["extensions_dir"]).resolve()
    assert ext_dir.is_relative_to(user_resources.resolve())
    assert Path(res["module_file"]).resolve() == ext_dir / "user_default" / "footstep_planner" / "__init__.py"
    # scipy comes from the bundled wheel, which Blender unpacked into the extensions' site-packages.
    assert Path(res["scipy_file"]).resolve().is_relative_to(ext_dir), res["scipy_file"]
    assert res["scipy_version"] == "1.17.1"
    assert res["kdtree_index"] == 0
    # it bakes the sample character, and disabling it leaves nothing of it registered
    assert res["bake"] == ["FINISHED"] and res["tracks"] == ["Footstep: Footstep Mannequin to goal"], proc.stdout
    assert "frames baked into" in res["report"]
    assert res["left_registered"] == [] and not res["enabled_after"], res


def test_the_manifest_names_a_maintainer_and_a_licence_it_ships():
    name, _, mail = MANIFEST["maintainer"].partition(" <")
    assert name and mail.endswith(">") and "@" in mail
    assert not mail.rstrip(">").endswith(("example.com", "example.org", ".example", ".invalid"))
    assert MANIFEST["license"] == ["SPDX:GPL-3.0-or-later"]
    text = (ROOT / "LICENSE").read_text(encoding="utf-8")
    assert "GNU GENERAL PUBLIC LICENSE" in text and "Version 3, 29 June 2007" in text
    assert "END OF TERMS AND CONDITIONS" in text and "How to Apply These Terms" in text  # (the whole text)


def test_the_files_permission_names_every_kind_read_and_written():
    files = MANIFEST["permissions"]["files"]
    assert len(files) <= 64 and files[-1].isalnum()  # (Blender's limits)
    read, _, written = files.partition("; write ")
    for kind in ("BVH", "FBX", "glTF", "GLB", "blend", "JSON"):
        assert kind in read, kind
    for kind in ("blend", "PNG", "JSON"):
        assert kind in written, kind
