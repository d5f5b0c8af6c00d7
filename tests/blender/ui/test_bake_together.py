"""Bake Together from the panel (issue 29): a list of characters with their goals, baked in
one space and time in the list's order; the overlay shows each character's footprints in
its own colour; Esc takes the whole run back; bad rows are refused by row, the scene as it
was."""

import colorsys
from importlib import import_module

import numpy as np
import pytest

from crowd_scenes import crossing, dead_end, played_bodies



def _crossing(fp):
    """The crossing (``crowd_scenes.crossing``) with two sample characters, A the panel's
    character with its goal and start."""
    scene, a, b = crossing(fp)
    fs = scene.footstep
    fs.character, fs.goal, fs.start = a, scene.objects["GoalA"], scene.objects["StartA"]
    return scene, a, b


def _played(fp, scene, a, b):
    """(A's body, B's, the first frame) as Blender plays the scene from the current frame
    to its end, and each one's object matrices at the last frame."""
    first, n = scene.frame_current, scene.frame_end - scene.frame_current + 1
    return played_bodies(fp, scene, [a, b], first, n), first


def _arrived(scene, bodies, goals) -> None:
    for body, goal in zip(bodies, goals):
        end = body.hips[-1, :2]
        assert np.linalg.norm(end - np.array(scene.objects[goal].location)[:2]) < 0.35, (goal, end)


def _listed(scene, b):
    """The panel's list made as an animator makes it: + adds the panel's character with its
    goal and start; with B active, + adds B, whose goal and start are then picked."""
    import bpy

    assert bpy.ops.footstep.cast_add() == {"FINISHED"}
    bpy.context.view_layer.objects.active = b
    assert bpy.ops.footstep.cast_add() == {"FINISHED"}
    row = scene.footstep.cast[1]
    assert row.character == b and row.goal is None  # (B's goal is not the panel's)
    row.goal, row.start = scene.objects["GoalB"], scene.objects["StartB"]


def _state(scene):
    """What a run may change: the actions, each armature's NLA tracks, the frame range."""
    import bpy

    return (sorted(a.name for a in bpy.data.actions),
            {o.name: [t.name for t in o.animation_data.nla_tracks] if o.animation_data else []
             for o in scene.objects if o.type == "ARMATURE"},
            (scene.frame_start, scene.frame_end))


def test_bake_together_from_the_panel_keeps_the_two_apart_and_colours_each(fp, empty_scene):
    """The panel's list, A then B, baked together: each gets a planner track and arrives;
    as Blender plays the scene the two bodies never touch and no foot stands on the
    other's footprint; the panel drew the list and its button; the overlay shows both,
    each in its own colour (the review sheet's), and one alone again in the classic
    colours once the other's bake is cleared."""
    import bpy

    from conftest import draw_tab

    scene, a, b = _crossing(fp)
    _listed(scene, b)
    calls = draw_tab(fp, bpy.context)
    assert any(c[0] == "template_list" and c[1][0] == "FOOTSTEP_UL_cast" for c in calls)
    assert any(c[0] == "operator" and c[1][0] == "footstep.bake_together" for c in calls)

    assert bpy.ops.footstep.bake_together() == {"FINISHED"}
    fs = scene.footstep
    print(fs.last_report)
    assert fs.last_report.startswith("2 of 2 characters baked together"), fs.last_report
    assert f"nearest {a.name}" in fs.last_report and f"nearest {b.name}" in fs.last_report
    bake = import_module(fp.__name__ + ".blender.write.bake")
    crowd = import_module(fp.__name__ + ".core.report.crowd")
    for ob in (a, b):
        assert len(bake.owned_tracks(ob)) == 1, ob.name

    # as Blender plays the scene: each arrives, and the bodies keep apart
    bodies, first = _played(fp, scene, a, b)
    fig = crowd.pair_figures(bodies[1], bodies[0], first)
    print("B against A, from the panel:", fig)
    assert fig["least_distance_m"] > 0.1 and fig["frames_overlapping"] == 0, fig
    assert fig["frames_on_one_footprint"] == 0, fig
    _arrived(scene, bodies, ("GoalA", "GoalB"))

    # the overlay: both, each in its colour (the hue of its left foot's footprints)
    overlay = import_module(fp.__name__ + ".blender.ui.overlay")
    geo = import_module(fp.__name__ + ".core.report.overlay")
    shown = overlay.shown(scene)
    assert len(shown) == 2
    hues = []
    for k, c in enumerate(shown):
        assert len(c["triangles"]) and len(c["body"])
        tint = geo.character_tint(k)
        assert tuple(c["body_colour"][:3]) == tint
        hue = colorsys.rgb_to_hls(*tint)[0]
        got = {round(colorsys.rgb_to_hls(*rgb[:3])[0], 3) for rgb in c["colours"].astype(float)}
        assert min(abs(g - hue) for g in got) < 1e-3, (k, got, hue)
        hues.append(hue)
    assert abs(hues[0] - hues[1]) > 0.1

    fs.character = b
    assert bpy.ops.footstep.clear() == {"FINISHED"}
    (alone,) = overlay.shown(scene)
    assert tuple(alone["body_colour"]) == geo.BODY  # (one character: the classic colours again)


def test_esc_during_bake_together_takes_back_every_bake_of_the_run(fp, empty_scene, monkeypatch):
    """The operator's own modal run, as Blender drives it (timer ticks, then Esc), stopped
    once both characters are baked but before they are measured: nothing of the run is
    left, the scene's actions, tracks and frame range as they were, and the panel says so."""
    import bpy

    from test_operators_behave import _Modal

    scene, a, b = _crossing(fp)
    _listed(scene, b)
    before = _state(scene)
    cast = import_module(fp.__name__ + ".blender.ui.cast")
    bake = import_module(fp.__name__ + ".blender.write.bake")
    run = _Modal(fp, cast.FOOTSTEP_OT_bake_together, bpy.context, monkeypatch)
    for _ in range(100):  # (until both are baked: the shot's measure is next)
        assert run.tick() == {"RUNNING_MODAL"}
        if all(bake.owned_tracks(o) for o in (a, b)):
            break
    assert all(bake.owned_tracks(o) for o in (a, b))
    assert run.esc() == {"CANCELLED"}
    assert run.reports == [({"INFO"}, "bake together cancelled: every bake of the run was taken back")]
    assert _state(scene) == before
    assert run.progress[-1] == "end"


def test_bake_together_refuses_bad_rows_by_row_and_changes_nothing(fp, empty_scene):
    """A row without a goal, and one character listed twice: refused before anything runs,
    the message naming each row at fault; the scene as it was."""
    import bpy

    scene, a, b = _crossing(fp)
    assert bpy.ops.footstep.cast_add() == {"FINISHED"}
    row = scene.footstep.cast.add()
    row.character = a
    row = scene.footstep.cast.add()
    row.character = b  # (no goal)
    before = _state(scene)
    cast = import_module(fp.__name__ + ".blender.ui.cast")
    errors = import_module(fp.__name__ + ".core.base.errors")
    try:
        cast.cast_jobs(bpy.context)
        raise AssertionError("refused rows were taken")
    except errors.FootstepError as ex:
        msg = str(ex)
    print(msg)
    assert f"row 2 ({a.name}): {a.name!r} is in row 1 too" in msg
    assert f"row 3 ({b.name}): pick its goal" in msg
    with pytest.raises(RuntimeError, match="pick its goal"):  # (an operator's error, run from a script)
        bpy.ops.footstep.bake_together()
    assert _state(scene) == before
    # the rows moved and removed as listed
    scene.footstep.cast_index = 2
    assert bpy.ops.footstep.cast_move(direction="UP") == {"FINISHED"}
    assert [r.character for r in scene.footstep.cast] == [a, b, a] and scene.footstep.cast_index == 1
    assert bpy.ops.footstep.cast_remove() == {"FINISHED"}
    assert [r.character for r in scene.footstep.cast] == [a, a]


def test_a_character_the_one_above_blocks_is_planned_first_and_both_arrive(fp, empty_scene):
    """A dead-end passage 0.9 m wide between walls (no room for two bodies side by side):
    A, listed first, goes to its mouth and stands there; B, listed second, goes to its far
    end. Planned in the list's order, A would stand in B's way for good (alone B has a way,
    round A none, and no stand of B's lets A pass): so the shot is planned again with B
    first, and A stands on its way until B has gone in. Both arrive; as Blender plays the
    scene the bodies never touch; the panel and A's report say the order and why."""
    import json

    import bpy

    scene, a, b = dead_end(fp)
    fs = scene.footstep
    fs.character, fs.goal, fs.start = a, scene.objects["GoalA"], scene.objects["StartA"]
    _listed(scene, b)

    assert bpy.ops.footstep.bake_together() == {"FINISHED"}
    print(fs.last_report)
    assert fs.last_report.startswith("2 of 2 characters baked together"), fs.last_report
    assert f"row 2 ({b.name}) baked" in fs.last_report and "planned 1 of 2: row 2" in fs.last_report
    doc_a = json.loads(fs.plan_json)
    assert doc_a["shot"] == {"listed": 1, "planned": 2, "of": 2}
    assert doc_a.get("stands"), doc_a.get("stands")  # (A stands on its way to let B by)
    (fig,) = doc_a["quality"]["others"]
    assert fig["character"] == b.name and fig["least_distance_m"] > 0.1 and fig["frames_overlapping"] == 0, fig

    # as Blender plays the scene, over both bakes' frames: both arrive, never touching
    crowd = import_module(fp.__name__ + ".core.report.crowd")
    bodies, first = _played(fp, scene, a, b)
    both = crowd.pair_figures(bodies[0], bodies[1], first)
    print("A against B over the whole shot:", both)
    assert both["least_distance_m"] > 0.1 and both["frames_overlapping"] == 0, both
    _arrived(scene, bodies, ("GoalA", "GoalB"))
