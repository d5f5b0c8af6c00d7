"""Importing clips into a character: one armature, one Action per clip, from BVH, FBX or glTF files.

The first file imported into a new library gives the armature (for FBX and glTF, Blender's own
importers; for BVH, the armature and keys Blender's BVH importer would make, made here from the
motion ``core.bvh`` reads, whole F-curves at a time; then brought to metres, Z up and an identity
object transform, keys at the scene's frame rate whatever the file's, from frame 1; a clip longer
than ``SAMPLED_FRAMES`` kept as samples). Every further file, or every file imported into an
existing armature, is retargeted onto that armature's bones and added as new Actions: nothing of
the user's is replaced or renamed. A BVH file is retargeted in the BVH sense (each joint's
rotation relative to the rest pose is kept); an FBX or glTF file bone by bone (each bone's
rotation relative to its parent is kept: an FBX's rest pose is whatever pose it was written in, a
Mixamo download without skin its first frame, while its joint axes are the rig's own).

A file may hold several clips (an FBX's takes, a glTF's animations): each becomes an Action of
its own, named after its take (``Man_Walk``, not the importer's ``HumanArmature|HumanArmature|
Man_Walk``); a file of one clip gives one Action named after the file. A name already taken keeps
Blender's numbered name (``walk.001``) and the import's report says so.

FBX and glTF: whatever the file's axes and unit, Blender's importers give an armature object
turned and scaled (Mixamo: 90 degrees about X, scale 0.01, the keys in centimetres). That
transform is moved into the bones (``Armature.transform``) and the location keys (times its
scale), so the armature object ends with identity rotation and unit scale and every bone where it
was in the world. Where a clip moves the armature object itself (root motion on the object), that
motion is moved onto the root bones (the hips on most rigs), clip by clip, so the bones play the
same path in the world and the object stays unkeyed (``_fold_object_motion``). A skinned mesh of
the first file is kept, parented to the new armature; everything else the importers made is
removed.

``import_clip_files`` imports every file and clip it can and reports each refused one with its
reason (``ClipImport``), leaving nothing of a refused one in the scene; ``import_clips`` is all or
nothing: the first refusal raises and nothing is left.
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import re
import struct
from dataclasses import dataclass, field

import bpy
import numpy as np
from mathutils import Matrix
from scipy.spatial.transform import Rotation

from ...core.clips.bvh import BvhError, read_bvh, read_skeleton
from ...core.clips.roles import map_roles
from ..write.keys import new_fcurve
from .scene import (ARMATURE_PROP, SOURCE_FILE_PROP, SOURCE_FPS_PROP, _matrices, armature_actions,
                    sample_basis, scene_fps)
from ...core.base.errors import FootstepError
from ..write.keys import fill_keys

#: the clip files the import reads
CLIP_EXTENSIONS = (".bvh", ".fbx", ".glb", ".gltf")
#: the files Blender's own scene importers read, by extension: their format's name
_SCENE_FORMATS = {".fbx": "FBX", ".glb": "glTF", ".gltf": "glTF"}

#: the bpy.data collections an importer may add to (all of it is ours to remove)
_ID_COLLECTIONS = ("objects", "armatures", "meshes", "actions", "materials", "images", "textures",
                   "node_groups", "cameras", "lights", "curves", "shape_keys", "collections")


class ClipImportError(FootstepError):
    """An import that cannot be done; names the file, take or bone at fault."""


@dataclass
class _SceneClip:
    """An FBX or glTF file (``kind``) read by Blender's own importer; ``fps`` (its frame
    rate) is known once Blender read it."""

    path: str
    kind: str
    fps: float = 0.0


@dataclass
class ClipOutcome:
    """One file or take of an import: imported as the action named ``clip`` (with
    ``notes`` on what was done to it), or refused with ``error`` (one line naming the file
    and take)."""

    path: str
    take: str | None = None
    clip: str | None = None
    notes: list[str] = field(default_factory=list)
    error: str | None = None

    @property
    def label(self) -> str:
        """The file's name, and the take's when the file holds several."""
        name = os.path.basename(self.path)
        return name if self.take is None else f"{name} take {self.take!r}"


@dataclass
class ClipImport:
    """What an import did: the armature (None when nothing was imported), the actions it
    made (in file and take order) and one outcome per file or take."""

    armature: object = None
    actions: list = field(default_factory=list)
    outcomes: list[ClipOutcome] = field(default_factory=list)

    @property
    def refused(self) -> list[ClipOutcome]:
        return [o for o in self.outcomes if o.error]

    def report(self) -> list[str]:
        """The import's report as a person reads it: the clips imported, a line for each
        note (a name taken, root motion moved onto the hips), the files and takes refused
        (their reasons are the outcomes' errors)."""
        lines = [f"imported {len(self.actions)} clip(s) into armature {self.armature.name!r}: "
                 + ", ".join(a.name for a in self.actions) if self.actions else "imported no clip"]
        lines += [f"  {note}" for o in self.outcomes for note in o.notes]
        if self.refused:
            lines.append(f"refused {len(self.refused)}: " + ", ".join(o.label for o in self.refused))
        return lines


@dataclass
class _Take:
    """One clip of a file while it is imported: its action, the name it is to have, its
    take's name in a file of several (else None), why it was refused, and the armature
    object's channels moved onto bones ``onto``."""

    action: object
    want: str
    take: str | None = None
    error: str | None = None
    moved: list[str] = field(default_factory=list)
    onto: str = "the hips"

    def where(self, path: str) -> str:
        return path if self.take is None else f"{path}: take {self.take!r}"


def import_clips(paths, target=None, name: str | None = None, scale: float | None = None):
    """Import BVH, FBX and glTF files (any mix, of one skeleton) as Actions of one armature,
    all or nothing.

    ``target``: an existing armature object to add the clips to; when None the first
    file's skeleton becomes a new armature (named ``name`` or after the file).
    ``scale``: metres per BVH unit; None guesses from the skeleton's height (FBX and glTF
    files carry their unit). Returns ``(armature_object, [actions])``. The first file or
    take refused raises ClipImportError naming it, and nothing is left in the scene.
    """
    done = _import(paths, target, name, scale, strict=True)
    return done.armature, done.actions


def import_clip_files(paths, target=None, name: str | None = None, scale: float | None = None) -> ClipImport:
    """``import_clips`` of every file and take that can be imported: each one refused is
    reported in the result's outcomes with its reason and nothing of it stays in the
    scene; the first file that imports gives the new armature (``target`` None)."""
    return _import(paths, target, name, scale, strict=False)


def clip_fps(path: str) -> float:
    """The frame rate of a BVH, FBX or glTF clip file (a glTF's: its keys' spacing);
    ClipImportError naming the file when it is none of them or cannot be read."""
    src = _source(os.path.abspath(path))
    if not isinstance(src, _SceneClip):
        return float(src.fps)
    return _fbx_file_fps(src.path) if src.kind == "FBX" else _gltf_file_fps(src.path)


def _source(path: str):
    """The BvhSkeleton of a BVH file (read, its legs mapped) or a _SceneClip (an FBX or
    glTF file, by its header); ClipImportError naming the file otherwise."""
    ext = os.path.splitext(path)[1].lower()
    if ext in _SCENE_FORMATS:
        _check_header(path, _SCENE_FORMATS[ext], ext)
        return _SceneClip(path, _SCENE_FORMATS[ext])
    if ext != ".bvh":
        raise ClipImportError(f"{path}: not a clip file: import reads {', '.join(CLIP_EXTENSIONS)} files")
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


def _tree(names, parents) -> dict:
    return {n: (names[p] if p >= 0 else None) for n, p in zip(names, parents)}


def _bone_tree(ob) -> dict:
    return {b.name: (b.parent.name if b.parent else None) for b in ob.data.bones}


def _check_bvh_fits(sk, target, users: bool, first_path: str) -> None:
    """Before a BVH file is imported onto armature ``target``: ClipImportError unless
    every joint is a bone of the user's ``target`` (``users``), or the joints and their
    parents are the bones of the first file's armature ``target``."""
    if users:
        have = {b.name for b in target.data.bones}
        missing = [n for n in sk.names if n not in have]
        if missing:
            raise ClipImportError(
                f"{sk.path}: joints {', '.join(missing[:6])} are not bones of armature "
                f"{target.name!r}; clips of one library must share one skeleton")
    elif _tree(sk.names, sk.parents) != _bone_tree(target):
        raise ClipImportError(f"{sk.path}: its skeleton differs from {first_path}'s; "
                              "clips of one library must share one skeleton")


def _check_fits(ob, path: str, target, users: bool, first_path: str) -> None:
    """The check above for a file already imported as armature ``ob`` (an FBX or glTF):
    its bones are bones of the user's ``target`` (``users``), or the same bones with the
    same parents as the first file's armature ``target``."""
    if users:
        have = {b.name for b in target.data.bones}
        missing = [b.name for b in ob.data.bones if b.name not in have]
        if missing:
            raise ClipImportError(
                f"{path}: joints {', '.join(missing[:6])} are not bones of armature "
                f"{target.name!r}; clips of one library must share one skeleton")
    elif _bone_tree(ob) != _bone_tree(target):
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


def _import(paths, target, name, scale, strict: bool) -> ClipImport:
    paths = [os.path.abspath(p) for p in paths]
    if not paths:
        raise ClipImportError("no clip files given")
    if target is not None and target.type != "ARMATURE":
        raise ClipImportError(f"{target.name!r} is not an armature")
    with _selection_kept():
        return _import_all(paths, target, name, scale, strict)


def _import_all(paths, target, name, scale, strict: bool) -> ClipImport:
    """Each file imported by Blender in turn (``_import_path``), the first that imports
    becoming the armature when ``target`` is None, the others retargeted onto it; a file
    or take refused leaves nothing (``strict``: raises, and nothing of any file is left).
    The importers' scratch data is removed at the end; on any other error, everything
    made."""
    done = ClipImport(target)
    users, made, keep = target is not None, [], []
    taken = {a.name for a in armature_actions(target)} if users else set()
    first_path, mine = None, []
    try:
        for path in paths:
            mine = []  # what this file's import made
            try:
                ob, takes, meshes = _import_path(path, done.armature, users, first_path, name, scale, mine)
            except ClipImportError as ex:
                _remove_ids(mine)
                if strict:
                    raise
                done.outcomes.append(ClipOutcome(path, error=str(ex)))
                continue
            refused = [t for t in takes if t.error]
            if refused and (strict or len(refused) == len(takes)):  # (nothing of the file is kept)
                _remove_ids(mine)
                if strict:
                    raise ClipImportError(refused[0].error)
                done.outcomes += [ClipOutcome(path, t.take, error=t.error) for t in refused]
                continue
            made += mine
            if done.armature is None:
                done.armature, first_path, keep = ob, path, meshes
            _record(done, path, takes, taken)
        _remove_scratch(made, keep=[done.armature, *keep], actions=done.actions)
        return done
    except BaseException:
        _remove_ids(made + mine)
        raise


def _import_path(path, target, users: bool, first_path, name, scale, made: list):
    """(armature, [_Take], [skinned meshes kept]) of one file: a new armature (named
    ``name`` or after the file) when ``target`` is None, else the file checked to be
    ``target``'s skeleton and its takes retargeted onto it. ClipImportError naming the
    file when it cannot be imported at all; a take refused has its ``error``."""
    src = _source(path)
    if target is not None and not isinstance(src, _SceneClip):
        _check_bvh_fits(src, target, users, first_path)
    ob, takes, meshes = _import_file(src, scale, made)
    good = [t for t in takes if not t.error]
    if target is None:
        ob.name = name or os.path.splitext(os.path.basename(src.path))[0]
        if isinstance(src, _SceneClip):
            ob.data.name = ob.name  # (the importer's "Armature")
        for t in good:
            _tag_source(t.action, src, ob)
        _play_first(ob, good)
        return ob, takes, meshes
    _check_fits(ob, src.path, target, users, first_path)
    for t in good:
        t.action = _retarget(ob, t.action, target, src, local=isinstance(src, _SceneClip))
        made.append(t.action)
    return target, takes, []


def _play_first(ob, takes) -> None:
    """Give a new armature its first clip as its active action (nothing else plays)."""
    ad = ob.animation_data_create()
    bpy.context.view_layer.update()  # (assigning to an armature never evaluated crashes)
    for track in list(ad.nla_tracks):  # (the glTF importer's, of this new armature)
        ad.nla_tracks.remove(track)
    ad.action = takes[0].action if takes else None
    if takes:
        ad.action_slot = takes[0].action.slots[0]


def _record(done: ClipImport, path: str, takes, taken: set) -> None:
    """Add a file's takes to ``done``: each imported one named (``_name_clip``), its
    outcome with its notes; each refused one with its reason."""
    for t in takes:
        if t.error:
            done.outcomes.append(ClipOutcome(path, t.take, error=t.error))
            continue
        label = ClipOutcome(path, t.take).label
        notes = [n for n in (_name_clip(t.action, t.want, taken, done.armature, label),) if n]
        if t.moved:
            notes.insert(0, f"{t.action.name}: the armature object's motion ({', '.join(t.moved)}) was moved "
                            f"onto {t.onto}")
        taken.add(t.action.name)
        done.actions.append(t.action)
        done.outcomes.append(ClipOutcome(path, t.take, t.action.name, notes))


def _name_clip(act, want: str, taken: set, armature, label: str) -> str | None:
    """Name ``act`` ``want``; where that name is taken (by a clip of ``armature``, in
    ``taken``, or by another action of the file) it keeps Blender's numbered name, and the
    note saying so (naming the file and take, ``label``) is returned."""
    act.name = want
    if act.name == want:
        return None
    why = (f"armature {armature.name!r} already has a clip named {want!r}" if want in taken
           else f"another action in the file is named {want!r}")
    return f"{act.name} ({label}): {why}"


def _import_file(src, scale, made: list):
    """(armature object, [_Take], [its skinned meshes]) of one file, in metres, Z up,
    keyed from frame 1 at the scene's rate; what is made is appended to ``made``."""
    if isinstance(src, _SceneClip):
        return _scene_import(src, made)
    ob, act = _bvh_import(src, scale, made)
    return ob, [_Take(act, os.path.splitext(os.path.basename(src.path))[0])], []


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
            q = bvh_quats([chans[k][0] for k in rot], cols[:, rot], to_bone)
            for i in range(4):  # w x y z
                _curve(cbag, f"{base}.rotation_quaternion", i, sk.names[j], frames, q[:, i])


def bvh_quats(axes: list[str], degrees: np.ndarray, to_bone: np.ndarray) -> np.ndarray:
    """Quaternions (F, 4; w x y z, w >= 0 as Blender's importer gives them) of BVH rotation
    channels about ``axes`` ("X", "Y", "Z") by ``degrees`` (F, len(axes)), the first
    outermost (R = R0 R1 R2: scipy's intrinsic order), seen in the bone's rest axes:
    ``to_bone`` R ``to_bone``^T, ``to_bone`` (3, 3) taking the file's axes to the bone's."""
    rot = Rotation.from_euler("".join(axes).upper(), np.asarray(degrees, np.float64), degrees=True)
    m = Rotation.from_matrix(to_bone)
    return (m * rot * m.inv()).as_quat(canonical=True)[:, [3, 0, 1, 2]]


# -- FBX and glTF ---------------------------------------------------------------------

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


def _skinned_to(mesh_ob, ob) -> bool:
    """Whether mesh object ``mesh_ob`` is deformed by armature object ``ob``."""
    return any(m.type == "ARMATURE" and m.object == ob for m in mesh_ob.modifiers) or (
        mesh_ob.parent == ob and mesh_ob.parent_type == "ARMATURE")


def _fcurves(act):
    for layer in act.layers:
        for strip in layer.strips:
            for cb in strip.channelbags:
                yield cb, cb.fcurves


# -- the armature object's transform, moved into the bones ------------------------------

#: the armature object's own transform channels
_OBJECT_PATHS = ("location", "rotation_euler", "rotation_quaternion", "rotation_axis_angle", "scale")


def _normalise(ob, takes, meshes, path) -> None:
    """Move armature object ``ob``'s world transform (rotation, uniform scale, location,
    any parent's) into its bones and the location keys of the ``takes``' actions, leaving
    the object at the identity, unkeyed, and every bone where it was in the world: the
    transform where the first clip that keys the object starts (else the object's own),
    and in each clip whose keys move the object, that motion moved onto the root bones
    (``_fold_object_motion``; a clip that scales the object is refused). ``meshes``
    (skinned to it) keep their world shape, their transform moved into their vertices,
    parented to ``ob``."""
    bpy.context.view_layer.update()  # (the importer's matrices, parents included)
    parent = np.array(ob.parent.matrix_world @ ob.matrix_parent_inverse) if ob.parent else np.eye(4)
    motions = {id(t): _object_motion(ob, t.action, parent) for t in takes}
    for t in takes:
        if motions[id(t)] is not None and not _steady_scale(motions[id(t)][1]):
            t.error = _scaled(t, ob, path)
    keyed = [motions[id(t)] for t in takes if motions[id(t)] is not None and not t.error]
    if not any(not t.error for t in takes):
        return  # (nothing of the file is kept)
    world = keyed[0][1][0] if keyed else np.array(ob.matrix_world)
    s = _uniform_scale(ob, world, path)
    roots = [b.name for b in ob.data.bones if b.parent is None]
    rest = {n: np.array(ob.data.bones[n].matrix_local) for n in roots}
    folds = [(t, *_object_change(t, motions[id(t)], world, ob, path, roots)) for t in takes
             if motions[id(t)] is not None]
    worlds = [_mesh_world(mo, ob, world) for mo in meshes]
    ob.parent = None
    ob.data.transform(Matrix(world.tolist()))
    ob.matrix_world = Matrix.Identity(4)
    for t in takes:
        _scale_locations(t.action, s)
    for t, frames, w, basis in folds:
        if t.moved and not t.error:
            _fold_object_motion(ob, t.action, frames, w, basis, rest, s)
    for mo, mw in zip(meshes, worlds):
        mo.data.transform(Matrix(mw.tolist()), shape_keys=True)
        mo.parent = ob
        mo.matrix_parent_inverse = Matrix.Identity(4)
        mo.matrix_basis = Matrix.Identity(4)


def _uniform_scale(ob, world: np.ndarray, path: str) -> float:
    """The uniform scale of transform ``world``; ClipImportError when it mirrors or is
    uneven."""
    lin = world[:3, :3]
    scales = np.linalg.norm(lin, axis=0)
    s = float(np.cbrt(abs(np.linalg.det(lin))))
    if np.linalg.det(lin) <= 0 or np.abs(scales - s).max() > 1e-4 * s:
        raise ClipImportError(f"{path}: the armature {ob.name!r} comes in mirrored or unevenly "
                              f"scaled (scale {', '.join(f'{x:.4g}' for x in scales)}); only a "
                              "uniform scale can be turned into metres")
    return s


def _steady_scale(world: np.ndarray, size: float | None = None) -> bool:
    """Whether the world matrices (F, 4, 4) keep one scale (``size``, default their
    first's) on every axis."""
    scales = np.linalg.norm(world[:, :3, :3], axis=1)
    size = scales[0, 0] if size is None else size
    return bool(size > 0 and np.abs(scales - size).max() <= 1e-5 * size)


def _scaled(t, ob, path: str) -> str:
    return (f"{t.where(path)}: the armature object {ob.name!r} is scaled by the clip's keys; only its "
            "location and rotation can be moved onto the hips (apply the scale and export again)")


def _mesh_world(mo, ob, world: np.ndarray) -> np.ndarray:
    """Mesh ``mo``'s world matrix with armature ``ob`` at ``world``."""
    if mo.parent == ob:
        return world @ np.array(mo.matrix_parent_inverse @ mo.matrix_basis)
    return np.array(mo.matrix_world)


def _object_curves(act) -> list:
    """``act``'s F-curves on the armature object's own transform."""
    return [fc for _, curves in _fcurves(act) for fc in curves if fc.data_path in _OBJECT_PATHS]


def _object_motion(ob, act, parent: np.ndarray):
    """(frames (F,), the armature object's world matrices (F, 4, 4) there) as ``act``
    keys its transform (every key and whole frame of the clip; a channel it does not key
    as the object holds it), or None when ``act`` keys none of it."""
    curves = {(fc.data_path, fc.array_index): fc for fc in _object_curves(act)}
    if not curves:
        return None
    keys = _key_frames(act)
    frames = np.union1d(keys, np.arange(np.ceil(keys[0]), np.floor(keys[-1]) + 1))

    def chan(path, now):
        return np.stack([_evaluate(curves[path, i], frames) if (path, i) in curves else np.full(len(frames), v)
                         for i, v in enumerate(now)], axis=1)

    mode = ob.rotation_mode
    if mode == "QUATERNION":
        rot = Rotation.from_quat(chan("rotation_quaternion", ob.rotation_quaternion)[:, [1, 2, 3, 0]])
    elif mode == "AXIS_ANGLE":
        aa = chan("rotation_axis_angle", ob.rotation_axis_angle)
        rot = Rotation.from_rotvec(aa[:, 1:] / np.maximum(np.linalg.norm(aa[:, 1:], axis=1), 1e-12)[:, None]
                                   * aa[:, :1])
    else:  # (Blender's Euler order is scipy's extrinsic lower-case order)
        rot = Rotation.from_euler(mode.lower(), chan("rotation_euler", ob.rotation_euler)[:, ["XYZ".index(c)
                                                                                             for c in mode]])
    basis = np.tile(np.eye(4), (len(frames), 1, 1))
    basis[:, :3, :3] = rot.as_matrix() * chan("scale", ob.scale)[:, None, :]
    basis[:, :3, 3] = chan("location", ob.location)
    return frames, parent @ basis


def _evaluate(fc, frames: np.ndarray) -> np.ndarray:
    """F-curve ``fc`` at ``frames``, as Blender plays it."""
    return np.fromiter((fc.evaluate(f) for f in frames), float, len(frames))


def _object_change(t: _Take, motion, world: np.ndarray, ob, path: str, roots):
    """For take ``t`` whose keys give the armature object the world matrices of
    ``motion`` (frames, (F, 4, 4)): which of location and rotation differ from ``world``
    (in ``t.moved``; a scale that differs refuses the take), and the root bones' bases
    (F, R, 4, 4) there; the object's keys are taken out of the take. Returns (frames,
    world matrices, bases)."""
    frames, w = motion
    size = abs(np.linalg.det(world[:3, :3])) ** (1 / 3)
    if not t.error and not _steady_scale(w, size):
        t.error = _scaled(t, ob, path)
    if np.abs(w[:, :3, 3] - world[:3, 3]).max() > 1e-5 * max(1.0, size):
        t.moved.append("location")
    if np.abs(w[:, :3, :3] - world[:3, :3]).max() > 1e-5 * size:
        t.moved.append("rotation")
    basis = None
    if t.moved and not t.error:
        basis = sample_basis(ob, t.action, frames)[:, [ob.pose.bones.find(n) for n in roots]]
    for _, curves in _fcurves(t.action):
        for fc in [fc for fc in curves if fc.data_path in _OBJECT_PATHS]:
            curves.remove(fc)
    return frames, w, basis


def _fold_object_motion(ob, act, frames, world, basis, rest: dict, s: float) -> None:
    """Key ``act``'s root bones (``rest``: their rest matrices before the armature's
    transform was moved into its bones, now ``ob``'s; ``basis`` (F, R, 4, 4) their
    bases then) at ``frames`` so that, the armature object at the identity, they are
    where the object's motion ``world`` (F, 4, 4; uniform scale ``s``) put them: each
    root's new basis is rest'^-1 @ world @ rest @ basis, its scale taken out."""
    bags = [cb for cb, curves in _fcurves(act) if any(fc.data_path.startswith("pose.bones[") for fc in curves)]
    cbag = bags[0] if bags else next(cb for cb, _ in _fcurves(act))
    unscale = np.diag([1 / s, 1 / s, 1 / s, 1.0])
    for k, (name, r_old) in enumerate(rest.items()):
        r_new = np.array(ob.data.bones[name].matrix_local)
        new = np.linalg.inv(r_new) @ world @ r_old @ basis[:, k] @ unscale
        base = f'pose.bones["{bpy.utils.escape_identifier(name)}"]'
        paths = {f"{base}.{prop}" for prop in ("location", *_OBJECT_PATHS[1:4])}  # (its location and rotations)
        for fc in [fc for fc in cbag.fcurves if fc.data_path in paths]:
            cbag.fcurves.remove(fc)
        pb = ob.pose.bones[name]
        _write_rotation(cbag, base, name, pb.rotation_mode, Rotation.from_matrix(new[:, :3, :3]), frames)
        for i in range(3):
            _curve(cbag, f"{base}.location", i, name, frames, new[:, i, 3])


def _onto(ob, roles) -> str:
    """The bones the armature object's motion is moved onto, as the report names them."""
    roots = [b.name for b in ob.data.bones if b.parent is None]
    if roots == [roles.bone("hips")]:
        return "the hips"
    return f"the root bone{'s' if len(roots) > 1 else ''} " + ", ".join(repr(n) for n in roots)


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


def _check_legs(ob, path):
    """The roles of armature ``ob``'s bones; ClipImportError naming the file when its legs
    cannot be mapped."""
    bones = ob.data.bones
    names = [b.name for b in bones]
    parents = [names.index(b.parent.name) if b.parent else -1 for b in bones]
    heads = np.array([b.head_local for b in bones], float).reshape(-1, 3)
    tails = np.array([b.tail_local for b in bones], float).reshape(-1, 3)
    roles = map_roles(names, parents, heads, tails)
    if not roles.ok:
        raise ClipImportError(f"{path}: skeleton has no usable legs: {roles.describe()}")
    return roles


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
    height. FBX and glTF sense (``local``): each bone's rotation relative to its parent is
    kept (the bones' axes are the file's joint axes, the same in every file of a rig, while
    the rest pose is whatever pose the file was written in), and the size is the legs'
    length."""
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
    fc = new_fcurve(cbag, path, index, group)
    fill_keys(fc, frames, values)
    if sampled:
        fc.convert_to_samples(int(frames[0]), int(frames[-1]) + 1)
