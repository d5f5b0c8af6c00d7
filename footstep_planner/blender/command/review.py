"""The demo's pictures: Workbench renders of the baked character at a few frames, a top
view of the scene with the footprints and the body path drawn in, composed into one
review sheet (with a title and captions when matplotlib is there), and the synthesis
curves. The footprints' quads and colours are those of the viewport overlay
(``core/report/overlay.py``)."""

from __future__ import annotations

import math
import os
import textwrap

import bpy
import numpy as np

from ...core.report import overlay as geo
from ...core.report.overlay import CHARACTER_COLOURS, COLOUR_NAMES
from ...core.plan.surface import FootShape


def plot_curves(doc, out_dir: str, name: str) -> list[str]:
    """The synthesis curves of report ``doc`` as PNGs (none, said so, without matplotlib)."""
    try:
        from ...core.report.plots import plot_synthesis

        return plot_synthesis(doc, out_dir, name)
    except ImportError:
        print("(matplotlib not available: no curves)")
        return []


def review_sheet(scene, ob, doc, out_dir: str, name: str, foot: FootShape | None = None) -> tuple[str, list[str]]:
    """Workbench renders of the baked character at a few frames along its path (the
    middle of a jump among them, if it jumps) and a top view with the footprints (drawn
    with the planner's ``foot`` shape), side by side in one PNG. Returns (sheet path, the
    frame renders' paths and the top view's)."""
    fps = doc["footprints"]
    n = len(fps)
    picks = [fps[int(i * (n - 1) / 5)]["frame"] for i in (1, 2, 3, 4)]
    jumps = [i for i, f in enumerate(fps) if f.get("jump")]
    airborne = None
    if jumps:  # the first jump's flight, half way between take-off and landing
        i = jumps[0]
        take_off = fps[i - 1]["planted_frames"][1] if i > 0 else fps[i]["frame"]
        airborne = int((take_off + fps[i]["planted_frames"][0]) // 2)
        picks[1] = airborne
    picks = sorted(set(int(f) for f in picks))
    size = foot.scale if foot is not None else 1.0  # (a giant's camera stands further off)
    shots = [_render_character(scene, ob, f, os.path.join(out_dir, f"{name}_frame{f:04d}.png"), size) for f in picks]
    _draw_footprints(scene, doc, foot or FootShape())
    top = os.path.join(out_dir, f"{name}_top.png")
    scene.frame_set(doc["frame_end"])
    _render_top(scene, top)
    sheet = os.path.join(out_dir, f"{name}_review.png")
    captions = []
    doing = {"walk": "walking", "run": "running"}
    for f in picks:
        near = min(fps, key=lambda fp: abs(fp["frame"] - f))
        what = ("in the air over a gap" if f == airborne
                else f"jogging ({near['blend']:.0%} run)" if near.get("blend")  # (a jog laid it: the walk and the run blended)
                else f"{doing.get(near.get('gait'), near.get('gait'))} ({near.get('clip', '')})")
        captions.append(f"frame {f}: {what}")
    q = doc["quality"]
    title = (f"{scene.name}: {n} footprints ({len(jumps)} jumps), frames {doc['frame_start']}-{doc['frame_end']}; "
             f"goal {q['goal']['distance_m'] * 100:.1f} cm, foot skate max {q['foot_skate']['max_mm']:.2f} mm")
    try:
        _compose_labelled(top, shots, captions, title, sheet)
    except ImportError:  # (no matplotlib, as inside Blender: the same sheet without words)
        _compose([top] + shots, sheet)
    return sheet, shots + [top]


#: the top view's caption on a one-character sheet
ONE_LEGEND = "top view: footprints (left blue, right red, jump landings yellow), body path (orange)"
#: each character's colour on a shot's sheet (``crowd_sheet``), in job order: the overlay's
PALETTE = CHARACTER_COLOURS


def crowd_sheet(scene, shot: list, out_dir: str, name: str, frames: list[int],
                foot: FootShape | None = None) -> str:
    """The review sheet of a shot of several characters baked together: ``shot`` is
    [(armature, its report)] in the order they were planned; a top view with each one's
    footprints and body path in its own colour (``PALETTE``: the right foot's darker), and
    Workbench renders at ``frames`` (where two pass nearest: of the character whose report
    names the pair nearest at that frame). Draws in the scene (the caller's scratch copy)."""
    foot = foot or FootShape()
    for k, (ob, doc) in enumerate(shot):
        _draw_footprints(scene, doc, foot, tint=PALETTE[k % len(PALETTE)], tag=f" {k + 1}")
    top = os.path.join(out_dir, f"{name}_top.png")
    scene.frame_set(max(doc["frame_end"] for _, doc in shot))
    _render_top(scene, top)
    shots, captions = [], []
    for f in frames:  # (the pair nearest at the frame: a later character's report and the other it names)
        at = [(x["least_distance_m"], k, x) for k, (o, d) in enumerate(shot)
              for x in d["quality"].get("others", []) if x.get("least_distance_frame") == f]
        best = min(at, key=lambda a: a[:2]) if at else None
        ob, near = (shot[best[1]][0], best[2]) if best else (shot[0][0], None)
        shots.append(_render_character(scene, ob, f, os.path.join(out_dir, f"{name}_frame{f:04d}.png"), foot.scale))
        captions.append(f"frame {f}: {ob.name}" + (f" and {near['character']}, {near['least_distance_m']:.2f} m apart"
                                                    if near else ""))
    if len(shot) <= len(COLOUR_NAMES):
        legend = "top view: " + ", ".join(f"{ob.name} {_colour_name(k)}" for k, (ob, _) in enumerate(shot))
    else:  # (too many to name: the colours repeat in job order)
        legend = (f"top view: {len(shot)} characters, each in its colour by job order, the colours repeating every "
                  f"{len(COLOUR_NAMES)} ({', '.join(COLOUR_NAMES)}): {shot[0][0].name} "
                  f"{_colour_name(0)}, {shot[1][0].name} {_colour_name(1)}, ...")
    legend = "\n".join(textwrap.wrap(legend, 110))
    least = min((x["least_distance_m"] for _, d in shot for x in d["quality"].get("others", [])), default=None)
    title = (f"{scene.name}: {len(shot)} characters planned together" +
             (f"; bodies {least:.2f} m apart at the nearest" if least is not None else ""))
    sheet = os.path.join(out_dir, f"{name}_review.png")
    try:
        _compose_labelled(top, shots, captions, title, sheet, legend)
    except ImportError:
        _compose([top] + shots, sheet)
    return sheet


def _colour_name(k: int) -> str:
    return COLOUR_NAMES[k % len(COLOUR_NAMES)]


def _compose_labelled(top: str, shots: list[str], captions: list[str], title: str, out: str,
                      legend: str = ONE_LEGEND) -> None:
    """The review sheet with a title and captions (matplotlib): the top view on the left,
    the frames in two columns beside it."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = (len(shots) + 1) // 2
    fig = plt.figure(figsize=(18, 8.4), dpi=100)
    grid = fig.add_gridspec(rows, 4, width_ratios=[1.15, 1.15, 1, 1], wspace=0.02, hspace=0.12)
    ax = fig.add_subplot(grid[:, :2])
    ax.imshow(plt.imread(top))
    ax.set_title(legend, fontsize=10)
    ax.axis("off")
    for k, (png, cap) in enumerate(zip(shots, captions)):
        a = fig.add_subplot(grid[k // 2, 2 + k % 2])
        a.imshow(plt.imread(png))
        a.set_title(cap, fontsize=10)
        a.axis("off")
    fig.suptitle(title, fontsize=12)
    fig.savefig(out, bbox_inches="tight")
    plt.close(fig)


def _compose(paths: list[str], out: str) -> None:
    """One PNG: the first image (square) on the left, the others in a 2-column grid of
    half its height beside it."""
    imgs = []
    for p in paths:
        im = bpy.data.images.load(p)
        a = np.empty(im.size[0] * im.size[1] * 4, np.float32)
        im.pixels.foreach_get(a)
        imgs.append(a.reshape(im.size[1], im.size[0], 4))
        bpy.data.images.remove(im)
    big = imgs[0]
    H = big.shape[0]
    h = H // 2
    cells = []
    for a in imgs[1:]:
        # nearest-neighbour scale to height h
        ys = (np.arange(h) * a.shape[0] / h).astype(int)
        w = int(round(a.shape[1] * h / a.shape[0]))
        xs = (np.arange(w) * a.shape[1] / w).astype(int)
        cells.append(a[ys][:, xs])
    w = max(c.shape[1] for c in cells) if cells else 0
    cols = 2
    rows = (len(cells) + cols - 1) // cols
    sheet = np.ones((max(H, rows * h), big.shape[1] + cols * w, 4), np.float32)
    sheet[sheet.shape[0] - H:, :big.shape[1]] = big
    for k, c in enumerate(cells):
        r, col = divmod(k, cols)
        y0 = sheet.shape[0] - (r + 1) * h  # Blender's pixels start at the bottom row
        x0 = big.shape[1] + col * w
        sheet[y0:y0 + h, x0:x0 + c.shape[1]] = c
    im = bpy.data.images.new("footstep review sheet", sheet.shape[1], sheet.shape[0], alpha=True)
    im.pixels.foreach_set(sheet.ravel())
    im.filepath_raw = out
    im.file_format = "PNG"
    im.save()
    bpy.data.images.remove(im)


def _render_character(scene, ob, frame: int, path: str, size: float = 1.0) -> str:
    """A Workbench render of the character at ``frame``, from the side and a little above,
    the camera ``size`` (the body's scale) times as far off as for a human."""
    from mathutils import Vector

    scene.frame_set(frame)
    bpy.context.view_layer.update()
    heads = np.array([tuple(ob.matrix_world @ pb.head) for pb in ob.pose.bones])
    hips = np.r_[heads[:, :2].mean(axis=0), 0.5 * (heads[:, 2].min() + heads[:, 2].max())]  # (the body's middle)
    cam = scene.objects.get("CharacterCamera")
    if cam is None:
        cam = bpy.data.objects.new("CharacterCamera", bpy.data.cameras.new("CharacterCamera"))
        scene.collection.objects.link(cam)
    yaw = ob.matrix_world.to_euler("XYZ").z
    spot, hidden = _camera_spot(scene, hips, yaw, size)
    cam.location = tuple(spot)
    cam.rotation_euler = (Vector(hips.tolist()) - cam.location).to_track_quat("-Z", "Y").to_euler()
    scene.camera = cam
    scene.render.engine = "BLENDER_WORKBENCH"
    scene.display.shading.color_type = "MATERIAL"
    scene.render.resolution_x, scene.render.resolution_y = 640, 480
    scene.render.filepath = path
    try:
        bpy.ops.render.render(write_still=True)
    finally:
        for other in hidden:
            other.hide_render = False
    return path


#: m: the character camera stands this far from the hips, this high above them ...
CAMERA_DISTANCE, CAMERA_RISE = 4.0, 0.8
#: ... at the character's side if the view is clear, else the first of these turns (rad)
#: about it from there that is (a stairwell's walls, a corridor).
#: m above the hips of the points the camera must see (head, hips, feet).
VIEW_POINTS = (0.7, 0.0, -0.8)
CAMERA_TURNS = (0.0, math.pi, math.pi / 4, -math.pi / 4, 3 * math.pi / 4, -3 * math.pi / 4,
                math.pi / 2, -math.pi / 2)


def _camera_spot(scene, hips: np.ndarray, yaw: float, size: float = 1.0) -> tuple[np.ndarray, list]:
    """Where the character camera sees the hips unobstructed (the rig's +X side first,
    then round it: ``CAMERA_TURNS``), and the objects hidden from the render to see them
    at all when every spot is blocked (their ``hide_render`` set: the caller restores it)."""
    from mathutils import Vector

    depsgraph = bpy.context.evaluated_depsgraph_get()
    first, blockers = None, []
    for turn in CAMERA_TURNS:
        d = np.array([math.cos(yaw + turn), math.sin(yaw + turn), 0.0])
        spot = hips + size * (CAMERA_DISTANCE * d + [0.0, 0.0, CAMERA_RISE])
        first = spot if first is None else first
        hits = []
        for aim in VIEW_POINTS:  # (the head, the hips and the feet in view)
            way = hips + [0.0, 0.0, size * aim] - spot
            reach = float(np.linalg.norm(way)) - 0.6 * size  # (up to the character's reach, not into it)
            hit, _, _, _, other, _ = scene.ray_cast(depsgraph, Vector(spot.tolist()),
                                                    Vector((way / np.linalg.norm(way)).tolist()), distance=reach)
            if hit:
                hits.append(other.original if other is not None else None)
        if not hits:
            return spot, []
        blockers += hits
    hidden = [b for b in dict.fromkeys(blockers) if b is not None and not b.hide_render]
    for b in hidden:
        b.hide_render = True
    return first, hidden


def _material(name: str, rgba) -> bpy.types.Material:
    m = bpy.data.materials.new(name)
    m.diffuse_color = rgba
    return m


def _draw_footprints(scene, doc, foot: FootShape, tint=None, tag: str = "") -> None:
    """The baked footprints (report ``doc``) as the viewport overlay draws them (quads of
    the ``foot`` shape, left blue, right red, jump landings yellow, shaded by clip) and the
    body trajectory as a thin orange tube, in a collection of the demo's own. Each object's
    colour is its overlay colour (opaque); its material carries the foot's base colour.
    With ``tint`` (r, g, b) every footprint and the tube are that colour (the right foot's
    darker): one character's among others'."""
    coll = bpy.data.collections.new("Footprints (demo)" + tag)
    scene.collection.children.link(coll)
    fps = doc["footprints"]
    mats = {key: _material(f"footprint_{key}", (*rgb, 1.0))
            for key, rgb in (("L", geo.LEFT), ("R", geo.RIGHT), ("J", geo.JUMP))}
    mats["B"] = _material("footprint_B", geo.BODY)
    feet = ["LR".index(f["foot"]) for f in fps]
    tri, col = geo.footprint_triangles([f["position"] for f in fps], [f["heading"] for f in fps],
                                       doc["forward"], foot, feet, [f.get("clip", "") for f in fps],
                                       [bool(f.get("jump")) for f in fps])
    for i, f in enumerate(fps):
        me = bpy.data.meshes.new(f"footprint{i}")
        me.from_pydata(tri[6 * i:6 * i + 6].tolist(), [], [(0, 1, 2), (3, 4, 5)])
        key = "J" if f.get("jump") else f["foot"]
        me.materials.append(mats[key])
        fob = bpy.data.objects.new(f"footprint{i:03d}{tag}", me)
        fob.color = (*col[6 * i, :3], 1.0) if tint is None else \
            (*(np.asarray(tint) * (geo.RIGHT_SHADE if f["foot"] == "R" else 1.0)), 1.0)
        coll.objects.link(fob)
    seg = geo.polyline_segments(np.asarray(doc["synthesis"]["body"]["position"])[::2])
    body = np.concatenate([seg[::2], seg[-1:]])  # the lifted polyline's points again
    cu = bpy.data.curves.new("body_trajectory", "CURVE")
    cu.dimensions = "3D"
    cu.bevel_depth = 0.03
    sp = cu.splines.new("POLY")
    sp.points.add(len(body) - 1)
    sp.points.foreach_set("co", np.c_[body, np.ones(len(body))].astype(np.float32).ravel())
    cu.materials.append(mats["B"])
    bob = bpy.data.objects.new("body_trajectory" + tag, cu)
    bob.color = geo.BODY if tint is None else (*tint, 1.0)
    coll.objects.link(bob)


def _render_top(scene, path):
    """An orthographic top view of the whole scene: traversable surfaces light, obstacles
    dark, the drawn footprints and trajectory in their colours (object colours: the demo's
    own scene, so setting them changes nothing of the user's)."""
    from ..read.surfaces import tagged_objects

    walk, block = tagged_objects(scene)
    for ob in walk:
        ob.color = (0.78, 0.78, 0.74, 1.0)
    for ob in block:
        ob.color = (0.22, 0.25, 0.3, 1.0)
    scene.display.shading.color_type = "OBJECT"
    pts = np.array([ob.matrix_world @ v.co for ob in scene.objects if ob.type == "MESH"
                    for v in ob.data.vertices])
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    cam = bpy.data.objects.new("TopCamera", bpy.data.cameras.new("TopCamera"))
    scene.collection.objects.link(cam)
    cam.data.type = "ORTHO"
    cam.data.ortho_scale = float(max(hi[:2] - lo[:2])) * 1.08
    cam.location = (float(lo[0] + hi[0]) / 2, float(lo[1] + hi[1]) / 2, float(hi[2]) + 20)
    scene.camera = cam
    scene.render.engine = "BLENDER_WORKBENCH"
    scene.render.resolution_x = scene.render.resolution_y = 800
    scene.render.filepath = path
    scene.render.image_settings.file_format = "PNG"
    bpy.ops.render.render(write_still=True)
