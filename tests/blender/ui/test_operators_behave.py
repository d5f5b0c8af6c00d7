"""Operators that behave like Blender's own: a greyed button says why, the main operators
are in a menu (so F3 finds them), Esc during Bake cancels only what was not written and
says what was kept, the status bar is given back, and nothing of one file's plan (the
overlay's footprints, the reports) outlives it or is saved into it."""

import shutil
from importlib import import_module
from types import SimpleNamespace

import numpy as np
import pytest

from conftest import Recorder


def _mod(fp, name):
    return import_module(f"{fp.__name__}.blender.{name}")


@pytest.fixture(scope="module")
def mannequin_file(fp, tmp_path_factory):
    """The Jumps sample scene with the Footstep Mannequin and its generated clips as the
    planner's character, walking from Start to Goal, saved once for the module."""
    import bpy

    bpy.ops.wm.read_homefile(use_empty=True)
    scene = _mod(fp, "sample.sample_scenes").build("jumps")
    scene.render.fps = 30
    ob, _ = _mod(fp, "sample.mannequin").add_to_scene(scene, "Start")
    fs = scene.footstep
    fs.character, fs.goal, fs.start = ob, scene.objects["Goal"], scene.objects["Start"]
    fs.edit_footprints = False
    path = str(tmp_path_factory.mktemp("operators") / "jumps.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path, copy=True)
    return path


@pytest.fixture
def mannequin_scene(fp, mannequin_file, tmp_path):
    """(scene, character): a copy of ``mannequin_file`` opened for the test (nothing it
    saves reaches the next test)."""
    import bpy

    path = tmp_path / "jumps.blend"
    shutil.copyfile(mannequin_file, path)
    bpy.ops.wm.open_mainfile(filepath=str(path))
    scene = bpy.context.scene
    return scene, scene.footstep.character


def _footstep_operators():
    import bpy

    return [getattr(bpy.ops.footstep, name) for name in dir(bpy.ops.footstep)]


def test_every_greyed_operator_says_why(fp, empty_scene):
    """With no character, every operator that is not available raises with its poll's own
    reason (what Blender shows on the greyed button), never 'context is incorrect': no
    character, or for the list of characters baked together, the empty list."""
    greyed = [op for op in _footstep_operators() if not op.poll()]
    assert len(greyed) >= 10  # plan, bake, clear, re-plan, analyze, build graph, lock, generate; the list's
    for op in greyed:
        with pytest.raises(RuntimeError) as err:
            op()
        msg = str(err.value)
        assert "context is incorrect" not in msg, msg
        if op.idname_py().startswith(("footstep.cast_", "footstep.bake_together")):
            assert "the list of characters to bake together is empty" in msg, msg
        else:
            assert "no character" in msg and "armature" in msg, msg


def test_the_reason_names_a_character_that_is_no_armature(fp, empty_scene):
    import bpy

    mesh = bpy.data.objects.new("Crate", bpy.data.meshes.new("Crate"))
    empty_scene.collection.objects.link(mesh)
    ops = import_module(fp.__name__ + ".blender.ui.operators")
    # (a Character can only be picked among armatures: the active object is what is left)
    assert ops.character(bpy.context) is None
    with pytest.raises(RuntimeError, match="no character"):
        bpy.ops.footstep.generate_clips()


def test_the_main_operators_are_in_object_animation(fp, empty_scene):
    import bpy

    panel = _mod(fp, "ui.panel")
    stub = Recorder()
    panel.FOOTSTEP_MT_animation.draw(SimpleNamespace(layout=stub), bpy.context)
    listed = [a[0] for name, a, _ in stub.log if name == "operator"]
    assert set(listed) >= {"footstep.plan", "footstep.bake", "footstep.clear", "footstep.replan",
                           "footstep.analyze_clips", "footstep.import_clips", "footstep.generate_clips"}
    for idname in listed:  # each names an operator that exists
        cat, name = idname.split(".")
        assert name in dir(getattr(bpy.ops, cat)), idname
    hooks = bpy.types.VIEW3D_MT_object_animation._dyn_ui_initialize()
    assert panel._menu_animation in hooks
    stub = Recorder()
    panel._menu_animation(SimpleNamespace(layout=stub), bpy.context)
    assert ("menu", ("FOOTSTEP_MT_animation",)) in [(n, a) for n, a, _ in stub.log]


def test_unregister_leaves_nothing_registered(fp, empty_scene):
    """Disabling the add-on takes down its classes, menus, properties and handler (and
    enabling it again brings them back)."""
    import bpy

    panel, session = _mod(fp, "ui.panel"), _mod(fp, "ui.session")
    fp.unregister()
    try:
        assert not [n for n in dir(bpy.types) if n.startswith(("FOOTSTEP_", "footstep_"))]
        assert not hasattr(bpy.types.Scene, "footstep") and not hasattr(bpy.types.Object, "footstep")
        assert panel._menu_animation not in bpy.types.VIEW3D_MT_object_animation._dyn_ui_initialize()
        assert session._on_load_post not in bpy.app.handlers.load_post
    finally:
        fp.register()
    assert hasattr(bpy.types, "FOOTSTEP_MT_animation") and hasattr(bpy.types.Scene, "footstep")
    assert session._on_load_post in bpy.app.handlers.load_post


def test_a_new_file_forgets_the_last_plan(fp, empty_scene, tmp_path):
    """The overlay's footprints and the scene's reports belong to their file: File > New
    (or opening another file) drops them, and saving never writes them into the .blend."""
    import bpy

    overlay = _mod(fp, "ui.overlay")
    fs = empty_scene.footstep
    overlay.mark(empty_scene, waypoints=np.zeros((2, 3)))
    fs.last_report = "40 footprints, 632 frames: a report to forget"
    fs.plan_json = '{"footprints": []}'
    fs.edit_problem = "footprint 3 is off every traversable surface"
    assert empty_scene.name in overlay.LAST and fs.last_report.startswith("40 footprints")
    path = str(tmp_path / "saved.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path, compress=False)
    with open(path, "rb") as f:
        data = f.read()
    assert b"a report to forget" not in data and b"off every traversable" not in data

    bpy.ops.wm.read_homefile(use_empty=True)  # File > New
    assert overlay.LAST == {}
    fs = bpy.context.scene.footstep
    assert (fs.last_report, fs.plan_json, fs.edit_problem) == ("", "", "")

    overlay.mark(bpy.context.scene, refused=np.zeros((1, 3)))
    bpy.ops.wm.open_mainfile(filepath=path)  # the saved file: still nothing of the kind
    assert overlay.LAST == {}
    fs = bpy.context.scene.footstep
    assert (fs.last_report, fs.plan_json, fs.edit_problem) == ("", "", "")


class _Modal:
    """Drives an operator's own modal code as Blender would (invoke, timer events, then
    Esc), on an object standing in for the running operator."""

    METHODS = ("invoke", "modal", "_begin", "_end", "_start", "_finish", "_cancel", "_stopped", "_analysed", "_apply",
               "_refused", "_files", "_imported", "execute", "_stepping")

    def __init__(self, fp, cls, context, monkeypatch, window=None, invoke=True, **props):
        ops = _mod(fp, "ui.operators")
        self.status, self.reports, self.progress = [], [], []
        monkeypatch.setattr(ops, "_status", lambda _ctx, text: self.status.append(text))
        wm = SimpleNamespace(progress_begin=lambda *a: None, progress_end=lambda: self.progress.append("end"),
                             progress_update=lambda v: self.progress.append(v),
                             event_timer_add=lambda *a, **k: "timer", event_timer_remove=lambda t: None,
                             modal_handler_add=lambda op: None)
        self.context = SimpleNamespace(window_manager=wm, window=window, scene=context.scene,
                                       active_object=context.active_object, workspace=None)
        self.op = SimpleNamespace(report=lambda level, msg: self.reports.append((level, msg)), _timer=None, **props)
        for name in self.METHODS:
            if hasattr(cls, name):
                setattr(self.op, name, getattr(cls, name).__get__(self.op))
        if invoke:
            assert self.op.invoke(self.context, None) == {"RUNNING_MODAL"}

    def tick(self):
        return self.op.modal(self.context, SimpleNamespace(type="TIMER", value="NOTHING"))

    def esc(self):
        return self.op.modal(self.context, SimpleNamespace(type="ESC", value="PRESS"))


def _Bake(fp, context, monkeypatch):
    return _Modal(fp, _mod(fp, "ui.operators").FOOTSTEP_OT_bake, context, monkeypatch, markers=False, force=False,
                  new_track=False)


def test_esc_before_the_bake_is_written_changes_nothing(fp, mannequin_scene, monkeypatch):
    import bpy

    scene, ob = mannequin_scene
    bake = _mod(fp, "write.bake")
    tracks = [t.name for t in ob.animation_data.nla_tracks] if ob.animation_data else []
    n_actions = len(bpy.data.actions)
    run = _Bake(fp, bpy.context, monkeypatch)
    assert run.tick() == {"RUNNING_MODAL"}  # planned; inverse kinematics next
    assert run.tick() == {"RUNNING_MODAL"}  # solved; the bake next
    assert run.esc() == {"CANCELLED"}
    assert run.reports == [({"INFO"}, "bake cancelled: nothing was changed")]
    assert run.status[-1] is None and "end" in run.progress  # the status bar is given back
    assert ([t.name for t in ob.animation_data.nla_tracks] if ob.animation_data else []) == tracks
    assert len(bpy.data.actions) == n_actions and not bake.owned_tracks(ob)


def test_esc_while_the_bake_is_measured_takes_it_back_and_says_so(fp, mannequin_scene, monkeypatch):
    """Esc once the keys are written but before their quality is measured: the bake is not
    yet accepted (a bake that plays wrong is taken back), so it is taken back, the scene
    is as it was (its frame range too), and the report's "nothing was changed" is true."""
    import bpy

    from fingerprint import differences, fingerprint

    scene, ob = mannequin_scene
    bake = _mod(fp, "write.bake")
    before = fingerprint()
    run = _Bake(fp, bpy.context, monkeypatch)
    for _ in range(4):  # planning, inverse kinematics, bake: the quality is measured next
        assert run.tick() == {"RUNNING_MODAL"}
    assert len(bake.owned_tracks(ob)) == 1  # (the keys are in the scene, not yet measured)
    assert run.esc() == {"CANCELLED"}
    ((level, msg),) = run.reports
    assert level == {"INFO"} and msg == "bake cancelled: nothing was changed"
    assert bake.owned_tracks(ob) == []
    assert differences(before, fingerprint()) == []
    assert run.status[-1] is None and "end" in run.progress


def test_a_bake_run_to_the_end_reports_its_quality(fp, mannequin_scene, monkeypatch):
    import bpy

    scene, ob = mannequin_scene
    run = _Bake(fp, bpy.context, monkeypatch)
    for _ in range(10):
        if run.tick() == {"FINISHED"}:
            break
    else:
        pytest.fail("the bake did not finish")
    assert "frames baked into" in scene.footstep.last_report and "skate" in scene.footstep.last_report
    assert run.status[-1] is None


@pytest.fixture
def bare_mannequin(fp, empty_scene):
    """The Footstep Mannequin without clips, as the planner's character."""
    ob, _ = _mod(fp, "sample.mannequin").build(empty_scene.collection)
    empty_scene.footstep.character = ob
    return ob


def test_generate_sample_clips_shows_progress_and_esc_keeps_whole_clips(fp, bare_mannequin, monkeypatch):
    import bpy

    gen = _mod(fp, "sample.mannequin").FOOTSTEP_OT_generate_clips
    run = _Modal(fp, gen, bpy.context, monkeypatch)
    names = run.op._names
    assert len(names) >= 10
    assert run.tick() == {"RUNNING_MODAL"} and run.tick() == {"RUNNING_MODAL"}
    assert run.progress == [1, 2] and "2 of" in run.status[-1]
    assert run.esc() == {"FINISHED"}  # the two clips written: one undo step
    assert run.status[-1] is None and run.progress[-1] == "end"
    level, msg = run.reports[0]
    assert level == {"WARNING"} and f"kept the 2 clip(s) written ({names[0]}, {names[1]})" in msg
    assert "not generated: " + ", ".join(names[2:]) in msg
    props = bare_mannequin.data.footstep
    assert sorted(c.name for c in props.clips) == sorted(names[:2])  # the library analysed: what is there


def test_generate_sample_clips_cancelled_at_once_changes_nothing(fp, bare_mannequin, monkeypatch):
    import bpy

    n_actions = len(bpy.data.actions)
    run = _Modal(fp, _mod(fp, "sample.mannequin").FOOTSTEP_OT_generate_clips, bpy.context, monkeypatch)
    assert run.esc() == {"CANCELLED"}
    assert run.reports == [({"INFO"}, "clip generation cancelled: nothing was changed")]
    assert len(bpy.data.actions) == n_actions and run.status[-1] is None


def _library(ob):
    return [(c.name, c.usage, c.summary) for c in ob.data.footstep.clips]


def test_analyze_clips_shows_progress_and_esc_changes_nothing(fp, mannequin_scene, monkeypatch):
    import bpy

    scene, ob = mannequin_scene
    for c in ob.data.footstep.clips:
        c.summary = "as the user last saw it"
    before = _library(ob)
    run = _Modal(fp, _mod(fp, "ui.operators").FOOTSTEP_OT_analyze_clips, bpy.context, monkeypatch, reset=False)
    n = len(run.op._names)
    assert n >= 10
    for k in range(3):
        assert run.tick() == {"RUNNING_MODAL"}
    assert run.progress == [1, 2, 3] and f"3 of {n} clips" in run.status[-1]
    assert run.esc() == {"CANCELLED"}
    assert run.reports == [({"INFO"}, f"analysis cancelled after 3 of {n} clips: nothing was changed")]
    assert _library(ob) == before and run.status[-1] is None


def test_analyze_clips_stepped_gives_what_a_script_gets(fp, mannequin_scene, monkeypatch):
    import bpy

    scene, ob = mannequin_scene
    assert bpy.ops.footstep.analyze_clips() == {"FINISHED"}  # (a script: execute)
    whole = _library(ob)
    for c in ob.data.footstep.clips:
        c.summary = ""
    run = _Modal(fp, _mod(fp, "ui.operators").FOOTSTEP_OT_analyze_clips, bpy.context, monkeypatch, reset=False)
    for _ in range(len(run.op._names)):
        result = run.tick()
    assert result == {"FINISHED"} and _library(ob) == whole
    assert run.reports[-1][1].endswith(f"analysed {len(run.op._names)} clip(s)") and run.status[-1] is None


class _Import(_Modal):
    """Import Clips driven as from the UI: the file browser's choice (then ``op.execute``),
    timer events and Esc, on an object standing in for the running operator."""

    def __init__(self, fp, context, monkeypatch, folder, names):
        ops = _mod(fp, "ui.operators")
        super().__init__(fp, ops.FOOTSTEP_OT_import_clips, context, monkeypatch, window="the window", invoke=False,
                         directory=str(folder), files=[SimpleNamespace(name=n) for n in names], filepath="",
                         target="NEW", _paths=[], _done=None)
        monkeypatch.setattr(ops, "_in_ui", lambda _ctx: True)  # (as in Blender's UI)


def _walkers(folder, n):
    from bvh_files import walker

    names = [f"walk{k}.bvh" for k in range(n)]
    for name in names:
        walker(str(folder / name))
    return names


def test_import_clips_from_the_ui_steps_a_file_at_a_time_and_esc_keeps_whole_files(fp, empty_scene, tmp_path,
                                                                                 monkeypatch):
    import bpy

    names = _walkers(tmp_path, 3)
    run = _Import(fp, bpy.context, monkeypatch, tmp_path, names)
    n_objects, n_actions = len(bpy.data.objects), len(bpy.data.actions)
    assert run.op.execute(run.context) == {"RUNNING_MODAL"}
    assert (len(bpy.data.objects), len(bpy.data.actions)) == (n_objects, n_actions)  # (nothing read yet)
    assert run.tick() == {"RUNNING_MODAL"}
    assert run.progress == [1] and "1 of 3 files" in run.status[-1] and "Esc" in run.status[-1]
    assert run.esc() == {"FINISHED"}  # (what is kept is one undo step)
    warning = [m for level, m in run.reports if level == {"WARNING"}][0]
    assert "stopped after 1 of 3 files" in warning and "walk0.bvh" in warning
    assert "not read: walk1.bvh, walk2.bvh" in warning
    ob = empty_scene.footstep.character
    assert ob is not None and ob.type == "ARMATURE"
    assert len(bpy.data.actions) == n_actions + 1  # walk0's clip, whole; none of the others
    assert run.status[-1] is None and run.progress[-1] == "end"


def test_import_clips_from_the_ui_imports_every_file_into_one_armature(fp, empty_scene, tmp_path, monkeypatch):
    import bpy

    names = _walkers(tmp_path, 3)
    run = _Import(fp, bpy.context, monkeypatch, tmp_path, names)
    n_actions = len(bpy.data.actions)
    assert run.op.execute(run.context) == {"RUNNING_MODAL"}
    assert [run.tick() for _ in names] == [{"RUNNING_MODAL"}, {"RUNNING_MODAL"}, {"FINISHED"}]
    armatures = [o for o in bpy.data.objects if o.type == "ARMATURE"]
    assert len(armatures) == 1 and len(bpy.data.actions) == n_actions + 3
    assert empty_scene.footstep.character == armatures[0]
    assert run.progress == [1, 2, 3, "end"] and run.status[-1] is None


def test_import_clips_esc_before_any_file_changes_nothing(fp, empty_scene, tmp_path, monkeypatch):
    import bpy

    names = _walkers(tmp_path, 2)
    run = _Import(fp, bpy.context, monkeypatch, tmp_path, names)
    n_objects, n_actions = len(bpy.data.objects), len(bpy.data.actions)
    assert run.op.execute(run.context) == {"RUNNING_MODAL"}
    assert run.esc() == {"CANCELLED"}
    assert run.reports == [({"INFO"}, "import cancelled before walk0.bvh: nothing was changed")]
    assert (len(bpy.data.objects), len(bpy.data.actions)) == (n_objects, n_actions)


def _baked_with_a_moved_footprint(fp, mannequin_scene):
    """The mannequin baked on Jumps with its footprints as handles, the middle one moved
    10 cm (three either side locked): ready to Re-plan."""
    import bpy

    scene, ob = mannequin_scene
    scene.footstep.edit_footprints = True
    assert bpy.ops.footstep.bake() == {"FINISHED"}
    handles = _mod(fp, "ui.handles")
    hs = handles.handles(ob)
    k = len(hs) // 2
    handles.set_locked([hs[k - 3], hs[k + 3]], True)
    hs[k].location.y += 0.1
    return scene, ob


def test_replan_from_the_ui_shows_progress_and_esc_changes_nothing(fp, mannequin_scene, monkeypatch):
    import bpy

    from fingerprint import differences, fingerprint

    scene, ob = _baked_with_a_moved_footprint(fp, mannequin_scene)
    before = fingerprint()
    run = _Modal(fp, _mod(fp, "ui.operators").FOOTSTEP_OT_replan, bpy.context, monkeypatch)
    for _ in range(4):  # planning, inverse kinematics, bake: the quality is measured next
        assert run.tick() == {"RUNNING_MODAL"}
    assert "Esc to cancel" in run.status[-1] and len(run.progress) == 4
    assert run.esc() == {"CANCELLED"}
    assert run.reports == [({"INFO"}, "re-plan cancelled: nothing was changed")]
    diff = differences(before, fingerprint())
    assert diff == [], "\n".join(d[:150] + " ... " + d[-250:] for d in diff)
    assert run.status[-1] is None and run.progress[-1] == "end"


def test_replan_from_the_ui_run_to_the_end_rebakes_the_span(fp, mannequin_scene, monkeypatch):
    import bpy

    scene, ob = _baked_with_a_moved_footprint(fp, mannequin_scene)
    run = _Modal(fp, _mod(fp, "ui.operators").FOOTSTEP_OT_replan, bpy.context, monkeypatch)
    for _ in range(10):
        if run.tick() == {"FINISHED"}:
            break
    else:
        pytest.fail("the re-plan did not finish")
    report = scene.footstep.last_report  # (the span re-keyed, or the whole path where a splice would slide)
    assert report.startswith("re-planned ") and ("re-keyed frames" in report or "whole path" in report)
    assert "skate" in report and len(_mod(fp, "write.bake").owned_tracks(ob)) == 1
    assert run.status[-1] is None
