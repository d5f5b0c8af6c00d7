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
#: s: how long a test waits for a subprocess before taking it for hung. Only a hang: a
#: slow or loaded machine must never fail a test by time (speed is the benchmarks').
HANG_SECONDS = 900
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)

QUATERNIUS = os.path.join(SHARED, "clips", "quaternius_male_casual", "Male_Casual.fbx")


def needs_shared(path: str, what: str):
    """Mark ``shared``: the test reads ``path`` under ../shared (``what`` it is); where the
    path is absent it is skipped, with a reason that names it (``pytest_runtest_setup``).
    ``-m "not shared"`` leaves all of them out."""
    return pytest.mark.shared(path=path, reason=f"{what} not found at {path} (../shared beside the project; "
                                                "CI has it)")


needs_cmu = needs_shared(CMU, "real motion capture")
needs_quaternius = needs_shared(QUATERNIUS, "the Quaternius character")


def pytest_runtest_setup(item):
    for mark in item.iter_markers("shared"):
        if not os.path.exists(mark.kwargs["path"]):
            pytest.skip(mark.kwargs["reason"])


def pytest_collection_modifyitems(config, items):
    """Mark ``blender`` every test that runs inside Blender (it uses the enabled add-on,
    ``fp``, or its module imports bpy): ``-m "not blender"`` runs the pure core's tests."""
    for item in items:
        module = getattr(item, "module", None)
        if "fp" in getattr(item, "fixturenames", ()) or (module is not None and "bpy" in vars(module)):
            item.add_marker(pytest.mark.blender)


def cmu(name: str) -> str:
    """Path of a CMU clip by a unique part of its name, e.g. cmu('16_16')."""
    hits = [f for f in sorted(os.listdir(CMU)) if name in f and f.endswith(".bvh")]
    assert len(hits) == 1, f"{name!r} matches {hits}"
    return os.path.join(CMU, hits[0])


from benchmarks.library import LIBRARY  # noqa: E402  (the CMU library tests and benchmarks plan with)


def plane(x0, x1, y0, y1, z=0.0, tilt_x=0.0, name="floor"):
    """A rectangle at height z + tilt_x * x, as a core TriMesh."""
    import numpy as np

    from footstep_planner.core.plan.surface import TriMesh

    v = np.array([[x0, y0, z + tilt_x * x0], [x1, y0, z + tilt_x * x1],
                  [x1, y1, z + tilt_x * x1], [x0, y1, z + tilt_x * x0]])
    return TriMesh(v, np.array([[0, 1, 2], [0, 2, 3]]), np.zeros(2, np.int64), (name,))


def box(lo, hi, name="box"):
    """A closed axis-aligned box as a core TriMesh."""
    import numpy as np

    from footstep_planner.core.plan.surface import TriMesh

    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    v = np.array([[x, y, z] for z in (lo[2], hi[2]) for y in (lo[1], hi[1]) for x in (lo[0], hi[0])])
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    tris = [t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))]
    return TriMesh(v, np.array(tris), np.zeros(12, np.int64), (name,))


def standing(x, y, heading, forward):
    """Both feet standing side by side 0.1 m either side of (x, y), turned ``heading``
    from ``forward`` (x, y): the start footprints of a plan (core PathFootprint)."""
    import numpy as np

    from footstep_planner.core.footprint import PathFootprint

    ang = heading + np.arctan2(forward[1], forward[0])
    left = np.array([-np.sin(ang), np.cos(ang), 0.0])
    p = np.array([x, y, 0.0])
    return [PathFootprint(0, p + 0.1 * left, heading, 0.0, "start", "walk"),
            PathFootprint(1, p - 0.1 * left, heading, 0.0, "start", "walk")]


def scene_with_cmu(fp, name, fps=30):
    """Sample scene ``name`` built in an empty file, with the CMU library imported as
    armature "CMU"."""
    from importlib import import_module

    import bpy

    bpy.ops.wm.read_homefile(use_empty=True)
    import_module(fp.__name__ + ".blender.sample.sample_scenes").build(name)
    scene = bpy.context.scene
    scene.render.fps = fps
    return scene, cmu_armature(fp)


_IMPORTED: dict = {}


def cmu_armature(fp, names=tuple(LIBRARY), name="CMU"):
    """CMU clips ``names`` as one armature ``name`` in the current file, at its scene's
    frame rate: imported by the add-on (``import_clips``) the first time in a test process,
    then appended from a file holding what that import made (the same armature, actions,
    slots and tags, in a tenth of the time: these tests are about what comes after the
    import; the import's own tests import)."""
    from importlib import import_module

    import bpy

    scene = bpy.context.scene
    key = (tuple(names), name, scene.render.fps, scene.render.fps_base)
    if key not in _IMPORTED:
        clips = import_module(fp.__name__ + ".blender.read.clips")
        ob, actions = clips.import_clips([cmu(n) for n in names], name=name)
        path = os.path.join(tempfile.mkdtemp(prefix="fp_cmu_"), "cmu.blend")
        bpy.data.libraries.write(path, {ob, *actions}, compress=False)
        _IMPORTED[key] = (path, {a.name for a in actions if a.use_fake_user})
        return ob
    path, fake = _IMPORTED[key]
    with bpy.data.libraries.load(path, link=False) as (src, dst):
        dst.objects = [name]
        dst.actions = list(src.actions)
    for a in dst.actions:  # (a file written keeps no fake users)
        a.use_fake_user = a.name in fake
    ob = dst.objects[0]
    scene.collection.objects.link(ob)
    bpy.context.view_layer.update()  # (evaluated once, as the import leaves it)
    return ob


def rigify_rig(shared_dir: str, run_id: str):
    """(rig, metarig): Rigify's human metarig and the rig Rigify generates from it, in the
    current file's scene (at the origin, as Rigify leaves them). Generated by Rigify once
    in a test run, by the first test process to ask, which writes both to a file in
    ``shared_dir`` (the others wait for it); then appended from that file: the same objects,
    bones, constraints, drivers and widgets, in a second instead of ten (these tests are
    about what the planner does with a generated rig, not about Rigify's generation)."""
    import fcntl

    import addon_utils
    import bpy

    addon_utils.enable("rigify", default_set=True)
    scene = bpy.context.scene
    path = os.path.join(shared_dir, f"rigify-{run_id}-{bpy.app.version_string.replace(' ', '_')}.blend")
    with open(path + ".lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)  # (released as the file closes)
        if not os.path.exists(path):
            bpy.ops.object.armature_human_metarig_add()
            meta = bpy.context.object
            bpy.ops.object.mode_set(mode="OBJECT")
            assert bpy.ops.pose.rigify_generate() == {"FINISHED"}
            rig = bpy.data.objects["rig"]
            bpy.context.view_layer.update()
            part = path + ".part"
            bpy.data.libraries.write(part, {rig, meta}, compress=False)
            os.replace(part, path)
            return rig, meta
    with bpy.data.libraries.load(path, link=False) as (src, dst):
        dst.objects = ["rig", "metarig"]
    rig, meta = dst.objects
    for ob in (rig, meta):
        ob.use_fake_user = False  # (a file written with libraries.write gives every ID a fake user)
        scene.collection.objects.link(ob)
    bpy.context.view_layer.objects.active = rig
    bpy.context.view_layer.update()
    return rig, meta


@pytest.fixture(scope="session")
def rigify_cache(tmp_path_factory, request):
    """(folder, run id) shared by every test process of this run (pytest-xdist's workers),
    for ``rigify_rig``."""
    import uuid

    worker = getattr(request.config, "workerinput", None)
    if worker is None:  # (one process: its own folder)
        return str(tmp_path_factory.getbasetemp()), uuid.uuid4().hex
    return str(tmp_path_factory.getbasetemp().parent), worker["testrunuid"]


def analyse_bvh(fp, paths, fps):
    """Analyse BVH files at a scene rate; plain results only (no bpy references kept)."""
    from importlib import import_module

    import bpy

    clips = import_module(fp.__name__ + ".blender.read.clips")
    character = import_module(fp.__name__ + ".blender.read.character")
    bpy.ops.wm.read_homefile(use_empty=True)
    bpy.context.scene.render.fps = fps
    bpy.context.scene.render.fps_base = 1.0
    out = {}
    for p in paths:
        ob, _ = clips.import_clips([p])
        res = character.analyze_character(ob)
        assert not res.errors, res.errors
        for a in res.analyses:
            out[a.name] = a
    return out


def plan_sample(fp, name, **kw):
    """Sample scene ``name`` with the CMU character, planned from Start to Goal:
    (scene, PlanResult, PlanSetup, goal)."""
    from importlib import import_module

    import numpy as np

    scene, ob = scene_with_cmu(fp, name)
    planning = import_module(fp.__name__ + ".blender.planning")
    goal = np.array(scene.objects["Goal"].location)
    result, setup = planning.plan(scene, ob, goal, start_marker=scene.objects["Start"], **kw)
    return scene, result, setup, goal


class Recorder:
    """Stands in for a UILayout: checks each call against the real UILayout's RNA
    signature (so a keyword Blender 5.0 lacks fails here, not in the user's viewport),
    records it, and returns a recorder for sub-layouts."""

    def __init__(self, log=None):
        self.log = [] if log is None else log

    def __getattr__(self, name):
        import bpy

        fn = bpy.types.UILayout.bl_rna.functions.get(name)
        assert fn is not None, f"UILayout has no {name}()"
        params = [p.identifier for p in fn.parameters if not p.is_output]

        def call(*args, **kwargs):
            unknown = set(kwargs) - set(params)
            assert not unknown, f"UILayout.{name}() has no parameter {unknown}"
            assert len(args) <= len(params), f"UILayout.{name}(): too many arguments"
            self.log.append((name, args, kwargs))
            return Recorder(self.log)
        return call

    def __setattr__(self, name, value):
        if name == "log":
            object.__setattr__(self, name, value)


def draw_tab(fp, context) -> list:
    """Draw the planner's sidebar tab as Blender would, into a Recorder: the main panel and
    each sub-panel whose poll passes (open or closed). Returns the calls."""
    from importlib import import_module

    stub = Recorder()
    for cls in import_module(fp.__name__ + ".blender.ui.panel").TAB_PANELS:
        if not hasattr(cls, "poll") or cls.poll(context):
            cls.draw(type("P", (), {"layout": stub})(), context)
    return stub.log


def _reraise(ex):
    raise ex


def pytest_sessionfinish(session, exitstatus):
    session.config.stash[_EXIT_STATUS] = int(exitstatus)


_EXIT_STATUS = pytest.StashKey[int]()


@pytest.hookimpl(trylast=True)
def pytest_unconfigure(config):
    """On Blender 4.5 a process that generated a Rigify rig hangs for ever in Blender's
    own exit handlers (a thread of Blender's waits on a condition its static destructor
    destroys): once pytest has reported, leave with its status and Blender's temp folder
    removed, as Blender's exit would."""
    bpy = sys.modules.get("bpy")
    app = getattr(bpy, "app", None)
    if app is None or app.version >= (5, 0, 0) or _EXIT_STATUS not in config.stash:
        return
    import shutil

    shutil.rmtree(app.tempdir, ignore_errors=True)
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(config.stash[_EXIT_STATUS])


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


@pytest.fixture(scope="session")
def bench_character(fp):
    """The planner benchmark's character: CMU subject 16's library, analysed
    (``benchmarks/scene_generator.cmu_character``)."""
    from benchmarks.scene_generator import cmu_character

    return cmu_character(fp.__name__)


def own_strides(character):
    """``character`` (``scene_generator.Character``) with its clips' own strides only
    (no adapted strides: ``Settings.stride_min`` 1)."""
    from dataclasses import replace

    return replace(character, steps=character.steps.take(character.steps.stride == 1.0))


@pytest.fixture
def empty_scene(fp):
    """A fresh empty scene at 24 fps, the add-on still enabled."""
    import bpy

    bpy.ops.wm.read_homefile(use_empty=True)
    bpy.context.scene.render.fps = 24
    bpy.context.scene.render.fps_base = 1.0
    return bpy.context.scene
