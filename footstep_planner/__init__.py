"""Footstep Planner: plan bipedal locomotion over tagged meshes and bake it to NLA.

This file is Blender glue only: it registers the Blender layer (properties, operators,
panels and the ``footstep`` command-line verb). All the maths lives in ``core`` and never
imports bpy, so ``footstep_planner.core`` can be used and tested without Blender.
"""

try:  # the core is importable without Blender; only the glue below needs bpy
    import bpy  # noqa: F401
except ImportError:  # pragma: no cover - plain-Python use of the core
    bpy = None


def register():
    from .blender import register as _register

    _register()


def unregister():
    from .blender import unregister as _unregister

    _unregister()
