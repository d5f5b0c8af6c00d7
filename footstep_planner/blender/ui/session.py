"""What the planner keeps for this Blender session only, never in the user's .blend: each
scene's scratch state (the last plan's JSON, the last report, why the last edit was
refused) and the overlay's last plan. Opening a file, or File > New, forgets all of it."""

from __future__ import annotations

import bpy
from bpy.app.handlers import persistent

#: scene (by its session id) -> {name: value} of its scratch state
_SCRATCH: dict[int, dict] = {}


def scratch(scene) -> dict:
    """The scratch state of ``scene`` (a dict to read and write), for this session."""
    return _SCRATCH.setdefault(scene.session_uid, {})


class Scratch:
    """A per-scene value of a scene PropertyGroup kept at runtime (``scratch``), read and
    written as the StringProperty it replaces was, but never saved into the file."""

    def __init__(self, default: str = "", doc: str = ""):
        self.default, self.__doc__ = default, doc

    def __set_name__(self, owner, name):
        self.name = name

    def __get__(self, pg, owner=None):
        if pg is None:
            return self
        return scratch(pg.id_data).get(self.name, self.default)

    def __set__(self, pg, value):
        scratch(pg.id_data)[self.name] = str(value)


def forget() -> None:
    """Drop every scene's scratch state and the overlay's last plans."""
    from . import overlay

    _SCRATCH.clear()
    overlay.LAST.clear()


@persistent
def _on_load_post(*_args) -> None:
    # the previous file's footprints and reports are not this file's: never draw them
    forget()


def register():
    if _on_load_post not in bpy.app.handlers.load_post:
        bpy.app.handlers.load_post.append(_on_load_post)


def unregister():
    if _on_load_post in bpy.app.handlers.load_post:
        bpy.app.handlers.load_post.remove(_on_load_post)
    forget()
