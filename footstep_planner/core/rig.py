"""A rig description built from any armature, and forward kinematics in numpy.

Conventions (Blender's): right-handed, Z up, metres. Matrices are 4x4, row-major in numpy
(``M @ v`` for column vectors). "Armature space" is the armature object's local space;
``world = object_matrix @ armature``. A bone's pose basis is its local transform relative
to its rest pose (Blender's ``PoseBone.matrix_basis``), so with default inherit flags::

    pose[b] = pose[parent] @ inv(rest[parent]) @ rest[b] @ basis[b]

where ``rest[b]`` is ``Bone.matrix_local`` (armature space).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .roles import RoleMapping, map_roles
from .errors import FootstepError


class RigError(FootstepError):
    """A rig that cannot be used; the message names the armature and the bones at fault."""


@dataclass(frozen=True)
class Rig:
    name: str
    names: tuple[str, ...]
    parents: np.ndarray  # (B,) int, -1 for roots
    rest: np.ndarray  # (B, 4, 4) armature-space rest matrices (Bone.matrix_local)
    tails: np.ndarray  # (B, 3) armature-space rest tails
    roles: RoleMapping
    order: np.ndarray = field(repr=False, default=None)  # topological order (parents first)
    rest_rel: np.ndarray = field(repr=False, default=None)  # (B, 4, 4) parent-relative rest

    @staticmethod
    def build(name, names, parents, rest, tails, overrides=None) -> "Rig":
        """Build a rig and map its roles. ``overrides`` is role -> bone name, set by hand."""
        names = tuple(names)
        parents = np.asarray(parents, dtype=np.int64)
        rest = np.asarray(rest, dtype=np.float64).reshape(-1, 4, 4)
        tails = np.asarray(tails, dtype=np.float64).reshape(-1, 3)
        if not (len(names) == len(parents) == len(rest) == len(tails)):
            raise RigError(f"armature {name!r}: inconsistent bone arrays")
        order = topological_order(parents)
        rest_rel = rest.copy()
        has_parent = parents >= 0
        rest_rel[has_parent] = np.linalg.inv(rest[parents[has_parent]]) @ rest[has_parent]
        roles = map_roles(names, parents, rest[:, :3, 3], tails, overrides=overrides)
        return Rig(name, names, parents, rest, tails, roles, order, rest_rel)

    def index(self, bone: str) -> int:
        try:
            return self.names.index(bone)
        except ValueError:
            raise RigError(f"armature {self.name!r} has no bone {bone!r}") from None

    def role_index(self, role: str) -> int:
        return self.index(self.roles.bone(role))

    def require_legs(self) -> None:
        """Raise RigError naming the roles that could not be mapped."""
        if not self.roles.ok:
            raise RigError(f"armature {self.name!r}: {self.roles.describe()}")

    def foot_chain(self, side: str) -> tuple[int, int | None]:
        """(foot bone index, toe bone index or None) for side 'l' or 'r'."""
        foot = self.role_index(f"foot_{side}")
        toe = self.roles.roles.get(f"toe_{side}")
        return foot, (self.index(toe) if toe else None)

    def ball_local(self, side: str) -> np.ndarray:
        """The ball of the foot in the foot bone's rest frame: the toe bone's head, or the
        foot's tail when the rig has no toe bone (homogeneous 4-vector)."""
        foot, toe = self.foot_chain(side)
        p = self.rest[toe, :3, 3] if toe is not None else self.tails[foot]
        return np.linalg.inv(self.rest[foot]) @ np.append(p, 1.0)

    def forward_axis(self) -> np.ndarray:
        """The character's forward direction in the rest pose (unit, horizontal, armature
        space): perpendicular to the line between the thighs, on the side the feet point to.
        For most rigs this is -Y."""
        tl = self.rest[self.role_index("thigh_l"), :3, 3]
        tr = self.rest[self.role_index("thigh_r"), :3, 3]
        left = tl - tr
        left[2] = 0.0
        if np.linalg.norm(left) < 1e-9:
            raise RigError(f"armature {self.name!r}: the thighs coincide; cannot tell forward")
        fwd = np.cross(left, [0.0, 0.0, 1.0])
        fwd /= np.linalg.norm(fwd)
        return fwd


def topological_order(parents: np.ndarray) -> np.ndarray:
    """Bone indices ordered so that every parent comes before its children."""
    parents = np.asarray(parents)
    depth = np.zeros(len(parents), dtype=np.int64)
    for i in range(len(parents)):
        d, p, seen = 0, parents[i], 0
        while p >= 0:
            d, p, seen = d + 1, parents[p], seen + 1
            if seen > len(parents):
                raise RigError("the bone hierarchy has a cycle")
        depth[i] = d
    return np.argsort(depth, kind="stable")


def forward_kinematics(rig: Rig, basis: np.ndarray, bones=None) -> np.ndarray:
    """Armature-space pose matrices (F, B, 4, 4) from pose bases (F, B, 4, 4).

    Assumes Blender's default inherit flags (inherit rotation and full scale, connected or
    not) and no constraints. Vectorized over frames; one matrix product per bone, and no
    array of the bases' size but the result. With ``bones`` (indices), only those and
    their ancestors are computed (the other entries are left undefined).
    """
    basis = np.asarray(basis, dtype=np.float64)
    order = rig.order
    if bones is not None:
        need = set()
        for b in bones:
            while b >= 0 and b not in need:
                need.add(int(b))
                b = rig.parents[b]
        order = [b for b in rig.order if b in need]
    pose = np.empty_like(basis)  # (one array of the bases' size: no copy of the locals)
    for b in order:
        local = rig.rest_rel[b] @ basis[:, b]
        p = rig.parents[b]
        pose[:, b] = local if p < 0 else pose[:, p] @ local
    return pose
