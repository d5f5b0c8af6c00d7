"""The command line's files and scenes: inputs checked (``check_input``), .blend files
opened and claimed as outputs, the scene and the armature picked by name, and the
command line's expected error (``CliError``). Shared by the verbs (``cli``, ``clip_verbs``).
"""

from __future__ import annotations

import os

import bpy

from ...core.base.errors import FootstepError
from ...core.base.files import Outputs
from ...core.base.settings import Settings
from . import batch


class CliError(FootstepError):
    """An expected problem: its message is printed without a traceback."""



def check_input(path: str, what: str = "file") -> str:
    """``path`` if it is a readable file; a CliError naming it otherwise."""
    if os.path.isdir(path):
        raise CliError(f"{path}: is a folder, not a {what}")
    if not os.path.exists(path):
        raise CliError(f"{path}: no such file")
    if not os.path.isfile(path):
        raise CliError(f"{path}: not a regular file (a pipe or a device?), not a {what}")
    if not os.access(path, os.R_OK):
        raise CliError(f"{path}: cannot read it (permission denied)")
    return path


def file_version() -> tuple:
    """The Blender file version the open file was saved with."""
    return tuple(bpy.data.version)


def open_blend(path: str) -> None:
    """Open a .blend file; CliError naming it when it can't be, or when a newer Blender
    saved it (this one would lose what it can't read, behind its own warning)."""
    check_input(path, ".blend file")
    try:
        bpy.ops.wm.open_mainfile(filepath=os.path.abspath(path), load_ui=False)
    except RuntimeError as ex:
        raise CliError(f"{path}: cannot open: {str(ex).strip()}") from None
    saved, ours = file_version(), tuple(bpy.app.version_file)
    if saved > ours:
        raise CliError(f"{path}: saved by a newer Blender (file version {'.'.join(map(str, saved))}) than this one "
                       f"({bpy.app.version_string}, file version {'.'.join(map(str, ours))}): what it can't read "
                       "would be lost; bake it with that Blender version or newer")


def claim_blend(outs: Outputs, path: str | None, what: str) -> str | None:
    """Claim a .blend output (refused unless it ends in .blend)."""
    if path is None:
        return None
    if not path.lower().endswith(".blend"):
        raise CliError(f"the {what} {path!r} must be a .blend file")
    return outs.claim(path, what)


def blend_writer(final: str):
    """A writer for ``Outputs.stage``: save a copy of the open file at the temporary path
    (the open file keeps its own path)."""
    def write(tmp: str) -> None:
        try:
            bpy.ops.wm.save_as_mainfile(filepath=tmp, compress=True, copy=True)
        except RuntimeError as ex:
            raise CliError(f"cannot save {final}: {str(ex).strip().splitlines()[-1]}") from None
        if not os.path.isfile(tmp) or os.path.getsize(tmp) == 0:
            raise CliError(f"cannot save {final}: Blender wrote nothing (is the disk full?)")
    return write


def empty_scene(fps: float | None) -> None:
    bpy.ops.wm.read_homefile(use_empty=True)
    if fps:
        set_scene_fps(bpy.context.scene, fps)


def set_scene_fps(scene, fps: float) -> None:
    scene.render.fps = max(1, int(round(fps)))
    scene.render.fps_base = scene.render.fps / fps


def pick_scene(name: str | None):
    """The scene to work in: ``--scene NAME`` (made the active one), else the active one."""
    if name is None:
        return bpy.context.scene
    scene = bpy.data.scenes.get(name)
    if scene is None:
        raise CliError(f"no scene named {name!r} in {bpy.data.filepath or 'the file'}; its scenes: "
                       + ", ".join(repr(s.name) for s in bpy.data.scenes))
    bpy.context.window.scene = scene
    return scene


def find_armature(name: str):
    ob = bpy.data.objects.get(name)
    if ob is None:
        raise CliError(f"no object named {name!r} in {bpy.data.filepath or 'the scene'}")
    missing = batch.missing_library(ob)
    if missing:
        raise CliError(missing)
    if name not in bpy.context.scene.objects:
        raise CliError(batch.not_in_scene(bpy.context.scene, ob))
    if ob.type != "ARMATURE":
        raise CliError(f"object {name!r} is a {ob.type.lower()}, not an armature")
    return ob


def settings_from_args(pairs) -> Settings:
    """The Settings of ``--set NAME=VALUE`` options, each converted and range-checked by
    the setting's own declaration (a SettingsError names the setting)."""
    return Settings.from_pairs(pairs)


def csv_names(csv: str) -> list[str]:
    return [n.strip() for n in csv.split(",") if n.strip()]


def read_text(path: str, what: str) -> str:
    check_input(path, what)
    try:
        with open(path, encoding="utf-8") as fh:
            return fh.read()
    except UnicodeDecodeError as ex:
        raise CliError(f"{path}: not a text file ({ex.reason} at byte {ex.start})") from None
