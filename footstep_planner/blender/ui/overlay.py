"""The viewport overlay for review: the planned footprints coloured by foot and clip (each
character in its own colour when several are shown: a shot baked together), the
body trajectory, optionally the footprints the search sampled, and arrows for the way
the Start (or the character) and the Goal face. The geometry comes from
``core/report/overlay.py``; this module only keeps the last run's arrays and draws them."""

from __future__ import annotations

import bpy
import numpy as np

from ...core.report import overlay as geo
from ..read.scene import facing_rotation

#: scene name -> the arrays of its last plan or bake (not saved with the file)
LAST: dict[str, dict] = {}
_HANDLE = None
_TEXT = None


def remember(scene, ob, path, positions, headings, forward, foot, body=None, sampled=None) -> None:
    """Show ``ob``'s plan or bake (its footprints, body path, and the footprints the search
    sampled) until its next one: each character of the scene keeps its own, so a shot
    baked together shows every character, each in its colour (``geo.character_tint``, in
    the order they were first shown; one character alone in the classic colours). Found by
    identity (the object), never by name."""
    feet, labels, jumps = [f.foot for f in path], [f.label for f in path], [f.jump for f in path]
    data = LAST.setdefault(scene.name, {})
    shown = data.setdefault("characters", {})
    key = ob.as_pointer()
    tint = geo.character_tint(list(shown).index(key) if key in shown else len(shown))
    tri, col = geo.footprint_triangles(positions, headings, forward, foot, feet, labels, jumps)
    shown[key] = {
        "triangles": tri.astype(np.float32), "colours": col.astype(np.float32),
        "tinted": geo.footprint_colours(feet, labels, jumps, tint).repeat(6, axis=0).astype(np.float32),
        "tint": (*tint, 1.0),
        "body": geo.polyline_segments(body).astype(np.float32) if body is not None else np.zeros((0, 3), np.float32),
        "path": list(path), "forward": np.asarray(forward, float),  # (its footprint handles, after a shot)
    }
    data.update({
        "sampled": geo.crosses(sampled).astype(np.float32) if sampled is not None else np.zeros((0, 3), np.float32),
        "path": list(path), "forward": np.asarray(forward, float),  # (the last plan's, for the footprint handles)
    })
    _redraw()


def path_of(scene, ob):
    """(footprints, forward) of ``ob``'s last plan or bake shown in ``scene``, or None."""
    got = (LAST.get(scene.name) or {}).get("characters", {}).get(ob.as_pointer())
    return None if got is None else (got["path"], got["forward"])


def forget(scene, ob) -> None:
    """``ob``'s footprints and body path out of the overlay (its bake cleared)."""
    (LAST.get(scene.name) or {}).get("characters", {}).pop(ob.as_pointer(), None)
    _redraw()


def shown(scene) -> list[dict]:
    """The footprints and body path of each character of ``scene`` the overlay shows, in the
    order they were first shown: their triangles, colours (each in its own colour when
    there are several) and body segments, with the colour its body path is drawn in."""
    live = {o.as_pointer() for o in scene.objects}
    chars = [c for k, c in (LAST.get(scene.name) or {}).get("characters", {}).items() if k in live]
    many = len(chars) > 1
    return [{"triangles": c["triangles"], "colours": c["tinted"] if many else c["colours"], "body": c["body"],
             "body_colour": c["tint"] if many else geo.BODY} for c in chars]


def _redraw():
    wm = getattr(bpy.context, "window_manager", None)
    for win in (wm.windows if wm else []):
        for area in win.screen.areas:
            if area.type == "VIEW_3D":
                area.tag_redraw()


def _draw():
    import gpu
    from gpu_extras.batch import batch_for_shader

    scene = bpy.context.scene
    fs = getattr(scene, "footstep", None)
    data = LAST.get(scene.name)
    if fs is None or not fs.show_overlay or data is None:
        return
    gpu.state.blend_set("ALPHA")
    gpu.state.depth_test_set("LESS_EQUAL")
    chars = shown(scene)
    tri = [c for c in chars if len(c["triangles"])]
    if tri:
        sh = gpu.shader.from_builtin("SMOOTH_COLOR")
        batch_for_shader(sh, "TRIS", {"pos": np.concatenate([c["triangles"] for c in tri]),
                                      "color": np.concatenate([c["colours"] for c in tri])}).draw(sh)
    sh = gpu.shader.from_builtin("UNIFORM_COLOR")
    lines = [(c["body"], c["body_colour"]) for c in chars]
    if fs.show_sampled:
        lines.append((data.get("sampled", ()), geo.SAMPLED))
    for points, colour in lines:
        if len(points):
            sh.uniform_float("color", colour)
            batch_for_shader(sh, "LINES", {"pos": points}).draw(sh)
    for points, colour in _marks(scene, data):
        sh.uniform_float("color", colour)
        batch_for_shader(sh, "LINES", {"pos": points}).draw(sh)
    arrows = _facing_arrows(scene, fs)
    if len(arrows):
        sh.uniform_float("color", geo.MARKER)
        batch_for_shader(sh, "LINES", {"pos": arrows}).draw(sh)
    gpu.state.depth_test_set("NONE")
    gpu.state.blend_set("NONE")


def mark(scene, **points) -> None:
    """Points to ring in the overlay until the next plan: ``replanned`` (the footprints the
    last re-plan made), ``waypoints``, ``refused`` (footprints an edit put where they
    can't be)."""
    data = LAST.setdefault(scene.name, {})
    for key, value in points.items():
        data[key] = np.asarray(value, float).reshape(-1, 3)
    _redraw()


def label_waypoints(scene, rows: list[dict]) -> None:
    """Name each waypoint (and the goal) in the overlay with its frame (played, else
    planned), the frame asked for and how it was met where the walk alone could not (a
    jog, a run, a wait): ``rows`` as the report's ``waypoints``."""
    labels = []
    for r in rows:
        ob = scene.objects.get(r["name"])
        if ob is None:
            continue
        got = r.get("achieved") if r.get("achieved") is not None else r.get("planned")
        text = f"{r['name']}: frame {got:.0f}" + ("" if r.get("arrive") is None else f" (asked {r['arrive']:.0f})")
        if r.get("pause"):
            text += f", stands {r['pause']:g} s"
        if r.get("met_by") in ("jog", "run", "wait"):  # (how its frame was met, where the walk alone could not)
            text += {"jog": f", jogs ({r.get('blend') or 0:.0%} run)", "run": ", runs",
                     "wait": f", waits {r.get('waited') or 0:.1f} s"}[r["met_by"]]
        labels.append((np.array(ob.matrix_world.translation, float), text))
    LAST.setdefault(scene.name, {})["labels"] = labels
    _redraw()


def _draw_labels():
    """The waypoints' names and frames, over the viewport (``label_waypoints``)."""
    import blf
    from bpy_extras.view3d_utils import location_3d_to_region_2d

    scene = bpy.context.scene
    fs = getattr(scene, "footstep", None)
    data = LAST.get(scene.name) or {}
    if fs is None or not fs.show_overlay or not data.get("labels"):
        return
    region, rv3d = bpy.context.region, bpy.context.region_data
    blf.size(0, 13)
    blf.color(0, *geo.WAYPOINT)
    for pos, text in data["labels"]:
        xy = location_3d_to_region_2d(region, rv3d, pos + [0.0, 0.0, 0.4])
        if xy is not None:
            blf.position(0, xy[0], xy[1], 0)
            blf.draw(0, text)


def _marks(scene, data) -> list:
    """(segments, colour) of the rings: locked and moved handles, the last re-plan's
    footprints, waypoints and refused footprints."""
    from . import handles

    locked = [np.array(h.matrix_world.translation) for ob in scene.objects if ob.type == "ARMATURE"
              for h in handles.handles(ob) if h.get(handles.LOCKED)]
    out = [(geo.rings(locked, 0.13), geo.LOCKED)]
    for key, colour, radius in (("replanned", geo.REPLANNED, 0.17), ("waypoints", geo.WAYPOINT, 0.35),
                                ("refused", geo.WARNING, 0.2)):
        if len(data.get(key, ())):
            out.append((geo.rings(data[key], radius), colour))
    return [(seg.astype(np.float32), c) for seg, c in out if len(seg)]


def _facing_arrows(scene, fs) -> np.ndarray:
    """Arrows showing the way the Start (else the character) and the Goal face: the
    heading the path starts and arrives with."""

    out = [geo.facing_arrow(np.array(ob.matrix_world.translation), facing_rotation(ob))
           for ob in (fs.start or fs.character, fs.goal) if ob is not None]
    return np.concatenate(out).astype(np.float32) if out else np.zeros((0, 3), np.float32)


def register():
    global _HANDLE, _TEXT
    if not bpy.app.background:  # no viewport to draw in without a window
        _HANDLE = bpy.types.SpaceView3D.draw_handler_add(_draw, (), "WINDOW", "POST_VIEW")
        _TEXT = bpy.types.SpaceView3D.draw_handler_add(_draw_labels, (), "WINDOW", "POST_PIXEL")


def unregister():
    global _HANDLE, _TEXT
    for h in (_HANDLE, _TEXT):
        if h is not None:
            bpy.types.SpaceView3D.draw_handler_remove(h, "WINDOW")
    _HANDLE = _TEXT = None
