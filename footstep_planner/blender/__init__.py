"""The Blender layer: everything that touches bpy. It reads scene data into plain arrays,
calls the core, and writes results back."""

from .command import cli
from .sample import mannequin
from .ui import cast, live, operators, overlay, panel, props, session

# registration order: properties before the operators and panels that use them
_MODULES = (props, session, operators, cast, mannequin, panel, overlay, live, cli)


def register():
    for mod in _MODULES:
        mod.register()


def unregister():
    for mod in reversed(_MODULES):
        mod.unregister()
