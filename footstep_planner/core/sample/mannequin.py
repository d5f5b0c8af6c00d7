"""The Footstep Mannequin's skeleton as data: the bone table and its rig, without Blender.

A humanoid of adult proportions (1.75 m) with the bone names of Blender's human metarig,
facing -Y in its rest pose (armature space, Z up, metres). Proportions: hip joints at
0.92, knees at 0.49, ankles at 0.08, feet 0.25 long, shoulders at 1.45, the top of the
head at 1.75; hips 0.18 apart. ``blender/sample/mannequin.py`` builds the armature and its body
from this table; ``rig()`` gives the same rig in numpy (rest matrices computed as
Blender computes them for a bone with roll 0), so the clip generator and its tests run
without Blender.
"""

from __future__ import annotations

import numpy as np

from ..clips.rig import Rig

HEIGHT = 1.75
NAME = "Footstep Mannequin"

#: name: (head, tail, parent, connected, capsule radius or 0 for no capsule), left side
_SIDE = {
    "thigh": ((0.09, 0.0, 0.92), (0.09, 0.0, 0.49), "spine", False, 0.075),
    "shin": ((0.09, 0.0, 0.49), (0.09, 0.01, 0.08), "thigh", True, 0.055),
    "foot": ((0.09, 0.01, 0.08), (0.09, -0.13, 0.02), "shin", True, 0.045),
    "toe": ((0.09, -0.13, 0.02), (0.09, -0.2, 0.02), "foot", True, 0.035),
    "heel.02": ((0.06, 0.05, 0.0), (0.12, 0.05, 0.0), "foot", False, 0.0),
    "shoulder": ((0.02, 0.0, 1.44), (0.17, 0.02, 1.44), "spine.003", False, 0.045),
    "upper_arm": ((0.19, 0.02, 1.43), (0.21, 0.04, 1.14), "shoulder", False, 0.05),
    "forearm": ((0.21, 0.04, 1.14), (0.22, 0.0, 0.88), "upper_arm", True, 0.04),
    "hand": ((0.22, 0.0, 0.88), (0.22, -0.01, 0.7), "forearm", True, 0.045),
}
_SPINE = [
    ("spine", (0.0, 0.02, 0.95), (0.0, 0.01, 1.07), None, 0.13),
    ("spine.001", (0.0, 0.01, 1.07), (0.0, 0.01, 1.19), "spine", 0.12),
    ("spine.002", (0.0, 0.01, 1.19), (0.0, 0.02, 1.31), "spine.001", 0.13),
    ("spine.003", (0.0, 0.02, 1.31), (0.0, 0.03, 1.47), "spine.002", 0.14),
    ("spine.004", (0.0, 0.03, 1.47), (0.0, 0.02, 1.53), "spine.003", 0.05),
    ("spine.005", (0.0, 0.02, 1.53), (0.0, 0.01, 1.58), "spine.004", 0.05),
    ("spine.006", (0.0, 0.01, 1.58), (0.0, 0.0, 1.75), "spine.005", 0.1),
]


def bone_table() -> list[tuple]:
    """(name, head, tail, parent, connected, radius) of every bone, parents first."""
    out = [(n, h, t, p, p is not None, r) for n, h, t, p, r in _SPINE]
    for side, sx in (("L", 1.0), ("R", -1.0)):
        for base, (h, t, parent, conn, r) in _SIDE.items():
            par = parent if parent.startswith("spine") else f"{parent}.{side}"
            out.append((f"{base}.{side}", (sx * h[0], h[1], h[2]), (sx * t[0], t[1], t[2]), par, conn, r))
    return out


def bone_matrix(head, tail, roll: float = 0.0) -> np.ndarray:
    """The 4x4 rest matrix (``Bone.matrix_local``) Blender gives a bone from head to tail:
    Y along the bone, X and Z from the least rotation of +Y onto it (Blender's
    ``vec_roll_to_mat3``), then turned by ``roll`` about the bone."""
    head, tail = np.asarray(head, float), np.asarray(tail, float)
    x, y, z = (tail - head) / np.linalg.norm(tail - head)
    theta, alt = 1.0 + y, x * x + z * z
    if theta > 6.1e-3 or alt > 2.5e-4 ** 2:
        if theta <= 6.1e-3:
            theta = alt * 0.5 + alt * alt * 0.125
        # columns: the bone's X, Y and Z axes
        b = np.array([[1 - x * x / theta, x, -x * z / theta],
                      [-x, y, -z],
                      [-x * z / theta, z, 1 - z * z / theta]])
    else:
        b = np.diag([-1.0, -1.0, 1.0])
    if roll:
        from scipy.spatial.transform import Rotation

        b = Rotation.from_rotvec(roll * np.array([x, y, z])).as_matrix() @ b
    m = np.eye(4)
    m[:3, :3] = b
    m[:3, 3] = head
    return m


def rig(name: str = NAME) -> Rig:
    """The mannequin's rig, as ``blender.read.scene.rig_from_armature`` reads it."""
    table = bone_table()
    names = [row[0] for row in table]
    parents = [names.index(row[3]) if row[3] else -1 for row in table]
    rest = np.array([bone_matrix(row[1], row[2]) for row in table])
    tails = np.array([row[2] for row in table], float)
    return Rig.build(name, names, parents, rest, tails)
