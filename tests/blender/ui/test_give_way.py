"""Re-planning one character of a shot re-plans only those it now meets (issue 29): the
edited character leads, and each other character it then meets as played gives way round
it (its own footprints that meet it searched again); one it does not meet keeps every key.
Measured as Blender plays the scene."""

import math
from importlib import import_module

import numpy as np
import pytest

from crowd_scenes import _floor, played_bodies


@pytest.fixture(scope="module")
def lanes(fp, tmp_path_factory):
    """A saved shot: a floor with three sample characters walking east side by side at one
    pace, A along y = 0, B along y = 1.2 (they never meet), C along y = 6 (far from both),
    each 6 m; all three in the panel's list with their goals and baked together (the file,
    the three names)."""
    import bpy

    scene, ss, floor = _floor(fp)
    ss._box(floor, "Floor", -6.0, 6.0, -3.0, 9.0, -0.2, 0.0)
    man = import_module(fp.__name__ + ".blender.sample.mannequin")
    obs = []
    for who, y in (("A", 0.0), ("B", 1.2), ("C", 6.0)):
        ss._marker(scene, f"Start{who}", (-3.0, y, 0.0), math.pi / 2)
        ss._marker(scene, f"Goal{who}", (3.0, y, 0.0), math.pi / 2)
        obs.append(man.add_to_scene(scene, f"Start{who}")[0])
    fs = scene.footstep
    for ob, who in zip(obs, "ABC"):
        bpy.context.view_layer.objects.active = ob
        fs.character = ob
        assert bpy.ops.footstep.cast_add() == {"FINISHED"}
        row = fs.cast[len(fs.cast) - 1]
        row.character, row.goal, row.start = ob, scene.objects[f"Goal{who}"], scene.objects[f"Start{who}"]
    assert bpy.ops.footstep.bake_together() == {"FINISHED"}, fs.last_report
    path = str(tmp_path_factory.mktemp("lanes") / "lanes.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path, copy=True)
    return path, [ob.name for ob in obs]


def _opened(lanes):
    """The saved shot opened: (scene, A, B, C)."""
    import bpy

    bpy.ops.wm.open_mainfile(filepath=lanes[0])
    scene = bpy.context.scene
    return (scene, *(scene.objects[n] for n in lanes[1]))


def _edit_a(fp, a):
    """A's middle footprint moved 1 m north, into B's lane: (its index, where it was put)."""
    handles = import_module(fp.__name__ + ".blender.ui.handles")
    hs = handles.handles(a)
    k = len(hs) // 2
    hs[k].location.y += 1.0
    return k, np.array(hs[k].location, float)


def _keys(ob) -> list:
    """Every key of the planner's bakes of ``ob`` (their actions, ``fingerprint``'s way)."""
    from fingerprint import _action

    return [_action(st.action) for tr in ob.animation_data.nla_tracks for st in tr.strips]


def test_an_edited_character_leads_and_only_the_one_it_now_meets_gives_way(fp, lanes, tmp_path):
    """Bake Together gives each character footprint handles. A's middle footprint moved 1 m
    into B's lane (where B walks then) and Re-plan: A keeps the footprint where it was put
    and is not re-planned round B; B, which A now meets, is re-planned round A between
    its own locks (the rest of its path as it was; the report says it came within the
    clearance, and how near it now comes); C, far from both, keeps every key and handle. As Blender plays the saved scene the bodies of A and B keep
    their clearance and no foot stands on the other's footprint, and all three arrive."""
    import bpy

    scene, a, b, c = _opened(lanes)
    handles = import_module(fp.__name__ + ".blender.ui.handles")
    crowd = import_module(fp.__name__ + ".core.report.crowd")
    clearance = import_module(fp.__name__ + ".core.base.settings").Settings().character_clearance
    for ob in (a, b, c):
        assert handles.handles(ob), ob.name  # (every character of the shot can be edited)
    c_keys, c_plan = _keys(c), handles.read_plan(c)[0]

    first, n = scene.frame_current, scene.frame_end - scene.frame_current + 1
    before = played_bodies(fp, scene, [a, b], first, n)
    assert crowd.pair_figures(before[0], before[1], first)["least_distance_m"] > 0.5  # (apart in their lanes)

    names = [a.name, b.name, c.name]
    bh = handles.handles(b)  # (B's third footprint and third from last locked: it gives way between them)
    handles.set_locked([bh[2], bh[-3]], True)
    b_before = [f.position.copy() for f in handles.read_plan(b)[0].footprints]
    k, put = _edit_a(fp, a)
    scene.footstep.character = a
    assert bpy.ops.footstep.replan() == {"FINISHED"}
    report = scene.footstep.last_report
    print(report)
    assert f"{b.name} came within" in report and "re-planned round it" in report, report
    assert c.name not in report

    plan, _ = handles.read_plan(a)
    assert np.allclose(plan.footprints[k].position, put, atol=1e-6)  # (the edit stands)
    # B: re-planned between its locks only, the rest of its path as it was
    b_after = [f.position for f in handles.read_plan(b)[0].footprints]
    assert all(np.array_equal(p, q) for p, q in zip(b_after[:3], b_before[:3]))
    assert all(np.array_equal(p, q) for p, q in zip(b_after[-3:], b_before[-3:]))
    assert any(not np.allclose(p[:2], q[:2]) for p, q in zip(b_after[3:-3], b_before[3:-3])) \
        or len(b_after) != len(b_before)
    # C: not met, not touched
    assert _keys(c) == c_keys
    assert [f.position.tolist() for f in handles.read_plan(c)[0].footprints] == \
        [f.position.tolist() for f in c_plan.footprints]

    # as Blender plays the saved scene
    saved = str(tmp_path / "shot.blend")
    bpy.ops.wm.save_as_mainfile(filepath=saved, copy=True)
    bpy.ops.wm.open_mainfile(filepath=saved)
    scene = bpy.context.scene
    obs = [scene.objects[ob_name] for ob_name in names]
    n = scene.frame_end - first + 1
    bodies = played_bodies(fp, scene, obs, first, n)
    fig = crowd.pair_figures(bodies[0], bodies[1], first)
    print("A against B after the edit:", fig)
    assert fig["least_distance_m"] > clearance - 0.05 and fig["frames_overlapping"] == 0, fig
    assert fig["frames_on_one_footprint"] == 0, fig
    for body, who in zip(bodies, "ABC"):
        goal = np.array(scene.objects[f"Goal{who}"].location)[:2]
        assert np.linalg.norm(body.hips[-1, :2] - goal) < 0.35, (who, body.hips[-1])


def test_esc_while_one_gives_way_keeps_the_edited_bake_and_leaves_that_one_as_it_was(fp, lanes, monkeypatch):
    """Re-plan from the UI, stopped with Esc while B gives way: A's re-plan is kept (the
    edited footprint where it was put, its handles the new path) and said to be; B is as it
    was, every key."""
    import bpy

    from test_operators_behave import _Modal, _mod

    scene, a, b, c = _opened(lanes)
    handles = import_module(fp.__name__ + ".blender.ui.handles")
    b_keys = _keys(b)
    k, put = _edit_a(fp, a)
    scene.footstep.character = a
    run = _Modal(fp, _mod(fp, "ui.operators").FOOTSTEP_OT_replan, bpy.context, monkeypatch)
    for _ in range(30):
        assert run.tick() == {"RUNNING_MODAL"}
        if run.status[-1] and run.status[-1].startswith(f"Footstep: re-plan: {b.name}: quality"):
            break
    else:
        raise AssertionError(f"B never gave way: {run.status}")
    assert run.esc() == {"FINISHED"}
    (level, msg), = run.reports
    assert level == {"WARNING"} and msg.startswith(f"re-plan stopped: {a.name} re-planned and kept"), msg
    assert np.allclose(handles.read_plan(a)[0].footprints[k].position, put, atol=1e-6)
    assert _keys(b) == b_keys
