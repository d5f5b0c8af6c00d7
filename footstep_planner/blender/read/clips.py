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

This module holds the entry points and the import's course, file by file; the parts are
``bvh_import`` (BVH files), ``fbx_gltf_import`` (FBX and glTF with Blender's importers),
``root_motion`` (the armature object's transform and motion moved into the bones),
``retarget`` (a clip onto another armature's bones), ``clip_keys`` (the clips' F-curves) and
``clip_checks`` (the error, the outcomes and the checks they share).
"""

from __future__ import annotations

import contextlib
import os

import bpy

from .bvh_import import _bvh_import, _legged_skeleton
from .clip_checks import (ClipImport, ClipImportError, ClipOutcome, _check_bvh_fits, _check_fits,
                          _SceneClip, _tag_source, _Take)
from .fbx_gltf_import import _check_header, _fbx_file_fps, _gltf_file_fps, _scene_import
from .retarget import _retarget
from .scene import armature_actions


#: the clip files the import reads
CLIP_EXTENSIONS = (".bvh", ".fbx", ".glb", ".gltf")
#: the files Blender's own scene importers read, by extension: their format's name
_SCENE_FORMATS = {".fbx": "FBX", ".glb": "glTF", ".gltf": "glTF"}


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
