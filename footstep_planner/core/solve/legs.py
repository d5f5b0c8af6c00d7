"""The leg's closed-form solve (thesis 3.8.2, step 5 of ``ik``) and its reach: with the body
fixed, the ankle goes to its target and the knee stays in the plane of the clip's own knee
(``two_bone``), the thigh and the shin turned by the least rotation (``min_rotation``); the
pose bases set from armature-space rotations (``chain_bases``), the toe bent about the
foot's lateral axis (``_solve_legs``). Also the leg bones and their lengths (``_Legs``,
``leg_lengths``), their world matrices (``body_frames``, ``_legs_in_world``) and how far the
hips must come down for an ankle to lie in reach (``reach_need``, ``MAX_REACH``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from ..clips.rig import Rig, left_product

#: The leg is never stretched past this share of its length (a straight knee pops).
MAX_REACH = 0.995

SIDES = ("l", "r")


def body_frames(pos: np.ndarray, yaw: np.ndarray) -> np.ndarray:
    """(F, 4, 4) world matrices of the armature object: rotation about Z, translation."""
    c, s = np.cos(yaw), np.sin(yaw)
    m = np.tile(np.eye(4), (len(yaw), 1, 1))
    m[:, 0, 0], m[:, 0, 1], m[:, 1, 0], m[:, 1, 1] = c, -s, s, c
    m[:, :3, 3] = pos
    return m


def turned(yaw: np.ndarray, m: np.ndarray, pos: np.ndarray | None = None) -> np.ndarray:
    """``body_frames(pos, yaw) @ m`` without the products: matrices ``m`` (F, ..., R, C)
    (R 3 or 4; rotations, or 4x4s with a bottom row (0, 0, 0, 1)) turned by ``yaw`` (F,)
    rad about +Z, and a 4x4's translation moved by ``pos`` (F, 3) m. (A stack of small
    matrix products costs several times these row operations.)"""
    shape = (-1,) + (1,) * (m.ndim - 2)
    c, s = np.cos(yaw).reshape(shape), np.sin(yaw).reshape(shape)
    out = np.array(m, float, copy=True)
    x, y = m[..., 0, :], m[..., 1, :]
    out[..., 0, :] = c * x - s * y
    out[..., 1, :] = s * x + c * y
    if pos is not None:
        out[..., :3, 3] += np.asarray(pos, float).reshape((len(pos),) + (1,) * (m.ndim - 3) + (3,))
    return out


def min_rotation(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(F, 3, 3) least rotations taking directions a (F, 3) onto b (F, 3)."""
    a = a / np.linalg.norm(a, axis=1, keepdims=True)
    b = b / np.linalg.norm(b, axis=1, keepdims=True)
    v = np.cross(a, b)
    c = np.einsum("fi,fi->f", a, b)
    k = np.zeros((len(a), 3, 3))
    k[:, 0, 1], k[:, 0, 2], k[:, 1, 0] = -v[:, 2], v[:, 1], v[:, 2]
    k[:, 1, 2], k[:, 2, 0], k[:, 2, 1] = -v[:, 0], -v[:, 1], v[:, 0]
    s2 = np.einsum("fi,fi->f", v, v)
    with np.errstate(invalid="ignore", divide="ignore"):
        f = np.where(s2 > 1e-18, (1 - c) / np.where(s2 > 1e-18, s2, 1.0), 0.5)
    r = np.eye(3)[None] + k + f[:, None, None] * (k @ k)
    # (nearly) opposite directions: half a turn about an axis perpendicular to a, then
    # the small rest of the way from -a to b
    opp = c < -1 + 1e-6
    if opp.any():
        axis = np.cross(a[opp], np.where(np.abs(a[opp, :1]) < 0.9, [[1.0, 0, 0]], [[0, 1.0, 0]]))
        half = Rotation.from_rotvec(np.pi * axis / np.linalg.norm(axis, axis=1, keepdims=True)).as_matrix()
        r[opp] = min_rotation(-a[opp], b[opp]) @ half
    return r


def leg_lengths(rig: Rig, side: str) -> tuple[float, float]:
    """(thigh, shin) rest lengths of one leg: hip to knee and knee to ankle, m."""
    thigh, shin, foot = rig.role_index(f"thigh_{side}"), rig.role_index(f"shin_{side}"), rig.foot_chain(side)[0]
    return (float(np.linalg.norm(rig.rest[shin, :3, 3] - rig.rest[thigh, :3, 3])),
            float(np.linalg.norm(rig.rest[foot, :3, 3] - rig.rest[shin, :3, 3])))


@dataclass(frozen=True)
class _Legs:
    """The leg bones of a rig, per side (0 left, 1 right): indices and rest lengths (m)."""

    thigh: tuple[int, int]
    shin: tuple[int, int]
    foot: tuple[int, int]
    thigh_len: tuple[float, float]  # hip to knee
    shin_len: tuple[float, float]  # knee to ankle
    chain: list  # every leg bone's index, sorted
    toe_bones: tuple = ()  # the toe bones the rig has

    @classmethod
    def of(cls, rig: Rig) -> "_Legs":
        thigh = tuple(rig.role_index(f"thigh_{x}") for x in SIDES)
        shin = tuple(rig.role_index(f"shin_{x}") for x in SIDES)
        foot = tuple(rig.foot_chain(x)[0] for x in SIDES)
        toes = tuple(b for b in (rig.foot_chain(x)[1] for x in SIDES) if b is not None)
        L1, L2 = zip(*(leg_lengths(rig, x) for x in SIDES))
        return cls(thigh, shin, foot, L1, L2, sorted(set(thigh) | set(shin) | set(foot)), toes)


def _legs_in_world(pose: np.ndarray, legs: _Legs, pos: np.ndarray, yaw: np.ndarray) -> np.ndarray:
    """World matrices (F, b, 4, 4) of the leg bones (``legs.chain``; the other entries are
    not set; b: up to the last leg bone, not every bone, so a long path's world is no
    larger than it needs) from their armature-space matrices ``pose`` (F, B, 4, 4), the
    armature object at ``pos`` (F, 3) m turned by ``yaw`` (F,) rad about +Z."""
    w = np.empty((len(pose), max(legs.chain) + 1, 4, 4))
    w[:, legs.chain] = turned(yaw, pose[:, legs.chain], pos)
    return w


def reach_need(hip: np.ndarray, ankle: np.ndarray, reach: float) -> np.ndarray:
    """(F,) m the hip (F, 3) must come down for the ankle (F, 3) to lie within ``reach``
    of it (negative: it could rise that much)."""
    v = ankle - hip
    horiz = np.hypot(v[:, 0], v[:, 1])
    return -v[:, 2] - np.sqrt(np.maximum(reach * reach - horiz * horiz, 0.0))


def two_bone(H: np.ndarray, K0: np.ndarray, A0: np.ndarray, A: np.ndarray, L1, L2,
             forward: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A leg in closed form (thesis 3.8.2), vectorized over frames.

    ``H``, ``K0``, ``A0`` (F, 3): hip, knee and ankle of the leg as posed now; ``A`` (F, 3)
    the ankle's target (kept within ``MAX_REACH`` of the leg's length), ``L1`` and ``L2`` the
    thigh's and the shin's lengths (m; each a number, or (F,) a frame); ``forward`` (F, 3)
    the character's forward. The knee stays in the plane of the posed knee (the swivel
    closest to it), or bends forward as the posed leg straightens (a straight knee gives no
    side). Returns (r1, r2) (F, 3, 3): the least world rotation of the thigh, and the one
    that then takes the shin onto the target (the shin's world rotation is r2 @ r1 @ old).
    """
    v = A - H
    d = np.linalg.norm(v, axis=1)
    d_c = np.clip(d, abs(L1 - L2) + 1e-4, MAX_REACH * (L1 + L2))
    u = v / np.maximum(d, 1e-9)[:, None]
    A = H + u * d_c[:, None]
    u0 = (A0 - H) / np.maximum(np.linalg.norm(A0 - H, axis=1, keepdims=True), 1e-9)
    pole = K0 - H  # the posed knee, off the posed hip-ankle line ...
    pole -= np.einsum("fi,fi->f", pole, u0)[:, None] * u0
    m = np.linalg.norm(pole, axis=1)
    pole -= np.einsum("fi,fi->f", pole, u)[:, None] * u  # ... carried to the new line
    fb = forward - np.einsum("fi,fi->f", forward, u)[:, None] * u
    fb /= np.maximum(np.linalg.norm(fb, axis=1, keepdims=True), 1e-9)
    firm = 0.15 * L1
    pole += (firm * np.clip(1.0 - m / firm, 0.0, 1.0))[:, None] * fb
    pole /= np.maximum(np.linalg.norm(pole, axis=1, keepdims=True), 1e-12)
    a = (L1 ** 2 - L2 ** 2 + d_c ** 2) / (2 * d_c)
    h = np.sqrt(np.maximum(L1 ** 2 - a * a, 0.0))
    K = H + a[:, None] * u + h[:, None] * pole
    r1 = min_rotation(K0 - H, K - H)
    r2 = min_rotation(np.einsum("fij,fj->fi", r1, A0 - K0), A - K)
    return r1, r2


def chain_bases(rig: Rig, chain: list, parent_rot: np.ndarray, arm: dict, basis: np.ndarray) -> None:
    """Set the rotations of pose bases ``basis`` (F, B, 4, 4), in place, from armature-space
    rotations: ``arm`` maps each bone of ``chain`` (parents first, each an ancestor of the
    next) to its wanted armature-space rotation (F, 3, 3); ``parent_rot`` (F or 1, 3, 3)
    is the first bone's parent's. Bones between two of the chain (a Rigify leg's split
    halves, thigh.001 between thigh and shin) keep their bases and turn with the chain."""
    known = {int(rig.parents[chain[0]]): parent_rot}
    for b in chain:
        p, between = int(rig.parents[b]), []
        while p not in known and p >= 0:
            between.append(p)
            p = int(rig.parents[p])
        rot = known.get(p, parent_rot)
        for q in reversed(between):  # their armature rotation, following the chain
            rot = rot @ rig.rest_rel[q, :3, :3] @ basis[:, q, :3, :3]
        rr = rig.rest_rel[b, :3, :3]
        basis[:, b, :3, :3] = left_product(rr.T, np.swapaxes(rot, -1, -2) @ arm[b])  # (matmul: a third of einsum's)
        known[b] = arm[b]


def _lateral(rot: np.ndarray, heel_to_toe: np.ndarray, where: np.ndarray) -> np.ndarray:
    """(3,) a foot's lateral axis (to its right, unit) in its bone's frame: across the
    sole's length ``heel_to_toe`` (3,) and the world's up, averaged over the frames
    ``where`` (F,) of its world rotations ``rot`` (F, 3, 3) (a foot rolled steeply in
    the air has a poor one of its own)."""
    f = np.einsum("fij,j->fi", rot[where], heel_to_toe)
    side = np.cross(f, [0.0, 0.0, 1.0])
    side /= np.maximum(np.linalg.norm(side, axis=1, keepdims=True), 1e-12)
    lat = np.einsum("fji,fj->i", rot[where], side)
    return lat / max(float(np.linalg.norm(lat)), 1e-12)


def _solve_legs(rig: Rig, basis: np.ndarray, pose: np.ndarray, world: np.ndarray, legs: _Legs,
                ankle_t: np.ndarray, rot_t: np.ndarray, lift: list, yaw: np.ndarray, toes=None) -> np.ndarray:
    """Thesis 3.8.2: a copy of ``basis`` (F, B, 4, 4) with both legs solved in closed form
    (``two_bone``, the knee towards the rig's forward) so each ankle reaches its target
    ``ankle_t`` (2, F, 3) raised by ``lift`` (2 x (F,)) m and each foot takes ``rot_t``
    (2, F, 3, 3); ``world`` holds the legs' current world matrices, ``pose`` the
    armature-space ones (the toes' too), the object turned by ``yaw`` (F,) rad. ``toes``
    (bends (2 x (F,)) rad, heel-to-ball (2, 3) in the foot bones' frames): each toe bone
    bent up by that much more than its clip bends it, about the foot's lateral axis."""
    F = len(yaw)
    basis = basis.copy()
    fwd = turned(yaw, np.broadcast_to(rig.forward_axis()[:, None], (F, 3, 1)))[..., 0]
    # both legs at once, the left's frames then the right's (each step reads a row alone)
    Wt, Ws, Wf = (np.concatenate([world[:, b] for b in bones]) for bones in (legs.thigh, legs.shin, legs.foot))
    A = np.concatenate([ankle_t[0], ankle_t[1]])
    A[:, 2] += np.concatenate(lift)
    r1, r2 = two_bone(Wt[:, :3, 3], Ws[:, :3, 3], Wf[:, :3, 3], A, np.repeat(legs.thigh_len, F),
                      np.repeat(legs.shin_len, F), np.concatenate([fwd, fwd]))
    back = -np.concatenate([yaw, yaw])
    thighs, shins = turned(back, r1 @ Wt[:, :3, :3]), turned(back, r2 @ r1 @ Ws[:, :3, :3])
    feet = turned(back, np.concatenate([rot_t[0], rot_t[1]]))
    for k in range(2):
        thigh, shin, foot = legs.thigh[k], legs.shin[k], legs.foot[k]
        rows = slice(k * F, (k + 1) * F)
        arm = {thigh: thighs[rows], shin: shins[rows], foot: feet[rows]}
        chain = [thigh, shin, foot]
        toe = rig.foot_chain(SIDES[k])[1]
        if toes is not None and toe is not None and toes[0][k].max() > 0.0:
            axis = rot_t[k] @ _lateral(rot_t[k], toes[1][k], toes[0][k] > 0)  # the foot's, as it bends
            rel = np.swapaxes(pose[:, foot, :3, :3], 1, 2) @ pose[:, toe, :3, :3]  # the clip's toe on its foot (rigid)
            arm[toe] = turned(-yaw, Rotation.from_rotvec(axis * toes[0][k][:, None]).as_matrix() @ rot_t[k] @ rel)
            chain.append(toe)
        p = rig.parents[thigh]
        parent_rot = pose[:, p, :3, :3] if p >= 0 else np.eye(3)[None]
        chain_bases(rig, chain, parent_rot, arm, basis)
    return basis
