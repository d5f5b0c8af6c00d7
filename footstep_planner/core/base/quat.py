"""Unit quaternions on one hemisphere (the one sign fix the core uses), and rotation
matrices taken as rotations at the cost they need (``rotations``).

A quaternion q and its negation -q are the same rotation. Blending, interpolating or
differencing quaternions needs the two sides on the same hemisphere (a non-negative
dot product), else the blend goes the long way round (or through zero). Every such
fix in the core goes through ``hemisphere_signs``: ``align`` puts quaternions on the
hemisphere of reference ones, ``continuous`` a sequence on one hemisphere.

Conventions: quaternions are arrays (..., 4) in any component order (the dot product
does not care; the core uses scipy's (x, y, z, w)); they need not be normalised. A
negation is exact in floating point, so these change signs and nothing else.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

#: A matrix whose columns are orthonormal to this is a rotation as it stands (a clip's
#: matrices read from Blender, in single precision, are rotations to about 1e-7).
RIGID_TOL = 1e-6


def hemisphere_signs(q: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """(...,) +1.0 where the quaternions ``q`` (..., 4) lie on the hemisphere of ``ref``
    (..., 4; broadcast against q) -- a dot product >= 0, so a zero ``ref`` keeps q --
    and -1.0 where they do not."""
    return np.where(np.einsum("...k,...k->...", q, ref) < 0, -1.0, 1.0)


def align(q: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """A new (..., 4) array: the quaternions ``q`` (..., 4), each negated where it lies
    on the other hemisphere from its ``ref`` (..., 4), so that dot(result, ref) >= 0."""
    return q * hemisphere_signs(q, ref)[..., None]


def continuous(q: np.ndarray) -> np.ndarray:
    """A new (N, ..., 4) array: the sequences of quaternions ``q`` (N, ..., 4) along
    axis 0 (samples) kept on one hemisphere, each sample negated where needed so that
    consecutive samples have a dot product >= 0 (no sign flips between samples). The
    first sample keeps its sign."""
    out = np.array(q, dtype=np.float64, copy=True)
    flip = np.cumprod(hemisphere_signs(out[1:], out[:-1]), axis=0)
    out[1:] *= flip[..., None]
    return out


def multiply(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(..., 4) the Hamilton products a b of quaternions ``a``, ``b`` (..., 4, broadcast)
    in scipy's order (x, y, z, w): the rotation b, then a (``Rotation(a) * Rotation(b)``),
    without scipy's per-call cost on large stacks. Unit in, unit out (to rounding)."""
    ax, ay, az, aw = np.moveaxis(np.asarray(a, float), -1, 0)
    bx, by, bz, bw = np.moveaxis(np.asarray(b, float), -1, 0)
    return np.stack([aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx,
                     aw * bz + ax * by - ay * bx + az * bw,
                     aw * bw - ax * bx - ay * by - az * bz], axis=-1)


def rotations(m: np.ndarray) -> Rotation:
    """scipy Rotations of matrices ``m`` (N, 3, 3): each one that is a rotation (the
    rotation read from it gives it back to RIGID_TOL) taken as it stands, each other one
    (a scale, shear or rounding in it) orthogonalised first (scipy's SVD: the nearest
    rotation). The same rotations as ``Rotation.from_matrix(m)`` to that tolerance, at
    about a fifth of its cost where none needs the SVD (one LAPACK call a matrix)."""
    m = np.asarray(m, np.float64)
    if not len(m):
        return Rotation.from_matrix(m)
    rot = Rotation.from_matrix(m, assume_valid=True)
    off = np.abs((rot.as_matrix() - m).reshape(len(m), 9)).max(axis=1)
    bad = np.flatnonzero(~(off < RIGID_TOL))
    if not len(bad):
        return rot
    q = rot.as_quat()
    q[bad] = Rotation.from_matrix(m[bad]).as_quat()
    return Rotation.from_quat(q)
