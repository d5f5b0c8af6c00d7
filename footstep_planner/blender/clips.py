"""Importing clips into a character: one armature, one Action per file, BVH or FBX.

The first file of a new library gives the armature (for FBX, Blender's own importer; for
BVH, the armature and keys Blender's BVH importer would make, made here from the motion
``core.bvh`` reads, whole F-curves at a time; then brought to metres, Z up and an identity
object transform, keys at the scene's frame rate whatever the file's; a clip longer than
``SAMPLED_FRAMES`` kept as samples). Every further file, or every file imported into an existing
armature, is retargeted onto that armature's bones and added as a new Action: nothing of
the user's is replaced or renamed. A BVH file is retargeted in the BVH sense (each
joint's rotation relative to the rest pose is kept); an FBX file bone by bone (each bone's
rotation relative to its parent is kept: an FBX's rest pose is whatever pose it was
written in, a Mixamo download without skin its first frame, while its joint axes are the
rig's own).

FBX (Mixamo and the like): whatever the file's axes and unit, Blender's importer gives an
armature object turned and scaled (Mixamo: 90 degrees about X, scale 0.01, the keys in
centimetres). That transform is moved into the bones (``Armature.transform``) and the
location keys (times its scale), so the armature object ends with identity rotation and
unit scale and every bone where it was in the world. A skinned mesh of the first file is
kept, parented to the new armature; everything else the importer made is removed.
"""

from __future__ import annotations

import contextlib
import io
import os
from dataclasses import dataclass

import bpy
import numpy as np
from mathutils import Matrix
from scipy.spatial.transform import Rotation

from ..core.bvh import BvhError, read_bvh, read_skeleton
from ..core.roles import map_roles
from .scene import (ARMATURE_PROP, SOURCE_FILE_PROP, SOURCE_FPS_PROP, _matrices, fill_keys, sample_basis,
                    scene_fps)
from ..core.errors import FootstepError

#: the clip files the import reads
CLIP_EXTENSIONS = (".bvh", ".fbx")

#: the bpy.data collections an importer may add to (all of it is ours to remove)
_ID_COLLECTIONS = ("objects", "armatures", "meshes", "actions", "materials", "images", "textures",
                   "node_groups", "cameras", "lights", "curves", "shape_keys", "collections")


class ClipImportError(FootstepError):
    """An import that cannot be done; names the file or bone at fault."""


@dataclass
class _FbxClip:
    """An FBX file to import; ``fps`` (its frame rate) is known once Blender read it."""

    path: str
    fps: float = 0.0


def import_clips(paths, target=None, name: str | None = None, scale: float | None = None):
    """Import BVH and FBX files (any mix, of one skeleton) as Actions of one armature.

    ``target``: an existing armature object to add the clips to; when None the first
    file's skeleton becomes a new armature (named ``name`` or after the file).
    ``scale``: metres per BVH unit; None guesses from the skeleton's height (FBX files
    carry their unit). Returns ``(armature_object, [actions])``. On error nothing is left
    in the scene.
    """
    paths = [os.path.abspath(p) for p in paths]
    if not paths:
        raise ClipImportError("no clip files given")
    sources = [_source(p) for p in paths]
    _check_one_skeleton([s for s in sources if not isinstance(s, _FbxClip)], target)
    with _selection_kept():
        return _import_all(sources, target, name, scale)


def clip_fps(path: str) -> float:
    """The frame rate of a BVH or FBX clip file; ClipImportError naming the file when it
    is neither or cannot be read."""
    src = _source(os.path.abspath(path))
    if not isinstance(src, _FbxClip):
        return float(src.fps)
    return _fbx_file_fps(src.path)


def _source(path: str):
    """The BvhSkeleton of a BVH file (read, its legs mapped) or an _FbxClip (a binary
    FBX by its header); ClipImportError naming the file otherwise."""
    ext = os.path.splitext(path)[1].lower()
    if ext == ".fbx":
        _check_fbx_header(path)
        return _FbxClip(path)
    if ext != ".bvh":
        raise ClipImportError(f"{path}: not a clip file: import reads {' and '.join(CLIP_EXTENSIONS)} files")
    return _legged_skeleton(path)


def _legged_skeleton(path: str):
    """The file's BvhSkeleton; ClipImportError naming the file when it cannot be read or
    its legs cannot be mapped to roles."""
    try:
        sk = read_skeleton(path)
    except BvhError as ex:
        raise ClipImportError(str(ex)) from None
    roles = map_roles(sk.names, sk.parents, sk.heads_z_up(), sk.tails_z_up())
    if not roles.ok:
        raise ClipImportError(f"{path}: skeleton has no usable legs: {roles.describe()}")
    return sk


def _check_one_skeleton(skeletons, target) -> None:
    """ClipImportError unless the clips share one skeleton: every joint is a bone of
    armature ``target``, or (no target) every file has the first file's joints and
    parents."""
    if target is not None:
        if target.type != "ARMATURE":
            raise ClipImportError(f"{target.name!r} is not an armature")
        have = {b.name for b in target.data.bones}
        for sk in skeletons:
            missing = [n for n in sk.names if n not in have]
            if missing:
                raise ClipImportError(
                    f"{sk.path}: joints {', '.join(missing[:6])} are not bones of armature "
                    f"{target.name!r}; clips of one library must share one skeleton")
        return
    if not skeletons:
        return
    first = skeletons[0]
    for sk in skeletons[1:]:
        if sk.names != first.names or sk.parents != first.parents:
            raise ClipImportError(f"{sk.path}: its skeleton differs from {first.path}'s; "
                                  "clips of one library must share one skeleton")


def _check_fits(ob, path: str, target, users: bool, first_path: str) -> None:
    """The check above for a file already imported as armature ``ob`` (an FBX, or a file
    after one): its bones are bones of the user's ``target`` (``users``), or the same
    bones with the same parents as the first file's armature ``target``."""
    def tree(o):
        return {b.name: (b.parent.name if b.parent else None) for b in o.data.bones}

    if users:
        have = {b.name for b in target.data.bones}
        missing = [b.name for b in ob.data.bones if b.name not in have]
        if missing:
            raise ClipImportError(
                f"{path}: joints {', '.join(missing[:6])} are not bones of armature "
                f"{target.name!r}; clips of one library must share one skeleton")
    elif tree(ob) != tree(target):
        raise ClipImportError(f"{path}: its skeleton differs from {first_path}'s; "
                              "clips of one library must share one skeleton")


@contextlib.contextmanager
def _selection_kept():
    """Put the user's selection, active object and its mode back afterwards, whatever
    happens (the importers select what they make, in object mode)."""
    view_layer = bpy.context.view_layer
    selected = list(bpy.context.selected_objects)
    active = view_layer.objects.active
    mode = active.mode if active is not None else "OBJECT"
    try:
        yield
    finally:
        names = {o.name for o in selected}
        for o in bpy.data.objects:
            if o.name in view_layer.objects:
                o.select_set(o.name in names)
        if active is not None and active.name in view_layer.objects:
            view_layer.objects.active = active
            if active.mode != mode:
                with contextlib.suppress(RuntimeError):
                    bpy.ops.object.mode_set(mode=mode)


def _import_all(sources, target, name, scale):
    """(armature, [one action per source]): each file imported by Blender, the first
    becoming the armature when ``target`` is None, the others retargeted onto it. The
    importers' scratch data is removed; on error, everything made."""
    made = []  # every data-block this import made
    users = target is not None
    try:
        actions, keep = [], []
        for src in sources:
            if target is None:
                target, act, keep = _import_first(src, name, scale, made)
            else:
                act = _import_more(src, target, users, sources[0].path, scale, made)
            actions.append(act)
        _remove_scratch(made, keep=[target, *keep], actions=actions)
        return target, actions
    except BaseException:
        _remove_ids(made)
        raise


def _import_first(src, name, scale, made: list):
    """(armature, action, [skinned meshes kept]) of the file that makes a new
    armature, named ``name`` or after the file."""
    ob, act, meshes = _import_file(src, scale, made)
    ob.name = name or os.path.splitext(os.path.basename(src.path))[0]
    if isinstance(src, _FbxClip):
        ob.data.name = ob.name  # (the importer's "Armature")
    _tag_source(act, src, ob)
    return ob, act, meshes


def _import_more(src, target, users: bool, first_path: str, scale, made: list):
    """The action of a file added to armature ``target``: imported, checked to be
    ``target``'s skeleton, retargeted onto it."""
    ob, act, _ = _import_file(src, scale, made)
    _check_fits(ob, src.path, target, users, first_path)
    new = _retarget(ob, act, target, src, local=isinstance(src, _FbxClip))
    made.append(new)
    return new


def _import_file(src, scale, made: list):
    """(armature object, action, [its skinned meshes]) of one file, in metres, Z up,
    keyed from frame 1 at the scene's rate; what is made is appended to ``made``."""
    if isinstance(src, _FbxClip):
        return _fbx_import(src, made)
    return (*_bvh_import(src, scale, made), [])


def _ids() -> set:
    """Every data-block of the collections importers add to."""
    return {i for attr in _ID_COLLECTIONS for i in getattr(bpy.data, attr)}


def _alive(ids) -> list:
    """Those of ``ids`` not removed yet."""
    out = []
    for i in ids:
        try:
            i.name
        except ReferenceError:
            continue
        out.append(i)
    return out


def _remove_ids(ids) -> None:
    ids = _alive(ids)
    if ids:
        bpy.data.batch_remove(ids)


def _remove_scratch(made, keep, actions) -> None:
    """Remove what the import made but keeps: objects not in ``keep``, actions not in
    ``actions``, then whatever that leaves unused."""
    keep, actions = set(keep), set(actions)
    _remove_ids([i for i in _alive(made) if (isinstance(i, bpy.types.Object) and i not in keep)
                 or (isinstance(i, bpy.types.Action) and i not in actions)])
    while True:
        unused = [i for i in _alive(made) if i.users == 0]
        if not unused:
            return
        _remove_ids(unused)


def _tag_source(act, src, target):
    """Mark a clip as imported for ``target``; a fake user keeps it in the file while no
    object plays it."""
    act[SOURCE_FPS_PROP] = src.fps
    act[SOURCE_FILE_PROP] = os.path.basename(src.path)
    act[ARMATURE_PROP] = target.data.name
    act.use_fake_user = True


# -- BVH ------------------------------------------------------------------------------

#: The file's axes (Y up, -Z forward) to Blender's (Z up, -Y forward): (x, y, z) -> (x, -z, y),
#: as Blender's BVH importer turns them (axis_forward "-Z", axis_up "Y").
_BVH_AXES = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])


def _bvh_import(sk, scale, made: list):
    """(armature object, action) of the BVH file of skeleton ``sk``, as Blender's BVH
    importer makes them (the same bones, rolls and connections, Y up turned to Z up,
    quaternion keys, LINEAR, from frame 1 at the scene's rate; ``scale`` metres per file
    unit, default guessed), the action named after the file; made here from the motion
    as ``core.bvh`` reads it, one whole F-curve at a time (``_curve``), so a long clip
    costs seconds and its 32-bit keys, not Python objects per frame and value."""
    sk, motion = _read_bvh(sk.path)
    scale = scale or sk.unit_scale()
    name = os.path.splitext(os.path.basename(sk.path))[0]
    arm = bpy.data.armatures.new(name)
    made.append(arm)
    ob = bpy.data.objects.new(name, arm)
    made.append(ob)
    bpy.context.collection.objects.link(ob)
    bones = _bvh_bones(ob, sk, scale)
    # Blender 5.0: a pose for the new armature (evaluated before its action is assigned:
    # the evaluated copy of a long action would double its memory)
    bpy.context.view_layer.update()
    act = bpy.data.actions.new(name)
    made.append(act)
    _bvh_keys(ob, act, sk, motion, scale, bones)
    return ob, act


def _read_bvh(path: str):
    try:
        return read_bvh(path)
    except BvhError as ex:
        raise ClipImportError(str(ex)) from None


def _bvh_rest(sk, scale: float):
    """(heads, tails (J, 3) and connected (J,) bool) of the joints' bones in the file's
    axes, in metres, laid out as Blender's BVH importer lays them: the tail at the End
    Site, the one child's head or the children's mean head; a bone shorter than 1 mm
    given the length and direction Blender's importer gives it (its parent's, or up)."""
    local, heads = sk.offsets * scale, sk.heads() * scale
    parents = np.array(sk.parents)
    rel = sk.end_sites * scale  # tail - head
    for j in range(len(parents)):
        kids = np.flatnonzero(parents == j)
        if len(kids) and not rel[j].any():
            rel[j] = local[kids].mean(axis=0)
    rel[np.linalg.norm(rel, axis=1) <= 0.001 * scale, 1] += scale / 10  # (the importer's first fix)
    size = np.linalg.norm(rel, axis=1)
    average = float(size[size > 0].mean()) if (size > 0).any() else 0.1
    h32, t32 = heads.astype(np.float32), (heads + rel).astype(np.float32)
    tails = heads + rel
    zero = np.linalg.norm(t32 - h32, axis=1) < 0.001 * (1 + 1e-5)  # (its second: 1 mm is too short)
    for j in np.flatnonzero(zero):
        p = parents[j]
        if p >= 0 and np.linalg.norm(rel[p]) > 0:
            tails[j] += rel[p]
        else:
            tails[j, 1] += average
    has_loc = np.array([any(c.endswith("POSITION") for c in chans) for chans in sk.channels])
    connected = np.array([p >= 0 and not has_loc[j] and not zero[p]
                          and np.allclose(local[p] + rel[p], local[j], rtol=0, atol=1e-7 * scale)
                          for j, p in enumerate(parents)], dtype=bool)
    return heads, tails, connected


def _bvh_bones(ob, sk, scale: float) -> list[str]:
    """Make armature ``ob``'s bones, one per joint (``_bvh_rest``), then turn the
    armature from the file's axes to Blender's; returns the bones' names (Blender may
    shorten a long joint name or number a repeated one)."""
    heads, tails, connected = _bvh_rest(sk, scale)
    view_layer = bpy.context.view_layer
    view_layer.objects.active = ob
    ob.select_set(True)
    try:
        bpy.ops.object.mode_set(mode="EDIT")
        made = [ob.data.edit_bones.new(n) for n in sk.names]
        for eb, h, t in zip(made, heads, tails):
            eb.head, eb.tail = h, t
        for j, p in enumerate(sk.parents):
            if p >= 0:
                made[j].parent = made[p]
                made[j].use_connect = bool(connected[j])
        names = [eb.name for eb in made]
        bpy.ops.object.mode_set(mode="OBJECT")
    except RuntimeError as ex:
        raise ClipImportError(f"{sk.path}: cannot make the armature: {ex}") from None
    axes = np.eye(4)
    axes[:3, :3] = _BVH_AXES
    ob.data.transform(Matrix(axes.tolist()))
    return names


def _bvh_keys(ob, act, sk, motion: np.ndarray, scale: float, bones: list[str]) -> None:
    """Key ``motion`` (F, channels) of file ``sk`` on armature ``ob``'s ``bones`` into
    ``act`` (a slot "Slot", as Blender's importer names it; assigned to ``ob``): each
    joint's position channels as its bone's location, its rotation channels as its
    bone's quaternion, both relative to the bone's rest, Blender's way."""
    rest = _matrices(ob.data.bones, "matrix_local")[[ob.data.bones.find(b) for b in bones], :3, :3]
    frames = 1.0 + np.arange(len(motion)) * (scene_fps() / sk.fps)  # (a rate of 120.0005 is 120)
    slot = act.slots.new(id_type="OBJECT", name="Slot")
    cbag = act.layers.new("Layer").strips.new(type="KEYFRAME").channelbag(slot, ensure=True)
    ad = ob.animation_data_create()
    ad.action, ad.action_slot = act, slot
    first = np.cumsum([0] + [len(c) for c in sk.channels])
    for j, chans in enumerate(sk.channels):
        cols = motion[:, first[j]:first[j + 1]]
        to_bone = rest[j].T @ _BVH_AXES  # file axes -> the bone's rest axes
        base = f'pose.bones["{bpy.utils.escape_identifier(bones[j])}"]'
        pos = [k for k, c in enumerate(chans) if c.endswith("POSITION")]
        if pos:
            p = np.zeros((len(motion), 3))
            for k in pos:
                p[:, "XYZ".index(chans[k][0])] = cols[:, k] * scale
            loc = (p - sk.offsets[j] * scale) @ to_bone.T
            for i in range(3):
                _curve(cbag, f"{base}.location", i, sk.names[j], frames, loc[:, i])
        rot = [k for k, c in enumerate(chans) if c.endswith("ROTATION")]
        if rot:
            q = _euler_quats([chans[k][0] for k in rot], cols[:, rot])
            m = Rotation.from_matrix(to_bone).as_quat()[[3, 0, 1, 2]]
            q = _qmul(_qmul(m[None], q), m[None] * [1, -1, -1, -1])
            q *= np.where(q[:, :1] < 0, -1.0, 1.0)  # w >= 0, as Blender's importer gives them
            for i in range(4):  # w x y z
                _curve(cbag, f"{base}.rotation_quaternion", i, sk.names[j], frames, q[:, i])


def _euler_quats(axes: list[str], degrees: np.ndarray) -> np.ndarray:
    """Quaternions (F, 4; w x y z) of BVH rotation channels: rotations about ``axes``
    ("X", "Y", "Z") by ``degrees`` (F, len(axes)), the first outermost (R = R0 R1 R2)."""
    half = np.radians(np.asarray(degrees, dtype=np.float64)) / 2
    q = np.zeros((len(half), 4))
    q[:, 0] = 1.0
    for k, axis in enumerate(axes):
        step = np.zeros_like(q)
        step[:, 0] = np.cos(half[:, k])
        step[:, 1 + "XYZ".index(axis)] = np.sin(half[:, k])
        q = _qmul(q, step)
    return q


def _qmul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton products of quaternions (..., 4; w x y z)."""
    aw, ax, ay, az = np.moveaxis(a, -1, 0)
    bw, bx, by, bz = np.moveaxis(b, -1, 0)
    return np.stack([aw * bw - ax * bx - ay * by - az * bz, aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx, aw * bz + ax * by - ay * bx + az * bw], axis=-1)


# -- FBX ------------------------------------------------------------------------------

_FBX_BINARY = b"Kaydara FBX Binary  \x00"


def _check_fbx_header(path: str) -> None:
    """ClipImportError naming the file unless it is there and starts as a binary FBX
    (the only kind Blender's importer reads)."""
    if os.path.isdir(path):
        raise ClipImportError(f"{path}: is a folder, not an FBX file")
    try:
        with open(path, "rb") as fh:
            head = fh.read(len(_FBX_BINARY))
    except OSError as ex:
        raise ClipImportError(f"{path}: cannot read: {ex.strerror or ex}") from None
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


def _fbx_import(src: _FbxClip, made: list):
    """(armature object, action, [skinned meshes]) from Blender's FBX importer, brought
    to an identity object transform (metres, Z up) and the scene's frame rate, the action
    named after the file; every data-block the importer made is appended to ``made``.
    ClipImportError naming the file when the importer fails, or the file holds no
    armature, several, no animation, or a skeleton without legs."""
    render = bpy.context.scene.render
    rate, base, fps = render.fps, render.fps_base, scene_fps()
    before = _ids()
    try:  # (quiet: the importer prints its progress, and a traceback when it fails)
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
            res = bpy.ops.import_scene.fbx(
                filepath=src.path, use_manual_orientation=False, global_scale=1.0,
                bake_space_transform=False, use_image_search=False, use_anim=True,
                anim_offset=1.0, use_subsurf=False, use_custom_props=False,
                ignore_leaf_bones=False, force_connect_children=False,
                automatic_bone_orientation=False, use_prepost_rot=True,
                primary_bone_axis="Y", secondary_bone_axis="X")
    except Exception as ex:  # RuntimeError for reported errors; the parser's own otherwise
        made.extend(_ids() - before)
        msg = " ".join(str(ex).replace("Error: ", "").replace(f" file '{src.path}'", " the file").split())
        raise ClipImportError(f"{src.path}: Blender's FBX importer cannot read it: {msg}") from None
    finally:
        # the importer sets the scene's rate to the file's and keys at its integer part
        keyed_fps, src.fps = float(render.fps), scene_fps()
        render.fps, render.fps_base = rate, base
    new = _ids() - before
    made.extend(new)
    if res != {"FINISHED"}:
        raise ClipImportError(f"{src.path}: Blender's FBX importer failed")
    objects = [o for o in new if isinstance(o, bpy.types.Object)]
    arms = sorted((o for o in objects if o.type == "ARMATURE"), key=lambda o: o.name)
    if not arms:
        what = ", ".join(sorted(f"{o.type.lower()} {o.name!r}" for o in objects)) or "nothing"
        raise ClipImportError(f"{src.path}: no armature in the file (it holds {what}); a clip "
                              "file must hold one character's skeleton")
    if len(arms) > 1:
        raise ClipImportError(f"{src.path}: {len(arms)} armatures in the file "
                              f"({', '.join(repr(o.name) for o in arms)}); a clip file must hold "
                              "one character's skeleton")
    ob = arms[0]
    acts = [a for a in new if isinstance(a, bpy.types.Action) and _keys_bones(a)]
    meshes = [o for o in objects if o.type == "MESH" and _skinned_to(o, ob)]
    check_fbx_data(ob, acts, src.path)
    _normalise(ob, acts, meshes, src.path)
    bpy.context.view_layer.update()
    _check_legs(ob, src.path)
    act = _fbx_action(ob, acts, src.path)
    _retime(act, keyed_fps, fps)
    act.name = os.path.splitext(os.path.basename(src.path))[0]
    return ob, act, meshes


def check_fbx_data(ob, actions, path: str) -> None:
    """ClipImportError naming the file and the first fault in what Blender's FBX importer
    made of it: an armature transform or a bone that is not finite, a bone of no length,
    or a key of ``actions`` (its frame or value) that is not a finite number, named by
    bone, channel and frame."""
    if not np.isfinite(np.array(ob.matrix_world)).all():
        raise ClipImportError(f"{path}: the armature {ob.name!r} has a transform that is not finite")
    bones = ob.data.bones
    ends = np.empty((2, len(bones) * 3))
    bones.foreach_get("head_local", ends[0])
    bones.foreach_get("tail_local", ends[1])
    ends = ends.reshape(2, -1, 3)
    length = np.linalg.norm(ends[1] - ends[0], axis=1)
    for i in np.flatnonzero(~np.isfinite(ends).all(axis=(0, 2)) | ~(length > 1e-9)):
        what = "is not finite" if not np.isfinite(ends[:, i]).all() else "has no length"
        raise ClipImportError(f"{path}: bone {bones[i].name!r} {what}; fix the skeleton and export again")
    for act in actions:
        for _, curves in _fcurves(act):
            for fc in curves:
                co = np.empty(2 * len(fc.keyframe_points))
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


def _fbx_action(ob, actions, path):
    """The one action (of ``actions``, those keying bones) the importer made for
    armature ``ob``."""
    if not actions:
        raise ClipImportError(f"{path}: the armature {ob.name!r} has no animation; a clip file "
                              "must animate its skeleton")
    if len(actions) > 1:
        raise ClipImportError(f"{path}: {len(actions)} animations (takes) in the file "
                              f"({', '.join(sorted(a.name for a in actions))}); export one clip per file")
    act = actions[0]
    ad = ob.animation_data
    if ad is None or ad.action != act:
        raise ClipImportError(f"{path}: Blender's FBX importer did not give its animation to "
                              f"the armature {ob.name!r}")
    return act


def _skinned_to(mesh_ob, ob) -> bool:
    """Whether mesh object ``mesh_ob`` is deformed by armature object ``ob``."""
    return any(m.type == "ARMATURE" and m.object == ob for m in mesh_ob.modifiers) or (
        mesh_ob.parent == ob and mesh_ob.parent_type == "ARMATURE")


def _normalise(ob, actions, meshes, path) -> None:
    """Move armature object ``ob``'s world transform (rotation, uniform scale, location,
    any parent's) into its bones and the location keys of ``actions``, leaving the object at the
    identity and every bone where it was in the world; ``meshes`` (skinned to it) keep
    their world shape, their transform moved into their vertices, parented to ``ob``."""
    bpy.context.view_layer.update()  # (the importer's matrices, parents included)
    world = ob.matrix_world.copy()
    lin = np.array(world)[:3, :3]
    scales = np.linalg.norm(lin, axis=0)
    s = float(np.cbrt(abs(np.linalg.det(lin))))
    if np.linalg.det(lin) <= 0 or np.abs(scales - s).max() > 1e-4 * s:
        raise ClipImportError(f"{path}: the armature {ob.name!r} comes in mirrored or unevenly "
                              f"scaled (scale {', '.join(f'{x:.4g}' for x in scales)}); only a "
                              "uniform scale can be turned into metres")
    worlds = [mo.matrix_world.copy() for mo in meshes]
    for act in actions:
        _check_object_keys(act, ob, path)
    ob.parent = None
    ob.data.transform(world)
    ob.matrix_world = Matrix.Identity(4)
    for act in actions:
        _scale_locations(act, s)
    for mo, mw in zip(meshes, worlds):
        mo.data.transform(mw, shape_keys=True)
        mo.parent = ob
        mo.matrix_parent_inverse = Matrix.Identity(4)
        mo.matrix_basis = Matrix.Identity(4)


def _fcurves(act):
    for layer in act.layers:
        for strip in layer.strips:
            for cb in strip.channelbags:
                yield cb, cb.fcurves


def _check_object_keys(act, ob, path) -> None:
    """Drop ``act``'s keys on the armature object's own transform when they only hold
    it still at its transform; ClipImportError when the object itself moves (that motion
    belongs on the hips)."""
    still = np.concatenate([np.array(ob.location), np.array(ob.rotation_euler),
                            np.array(ob.rotation_quaternion), np.array(ob.scale)])
    offset = {"location": 0, "rotation_euler": 3, "rotation_quaternion": 6, "scale": 10}
    for _, curves in _fcurves(act):
        for fc in list(curves):
            if fc.data_path not in offset:
                continue
            co = np.empty(2 * len(fc.keyframe_points))
            fc.keyframe_points.foreach_get("co", co)
            want = still[offset[fc.data_path] + fc.array_index]
            if len(co) and np.abs(co[1::2] - want).max() > 1e-5 * max(1.0, abs(want)):
                raise ClipImportError(f"{path}: the armature object {ob.name!r} itself is "
                                      f"animated ({fc.data_path}); only the bones' motion can be "
                                      "imported (put the root motion on the hips)")
            curves.remove(fc)


def _scale_locations(act, s: float) -> None:
    """Multiply every bone location key of ``act`` (values and handles) by ``s``."""
    for _, curves in _fcurves(act):
        for fc in curves:
            if fc.data_path.startswith("pose.bones[") and fc.data_path.endswith(".location"):
                _map_keys(fc, lambda x, y: (x, y * s))


def _retime(act, keyed_fps: float, fps: float) -> None:
    """Move ``act``'s keys (keyed at ``keyed_fps`` frames per second) to the scene's
    ``fps``, the first key at frame 1."""
    first = min((fc.keyframe_points[0].co[0] for _, curves in _fcurves(act) for fc in curves
                 if len(fc.keyframe_points)), default=1.0)
    k = fps / keyed_fps
    for _, curves in _fcurves(act):
        for fc in curves:
            _map_keys(fc, lambda x, y: (1.0 + (x - first) * k, y))
    if act.use_frame_range:
        act.frame_start, act.frame_end = (1.0 + (f - first) * k for f in (act.frame_start, act.frame_end))


def _map_keys(fc, fn) -> None:
    """Replace each key (and handle) point (x, y) of F-curve ``fc`` by ``fn(x, y)``."""
    n = len(fc.keyframe_points)
    if not n:
        return
    for attr in ("co", "handle_left", "handle_right"):
        xy = np.empty(2 * n)
        fc.keyframe_points.foreach_get(attr, xy)
        x, y = fn(xy[0::2], xy[1::2])
        xy[0::2], xy[1::2] = x, y
        fc.keyframe_points.foreach_set(attr, xy)
    fc.update()


def _check_legs(ob, path) -> None:
    """ClipImportError naming the file when armature ``ob``'s legs cannot be mapped."""
    bones = ob.data.bones
    names = [b.name for b in bones]
    parents = [names.index(b.parent.name) if b.parent else -1 for b in bones]
    heads = np.array([b.head_local for b in bones], float).reshape(-1, 3)
    tails = np.array([b.tail_local for b in bones], float).reshape(-1, 3)
    roles = map_roles(names, parents, heads, tails)
    if not roles.ok:
        raise ClipImportError(f"{path}: skeleton has no usable legs: {roles.describe()}")


def _key_frames(act) -> np.ndarray:
    """Sorted distinct frames (rounded to 1e-6) keyed or sampled on any F-curve of
    ``act``."""
    frames = set()
    for _, curves in _fcurves(act):
        for fc in curves:
            points = fc.keyframe_points if len(fc.keyframe_points) else fc.sampled_points
            co = np.empty(len(points) * 2)
            points.foreach_get("co", co)
            frames.update(np.round(co[0::2], 6).tolist())
    return np.array(sorted(frames))


def _retarget(src_ob, src_act, target, src, local: bool = False):
    """A new Action on ``target`` that poses each of its bones as ``src_act`` poses the
    same-named bone of ``src_ob``; the hips' translation is scaled by the ratio of the
    skeletons' sizes.

    BVH sense (``local`` False): each joint's rotation relative to its skeleton's own rest
    pose is kept (the rest poses are taken to be the same pose), and the size is the hip
    height. FBX sense (``local``): each bone's rotation relative to its parent is kept (the
    bones' axes are the file's joint axes, the same in every file of a rig, while the rest
    pose is whatever pose the file was written in), and the size is the legs' length."""
    frames = _key_frames(src_act)
    src_basis = sample_basis(src_ob, src_act, frames)
    src_names = [pb.name for pb in src_ob.pose.bones]
    src_rest = _matrices(src_ob.data.bones, "matrix_local")[
        [src_ob.data.bones.find(n) for n in src_names]]
    tgt_names = [pb.name for pb in target.pose.bones]
    tgt_rest = _matrices(target.data.bones, "matrix_local")[
        [target.data.bones.find(n) for n in tgt_names]]
    s_idx = {n: i for i, n in enumerate(src_names)}
    roles = map_roles(src_names, [s_idx[b.parent.name] if b.parent else -1
                                  for b in (src_ob.data.bones[n] for n in src_names)],
                      src_rest[:, :3, 3])
    hips = roles.bone("hips")
    if local:
        ratio = _leg_length(tgt_names, tgt_rest, roles) / _leg_length(src_names, src_rest, roles)
    else:
        ratio = _hip_height(tgt_names, tgt_rest, hips) / _hip_height(src_names, src_rest, hips)

    name = src_act.name
    src_act.name = "footstep_scratch"  # the importer's copy is scratch: free its name
    act = bpy.data.actions.new(name)
    _tag_source(act, src, target)
    slot = act.slots.new(id_type="OBJECT", name=target.name)
    cbag = act.layers.new("Layer").strips.new(type="KEYFRAME").channelbag(slot, ensure=True)
    for ti, bname in enumerate(tgt_names):
        if bname not in s_idx:
            continue
        si = s_idx[bname]
        ms, mt = src_rest[si, :3, :3], tgt_rest[ti, :3, :3]
        rb = src_basis[:, si, :3, :3]
        if local:  # the bone's rest in its parent's axes, in each skeleton
            ms = _parent_rest(src_ob, src_names, src_rest, bname).T @ ms
            mt = _parent_rest(target, tgt_names, tgt_rest, bname).T @ mt
            rot = Rotation.from_matrix(mt.T @ ms @ rb)
        else:
            world_rel = ms @ rb @ ms.T  # the joint's rotation in armature axes
            rot = Rotation.from_matrix(mt.T @ world_rel @ mt)
        pb = target.pose.bones[bname]
        base = f'pose.bones["{bpy.utils.escape_identifier(bname)}"]'
        _write_rotation(cbag, base, bname, pb.rotation_mode, rot, frames)
        if bname == hips:
            mt = tgt_rest[ti, :3, :3]
            head = (src_rest[si] @ src_basis[:, si])[:, :3, 3] * ratio
            loc = (head - tgt_rest[ti, :3, 3]) @ mt  # into the bone's rest axes
            for i in range(3):
                _curve(cbag, f"{base}.location", i, bname, frames, loc[:, i])
    return act


def _parent_rest(ob, names, rest, bone: str) -> np.ndarray:
    """The rest rotation (3, 3, armature axes) of bone ``bone``'s parent; the identity
    for a root bone. ``rest`` (B, 4, 4) in ``names`` order."""
    parent = ob.data.bones[bone].parent
    return np.eye(3) if parent is None else rest[names.index(parent.name), :3, :3]


def _leg_length(names, rest, roles) -> float:
    """Length of the legs, whatever their pose: thigh to shin to foot heads, both sides
    averaged (``rest`` (B, 4, 4) in ``names`` order), at least 1 mm."""
    total = 0.0
    for side in ("l", "r"):
        heads = [rest[names.index(roles.bone(f"{part}_{side}")), :3, 3] for part in ("thigh", "shin", "foot")]
        total += np.linalg.norm(heads[1] - heads[0]) + np.linalg.norm(heads[2] - heads[1])
    return max(total / 2, 1e-3)


def _hip_height(names, rest, hips):
    """Height of bone ``hips``' rest head above the lowest rest head (``rest`` (B, 4, 4)
    armature-space matrices in ``names`` order), at least 1 mm."""
    return max(float(rest[names.index(hips), 2, 3] - rest[:, 2, 3].min()), 1e-3)


def _write_rotation(cbag, base, group, mode, rot, frames):
    """Key ``rot`` (F rotations) at ``frames`` (F,) on the rotation channels of the pose
    bone at data path ``base`` in rotation mode ``mode``: quaternions (w first, signs
    kept continuous), axis-angle, or Euler angles (unwrapped) of that order."""
    if mode == "QUATERNION":
        q = rot.as_quat()[:, [3, 0, 1, 2]]
        flip = np.cumsum(np.r_[False, np.einsum("ij,ij->i", q[1:], q[:-1]) < 0]) % 2 == 1
        q[flip] *= -1
        for i in range(4):
            _curve(cbag, f"{base}.rotation_quaternion", i, group, frames, q[:, i])
    elif mode == "AXIS_ANGLE":
        rv = rot.as_rotvec()
        ang = np.linalg.norm(rv, axis=1)
        axis = np.where(ang[:, None] > 1e-12, rv / np.maximum(ang, 1e-12)[:, None], [0, 1, 0])
        vals = np.column_stack([ang, axis])
        for i in range(4):
            _curve(cbag, f"{base}.rotation_axis_angle", i, group, frames, vals[:, i])
    else:  # Euler 'XYZ' etc.: Blender's order is scipy's extrinsic lower-case order
        e = np.unwrap(rot.as_euler(mode.lower()), axis=0)
        for i in range(3):
            _curve(cbag, f"{base}.rotation_euler", i, group, frames, e[:, _euler_slot(mode, i)])


def _euler_slot(mode: str, axis: int) -> int:
    """Column of scipy's ``as_euler(mode.lower())`` that holds the angle about ``axis``."""
    return mode.lower().index("xyz"[axis])


#: A clip of more frames than this is kept as sampled F-curve points (Blender's baked
#: samples, one a scene frame: 16 bytes where a keyframe takes 72), so a 100,000 frame clip
#: of 31 joints takes 200 MB, not 900 (a channel that never changes: two keys). It plays and
#: analyses as the keys would; the Graph Editor's Channel > Samples to Keys makes keys to edit.
SAMPLED_FRAMES = 10_000


def _curve(cbag, path, index, group, frames, values):
    """A new F-curve ``path[index]`` in channel group ``group`` of ``cbag``, keyed
    ``values`` (F,) at ``frames`` (F,) with linear interpolation; past
    ``SAMPLED_FRAMES``, those keys sampled at every scene frame they span."""
    sampled = len(frames) > SAMPLED_FRAMES
    if sampled:  # the keys' line at the whole frames (they are those frames at the file's rate)
        whole = np.arange(np.ceil(frames[0] - 1e-6), np.floor(frames[-1] + 1e-6) + 1)
        frames, values = whole, np.interp(whole, frames, values).astype(np.float32)
        if values.min() == values.max():  # a still channel: two keys hold it
            sampled, frames, values = False, frames[[0, -1]], values[[0, -1]]
    fc = cbag.fcurves.new(path, index=index, group_name=group)
    fill_keys(fc, frames, values)
    if sampled:
        fc.convert_to_samples(int(frames[0]), int(frames[-1]) + 1)
