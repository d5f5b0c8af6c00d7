"""The Blender layer: everything that touches bpy. It reads scene data into plain arrays,
calls the core, and writes results back."""

import importlib

# Submodules that define register()/unregister(), in registration order.
_MODULES = ("props", "operators", "panel", "cli")


def _loaded():
    mods = []
    for name in _MODULES:
        try:
            mods.append(importlib.import_module(f"{__name__}.{name}"))
        except ModuleNotFoundError as ex:  # module not written yet
            if ex.name != f"{__name__}.{name}":
                raise
    return mods


def register():
    for mod in _loaded():
        mod.register()


def unregister():
    for mod in reversed(_loaded()):
        mod.unregister()
