"""Live re-plan (issue 30): a footprint handle moved as the viewport moves it (its
transform changed, then the depsgraph updated) is noted by the planner's handler, and the
timer's re-plan, once the hand rests, shows the new footprints in the overlay: only within
the span between the locks round it, every other footprint exactly where it was, nothing
baked. An edit that can't be honoured keeps the last good result and says why."""

from importlib import import_module

import numpy as np

from test_directing import CHAR, _move_middle_footprint, shot, shot_file, turns  # noqa: F401  (the fixtures)


def _baked(ob) -> list:
    from fingerprint import _action

    return [_action(st.action) for tr in ob.animation_data.nla_tracks for st in tr.strips]


def _drag(live):
    """The depsgraph update a drag makes, then the timer once the hand has rested (no event
    loop runs timers in a background process: it is called as Blender would call it, at a
    moment long after the last move)."""
    import bpy

    bpy.context.view_layer.update()  # (the handler runs on the update the move tagged)
    assert live._PENDING, "the moved handle was not noted"
    rested = max(at for at, _, _ in live._PENDING.values()) + 2 * live.DEBOUNCE
    live._tick(now=rested)  # (an injected moment: the test reads the timer's state, never a clock)
    assert not live._PENDING


def test_a_dragged_footprint_is_replanned_live_within_its_span_only(fp, turns):  # noqa: F811
    import bpy

    scene, ob, _ = turns
    live = import_module(fp.__name__ + ".blender.ui.live")
    overlay = import_module(fp.__name__ + ".blender.ui.overlay")
    handles = import_module(fp.__name__ + ".blender.ui.handles")
    assert bpy.app.handlers.depsgraph_update_post.count(live.on_depsgraph_update) == 1
    before = [f.position.copy() for f in overlay.path_of(scene, ob)[0]]
    keys = _baked(ob)

    scene.footstep.live_replan = False  # (off: a move is not followed)
    hs = handles.handles(ob)
    hs[2].location.x += 0.001
    bpy.context.view_layer.update()
    assert not live._PENDING
    hs[2].location.x -= 0.001

    scene.footstep.live_replan = True
    k, put = _move_middle_footprint(fp, ob, 0.12)
    _drag(live)
    after = [f.position for f in overlay.path_of(scene, ob)[0]]
    assert scene.footstep.edit_problem == ""
    assert any(np.allclose(p, put, atol=1e-6) for p in after)  # (the moved footprint where the hand left it)
    n_tail = len(before) - (k + 3)
    for i in range(k - 2):  # before the span, and from the lock after it on: exactly as they were
        assert np.array_equal(after[i], before[i])
    for i in range(1, n_tail + 1):
        assert np.array_equal(after[-i], before[-i])
    assert any(not np.allclose(a, b) for a, b in zip(after[k - 2:k + 3], before[k - 2:k + 3]))
    assert _baked(ob) == keys  # (nothing baked: Re-plan bakes what the overlay shows)
    assert len(handles.handles(ob)) == len(before)  # (no handle remade under the hand)

    # a drag that can't be honoured: the last good result stays, and the panel says why
    hs = handles.handles(ob)
    hs[k].location.z -= 3.0
    _drag(live)
    assert "off surface" in scene.footstep.edit_problem
    now = [f.position for f in overlay.path_of(scene, ob)[0]]
    assert len(now) == len(after) and all(np.array_equal(a, b) for a, b in zip(now, after))
    assert _baked(ob) == keys


def test_picking_a_handle_makes_its_drag_ready_and_playing_does_not(fp, turns):  # noqa: F811
    """With Live re-plan on, picking a handle (it becomes the active object, selected, as a
    click does before a drag) is an update of it: the timer's update then reads the
    surfaces and clips, and the drag's first update uses them. A frame change with a
    handle active (playing, scrubbing) notes nothing."""
    import bpy

    scene, ob, _ = turns
    live = import_module(fp.__name__ + ".blender.ui.live")
    handles = import_module(fp.__name__ + ".blender.ui.handles")
    scene.footstep.live_replan = True
    live._SETUPS.clear()
    h = handles.handles(ob)[5]
    bpy.context.view_layer.objects.active = h
    h.select_set(True)
    _drag(live)
    made = live._SETUPS[ob.as_pointer()]
    h.location.y += 0.05
    _drag(live)
    assert live._SETUPS[ob.as_pointer()] is made  # (the drag's update used it)

    scene.frame_set(scene.frame_current + 1)  # (as playing does)
    assert not live._PENDING and ob.as_pointer() not in live._SETUPS


def _directed(fp, scene, ob, k=None):
    """The panel directs ``ob`` to the scene's Goal from its Start, Live re-plan on, its
    footprint ``k`` (default the middle one) locked: (the live, overlay and handles modules,
    the overlay's footprints now, k)."""
    live, overlay, handles = (import_module(fp.__name__ + ".blender.ui." + m) for m in ("live", "overlay", "handles"))
    fs = scene.footstep
    fs.character, fs.goal, fs.start = ob, scene.objects["Goal"], scene.objects["Start"]
    fs.live_replan = True
    hs = handles.handles(ob)
    k = len(hs) // 2 if k is None else k
    handles.set_locked([hs[k]], True)
    return live, overlay, handles, [f.position.copy() for f in overlay.path_of(scene, ob)[0]], k


def test_a_moved_goal_is_followed_live_past_the_last_lock_and_replan_bakes_it(fp, turns):  # noqa: F811
    """Moving the Goal (a transform update of it, as a drag makes) re-plans the way from the
    last lock to it: every footprint up to the lock exactly where it was, the last one at the
    new goal, nothing baked. Re-plan then bakes the character there, and the handles it
    remakes keep the new goal: a second re-plan searches nothing."""
    scene, ob, _ = turns
    directing = import_module(fp.__name__ + ".blender.ui.directing")
    live, overlay, handles, before, k = _directed(fp, scene, ob)
    keys = _baked(ob)
    goal = scene.objects["Goal"]
    centre = np.array([17.0, 14.0])  # (the Turns scene's ring: the goal half a metre further out on it)
    out = np.array(goal.location)[:2] - centre
    goal.location.x, goal.location.y = centre + out * (4.5 / np.linalg.norm(out))
    _drag(live)
    assert scene.footstep.edit_problem == ""
    after = [f.position for f in overlay.path_of(scene, ob)[0]]
    assert all(np.array_equal(a, b) for a, b in zip(after[:k + 1], before[:k + 1]))
    assert np.linalg.norm(after[-1][:2] - np.array(goal.location)[:2]) < 0.5
    assert not np.allclose(after[-1], before[-1])
    assert _baked(ob) == keys

    doc, route, _ = directing.rebake_handles(scene, ob)
    assert route.edited.spans and route.edited.spans[-1][0] == k and route.edited.to_goal
    body = np.array(doc["synthesis"]["body"]["position"])[-1]
    assert np.linalg.norm(body[:2] - np.array(goal.location)[:2]) < 0.06
    again = directing.edit_of(scene, ob).route
    again(import_module(fp.__name__ + ".blender.planning").plan_setup(scene, ob), None, None)
    assert again.edited.spans == []


def test_a_moved_start_is_followed_live_up_to_the_first_lock(fp, turns):  # noqa: F811
    """Moving the Start re-plans the way from it to the first lock: the first footprint at
    the Start (the plan's first foot), every footprint from the lock on exactly where it
    was."""
    scene, ob, _ = turns
    live, overlay, _, before, k = _directed(fp, scene, ob, k=6)
    start = scene.objects["Start"]
    start.location.y += 0.4
    _drag(live)
    assert scene.footstep.edit_problem == ""
    after = [f.position for f in overlay.path_of(scene, ob)[0]]
    assert abs(after[0][1] - before[0][1] - 0.4) < 0.02
    tail = len(before) - k
    assert all(np.array_equal(a, b) for a, b in zip(after[-tail:], before[-tail:]))


def _shown(ob) -> np.ndarray:
    """(B, 3) the character's bone heads in the world as the viewport shows it now (the
    depsgraph evaluated, no frame set)."""
    import bpy

    bpy.context.view_layer.update()
    ev = ob.evaluated_get(bpy.context.evaluated_depsgraph_get())
    m = np.array(ev.matrix_world)
    return np.array([(m @ np.array(pb.matrix))[:3, 3] for pb in ev.pose.bones])


def test_the_pose_at_the_current_frame_follows_the_drag_and_the_bake_plays_after(fp, turns):  # noqa: F811
    """At the frame the dragged footprint stands on, the character shows at once what
    Re-plan will bake there (the live update solves the IK and poses it, unkeyed); another
    frame plays the bake again, exactly as it was."""
    scene, ob, doc = turns
    live = import_module(fp.__name__ + ".blender.ui.live")
    directing = import_module(fp.__name__ + ".blender.ui.directing")
    scene.footstep.live_replan = True
    k = len(doc["footprints"]) // 2
    frame = int(doc["footprints"][k]["frame"])
    scene.frame_set(frame)
    baked = _shown(ob)
    keys = _baked(ob)
    assert _move_middle_footprint(fp, ob, 0.12)[0] == k
    _drag(live)
    shown = _shown(ob)
    assert np.abs(shown - baked).max() > 0.05  # (the pose followed the drag)
    assert _baked(ob) == keys  # (unkeyed)
    scene.frame_set(frame + 1)
    scene.frame_set(frame)
    assert np.abs(_shown(ob) - baked).max() < 1e-6  # (another frame: the bake plays again)

    directing.rebake_handles(scene, ob)
    scene.frame_set(frame)
    assert np.abs(_shown(ob) - shown).max() < 0.005  # (Re-plan baked what the preview showed)


def test_a_moved_waypoint_takes_its_footprint_along_live_and_replan_bakes_it(fp, shot):  # noqa: F811
    """Baked through waypoints A and B from the panel, the footprints reaching them are
    locked and follow them: moving A re-plans the spans either side of its footprint live
    (from the start to it and from it to B's), every footprint from B's on exactly where it
    was; Re-plan bakes it, and the handles remade still follow A."""
    import bpy

    _, path = shot
    bpy.ops.wm.open_mainfile(filepath=path)
    scene = bpy.context.scene
    live = import_module(fp.__name__ + ".blender.ui.live")
    overlay = import_module(fp.__name__ + ".blender.ui.overlay")
    handles = import_module(fp.__name__ + ".blender.ui.handles")
    directing = import_module(fp.__name__ + ".blender.ui.directing")
    coll = bpy.data.collections.new("Way")
    scene.collection.children.link(coll)
    a, b = bpy.data.objects["A"], bpy.data.objects["B"]
    coll.objects.link(a)
    coll.objects.link(b)
    ob = bpy.data.objects[CHAR]
    fs = scene.footstep
    fs.character, fs.goal, fs.start, fs.waypoints = ob, scene.objects["Goal"], scene.objects["Start"], coll
    assert bpy.ops.footstep.bake() == {"FINISHED"}
    hs = handles.handles(ob)
    ia, ib = (next(i for i, h in enumerate(hs) if h.get(handles.WAYPOINT) == w) for w in (a, b))
    assert ia < ib and hs[ia][handles.LOCKED] and hs[ib][handles.LOCKED]
    before = [f.position.copy() for f in overlay.path_of(scene, ob)[0]]
    keys = _baked(ob)

    fs.live_replan = True
    a.location.y += 0.3
    _drag(live)
    assert fs.edit_problem == ""
    after = [f.position for f in overlay.path_of(scene, ob)[0]]
    tail = len(before) - ib
    assert all(np.array_equal(p, q) for p, q in zip(after[-tail:], before[-tail:]))
    assert any(np.allclose(p, before[ia] + [0.0, 0.3, 0.0], atol=1e-6) for p in after)  # (it went with A)
    assert _baked(ob) == keys

    directing.rebake_handles(scene, ob)
    hs = handles.handles(ob)
    moved = [h for h in hs if h.get(handles.WAYPOINT) == a]
    assert len(moved) == 1 and np.allclose(np.array(moved[0].location), before[ia] + [0.0, 0.3, 0.0], atol=1e-5)
    assert handles.waypoint_shift(moved[0]) is None  # (where A now is)
    again = directing.edit_of(scene, ob).route
    again(import_module(fp.__name__ + ".blender.planning").plan_setup(scene, ob), None, None)
    assert again.edited.spans == []


def test_letting_go_of_the_handle_bakes_what_the_drag_showed(fp, turns, monkeypatch):  # noqa: F811
    """While a transform runs (the hand on the handle) the update only shows the re-plan;
    once none runs, the timer bakes it as Re-plan would: the keys change, the handles are
    remade (the moved one where the hand left it, and active again), and the panel says so.
    A pick that moves nothing bakes nothing; without a window (a background process)
    nothing is ever baked by the timer."""
    import bpy

    scene, ob, _ = turns
    live = import_module(fp.__name__ + ".blender.ui.live")
    handles = import_module(fp.__name__ + ".blender.ui.handles")
    scene.footstep.live_replan = True
    keys = _baked(ob)
    assert live._dragging() is None  # (no window here)
    hand = {"on": False}
    monkeypatch.setattr(live, "_dragging", lambda: hand["on"])
    h = handles.handles(ob)[5]  # (a pick alone, as a click makes: an update, nothing re-planned, nothing baked)
    bpy.context.view_layer.objects.active = h
    h.select_set(True)
    _drag(live)
    assert _baked(ob) == keys and not live._RELEASE
    hand["on"] = True
    k, put = _move_middle_footprint(fp, ob, 0.12)
    bpy.context.view_layer.objects.active = handles.handles(ob)[k]
    bpy.context.view_layer.update()
    rested = max(at for at, _, _ in live._PENDING.values()) + 2 * live.DEBOUNCE
    live._tick(now=rested)
    assert _baked(ob) == keys and live._RELEASE  # (the hand still on it: kept for a later look, nothing baked)
    hand["on"] = False
    live._tick(now=rested + live.DEBOUNCE)
    assert not live._RELEASE and not live._PENDING
    assert _baked(ob) != keys
    hs = handles.handles(ob)
    assert np.allclose(np.array(hs[k].location), put, atol=1e-6)
    assert bpy.context.view_layer.objects.active == hs[k]
    assert scene.footstep.last_report.startswith("on release: re-planned")
