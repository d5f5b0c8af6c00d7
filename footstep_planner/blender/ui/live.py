"""Live re-plan (issue 30): the path follows the hand while a footprint handle is dragged.

With *Live re-plan* on (the panel, beside Re-plan), a depsgraph handler notes each
character whose footprint handles were moved or turned (a transform update of one); a
timer, ``DEBOUNCE`` s after the last such update,
re-plans each one as Re-plan would (``directing.edit_of``: the spans round what changed,
round the others where its bake was) and performs it, so the overlay shows the new
footprints and body path at once, the re-planned footprints ringed, and the character
at the current frame takes the pose the re-plan would bake there (``preview``: unkeyed,
until the frame changes and the bake plays again). Moving (or turning)
the character's Goal or Start (the panel's, or its list of characters') re-plans the way
from the last lock to the goal, or from the start to the first lock, the same way. Nothing
is baked and no handle is remade while the hand is on one: on release, or with **Re-plan**
(or Bake), what the overlay shows is baked. An edit that can't be honoured rings its footprint in the warning
colour and puts the reason in the panel; the last good result stays drawn. When the hand
lets go (no transform runs in any window any more) the timer bakes it as Re-plan would
(``bake_released``). A moved
waypoint takes the footprint that reaches it along (its handle locked and following it:
``handles.WAYPOINT``), and the spans either side are re-planned.

An update reads the scene's surfaces and the character's clips as a plan does; the next
ones use them again (``_SETUPS``), until anything but a handle changes. Picking a handle
updates it too (Blender tags the object picked), so that update reads them, and the
drag's own updates after it use them; another frame reads them again.
The handler only notes and the timer does the work: Blender calls timers from its event
loop, never while it draws, so the viewport is never held up by a plan. In a background
process there is no event loop: ``update`` is what the timer runs, for one character.
"""

from __future__ import annotations

import time

import bpy
import numpy as np
from bpy.app.handlers import persistent

from ...core.base.errors import FootstepError

#: s after the last moved handle before the re-plan runs (a drag's updates come tens of
#: milliseconds apart: the re-plan runs when the hand rests, not at every step of it)
DEBOUNCE = 0.15

#: character (object pointer) -> (time of its last moved handle, scene name, its name)
_PENDING: dict[int, tuple[float, str, str]] = {}
#: set while a live re-plan runs (its own depsgraph updates are not the hand's)
_BUSY: list = []
#: character (object pointer) -> (scene name, its name): updated while the hand was on a
#: handle (a transform running in a window), baked when it lets go (``bake_released``)
_RELEASE: dict[int, tuple[str, str]] = {}
#: character (object pointer) -> its last live re-plan's ``PlanSetup`` (surfaces read, clips
#: analysed, steps, clip tracks), used again by the next update of the same drag; every
#: entry dropped on any change in the scene but a handle's move (the surfaces, the clips,
#: the rig, the settings: whatever it was made of may have changed)
_SETUPS: dict[int, object] = {}


def _moved_character(scene, ob):
    """The character whose footprint handle ``ob`` (an object just moved) is, or None."""
    from . import handles

    owner = ob.get(handles.OWNED)
    return scene.objects.get(owner) if owner is not None and ob.get(handles.INDEX) is not None else None


@persistent
def on_depsgraph_update(scene, depsgraph) -> None:
    """Note the characters whose handles the hand moved (see the module); start the timer."""
    if _BUSY or not getattr(scene, "footstep", None) or not scene.footstep.live_replan:
        return
    now = time.monotonic()
    for u in depsgraph.updates:
        obj = u.id.original if isinstance(u.id, bpy.types.Object) else None
        char = _moved_character(scene, obj) if obj is not None else None
        directs = _directed(scene, obj) if obj is not None and char is None else []
        if char is None and not (directs and obj.type == "EMPTY"):  # (else: what the next update reads is read again)
            if not _is_handles_collection(u.id.original):
                _SETUPS.clear()
        if not u.is_updated_transform:
            continue
        for c in [char] if char is not None else directs:
            _PENDING[c.as_pointer()] = (now, scene.name, c.name)
    if _PENDING and not bpy.app.timers.is_registered(_tick):
        bpy.app.timers.register(_tick, first_interval=DEBOUNCE)


@persistent
def on_frame_change(scene, *_args) -> None:
    """Another frame: what a setup read at the last one (an obstacle where it stood then)
    is read again by the next update."""
    _SETUPS.clear()


def _directed(scene, obj) -> list:
    """The characters with footprint handles whose Goal or Start (``directing.directed_by``:
    the panel's, or its list of characters') ``obj`` is, or one of whose handles reaches
    the waypoint ``obj`` (``handles.WAYPOINT``)."""
    from . import handles
    from .directing import directed_by

    fs = scene.footstep
    out = []
    for char in [fs.character] + [e.character for e in fs.cast]:
        if (char is not None and char not in out and obj in directed_by(scene, char)
                and handles.owned_collection(char) is not None):
            out.append(char)
    if obj.type == "EMPTY":
        for name in handles.characters_reaching(obj):
            char = scene.objects.get(name)
            if char is not None and char not in out:
                out.append(char)
    return out


def _is_handles_collection(idb) -> bool:
    """Whether ``idb`` is the planner's collection of a character's handles (updated with
    them as they move)."""
    from . import handles

    return isinstance(idb, bpy.types.Collection) and idb.get(handles.OWNED) is not None


def _tick(now: float | None = None):
    """The timer: re-plan each character whose hand has rested ``DEBOUNCE`` s by ``now``
    (``time.monotonic``'s clock; Blender calls it without, the clock's now), and bake those
    re-planned once the hand has let go (``_dragging``: ``bake_released``); again later for
    those still moving or held."""
    now = time.monotonic() if now is None else now
    for key, (at, scene_name, name) in list(_PENDING.items()):
        if now - at < DEBOUNCE:
            continue
        del _PENDING[key]
        scene = bpy.data.scenes.get(scene_name)
        ob = scene.objects.get(name) if scene is not None else None
        if ob is None:
            continue
        got = update(scene, ob)
        if "problem" in got or not got["spans"] or _dragging() is None:
            _RELEASE.pop(key, None)  # (refused, nothing re-planned (a pick, a move undone), or no window: no bake)
        else:
            _RELEASE[key] = (scene_name, name)
    if _RELEASE and _dragging() is False:
        for key, (scene_name, name) in list(_RELEASE.items()):
            if key in _PENDING:  # (moved again since: its update comes first)
                continue
            del _RELEASE[key]
            scene = bpy.data.scenes.get(scene_name)
            ob = scene.objects.get(name) if scene is not None else None
            if ob is not None:
                bake_released(scene, ob)
    return DEBOUNCE if _PENDING or _RELEASE else None


def _dragging() -> bool | None:
    """Whether a transform (a drag with G, R or the gizmo) runs in a window now; None in a
    background process (no hand: the live re-plan bakes nothing itself)."""
    wm = bpy.context.window_manager
    windows = list(wm.windows) if wm is not None and not bpy.app.background else []
    if not windows:
        return None
    return any(op.bl_idname.startswith("TRANSFORM_OT") for w in windows for op in w.modal_operators)


def bake_released(scene, ob) -> dict | None:
    """The hand let go: Re-plan bakes what the live re-plan showed (``directing.rebake_handles``,
    the span re-keyed, the handles remade and the one that was active active again), with
    an undo step pushed where Blender lets a timer push one. Returns the report, or None
    where it is refused (the reason in the panel)."""
    from . import directing, handles
    from .operators import _settings, replan_summary

    fs = scene.footstep
    vl = bpy.context.view_layer
    active = vl.objects.active
    index = active.get(handles.INDEX) if active is not None and active.get(handles.OWNED) == ob.name else None
    _BUSY.append(ob)
    try:
        doc, route, _ = directing.rebake_handles(scene, ob, _settings(bpy.context), body_on=fs.body_on,
                                                 frame_range=fs.grow_frame_range)
        vl.update()  # (the bake's own updates, while busy: not the hand's)
    except FootstepError as ex:  # (its update was good: a bake whose measure fails, say)
        fs.edit_problem = fs.last_report = f"on release, not baked: {ex}"
        return None
    finally:
        _BUSY.remove(ob)
    fs.edit_problem = ""
    fs.last_report = "on release: " + replan_summary(doc, route)
    hs = handles.handles(ob)
    if index is not None and index < len(hs):
        hs[index].select_set(True)
        vl.objects.active = hs[index]
    try:
        bpy.ops.ed.undo_push(message="Footstep: re-plan on release")
    except RuntimeError:  # (no window to push it in)
        pass
    return doc


def update(scene, ob) -> dict:
    """Re-plan ``ob`` from its handles now (``directing.edit_of``), perform it and show it in
    the overlay; nothing baked. Returns {"footprints": the new path's, "spans": re-planned,
    "seconds"} or, where the edit can't be honoured, {"problem": why} (the footprint ringed
    in the warning colour, the panel saying why, the last good result still drawn)."""
    from .. import planning
    from . import directing, handles, overlay
    from .operators import _settings

    t0 = time.perf_counter()
    fs = scene.footstep
    _BUSY.append(ob)
    try:
        edit = directing.edit_of(scene, ob, _settings(bpy.context))
        planned = planning.plan_and_synthesize(scene, ob, edit.goal, None, None, edit.settings, route=edit.route,
                                               frame_start=edit.frame_start,
                                               not_around=tuple(o.name for o in edit.yielding),
                                               setup=_SETUPS.get(ob.as_pointer()))
        _SETUPS[ob.as_pointer()] = planned.setup
        shown = preview(scene, ob, planned, edit)
        # (reading the clips tags the armature, and the preview poses it: evaluated now, while
        # busy, those updates are the update's own, not a change that would drop the setup)
        bpy.context.view_layer.update()
    except FootstepError as ex:
        fs.edit_problem = str(ex)
        i, hs = getattr(ex, "footprint", None), handles.handles(ob)
        where = [np.array(hs[i].matrix_world.translation, float)] if i is not None and i < len(hs) else []
        overlay.mark(scene, refused=np.array(where, float).reshape(-1, 3), replanned=np.zeros((0, 3)))
        return {"problem": str(ex), "seconds": time.perf_counter() - t0}
    finally:
        _BUSY.remove(ob)
    fs.edit_problem = ""
    directing.show_replanned(scene, edit.route.edited)
    overlay.mark(scene, refused=np.zeros((0, 3)))
    return {"footprints": edit.route.edited.result.footprints, "spans": list(edit.route.edited.spans),
            "preview": shown, "seconds": time.perf_counter() - t0}


def preview(scene, ob, planned, edit) -> int | None:
    """Pose ``ob`` at the current frame as the re-plan ``planned`` would bake it (its IK
    solved, the frame's pose set unkeyed: ``write.bake.pose_frame``); the scene frame posed,
    or None where nothing is: the frame outside the character's bake (its keys would not
    put the pose back when the frame changes) or the new path's frames, or a Rigify rig
    (its controls drive the bones). The next frame change plays the bake again."""
    from ...core.solve.frames import solve
    from .. import rigify
    from ..write.bake import pose_frame
    from ..write.owned import BODY_PROP, owned_tracks, track_frames

    if edit.frame_start is None or rigify.is_rigify(ob):
        return None
    now = scene.frame_current
    tracks = [tr for tr in owned_tracks(ob) if not tr.mute and track_frames(tr)[0] <= now <= track_frames(tr)[1]]
    solved = planned.solved or solve(planned.synthesis, planned.setup, edit.settings)
    k = now - int(edit.frame_start)
    if not tracks or not 0 <= k < solved.ik.frames:
        return None
    body_on = str(tracks[0].strips[0].action.get(BODY_PROP, "OBJECT"))
    pose_frame(ob, planned.setup.rig, solved.ik, solved.spin, k, body_on)
    return now


_HANDLERS = ((bpy.app.handlers.depsgraph_update_post, on_depsgraph_update),
             (bpy.app.handlers.frame_change_post, on_frame_change))


def register():
    for handlers, fn in _HANDLERS:
        if fn not in handlers:
            handlers.append(fn)


def unregister():
    for handlers, fn in _HANDLERS:
        if fn in handlers:
            handlers.remove(fn)
    if bpy.app.timers.is_registered(_tick):
        bpy.app.timers.unregister(_tick)
    _PENDING.clear()
    _RELEASE.clear()
    _SETUPS.clear()
