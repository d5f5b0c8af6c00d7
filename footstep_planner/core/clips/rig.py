"""A rig description built from any armature, and forward kinematics in numpy.

Conventions (Blender's): right-handed, Z up, metres. Matrices are 4x4, row-major in numpy
(``M @ v`` for column vectors). "Armature space" is the armature object's local space;
``world = object_matrix @ armature``. A bone's pose basis is its local transform relative
to its rest pose (Blender's ``PoseBone.matrix_basis``), so with default inherit flags::

    pose[b] = pose[parent] @ inv(rest[parent]) @ rest[b] @ basis[b]

where ``rest[b]`` is ``Bone.matrix_local`` (armature space).

Two hierarchies. The planner (forward kinematics here, ``core.ik``, the synthesis) works
on a *planner hierarchy* in which each mapped foot hangs from its shin and each mapped toe
from its foot: ``Rig.parents``, ``Rig.rest_rel``, ``Rig.order``, and every pose basis the
core makes or reads. The armature's own parents are ``Rig.armature_parents`` (with
``Rig.armature_rest_rel``): they differ only where the rig's foot (toe) is parented
elsewhere, to the root or an IK control (game rigs), the bones ``Rig.reparented``.
``planner_basis`` and ``armature_basis`` turn pose bases from one to the other (what
Blender's ``PoseBone.matrix_basis`` holds is under the armature's). Where the two agree
(a foot under its shin) both return their input, and everything is as if there were one.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from .roles import RoleMapping, map_roles
from ..base.errors import FootstepError
from ..base.memo import Memo, digest


class RigError(FootstepError):
    """A rig that cannot be used; the message names the armature and the bones at fault."""


#: Rigs built in this process (``Rig.build``), by their name, bones, rest and role
#: overrides: a character read again (each job of a shot reads every other character's
#: rig, a re-plan its own) is given the rig built the first time, its arrays read only.
_BUILT = Memo(kept=256)


@dataclass(frozen=True)
class Rig:
    """An armature as the planner sees it (see the module's doc for the two hierarchies)."""

    name: str
    names: tuple[str, ...]
    parents: np.ndarray  # (B,) int, -1 for roots: the planner hierarchy (feet under shins)
    rest: np.ndarray  # (B, 4, 4) armature-space rest matrices (Bone.matrix_local)
    tails: np.ndarray  # (B, 3) armature-space rest tails
    roles: RoleMapping
    order: np.ndarray = field(repr=False, default=None)  # topological order (parents first)
    rest_rel: np.ndarray = field(repr=False, default=None)  # (B, 4, 4) parent-relative rest
    #: (B,) the armature's own parents and parent-relative rests (the planner's very arrays
    #: where the two hierarchies agree)
    armature_parents: np.ndarray = field(repr=False, default=None)
    armature_rest_rel: np.ndarray = field(repr=False, default=None)
    #: the bones whose planner parent is not their own, in planner order (parents first),
    #: and the armature's own topological order
    reparented: tuple[int, ...] = field(repr=False, default=())
    armature_order: np.ndarray = field(repr=False, default=None)
    #: the feet's heel, ball and toe tip, when known from the skinned mesh (``core.sole``)
    sole: object = field(repr=False, default=None)

    @staticmethod
    def build(name, names, parents, rest, tails, overrides=None) -> "Rig":
        """Build a rig and map its roles. ``parents`` are the armature's own; the rig's
        planner hierarchy (``parents``) hangs each mapped foot from its shin and each toe
        from its foot where the armature parents them elsewhere. ``overrides`` is role ->
        bone name, set by hand."""
        names = tuple(names)
        parents = np.asarray(parents, dtype=np.int64)
        rest = np.asarray(rest, dtype=np.float64).reshape(-1, 4, 4)
        tails = np.asarray(tails, dtype=np.float64).reshape(-1, 3)
        if not (len(names) == len(parents) == len(rest) == len(tails)):
            raise RigError(f"armature {name!r}: inconsistent bone arrays")
        key = digest(name, names, parents, rest, tails, dict(overrides or {}))
        built = _BUILT.get(key)
        if built is None:
            built = _BUILT.put(key, Rig._build(name, names, parents, rest, tails, overrides))
        return built

    @staticmethod
    def _build(name, names, parents, rest, tails, overrides) -> "Rig":
        """``build``'s work, on its arrays."""
        own_order = topological_order(parents)
        roles = map_roles(names, parents, rest[:, :3, 3], tails, overrides=overrides)
        plan = planner_parents(names, parents, roles)
        try:
            order = topological_order(plan)
        except RigError:
            raise RigError(f"armature {name!r}: a foot or toe mapped above its shin or foot; "
                           f"set the roles by hand ({roles.describe()})") from None
        rest_rel = _relative_rest(plan, rest)
        moved = tuple(int(b) for b in order if plan[b] != parents[b])
        if not moved:
            return Rig(name, names, parents, rest, tails, roles, order, rest_rel, parents, rest_rel, (), order)
        return Rig(name, names, plan, rest, tails, roles, order, rest_rel, parents,
                   _relative_rest(parents, rest), moved, own_order)

    def with_sole(self, sole) -> "Rig":
        """The same rig with the feet's sole points ``sole`` (``core.clips.sole.Sole``, or None)."""
        return replace(self, sole=sole)

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


def planner_parents(names, parents: np.ndarray, roles: RoleMapping) -> np.ndarray:
    """(B,) the planner hierarchy of an armature whose own parents are ``parents``: each
    mapped foot that does not descend from its mapped shin becomes the shin's child, each
    mapped toe that does not descend from its foot the foot's (bones in between, a split
    shin's halves, are kept); every other bone keeps its parent."""
    plan = np.array(parents, dtype=np.int64, copy=True)
    index = {n: i for i, n in enumerate(names)}
    for side in ("l", "r"):
        chain = [roles.roles.get(f"{p}_{side}") for p in ("shin", "foot", "toe")]
        for upper, lower in zip(chain, chain[1:]):
            if upper is None or lower is None:
                continue
            hi, lo = index[upper], index[lower]
            p = plan[lo]
            while p >= 0 and p != hi:
                p = plan[p]
            if p != hi:
                plan[lo] = hi
    return plan


def _relative_rest(parents: np.ndarray, rest: np.ndarray) -> np.ndarray:
    """(B, 4, 4) each bone's rest relative to its parent's under ``parents``."""
    rest_rel = rest.copy()
    has_parent = parents >= 0
    rest_rel[has_parent] = np.linalg.inv(rest[parents[has_parent]]) @ rest[has_parent]
    return rest_rel


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
    return _kinematics(rig.parents, rig.rest_rel, rig.order, basis, bones)


def armature_kinematics(rig: Rig, basis: np.ndarray, bones=None) -> np.ndarray:
    """``forward_kinematics`` under the armature's own hierarchy: armature-space pose
    matrices (F, B, 4, 4) from the pose bases Blender holds (``PoseBone.matrix_basis``)."""
    if not rig.reparented:
        return forward_kinematics(rig, basis, bones)
    return _kinematics(rig.armature_parents, rig.armature_rest_rel, rig.armature_order, basis, bones)


def left_product(c: np.ndarray, stack: np.ndarray) -> np.ndarray:
    """``c @ stack`` for one matrix c (N, M) and a stack (..., M, K): a single product of
    c with the stack's matrices side by side (numpy's stacked product of small matrices
    costs two or three times as much)."""
    k = stack.shape[-1]
    y = c @ np.moveaxis(stack, -2, 0).reshape(c.shape[1], -1)
    return np.moveaxis(y.reshape((c.shape[0],) + stack.shape[:-2] + (k,)), 0, -2)


def _kinematics(parents, rest_rel, order, basis, bones) -> np.ndarray:
    """Armature-space pose matrices (F, B, 4, 4) of pose bases (F, B, 4, 4) under the
    hierarchy ``parents`` (``rest_rel``: rests relative to the parents', ``order``: parents
    first); with ``bones``, only those and their ancestors."""
    basis = np.asarray(basis, dtype=np.float64)
    if bones is not None:
        need = set()
        for b in bones:
            while b >= 0 and b not in need:
                need.add(int(b))
                b = parents[b]
        order = [b for b in order if b in need]
    pose = np.empty_like(basis)  # (one array of the bases' size: no copy of the locals)
    for b in order:
        local = left_product(rest_rel[b], basis[:, b])
        p = parents[b]
        pose[:, b] = local if p < 0 else pose[:, p] @ local
    return pose


def planner_basis(rig: Rig, basis: np.ndarray) -> np.ndarray:
    """Pose bases (F, B, 4, 4) under the planner hierarchy from pose bases under the
    armature's own (Blender's ``matrix_basis``): the same armature-space pose. Only the
    ``rig.reparented`` bones' bases change (a foot's becomes relative to its shin);
    ``basis`` itself is returned when there are none. Vectorized over frames."""
    return _rebase(basis, rig.reparented, armature_kinematics, rig, rig.parents, rig.rest_rel)


def armature_basis(rig: Rig, basis: np.ndarray) -> np.ndarray:
    """Pose bases (F, B, 4, 4) under the armature's own hierarchy, what Blender keys, from
    pose bases under the planner's: the inverse of ``planner_basis`` (a foot parented to
    the root gets the location and rotation relative to the root that put it where the
    planner did). ``basis`` itself is returned when no bone is reparented."""
    return _rebase(basis, rig.reparented, forward_kinematics, rig, rig.armature_parents, rig.armature_rest_rel)


def _rebase(basis, bones, kinematics, rig: Rig, parents, rest_rel) -> np.ndarray:
    """``basis`` with the bases of ``bones`` made relative to their parents under
    ``parents`` (``rest_rel``), the pose given by ``kinematics(rig, basis, bones=...)``."""
    if not bones:
        return basis
    bones = list(bones)
    up = [int(parents[b]) for b in bones]
    pose = kinematics(rig, basis, bones=bones + [p for p in up if p >= 0])
    out = np.array(basis, dtype=np.float64, copy=True)
    for b, p in zip(bones, up):
        parent = pose[:, p] @ rest_rel[b] if p >= 0 else rest_rel[b][None]
        out[:, b] = np.linalg.solve(parent, pose[:, b])
    return out
