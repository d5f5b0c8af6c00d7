"""The character's pose at every frame of a schedule: the clips' bone rotations blended
by their weights, and the bases Blender keys.

Conventions: quaternions inside the core are scipy's (x, y, z, w); Blender's
(w, x, y, z) only at the bake. A pose basis is a bone's transform relative to its rest
(``PoseBone.matrix_basis``), see ``rig.py``. The armature object carries the body: its
origin is the body position on the ground, turned by the body heading; so "armature
space" is the body frame, and a clip's hips-in-root matrix is directly the hips'
armature-space matrix.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from ..base import quat as quaternions
from ..synth.schedule import Schedule
from ..synth.tracks import ClipTrack
from ..clips.rig import Rig


def _sample_pose(tr: ClipTrack, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(quats (F, B, 4), hips position (F, 3), hips quat (F, 4)) at clip times t (F,):
    linear interpolation between the clip's samples, quaternions normalised, a cyclic
    clip's loop seam closed (``ClipTrack.sample_pose``)."""
    return tr.sample_pose(np.asarray(t, float))


def blend_pose(schedule: Schedule, tracks: dict[str, ClipTrack]) -> tuple[np.ndarray, np.ndarray]:
    """Blended bone rotations (F, B, 4) and hips-in-root matrices (F, 4, 4) of a schedule.

    Rotations are blended as a weighted sum of quaternions put on one hemisphere, then
    normalised (the clips' poses at a frame are close, which is what makes this exact
    enough; it is also what the thesis does for the root). Only the frames where a clip
    has weight are sampled."""
    S = schedule
    F = S.n
    acc = None
    hp = np.zeros((F, 3))
    hq = np.zeros((F, 4))
    for c, name in enumerate(S.clips):
        w = S.weights[:, c]
        on = np.flatnonzero(w > 0)
        if not len(on):
            continue
        q, p, h = _sample_pose(tracks[name], S.clip_time[on, c])
        if acc is None:
            acc = np.zeros((F,) + q.shape[1:])
        ww = w[on]
        acc[on] += ww[:, None, None] * quaternions.align(q, acc[on])
        hq[on] += ww[:, None] * quaternions.align(h, hq[on])
        hp[on] += ww[:, None] * p
    if acc is None:
        raise ValueError("blend_pose: no clip has weight in the schedule")
    acc /= np.linalg.norm(acc, axis=-1, keepdims=True)
    hips = np.tile(np.eye(4), (F, 1, 1))
    hips[:, :3, :3] = Rotation.from_quat(hq / np.linalg.norm(hq, axis=-1, keepdims=True)).as_matrix()
    hips[:, :3, 3] = hp
    return acc, hips


def quat_to_matrix(q: np.ndarray) -> np.ndarray:
    """(..., 4) scipy quaternions -> (..., 3, 3)."""
    shape = q.shape[:-1]
    return Rotation.from_quat(q.reshape(-1, 4)).as_matrix().reshape(shape + (3, 3))


def pose_bases(rig: Rig, quat: np.ndarray, hips_in_root: np.ndarray) -> np.ndarray:
    """Pose bases (F, B, 4, 4) with the armature object at the body: every bone turns by
    its blended rotation; the bones above the hips stay at rest (the object carries the
    body), and the hips' basis puts the hips at ``hips_in_root`` in armature space."""
    F, B = quat.shape[:2]
    basis = np.zeros((F, B, 4, 4))  # (identities written in place: no tiled copy of a pose-sized array)
    basis[..., 3, 3] = 1.0
    basis[..., :3, :3] = quat_to_matrix(quat)
    h = rig.role_index("hips")
    above = []
    p = rig.parents[h]
    while p >= 0:
        above.append(p)
        p = rig.parents[p]
    for b in above:
        basis[:, b] = np.eye(4)
    # with the ancestors at rest, the hips' armature matrix is rest[h] @ basis[h]
    basis[:, h] = np.linalg.inv(rig.rest[h])[None] @ hips_in_root
    return basis
