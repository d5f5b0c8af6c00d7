"""The pure core never imports bpy: every module under ``footstep_planner.core`` imports in a
Python where bpy (and mathutils, Blender's other module) can't be imported at all.

Run in a fresh interpreter so no earlier test's import of bpy hides a dependency.
"""

import os
import subprocess
import sys

from conftest import ROOT

BLOCKED = r'''
import importlib, importlib.abc, pkgutil, sys

class Blocker(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in ("bpy", "mathutils", "bmesh", "gpu", "addon_utils"):
            raise ImportError(f"{name} is blocked: the core must not import Blender")
        return None

sys.meta_path.insert(0, Blocker())
import footstep_planner.core as core
names = [m.name for m in pkgutil.walk_packages(core.__path__, core.__name__ + ".")]
for name in names:
    importlib.import_module(name)
print(len(names))
'''


def test_every_core_module_imports_with_bpy_blocked():
    out = subprocess.run([sys.executable, "-c", BLOCKED], cwd=ROOT, capture_output=True, text=True,
                         env={**os.environ, "PYTHONPATH": ROOT})
    assert out.returncode == 0, out.stderr[-3000:]
    # every stage package and its modules were imported, not an empty walk
    packages = [d for d in os.listdir(os.path.join(ROOT, "footstep_planner", "core"))
                if os.path.isfile(os.path.join(ROOT, "footstep_planner", "core", d, "__init__.py"))]
    assert len(packages) >= 5
    assert int(out.stdout.split()[-1]) >= 40


def test_the_blocker_would_catch_a_core_module_importing_bpy(tmp_path):
    """The same check fails on a package whose module imports bpy (the test can fail)."""
    pkg = tmp_path / "footstep_planner" / "core" / "x"
    pkg.mkdir(parents=True)
    (tmp_path / "footstep_planner" / "__init__.py").write_text("")
    (tmp_path / "footstep_planner" / "core" / "__init__.py").write_text("")
    (pkg / "__init__.py").write_text("")
    (pkg / "bad.py").write_text("import bpy\n")
    out = subprocess.run([sys.executable, "-c", BLOCKED], cwd=tmp_path, capture_output=True, text=True,
                         env={**os.environ, "PYTHONPATH": str(tmp_path)})
    assert out.returncode != 0 and "blocked" in out.stderr
