"""The armature object's transform moved into the bones: an FBX or glTF armature brought to
an identity object transform, metres and Z up (``_normalise``), and a clip's motion of the
armature object itself (root motion on the object) moved onto the root bones, clip by clip, so
the bones play the same path in the world and the object stays unkeyed
(``_object_motion``, ``_object_change``, ``_fold_object_motion``).
"""

from __future__ import annotations

import bpy
import numpy as np
from mathutils import Matrix
from scipy.spatial.transform import Rotation

from ...core.base.quat import rotations
from .clip_checks import ClipImportError, _Take
from .clip_keys import _curve, _fcurves, _key_frames, _map_keys, _write_rotation
from .scene import sample_basis


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
        _write_rotation(cbag, base, name, pb.rotation_mode, rotations(new[:, :3, :3]), frames)
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
