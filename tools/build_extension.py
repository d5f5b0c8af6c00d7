#!/usr/bin/env python3
"""Build the Footstep Planner Blender extension zips: Python 3.11 and pip are all it needs.

Blender's extension tool wants ``blender_manifest.toml`` next to the add-on's
``__init__.py``; this repository keeps the manifest at the root and the add-on in
``footstep_planner/``. So this script:

1. downloads the scipy wheels listed in the manifest into ``./wheels/`` with pip (if missing),
2. copies ``footstep_planner/`` (without caches), the manifest, ``LICENSE`` and the wheels
   into a temporary staging directory,
3. writes one zip per platform into the output directory (default ``dist/``), laid out as
   ``blender --command extension build --split-platforms`` lays them out (the files at the
   zip's root, only that platform's wheel, the manifest with its ``[build.generated]``
   platform table), each with a ``<zip>.sha256`` checksum file (``sha256sum -c`` reads it),
4. validates the staging directory and every zip with Blender's own extension tool
   (``blender_ext.py``, shipped inside the ``bpy`` module and run without importing bpy)
   when this Python has the bpy module, and says that it did not when it has not.

``--platforms linux-x64,...`` restricts the build (and the downloads) to some of the
manifest's platforms: the staged manifest is rewritten to list only those platforms and
their wheels.

Exit codes: 0 success, 1 build/validation error, 3 a wheel could not be downloaded.
"""

from __future__ import annotations

import argparse
import fnmatch
import hashlib
import importlib.util
import os
import platform as _platform
import re
import shutil
import subprocess
import sys
import tempfile
import tomllib
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PACKAGE_DIR = ROOT / "footstep_planner"
MANIFEST = ROOT / "blender_manifest.toml"
LICENSE = ROOT / "LICENSE"
WHEELS_DIR = ROOT / "wheels"
DEFAULT_OUTPUT = ROOT / "dist"

EXIT_DOWNLOAD_FAILED = 3

# Never copied into the staging directory (the manifest's [build] excludes apply too).
_IGNORE = shutil.ignore_patterns("__pycache__", "*.pyc", "*.pyo", ".pytest_cache", ".hypothesis")

# Blender's spelling of systems and machines (as blender_ext.py spells them)
_SYSTEMS = {"darwin": "macos"}
_MACHINES = {"x86_64": "x64", "amd64": "x64", "aarch64": "arm64", "aarch32": "arm32"}
_WHEEL_SYSTEMS = {"macosx": "macos", "manylinux": "linux", "musllinux": "linux", "win": "windows"}


class DownloadError(RuntimeError):
    pass


def bpy_scripts_dir() -> Path | None:
    """``<site-packages>/bpy/<major.minor>/scripts``, found without importing bpy; None when
    this Python has no bpy module."""
    spec = importlib.util.find_spec("bpy")
    if spec is None or not spec.submodule_search_locations:
        return None
    bpy_dir = Path(list(spec.submodule_search_locations)[0])
    candidates = sorted(bpy_dir.glob("[0-9]*.[0-9]*/scripts"))
    return candidates[-1] if candidates else None


def blender_ext_path() -> Path | None:
    """Blender's extension tool (``blender_ext.py``) from the bpy module, or None."""
    scripts = bpy_scripts_dir()
    path = None if scripts is None else scripts / "addons_core" / "bl_pkg" / "cli" / "blender_ext.py"
    return path if path is not None and path.is_file() else None


def valid_tags_path() -> Path | None:
    # The same tag list `blender --command extension` validates against.
    scripts = bpy_scripts_dir()
    path = None if scripts is None else scripts / "modules" / "_bpy_internal" / "extensions" / "tags.py"
    return path if path is not None and path.is_file() else None


def load_blender_ext():
    """Import blender_ext.py as a module (it is a standalone script: no bpy needed)."""
    path = blender_ext_path()
    if path is None:
        raise SystemExit("error: Blender's extension tool needs the bpy module, which this Python (%s) lacks"
                         % sys.executable)
    spec = importlib.util.spec_from_file_location("_fp_blender_ext", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def platform_from_this_system() -> str:
    """This machine as a Blender platform, e.g. ``linux-x64``."""
    system, machine = _platform.system().lower(), _platform.machine().lower()
    return "%s-%s" % (_SYSTEMS.get(system, system), _MACHINES.get(machine, machine))


def blender_platforms_from_wheel_platform(tag: str) -> list[str]:
    """The Blender platforms a wheel's platform tag serves, as Blender reads it:
    ``win_amd64`` -> windows-x64, ``manylinux_2_28_x86_64`` -> linux-x64,
    ``macosx_12_0_arm64`` -> macos-arm64, ``macosx_10_9_universal2`` -> both macOS."""
    head, sep, tail = tag.partition("_")
    if not sep:
        return [tag]
    for src, dst in _WHEEL_SYSTEMS.items():
        if head == src or (head.startswith(src) and head[len(src):].isdigit()):
            head = dst
            break
    for src, dst in _MACHINES.items():
        if tail == src or tail.endswith("_" + src):
            tail = dst
            break
    else:
        tail = tail.rpartition("_")[2]
    tails = ["x64", "arm64"] if (head, tail) == ("macos", "universal2") else [tail]
    return ["%s-%s" % (head, t) for t in tails]


def wheel_platform_tag(wheel_name: str) -> str:
    """``scipy-1.17.1-cp311-cp311-win_amd64.whl`` -> ``win_amd64``."""
    return Path(wheel_name).stem.split("-")[-1]


def wheel_python_tag(wheel_name: str) -> str:
    return Path(wheel_name).stem.split("-")[-3]


def wheel_platforms(entry: str, all_platforms: list[str]) -> list[str]:
    """The Blender platforms a manifest wheel entry serves (every one for ``any``; a
    compressed tag set such as ``manylinux_2_27_x86_64.manylinux_2_28_x86_64`` by its first
    tag, as Blender reads it)."""
    tag = wheel_platform_tag(entry)
    return list(all_platforms) if tag == "any" else blender_platforms_from_wheel_platform(tag)


def wheels_by_platform(manifest: dict) -> dict[str, list[str]]:
    """Map every Blender platform of the manifest to the manifest wheel entries it uses."""
    result: dict[str, list[str]] = {p: [] for p in manifest.get("platforms", [])}
    for entry in manifest.get("wheels", []):
        plats = wheel_platforms(entry, list(result))
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
        raise SystemExit("error: Blender's extension %s failed (exit code %d)" % (args[0], proc.returncode))


def stage(stage_dir: Path, manifest_text: str, wheel_files: list[Path]) -> None:
    shutil.copytree(PACKAGE_DIR, stage_dir, ignore=_IGNORE)
    shutil.copy2(LICENSE, stage_dir / "LICENSE")  # (the licence the manifest declares, in full)
    (stage_dir / "blender_manifest.toml").write_text(manifest_text, encoding="utf-8")
    if wheel_files:
        (stage_dir / "wheels").mkdir(exist_ok=True)
        for wf in wheel_files:
            shutil.copy2(wf, stage_dir / "wheels" / wf.name)


def excluded(rel: str, is_dir: bool, patterns: list[str]) -> bool:
    """Whether ``rel`` (a path in the package, "/"-separated) is left out by the manifest's
    ``[build] paths_exclude_pattern``, read as Blender reads it (gitignore style): a
    trailing "/" matches directories only; a leading "/" or a "/" inside anchors the
    pattern at the package root; any other pattern matches a name at any depth. A path in
    an excluded directory is excluded."""
    parts = rel.split("/")
    if any(_excluded_itself("/".join(parts[:i]), True, patterns) for i in range(1, len(parts))):
        return True
    return _excluded_itself(rel, is_dir, patterns)


def _excluded_itself(rel: str, is_dir: bool, patterns: list[str]) -> bool:
    for pattern in patterns:
        if pattern.startswith("!"):
            raise SystemExit("error: negated build exclude patterns (%r) are not supported" % pattern)
        dir_only = pattern.endswith("/")
        pat = pattern.rstrip("/")
        if (dir_only and not is_dir) or not pat:
            continue
        if pat.startswith("/") or "/" in pat:
            want, got = pat.lstrip("/").split("/"), rel.split("/")
            if len(want) == len(got) and all(fnmatch.fnmatchcase(g, w) for g, w in zip(got, want)):
                return True
        elif fnmatch.fnmatchcase(rel.rsplit("/", 1)[-1], pat):
            return True
    return False


def package_files(stage_dir: Path, patterns: list[str]) -> list[str]:
    """The staged package's files (relative, "/"-separated, sorted) but the manifest and
    the wheels, which every zip adds itself, and what ``patterns`` exclude."""
    out = []
    for dirpath, dirnames, filenames in os.walk(stage_dir):
        rel_dir = Path(dirpath).relative_to(stage_dir).as_posix()
        rel_dir = "" if rel_dir == "." else rel_dir + "/"
        dirnames[:] = sorted(d for d in dirnames if not excluded(rel_dir + d, True, patterns)
                             and not (rel_dir == "" and d == "wheels"))
        out += [rel_dir + f for f in sorted(filenames) if not excluded(rel_dir + f, False, patterns)
                and rel_dir + f != "blender_manifest.toml"]
    return out


def _toml_string(value: str) -> str:
    return '"%s"' % value.replace("\\", "\\\\").replace('"', '\\"')


def generated_table(platform: str, wheels: list[str]) -> str:
    """The ``[build.generated]`` table Blender's split build appends to a platform zip's
    manifest (its platform and wheels)."""
    return ("\n\n# BEGIN GENERATED CONTENT.\n# This must not be included in source manifests.\n"
            "[build.generated]\nplatforms = [%s]\nwheels = [%s]\n# END GENERATED CONTENT.\n"
            % (_toml_string(platform), ", ".join(_toml_string(w) for w in wheels)))


#: Every entry's time stamp: the same sources give byte-identical zips (and checksums)
_ZIP_TIME = (1980, 1, 1, 0, 0, 0)


def _add(zf: zipfile.ZipFile, name: str, data: bytes, stored: bool) -> None:
    info = zipfile.ZipInfo(name, _ZIP_TIME)
    info.external_attr = 0o644 << 16
    info.compress_type = zipfile.ZIP_STORED if stored else zipfile.ZIP_DEFLATED
    zf.writestr(info, data, compresslevel=None if stored else 9)


def write_zip(path: Path, stage_dir: Path, manifest_text: str, files: list[str], wheels: list[str]) -> None:
    """One extension zip, written beside ``path`` and moved into place: the manifest, the
    ``wheels`` (manifest entries, stored: they are zips already), then ``files``."""
    tmp = path.with_name("." + path.name + ".tmp")
    try:
        with zipfile.ZipFile(tmp, "w") as zf:
            _add(zf, "blender_manifest.toml", manifest_text.encode("utf-8"), False)
            for entry in wheels:
                rel = entry[2:] if entry.startswith("./") else entry
                _add(zf, rel, (stage_dir / rel).read_bytes(), True)
            for rel in files:
                _add(zf, rel, (stage_dir / rel).read_bytes(), False)
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()


def write_checksum(path: Path) -> Path:
    """``<zip>.sha256`` beside the zip, as ``sha256sum`` writes it (``sha256sum -c`` checks it)."""
    digest = hashlib.sha256(path.read_bytes()).hexdigest()
    out = path.with_name(path.name + ".sha256")
    tmp = out.with_name("." + out.name + ".tmp")
    tmp.write_text("%s  %s\n" % (digest, path.name), encoding="utf-8")
    os.replace(tmp, out)
    return out


def check_zip(path: Path, manifest: dict, platform: str) -> None:
    """The checks that need no Blender: the zip's manifest reads as TOML, names its
    platform, and every file it promises is in the zip."""
    with zipfile.ZipFile(path) as zf:
        names = set(zf.namelist())
        got = tomllib.loads(zf.read("blender_manifest.toml").decode("utf-8"))
    generated = got.get("build", {}).get("generated", {})
    for key in ("schema_version", "id", "name", "tagline", "version", "type", "maintainer", "license",
                "blender_version_min"):
        if key not in got:
            raise SystemExit("error: %s: the manifest has no %r" % (path.name, key))
    if platform and generated.get("platforms") != [platform]:
        raise SystemExit("error: %s: the manifest does not name its platform %s" % (path.name, platform))
    wanted = ["__init__.py"] + [w[2:] if w.startswith("./") else w for w in generated.get("wheels", [])]
    lost = [n for n in wanted if n not in names]
    if lost or got["id"] != manifest["id"]:
        raise SystemExit("error: %s lacks %s" % (path.name, ", ".join(lost) or "its id"))


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
    by_platform = wheels_by_platform(manifest)
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

    validator = blender_ext_path()
    tags = ["--valid-tags", str(valid_tags_path())] if validator and valid_tags_path() else []
    if validator is None:
        print("note: Blender's extension validator was not run: this Python (%s) has no bpy module; "
              "the zips had this script's own checks only (with bpy installed, it validates them too)"
              % sys.executable, flush=True)
    patterns = list(manifest.get("build", {}).get("paths_exclude_pattern", []))
    out_dir = Path(args.output_dir).resolve()
    out_dir.mkdir(parents=True, exist_ok=True)
    tmp = tempfile.mkdtemp(prefix="fp_ext_stage_")
    try:
        stage_dir = Path(tmp) / manifest["id"]
        stage(stage_dir, manifest_text, wheel_files)
        if validator:
            run_tool(["validate", *tags, str(stage_dir)])
        files = package_files(stage_dir, patterns)
        for p in platforms or [""]:
            suffix = ("-" + p.replace("-", "_")) if p else ""
            z = out_dir / ("%s-%s%s.zip" % (manifest["id"], manifest["version"], suffix))
            wheels = [w for w in wheel_entries if w in by_platform.get(p, wheel_entries)]
            text = manifest_text + (generated_table(p, wheels) if p else "")
            write_zip(z, stage_dir, text, files, wheels)
            check_zip(z, manifest, p)
            if validator:  # what users install is the zip: validate it, too
                run_tool(["validate", *tags, str(z)])
            sums = write_checksum(z)
            print("built %s (%d bytes; checksum in %s)" % (z, z.stat().st_size, sums.name), flush=True)
    finally:
        if args.keep_stage:
            print("staging directory kept at %s" % tmp)
        else:
            shutil.rmtree(tmp, ignore_errors=True)
    print("validated with Blender's extension tool (%s)" % validator if validator
          else "not validated with Blender's extension tool (no bpy module in this Python)", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
