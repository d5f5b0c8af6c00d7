"""FBX and glTF files imported with Blender's own importers: the file's header checked
(``_check_header``), its frame rate read (``_fbx_file_fps``, ``_gltf_file_fps``), the importer
run quietly with the scene put back (``_run_fbx``, ``_run_gltf``), and what it made checked and
turned into takes (``_scene_import``: one armature, its clips in take order and named after
their takes, every key a finite number, keyed at the scene's rate from frame 1, the object's
transform moved into the bones by ``root_motion``).
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import re
import struct

import bpy
import numpy as np

from .clip_checks import ClipImportError, _SceneClip, _Take, _check_legs
from .clip_keys import _fcurves, _retime
from .root_motion import _normalise, _object_curves, _onto
from .scene import scene_fps


#: the bpy.data collections an importer may add to (all of it is ours to remove)
_ID_COLLECTIONS = ("objects", "armatures", "meshes", "actions", "materials", "images", "textures",
                   "node_groups", "cameras", "lights", "curves", "shape_keys", "collections")


def _ids() -> set:
    """Every data-block of the collections importers add to."""
    return {i for attr in _ID_COLLECTIONS for i in getattr(bpy.data, attr)}


_FBX_BINARY = b"Kaydara FBX Binary  \x00"


def _check_header(path: str, kind: str, ext: str) -> None:
    """ClipImportError naming the file unless it is there and starts as a file of its
    kind: a binary FBX (the only kind Blender's importer reads), a GLB, a glTF's JSON."""
    if os.path.isdir(path):
        raise ClipImportError(f"{path}: is a folder, not an {kind} file")
    try:
        with open(path, "rb") as fh:
            head = fh.read(len(_FBX_BINARY))
    except OSError as ex:
        raise ClipImportError(f"{path}: cannot read: {ex.strerror or ex}") from None
    if kind == "glTF":
        text = head.lstrip(b"\xef\xbb\xbf \t\r\n")
        if (ext == ".glb" and head[:4] != b"glTF") or (ext == ".gltf" and not text.startswith(b"{")):
            what = "binary glTF (no GLB header)" if ext == ".glb" else "glTF file (its JSON does not start with '{')"
            raise ClipImportError(f"{path}: not a valid {what}")
        return
    if head == _FBX_BINARY:
        return
    if head.lstrip(b"\xef\xbb\xbf \t\r\n").startswith((b";", b"FBXHeaderExtension")):
        raise ClipImportError(f"{path}: an ASCII FBX file; Blender's FBX importer reads binary "
                              "FBX only (save it as binary FBX)")
    raise ClipImportError(f"{path}: not a valid FBX file (no binary FBX header)")


def _fbx_file_fps(path: str) -> float:
    """The frame rate an FBX file declares (as Blender's importer reads it)."""
    from io_scene_fbx import parse_fbx
    from io_scene_fbx.fbx_utils import FBX_FRAMERATES
    from io_scene_fbx.import_fbx import elem_find_first, elem_props_get_enum, elem_props_get_number

    try:
        root, _ = parse_fbx.parse(path)
        props = elem_find_first(elem_find_first(root, b"GlobalSettings"), b"Properties70")
        custom = elem_props_get_number(props, b"CustomFrameRate", 25.0)
        mode = elem_props_get_enum(props, b"TimeMode")
    except Exception as ex:  # a broken file: the parser raises what it meets
        raise ClipImportError(f"{path}: not a valid FBX file ({ex})") from None
    fps = {eid: val for val, eid in FBX_FRAMERATES[1:]}.get(mode, custom)
    return float(fps if fps > 0 else 25.0)


def _gltf_json(path: str) -> dict:
    """The JSON document of a .gltf or .glb file; ClipImportError naming the file when
    it cannot be read."""
    try:
        with open(path, "rb") as fh:
            if path.lower().endswith(".glb"):
                fh.seek(12)
                size, kind = struct.unpack("<I4s", fh.read(8))
                if kind != b"JSON":
                    raise ValueError("its first chunk is not JSON")
                data = fh.read(size)
            else:
                data = fh.read()
        doc = json.loads(data.decode("utf-8-sig"))
        if not isinstance(doc, dict):
            raise ValueError("not a JSON object")
        return doc
    except (OSError, ValueError, struct.error, RecursionError) as ex:
        raise ClipImportError(f"{path}: not a valid glTF file ({str(ex)[:120]})") from None


def _gltf_file_fps(path: str) -> float:
    """A glTF file's frame rate: glTF keys times in seconds, so the rate its most finely
    sampled animation channel is keyed at (its keys' count over their time span, from the
    accessors' ``min`` and ``max`` the format requires), to 0.001; 24 when nothing is
    animated."""
    doc = _gltf_json(path)
    accessors = doc.get("accessors") or []
    rates = []
    for anim in doc.get("animations") or []:
        for sampler in anim.get("samplers") or []:
            try:
                acc = accessors[sampler["input"]]
                span = float(acc["max"][0]) - float(acc["min"][0])
                if acc["count"] > 1 and span > 0:
                    rates.append((acc["count"] - 1) / span)
            except (KeyError, IndexError, TypeError, ValueError):
                continue
    if not rates:
        return 24.0
    rate = max(rates)
    return float(round(rate)) if abs(rate - round(rate)) < 1e-3 * rate else round(rate, 3)


@contextlib.contextmanager
def _quiet():
    """The importers print their progress, and a traceback when they fail."""
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        yield


def _importer_failed(src, ex) -> ClipImportError:
    msg = " ".join(str(ex).replace("Error: ", "").replace(f" file '{src.path}'", " the file").split())
    return ClipImportError(f"{src.path}: Blender's {src.kind} importer cannot read it: {msg[:300]}")


def _run_fbx(src: _SceneClip, made: list) -> float:
    """Blender's FBX importer on ``src`` (what it makes appended to ``made``); returns the
    frame rate it keyed at. The scene's rate is put back (the importer sets the file's)."""
    render = bpy.context.scene.render
    rate, base = render.fps, render.fps_base
    before = _ids()
    try:
        with _quiet():
            res = bpy.ops.import_scene.fbx(
                filepath=src.path, use_manual_orientation=False, global_scale=1.0,
                bake_space_transform=False, use_image_search=False, use_anim=True,
                anim_offset=1.0, use_subsurf=False, use_custom_props=False,
                ignore_leaf_bones=False, force_connect_children=False,
                automatic_bone_orientation=False, use_prepost_rot=True,
                primary_bone_axis="Y", secondary_bone_axis="X")
    except Exception as ex:  # RuntimeError for reported errors; the parser's own otherwise
        made.extend(_ids() - before)
        raise _importer_failed(src, ex) from None
    finally:
        # the importer sets the scene's rate to the file's and keys at its integer part
        keyed_fps, src.fps = float(render.fps), scene_fps()
        render.fps, render.fps_base = rate, base
    made.extend(_ids() - before)
    if res != {"FINISHED"}:
        raise ClipImportError(f"{src.path}: Blender's FBX importer failed")
    return keyed_fps


def _run_gltf(src: _SceneClip, made: list) -> float:
    """Blender's glTF importer on ``src`` (what it makes appended to ``made``; the list of
    animation tracks it keeps on the file's first scene put back); returns the frame rate
    it keyed at (the importer's: the scene's ``fps`` times ``fps_base``)."""
    src.fps = _gltf_file_fps(src.path)
    render = bpy.context.scene.render
    keyed_fps = float(render.fps * render.fps_base)
    saved = _gltf_scene_state()
    before = _ids()
    try:
        with _quiet():
            res = bpy.ops.import_scene.gltf(
                filepath=src.path, import_pack_images=True, merge_vertices=False, import_shading="NORMALS",
                bone_heuristic="BLENDER", guess_original_bind_pose=True, disable_bone_shape=True,
                import_select_created_objects=False, import_scene_extras=False,
                import_scene_as_collection=False)
    except Exception as ex:  # RuntimeError for reported errors
        made.extend(_ids() - before)
        raise _importer_failed(src, ex) from None
    finally:
        _gltf_scene_state(saved)
    made.extend(_ids() - before)
    if res != {"FINISHED"}:
        raise ClipImportError(f"{src.path}: Blender's glTF importer failed")
    return keyed_fps


def _gltf_scene_state(saved=None):
    """The glTF importer's list of animation tracks on the first scene (names, applied
    index); with ``saved``, put it back as it was."""
    scene = bpy.data.scenes[0] if bpy.data.scenes else None
    tracks = getattr(scene, "gltf2_animation_tracks", None)
    if tracks is None:
        return None
    if saved is None:
        return [t.name for t in tracks], getattr(scene, "gltf2_animation_applied", None)
    names, applied = saved
    for i in reversed(range(len(tracks))):
        if tracks[i].name not in names:
            tracks.remove(i)
    if applied is not None:
        scene.gltf2_animation_applied = applied
    return None


def _scene_import(src: _SceneClip, made: list):
    """(armature object, [_Take], [skinned meshes]) from Blender's FBX or glTF importer,
    keyed at the scene's frame rate from frame 1 and brought to an identity object
    transform (metres, Z up; the object's own motion moved onto the root bones); every
    data-block the importer made is appended to ``made``. ClipImportError naming the file when the
    importer fails, or the file holds no armature, several, no animation, or a skeleton
    without legs; a take whose keys are not finite numbers, or that scales the armature
    object, is refused (its ``error``)."""
    fps = scene_fps()
    before = set(_ids())
    keyed_fps = (_run_fbx if src.kind == "FBX" else _run_gltf)(src, made)
    new = _ids() - before
    ob = _one_armature(src, [o for o in new if isinstance(o, bpy.types.Object)])
    takes = _file_takes(ob, new, src)
    meshes = [o for o in new if isinstance(o, bpy.types.Object) and o.type == "MESH" and _skinned_to(o, ob)]
    check_fbx_data(ob, [], src.path)
    for t in takes:
        try:
            check_fbx_data(ob, [t.action], t.where(src.path))
        except ClipImportError as ex:
            t.error = str(ex)
            continue
        _retime(t.action, keyed_fps, fps)
    _normalise(ob, [t for t in takes if not t.error], meshes, src.path)
    bpy.context.view_layer.update()
    onto = _onto(ob, _check_legs(ob, src.path))
    for t in takes:
        t.onto = onto
    return ob, takes, meshes


def _one_armature(src, objects):
    """The one armature object of those the importer made; ClipImportError naming the
    file when there is none or several."""
    arms = sorted((o for o in objects if o.type == "ARMATURE"), key=lambda o: o.name)
    if not arms:
        what = ", ".join(sorted(f"{o.type.lower()} {o.name!r}" for o in objects)) or "nothing"
        raise ClipImportError(f"{src.path}: no armature in the file (it holds {what}); a clip "
                              "file must hold one character's skeleton")
    if len(arms) > 1:
        raise ClipImportError(f"{src.path}: {len(arms)} armatures in the file "
                              f"({', '.join(repr(o.name) for o in arms)}); a clip file must hold "
                              "one character's skeleton")
    return arms[0]


def _file_takes(ob, new, src) -> list[_Take]:
    """The clips the importer made for armature ``ob``, in take order: FBX, its actions
    named "<object>|<take>"; glTF, the actions of the NLA tracks it made on ``ob`` (one
    per animation, the track named after it), other objects' slots taken out. A file of
    one clip gives it the file's name; of several, each its take's name (the importer's
    "<object>|" prefixes stripped). ClipImportError when none animates the armature."""
    if src.kind == "FBX":
        prefix = ob.name + "|"
        found = sorted(((a, _take_name(_unnumbered(a.name, new)[len(prefix):], ob.name)) for a in new
                        if isinstance(a, bpy.types.Action) and a.name.startswith(prefix)), key=lambda p: p[1])
    else:
        ad = ob.animation_data
        strips = [(s, tr.name) for tr in (ad.nla_tracks if ad else []) for s in tr.strips if s.action]
        found = sorted(((s.action, name) for s, name in strips), key=lambda p: p[1])
        for s, _ in strips:
            _only_slot(s.action, s.action_slot)
    found = [(a, n) for a, n in found if _keys_bones(a) or _object_curves(a)]
    if not found:
        raise ClipImportError(f"{src.path}: the armature {ob.name!r} has no animation; a clip file "
                              "must animate its skeleton")
    if len(found) == 1:
        return [_Take(found[0][0], os.path.splitext(os.path.basename(src.path))[0])]
    return [_Take(a, n, take=n) for a, n in found]


def _unnumbered(name: str, new) -> str:
    """An action's name without the ".001" Blender gave it because an action of the file
    (not one the importer made) had its name."""
    base = re.sub(r"\.\d{3}$", "", name)
    other = bpy.data.actions.get(base)
    return base if base != name and other is not None and other not in new else name


def _take_name(name: str, object_name: str) -> str:
    """A take's name without the object-name prefix Blender's FBX exporter gives it
    ("Armature|Walk"; the object named as in the file: without Blender's ".001")."""
    base = re.sub(r"\.\d{3}$", "", object_name)
    head, sep, rest = name.partition("|")
    return rest if sep and rest and head in (object_name, base) else name


def _only_slot(act, slot) -> None:
    """Take out of ``act`` every slot but ``slot`` (the glTF importer's one action per
    animation holds a slot for each object it moves)."""
    for other in [s for s in act.slots if s != slot]:
        act.slots.remove(other)


def check_fbx_data(ob, actions, path: str) -> None:
    """ClipImportError naming the file and the first fault in what Blender's FBX or glTF
    importer made of it: an armature transform or a bone that is not finite, a bone of no
    length, or a key of ``actions`` (its frame or value) that is not a finite number,
    named by bone, channel and frame."""
    if not np.isfinite(np.array(ob.matrix_world)).all():
        raise ClipImportError(f"{path}: the armature {ob.name!r} has a transform that is not finite")
    bones = ob.data.bones
    ends = np.empty((2, len(bones) * 3), np.float32)
    bones.foreach_get("head_local", ends[0])
    bones.foreach_get("tail_local", ends[1])
    ends = ends.astype(np.float64).reshape(2, -1, 3)
    length = np.linalg.norm(ends[1] - ends[0], axis=1)
    for i in np.flatnonzero(~np.isfinite(ends).all(axis=(0, 2)) | ~(length > 1e-9)):
        what = "is not finite" if not np.isfinite(ends[:, i]).all() else "has no length"
        raise ClipImportError(f"{path}: bone {bones[i].name!r} {what}; fix the skeleton and export again")
    for act in actions:
        for _, curves in _fcurves(act):
            for fc in curves:
                co = np.empty(2 * len(fc.keyframe_points), np.float32)
                fc.keyframe_points.foreach_get("co", co)
                bad = np.flatnonzero(~np.isfinite(co.reshape(-1, 2)).all(axis=1))
                if len(bad):
                    x, y = co[2 * bad[0]:2 * bad[0] + 2]
                    raise ClipImportError(f"{path}: {_channel(fc)}, frame {x:g}: the value {y} is not a "
                                          "finite number")


def _channel(fc) -> str:
    """An F-curve's channel as a person reads it: 'bone "Hips" location Y'."""
    path, prop = fc.data_path.rsplit(".", 1) if "." in fc.data_path else ("", fc.data_path)
    axes = "WXYZ" if prop in ("rotation_quaternion", "rotation_axis_angle") else "XYZ"
    axis = axes[fc.array_index] if fc.array_index < len(axes) else str(fc.array_index)
    if path.startswith('pose.bones["'):
        bone = path[len('pose.bones["'):-2].replace('\\"', '"')
        return f"bone {bone!r}, channel {prop} {axis}"
    return f"the armature object's channel {fc.data_path} {axis}"


def _keys_bones(act) -> bool:
    """Whether ``act`` has an F-curve on a pose bone."""
    return any(fc.data_path.startswith("pose.bones[") for _, curves in _fcurves(act) for fc in curves)


def _skinned_to(mesh_ob, ob) -> bool:
    """Whether mesh object ``mesh_ob`` is deformed by armature object ``ob``."""
    return any(m.type == "ARMATURE" and m.object == ob for m in mesh_ob.modifiers) or (
        mesh_ob.parent == ob and mesh_ob.parent_type == "ARMATURE")
