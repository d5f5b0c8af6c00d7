"""What keying the controls shares: small batched linear algebra (``_rot``, ``_swing``,
quaternions and matrices, ``heads_tails``), the ``_Solver`` that turns the DEF targets into the
wanted armature-space matrices of the controls, and those wanted matrices turned into the
controls' bases through their effective parents (``_bases``).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from ...core.base.quat import continuous
from .skeleton import _is_control


def _rest(ob, name):
    return np.array(ob.data.bones[name].matrix_local, dtype=np.float64)


def _rot(m):
    """Rotation part of (..., 4, 4) matrices, scale removed (columns normalised)."""
    r = np.asarray(m, np.float64)[..., :3, :3]
    return r / np.linalg.norm(r, axis=-2, keepdims=True)


def _compose(r, t):
    out = np.zeros(r.shape[:-2] + (4, 4))
    out[..., :3, :3] = r
    out[..., :3, 3] = t
    out[..., 3, 3] = 1.0
    return out


def _inv(m):
    return np.linalg.inv(m)


def _swing(a, b):
    """(F, 3, 3) minimal rotations taking unit vectors a to unit vectors b."""
    a = a / np.linalg.norm(a, axis=-1, keepdims=True)
    b = b / np.linalg.norm(b, axis=-1, keepdims=True)
    w = 1.0 + np.einsum("...i,...i->...", a, b)
    v = np.cross(a, b)
    q = np.concatenate([w[..., None], v], axis=-1)
    # opposite vectors (no axis of their own: w and v both vanish): half turn about any axis
    # perpendicular to a. Nearly opposite ones keep their own axis, v: a half turn about
    # another would miss b by their angle off opposite (1e-5 for b 1e-5 off -a).
    bad = (w < 1e-9) & (np.linalg.norm(v, axis=-1) < 1e-9)
    if np.any(bad):
        perp = np.cross(a[bad], np.array([1.0, 0.0, 0.0]))
        weak = np.linalg.norm(perp, axis=-1) < 1e-6
        perp[weak] = np.cross(a[bad][weak], np.array([0.0, 1.0, 0.0]))
        q[bad] = np.concatenate([np.zeros((perp.shape[0], 1)), perp], axis=-1)
    q /= np.linalg.norm(q, axis=-1, keepdims=True)
    return _quat_to_mat(q)


def _quat_to_mat(q):
    """(..., 4) quaternions (w, x, y, z) -> (..., 3, 3) rotation matrices."""
    q = np.asarray(q, np.float64)
    flat = Rotation.from_quat(q.reshape(-1, 4)[:, [1, 2, 3, 0]]).as_matrix()
    return flat.reshape(q.shape[:-1] + (3, 3))


def _mat_to_quat(r):
    """(F, 3, 3) rotation matrices -> (F, 4) unit quaternions (w, x, y, z), signs continuous
    (the first with w >= 0)."""
    q = Rotation.from_matrix(np.asarray(r, np.float64)).as_quat(canonical=True)[:, [3, 0, 1, 2]]
    return continuous(q)


def heads_tails(ob, mats, names):
    """(F, B, 4, 4) armature-space bone matrices -> heads, tails (F, B, 3). A bone's tail is its
    head plus its (possibly stretched) Y axis times its rest length."""
    mats = np.asarray(mats, np.float64)
    lengths = np.array([ob.data.bones[n].length for n in names])
    heads = mats[..., :3, 3]
    return heads, heads + mats[..., :3, 1] * lengths[:, None]


class _Solver:
    def __init__(self, ob, targets, frames):
        self.ob = ob
        self.t = {k: np.asarray(v, np.float64) for k, v in targets.items()}
        self.n = len(frames)
        self.want: dict[str, np.ndarray] = {}   # control -> (F, 4, 4) wanted armature matrix
        self.neutral: set[str] = set()
        self.props: dict[str, float] = {}     # data_path -> value
        self.via: dict[str, str] = {}         # control -> un-keyed bone its switched parent follows

    def rest(self, n):
        return _rest(self.ob, n)

    def T(self, d):
        m = self.t[d]
        if m.shape != (self.n, 4, 4):
            raise ValueError(f"target {d!r} has shape {m.shape}, expected ({self.n}, 4, 4)")
        return m

    def delta_rot(self, d):
        """Armature-space rotation taking DEF bone d from rest to its target (scale removed)."""
        return _rot(self.T(d)) @ _rot(self.rest(d)).T

    def head(self, d):
        return self.T(d)[:, :3, 3]

    def tail(self, d):
        m = self.T(d)
        return m[:, :3, 3] + m[:, :3, 1] * self.ob.data.bones[d].length

    def rigid(self, ctrl, d):
        """Control moves with DEF bone d: W = D_d R_c, D_d the target's rigid delta."""
        r = self.delta_rot(d)
        p0 = np.array(self.ob.data.bones[d].head_local)
        delta = _compose(r, self.head(d) - r @ p0)
        self.want[ctrl] = delta @ self.rest(ctrl)
        return delta

    def aim(self, ctrl, base_rot, pivot_rest, pivot, aim_rest, aim):
        """Control rotated by base_rot, then swung so aim_rest lands on aim; pivot_rest on pivot."""
        pivot_rest, aim_rest = np.asarray(pivot_rest, float), np.asarray(aim_rest, float)
        v = base_rot @ (aim_rest - pivot_rest)
        r = _swing(v, aim - pivot) @ base_rot
        delta = _compose(r, pivot - r @ pivot_rest)
        self.want[ctrl] = delta @ self.rest(ctrl)
        return delta

    def tweaks_of(self, defs):
        for d in defs:
            for c in self.ob.pose.bones[d].constraints:
                sub = getattr(c, "subtarget", "")
                if sub and _is_control(sub) and sub not in self.want:
                    self.neutral.add(sub)


def _effective_parent(ob, name, keyed):
    """Nearest keyed bone above ``name`` (following parents and full Copy Transforms): (bone, None);
    (None, top) when the chain ends at an un-keyed top bone; (None, None) for a root bone."""
    b = ob.data.bones[name].parent
    cur = b.name if b is not None else None
    last = None
    guard = 0
    while cur is not None and guard < 1000:
        guard += 1
        if cur in keyed:
            return cur, None
        pb = ob.pose.bones[cur]
        nxt = None
        for c in pb.constraints:
            if (c.type == "COPY_TRANSFORMS" and not c.mute and c.influence >= 1.0 - 1e-9
                    and c.target == ob and c.subtarget and c.mix_mode == "REPLACE"
                    and c.target_space == "WORLD" and c.owner_space == "WORLD"):
                nxt = c.subtarget
                break
        last = cur
        if nxt is None:
            par = ob.data.bones[cur].parent
            nxt = par.name if par is not None else None
        cur = nxt
    return None, last


def _current_delta(ob, name):
    """Armature-space delta (pose @ inv(rest)) of an un-keyed bone in the current pose."""
    if name is None:
        return np.eye(4)
    return np.array(ob.pose.bones[name].matrix, np.float64) @ _inv(_rest(ob, name))


def _bases(ob, want: dict, neutral: set, via: dict | None = None):
    """Basis matrices (F, 4, 4) of the solved controls. ``via``: {control: bone} for a
    control whose parent follows ``bone`` (un-keyed) through a parent switch (an Armature
    constraint keyed to that one target, e.g. foot_ik.L's MCH parent keyed to the root)."""
    keyed = set(want) | set(neutral)
    out = {}
    for c, w in want.items():
        e, top = _effective_parent(ob, c, keyed)
        if via and c in via:
            de = _current_delta(ob, via[c])[None]
        elif e is None:
            de = _current_delta(ob, top)[None]
        elif e in want:
            de = want[e] @ _inv(_rest(ob, e))[None]
        else:  # a neutral-keyed bone: resolve its own parent chain (rest relative)
            e2, top2 = _effective_parent(ob, e, set(want))
            de = (want[e2] @ _inv(_rest(ob, e2))[None]) if e2 is not None else _current_delta(ob, top2)[None]
        out[c] = _inv(_rest(ob, c))[None] @ _inv(de) @ w
    return out
