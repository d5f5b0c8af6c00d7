"""Footstep Planner: plan bipedal locomotion over tagged meshes and bake it to NLA.

This file is Blender glue only: it registers the Blender layer (properties, operators,
panels and the ``footstep`` command-line verb). All the maths lives in ``core`` and never
imports bpy, so ``footstep_planner.core`` can be used and tested without Blender.
"""

# (bpy is imported only by the Blender layer, when registered: the core stays importable
# without Blender, and ``python -m footstep_planner`` loads Blender inside its own guard)


def register():
    from .blender import register as _register

    _register()


def unregister():
    from .blender import unregister as _unregister

    _unregister()
