"""Test set-up: Blender as a module, the add-on enabled from this checkout.

The add-on is loaded as Blender loads an extension (a "dev" repository whose folder is the
project root), so it runs under its real package name ``bl_ext.dev.footstep_planner``.
Blender's user resources point to a temporary folder: no test touches the user's prefs.
Pure-core tests import ``footstep_planner.core`` directly; it never imports bpy.
"""

import os
import sys
import tempfile

os.environ.setdefault("BLENDER_USER_RESOURCES", tempfile.mkdtemp(prefix="fp_blender_"))

import pytest  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SHARED = os.path.join(os.path.dirname(ROOT), "shared")
CMU = os.path.join(SHARED, "mocap", "cmu")
MOD = "bl_ext.dev.footstep_planner"
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)

needs_cmu = pytest.mark.skipif(
    not os.path.isdir(CMU),
    reason=f"real motion capture not found at {CMU} (../shared beside the project; CI has it)")


def cmu(name: str) -> str:
    """Path of a CMU clip by a unique part of its name, e.g. cmu('16_16')."""
    hits = [f for f in sorted(os.listdir(CMU)) if name in f and f.endswith(".bvh")]
    assert len(hits) == 1, f"{name!r} matches {hits}"
    return os.path.join(CMU, hits[0])


def _reraise(ex):
    raise ex


@pytest.fixture(scope="session")
def fp():
    """The enabled add-on module (bl_ext.dev.footstep_planner)."""
    import bpy  # noqa: F401  (first: it puts Blender's own modules on the path)
    import addon_utils

    repos = bpy.context.preferences.extensions.repos
    if not any(r.module == "dev" for r in repos):
        repos.new(name="dev", module="dev", custom_directory=ROOT, source="USER")
    mod = addon_utils.enable(MOD, default_set=True, handle_error=_reraise)
    assert mod is not None, "the add-on did not enable"
    yield mod
    addon_utils.disable(MOD, default_set=True, handle_error=_reraise)


@pytest.fixture
def empty_scene(fp):
    """A fresh empty scene at 24 fps, the add-on still enabled."""
    import bpy

    bpy.ops.wm.read_homefile(use_empty=True)
    bpy.context.scene.render.fps = 24
    bpy.context.scene.render.fps_base = 1.0
    return bpy.context.scene
