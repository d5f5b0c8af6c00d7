#!/usr/bin/env python3
"""Build the Footstep Planner Blender extension zips.

Blender's extension tool wants ``blender_manifest.toml`` next to the add-on's
``__init__.py``; this repository keeps the manifest at the root and the add-on in
``footstep_planner/``. So this script:

1. downloads the scipy wheels listed in the manifest into ``./wheels/`` (if missing),
2. copies ``footstep_planner/`` (without caches), the manifest and the wheels into a
   temporary staging directory,
3. runs Blender's own extension tool (``blender_ext.py`` shipped inside the ``bpy``
   module, found without importing bpy): ``validate`` then
   ``build --split-platforms`` into the output directory (default ``dist/``).

``--platforms linux-x64,...`` restricts the build (and the downloads) to some of the
manifest's platforms: the staged manifest is rewritten to list only those platforms and
their wheels.

Exit codes: 0 success, 1 build/validation error, 3 a wheel could not be downloaded.
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import re
import shutil
import subprocess
import sys
import tempfile
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PACKAGE_DIR = ROOT / "footstep_planner"
MANIFEST = ROOT / "blender_manifest.toml"
WHEELS_DIR = ROOT / "wheels"
DEFAULT_OUTPUT = ROOT / "dist"

EXIT_DOWNLOAD_FAILED = 3

# Never copied into the staging directory (the manifest's [build] excludes apply too).
_IGNORE = shutil.ignore_patterns("__pycache__", "*.pyc", "*.pyo", ".pytest_cache", ".hypothesis")


class DownloadError(RuntimeError):
    pass


def bpy_scripts_dir() -> Path:
    """``<site-packages>/bpy/<major.minor>/scripts``, found without importing bpy."""
    spec = importlib.util.find_spec("bpy")
    if spec is None or not spec.submodule_search_locations:
        raise SystemExit("error: the bpy module is not installed in this Python (%s)" % sys.executable)
    bpy_dir = Path(list(spec.submodule_search_locations)[0])
    candidates = sorted(bpy_dir.glob("[0-9]*.[0-9]*/scripts"))
    if not candidates:
        raise SystemExit("error: no <version>/scripts directory in %s" % bpy_dir)
    return candidates[-1]


def blender_ext_path() -> Path:
    path = bpy_scripts_dir() / "addons_core" / "bl_pkg" / "cli" / "blender_ext.py"
    if not path.is_file():
        raise SystemExit("error: Blender's extension tool not found at %s" % path)
    return path


def valid_tags_path() -> Path:
    # The same tag list `blender --command extension` validates against.
    return bpy_scripts_dir() / "modules" / "_bpy_internal" / "extensions" / "tags.py"


def load_blender_ext():
    """Import blender_ext.py as a module (it is a standalone script: no bpy needed)."""
    spec = importlib.util.spec_from_file_location("_fp_blender_ext", blender_ext_path())
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def wheel_platform_tag(wheel_name: str) -> str:
    """``scipy-1.17.1-cp311-cp311-win_amd64.whl`` -> ``win_amd64``."""
    return Path(wheel_name).stem.split("-")[-1]


def wheel_python_tag(wheel_name: str) -> str:
    return Path(wheel_name).stem.split("-")[-3]


def wheels_by_platform(manifest: dict, blender_ext) -> dict[str, list[str]]:
    """Map every Blender platform of the manifest to the manifest wheel entries it uses."""
    result: dict[str, list[str]] = {p: [] for p in manifest.get("platforms", [])}
    for entry in manifest.get("wheels", []):
        plats = blender_ext.blender_platforms_from_wheel_platform(wheel_platform_tag(entry))
        if wheel_platform_tag(entry) == "any":
            plats = list(result)
        for p in plats:
            result.setdefault(p, []).append(entry)
    return result


def download_wheel(entry: str, wheels_dir: Path) -> Path:
    """Download one manifest wheel (``./wheels/<file>.whl``) with pip, unless present."""
    name = Path(entry).name
    target = wheels_dir / name
    if target.is_file():
        return target
    dist, version = name.split("-")[:2]
    py_tag = wheel_python_tag(name)  # e.g. cp311
    m = re.fullmatch(r"cp(\d)(\d+)", py_tag)
    if not m:
        raise DownloadError("cannot derive a Python version from wheel tag %r of %s" % (py_tag, name))
    cmd = [
        sys.executable, "-m", "pip", "download",
        "%s==%s" % (dist.replace("_", "-"), version),
        "--only-binary=:all:", "--no-deps",
        "--python-version", "%s.%s" % m.groups(),
        "--implementation", "cp",
        "-d", str(wheels_dir),
    ]
    # A compressed tag set (manylinux_2_27_x86_64.manylinux_2_28_x86_64) -> several --platform.
    for tag in wheel_platform_tag(name).split("."):
        cmd += ["--platform", tag]
    wheels_dir.mkdir(parents=True, exist_ok=True)
    print("+ " + " ".join(cmd), flush=True)
    proc = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    if proc.returncode != 0:
        raise DownloadError("pip could not download %s:\n%s" % (name, proc.stdout[-3000:]))
    if not target.is_file():
        got = sorted(p.name for p in wheels_dir.glob("%s-%s-*.whl" % (dist, version)))
        raise DownloadError(
            "pip did not produce %s (the manifest names a wheel that pip did not pick; "
            "wheels present: %s)\n%s" % (name, ", ".join(got) or "none", proc.stdout[-3000:])
        )
    return target


def _toml_array(key: str, values: list[str]) -> str:
    body = "".join('  "%s",\n' % v for v in values)
    return "%s = [\n%s]" % (key, body)


def restrict_manifest_text(text: str, platforms: list[str], wheels: list[str]) -> str:
    """Rewrite the top-level ``platforms``/``wheels`` arrays of the manifest text."""
    for key, values in (("platforms", platforms), ("wheels", wheels)):
        pattern = re.compile(r"^%s\s*=\s*\[[^\]]*\]" % key, re.MULTILINE)
        text, n = pattern.subn(lambda _m: _toml_array(key, values), text, count=1)
        if n != 1:
            raise SystemExit("error: could not find a top-level %r array in the manifest" % key)
    return text


def run_tool(args: list[str]) -> None:
    cmd = [sys.executable, str(blender_ext_path())] + args
    print("+ " + " ".join(cmd), flush=True)
    proc = subprocess.run(cmd)
    if proc.returncode != 0:
        raise SystemExit("error: blender_ext %s failed (exit code %d)" % (args[0], proc.returncode))


def stage(stage_dir: Path, manifest_text: str, wheel_files: list[Path]) -> None:
    shutil.copytree(PACKAGE_DIR, stage_dir, ignore=_IGNORE)
    (stage_dir / "blender_manifest.toml").write_text(manifest_text, encoding="utf-8")
    if wheel_files:
        (stage_dir / "wheels").mkdir(exist_ok=True)
        for wf in wheel_files:
            shutil.copy2(wf, stage_dir / "wheels" / wf.name)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--platforms", default="",
                    help="comma-separated subset of the manifest platforms to build "
                         "(e.g. linux-x64); default: all of them")
    ap.add_argument("--output-dir", default=str(DEFAULT_OUTPUT),
                    help="where the zips go (default: dist/)")
    ap.add_argument("--wheels-dir", default=str(WHEELS_DIR),
                    help="wheel download cache (default: wheels/)")
    ap.add_argument("--keep-stage", action="store_true",
                    help="keep the staging directory and print its path")
    args = ap.parse_args(argv)

    manifest_text = MANIFEST.read_text(encoding="utf-8")
    manifest = tomllib.loads(manifest_text)
    blender_ext = load_blender_ext()
    by_platform = wheels_by_platform(manifest, blender_ext)
    all_platforms = list(manifest.get("platforms", []))

    if args.platforms:
        platforms = [p.strip() for p in args.platforms.split(",") if p.strip()]
        unknown = [p for p in platforms if p not in all_platforms]
        if unknown:
            ap.error("platform(s) %s not in the manifest (%s)" % (", ".join(unknown), ", ".join(all_platforms)))
    else:
        platforms = all_platforms

    missing = [p for p in platforms if not by_platform.get(p)]
    if missing and manifest.get("wheels"):
        raise SystemExit("error: no wheel in the manifest for platform(s) %s" % ", ".join(missing))

    wheel_entries = [w for w in manifest.get("wheels", []) if any(w in by_platform[p] for p in platforms)]
    if platforms != all_platforms:
        manifest_text = restrict_manifest_text(manifest_text, platforms, wheel_entries)

    wheels_dir = Path(args.wheels_dir).resolve()
    try:
        wheel_files = [download_wheel(w, wheels_dir) for w in wheel_entries]
    except DownloadError as ex:
        print("error: %s" % ex, file=sys.stderr)
        return EXIT_DOWNLOAD_FAILED

    out_dir = Path(args.output_dir).resolve()
    out_dir.mkdir(parents=True, exist_ok=True)
    tmp = tempfile.mkdtemp(prefix="fp_ext_stage_")
    try:
        stage_dir = Path(tmp) / manifest["id"]
        stage(stage_dir, manifest_text, wheel_files)
        tags = ["--valid-tags", str(valid_tags_path())]
        run_tool(["validate", *tags, str(stage_dir)])
        build = ["build", *tags, "--source-dir", str(stage_dir), "--output-dir", str(out_dir)]
        if platforms:
            build.append("--split-platforms")
        run_tool(build)
        # Validate what was produced, too (the zips are what users install).
        for p in platforms or [""]:
            suffix = ("-" + p.replace("-", "_")) if p else ""
            z = out_dir / ("%s-%s%s.zip" % (manifest["id"], manifest["version"], suffix))
            if not z.is_file():
                raise SystemExit("error: expected output %s is missing" % z)
            run_tool(["validate", *tags, str(z)])
            print("built %s (%d bytes)" % (z, z.stat().st_size), flush=True)
    finally:
        if args.keep_stage:
            print("staging directory kept at %s" % tmp)
        else:
            shutil.rmtree(tmp, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
