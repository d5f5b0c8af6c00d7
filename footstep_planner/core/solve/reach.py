"""Reach (step 3 of ``ik``): where a planted ankle target lies beyond its leg's reach the
hips come down, smoothly and ahead of time, within a budget (``_drop_budget``:
``HIPS_DROP_MAX`` on level ground); beyond it the planted foot rolls about its pinned heel
or toe (``roll_to_reach``, at most ``MAX_ROLL``) and only what the roll cannot reach
lowers the hips further (``_reach_drop``). A swinging ankle out of reach is drawn in
towards its hip (``_swing_within_reach``).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from .easing import ease_peaks, lower_smoothly
from .legs import MAX_REACH, _Legs, reach_need
from .targets import FootTargets

#: A planted foot rolls (``MAX_ROLL``) to keep its leg within this share of its length:
#: a little short of ``MAX_REACH``, where the knee turns fastest for the reach it gives.
ROLL_REACH = 0.99
#: s either side of a frame whose planted ankle is out of reach over which the hips come
#: down (and go back up) smoothly.
REACH_EASE = 0.15
#: m the hips may come down for reach on level ground (more only where the ground under a
#: planted foot lies below the clip's foot, and only when rolling the foot cannot reach).
HIPS_DROP_MAX = 0.03
#: rad, the most a planted foot rolls about its pinned heel or toe (the other end rising)
#: to reach a footprint the capped hips cannot.
MAX_ROLL = np.radians(25.0)
#: rad/s at most a planted foot's roll for reach comes and goes (a foot that flips onto its
#: ball in a frame pops).
ROLL_RATE = np.radians(180.0)


def _drop_budget(floor_z: np.ndarray, tg: FootTargets, dp_z: np.ndarray, fps: float) -> np.ndarray:
    """(F,) m the hips may still come down for reach: ``HIPS_DROP_MAX`` below the clip's
    height, plus how far a planted foot's pinned point lies below the clip's floor
    ``floor_z`` (F,) m (the body's height before the offset: the ground drops there), less
    what the body offset ``dp_z`` (F,) m already lowered; eased like the drop."""
    low = np.zeros(len(floor_z))
    for k in range(2):
        low = np.maximum(low, np.where(tg.weight[k] >= 1.0, np.maximum(floor_z - tg.pin[k, :, 2], 0.0), 0.0))
    low = lower_smoothly(low, max(1, int(round(REACH_EASE * fps))))
    return np.maximum(HIPS_DROP_MAX + low + np.asarray(dp_z, float), 0.0)


def _reach_needs(world: np.ndarray, legs: _Legs, tg: FootTargets, drop: np.ndarray) -> np.ndarray:
    """(2, F) m the hips (in ``world``, then lowered by ``drop`` (F,)) must still come down
    for each planted ankle target to lie within ``MAX_REACH`` of its leg; 0 where free."""
    need = np.zeros((2, len(world)))
    for k in range(2):
        hip = world[:, legs.thigh[k], :3, 3] - drop[:, None] * [0.0, 0.0, 1.0]
        n = reach_need(hip, tg.ankle[k], MAX_REACH * (legs.thigh_len[k] + legs.shin_len[k]))
        need[k] = np.where(tg.weight[k] >= 1.0, np.maximum(n, 0.0), 0.0)
    return need


def _reach_drop(world: np.ndarray, legs: _Legs, tg: FootTargets, fps: float, budget: np.ndarray | None = None,
                heel_local: np.ndarray | None = None, toe_local: np.ndarray | None = None) -> np.ndarray:
    """(F,) m to lower the hips (smoothly, over ``REACH_EASE`` s either side, ahead of
    time) where a planted ankle target is beyond ``MAX_REACH`` of its leg's length from
    the hip joint in ``world`` (F, B, 4, 4). With a ``budget`` (F,) m the hips come down
    at most that far; a planted foot then rolls about its pinned heel or toe to keep its
    leg within ``ROLL_REACH`` (``roll_to_reach``, with ``heel_local``/``toe_local`` (2, 3):
    ``tg``'s ankle targets and foot rotations change in place) and the hips come down
    further only for what the roll cannot reach."""
    win = max(1, int(round(REACH_EASE * fps)))
    drop = lower_smoothly(_reach_needs(world, legs, tg, np.zeros(len(world))).max(axis=0), win)
    if budget is None:
        return drop
    drop = np.minimum(drop, budget)
    for k in range(2):
        hip = world[:, legs.thigh[k], :3, 3] - drop[:, None] * [0.0, 0.0, 1.0]
        toe_pinned = np.all(np.isclose(tg.pin_local[k], toe_local[k]), axis=1)
        tg.ankle[k], tg.foot_rot[k] = roll_to_reach(hip, tg.ankle[k], tg.foot_rot[k], tg.pin[k], toe_pinned,
                                                    tg.weight[k] >= 1.0, toe_local[k] - heel_local[k],
                                                    ROLL_REACH * (legs.thigh_len[k] + legs.shin_len[k]),
                                                    ROLL_RATE / fps)
    rest = _reach_needs(world, legs, tg, drop).max(axis=0)
    return drop + (lower_smoothly(rest, win) if rest.max() > 1e-6 else 0.0)


def roll_to_reach(hip: np.ndarray, ankle: np.ndarray, rot: np.ndarray, pin: np.ndarray, toe_pinned: np.ndarray,
                  planted: np.ndarray, heel_to_toe: np.ndarray, reach: float, rate: float | None = None
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Copies of one foot's ankle targets ``ankle`` (F, 3) and rotations ``rot`` (F, 3, 3),
    rolled where ``planted`` (F,) and the ankle is beyond ``reach`` (m) of ``hip`` (F, 3):
    about the pinned point ``pin`` (F, 3) and the foot's lateral axis, the free end rising
    (the heel when ``toe_pinned`` (F,), else the toe), by the least angle that brings the
    ankle within reach, at most ``MAX_ROLL`` (the pinned point stays put, so the foot does
    not slide). ``heel_to_toe`` (3,) in the foot bone's frame is the foot's length axis.
    Closed form: with the lever a = ankle - pin, d = pin - hip and Rodrigues' rotation
    about k, |d + R a|^2 = |d|^2 + |a|^2 + 2 (A cos phi + B sin phi + C).
    With ``rate`` (rad per frame) the roll comes and goes no faster (``ease_peaks``, over
    the planted frames about those that need it: the free end starts rising early)."""
    ankle, rot = ankle.copy(), rot.copy()
    idx = np.flatnonzero(planted & (np.linalg.norm(ankle - hip, axis=1) > reach + 1e-9))
    if not len(idx):
        return ankle, rot
    phi, better = _roll_angles(hip, ankle, rot, pin, toe_pinned, heel_to_toe, reach, idx)
    if rate is not None:
        roll = np.zeros(len(ankle))
        roll[idx[better]] = phi[better]
        roll = ease_peaks(np.maximum(roll, 0.0), rate) - ease_peaks(np.maximum(-roll, 0.0), rate)
        idx = np.flatnonzero(planted & (roll != 0.0))
        phi, better = roll[idx], np.ones(len(idx), bool)
    k = _roll_axis(rot[idx], heel_to_toe)
    R = Rotation.from_rotvec(k * phi[:, None]).as_matrix()
    new = pin[idx] + np.einsum("fij,fj->fi", R, ankle[idx] - pin[idx])
    ankle[idx] = np.where(better[:, None], new, ankle[idx])
    rot[idx] = np.where(better[:, None, None], R @ rot[idx], rot[idx])
    return ankle, rot


def _roll_axis(rot: np.ndarray, heel_to_toe: np.ndarray) -> np.ndarray:
    """(n, 3) the level axis across each foot (rotations ``rot`` (n, 3, 3), length axis
    ``heel_to_toe`` (3,) in the foot bone's frame) that a roll turns it about."""
    k = np.cross(np.einsum("fij,j->fi", rot, heel_to_toe), [0.0, 0.0, 1.0])
    return k / np.maximum(np.linalg.norm(k, axis=1, keepdims=True), 1e-12)


def _roll_angles(hip, ankle, rot, pin, toe_pinned, heel_to_toe, reach, idx) -> tuple[np.ndarray, np.ndarray]:
    """(phi (n,) rad, better (n,) bool) at the frames ``idx``: the least roll (signed about
    ``_roll_axis``, at most MAX_ROLL) that brings the ankle within ``reach`` of the hip
    (``roll_to_reach``), and whether it brings it nearer at all."""
    pivot = pin[idx]
    a, d = ankle[idx] - pivot, pivot - hip[idx]
    k = _roll_axis(rot[idx], heel_to_toe)
    ka = np.einsum("fi,fi->f", k, a)
    A = np.einsum("fi,fi->f", d, a - k * ka[:, None])
    B = np.einsum("fi,fi->f", d, np.cross(k, a))
    dot = lambda x, y: np.einsum("fi,fi->f", x, y)  # noqa: E731
    D = 0.5 * (reach ** 2 - dot(d, d) - dot(a, a)) - dot(d, k) * ka
    c = np.arccos(np.clip(D / np.maximum(np.hypot(A, B), 1e-12), -1.0, 1.0))
    cand = np.angle(np.exp(1j * (np.arctan2(B, A)[None] + np.array([[1.0], [-1.0]]) * c[None])))
    sign = np.where(toe_pinned[idx], -1.0, 1.0)
    mag = np.where(sign[None] * cand >= 0, np.abs(cand), np.inf).min(axis=0)
    phi = sign * np.minimum(mag, MAX_ROLL)
    new = pivot + np.einsum("fij,fj->fi", Rotation.from_rotvec(k * phi[:, None]).as_matrix(), a)
    return phi, np.linalg.norm(new - hip[idx], axis=1) < np.linalg.norm(ankle[idx] - hip[idx], axis=1)


#: A swinging foot's ankle is kept within this share of its leg's length of the hip: a
#: target further out (a foot reaching up a flight ahead of the body, a long leg's lift
#: over a riser) is drawn in towards the hip, eased over REACH_EASE s, so the knee bends
#: on as the clip bends it instead of locking straight and snapping when the target comes
#: back in reach.
SWING_REACH = 0.99


def _swing_within_reach(ankle: np.ndarray, lift: np.ndarray, free: np.ndarray, hip: np.ndarray, length: float,
                        fps: float) -> np.ndarray:
    """``ankle`` (F, 3) targets (raised by ``lift`` (F,) when solved) with the ``free``
    (F,) bool (swinging) frames' drawn in towards ``hip`` (F, 3) as far as they lie beyond
    SWING_REACH of the leg's ``length``, that pull eased over REACH_EASE s (never on a
    planted frame)."""
    a = ankle + lift[:, None] * [0.0, 0.0, 1.0]
    v = a - hip
    d = np.linalg.norm(v, axis=1)
    need = np.where(free, d - SWING_REACH * length, 0.0)
    if not (need > 0).any():
        return ankle
    pull = np.where(free, lower_smoothly(np.maximum(need, 0.0), max(1, int(round(REACH_EASE * fps)))), 0.0)
    pull = np.minimum(pull, np.maximum(d - 0.5 * length, 0.0))
    return ankle - (pull / np.maximum(d, 1e-9))[:, None] * v
