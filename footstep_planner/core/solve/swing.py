"""Swings, stairs and edges (step 4 of ``ik``): between two stances of a foot, the
correction that put it on the first footprint eases into the one the next needs
(``swing_targets``, ``_all_frame_targets``); a swing up or down a step's edge is retimed
so the foot clears the nosing (``_over_edge``, ``_stair_swing``); a pivot step of a turn
in place barely lifts the foot (``_low_swing``).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from ..plan.surface import EDGE_STEP, largest_step_along
from .easing import planted_either_side, smoothstep
from .legs import _Legs
from .targets import FootTargets

#: m of height between a swing's footprints from which it is retimed as a stair step
#: (``_stair_swing``; a step's edge, ``surface.EDGE_STEP``), fully from STAIR_RISE.
CLIMB_MIN = EDGE_STEP
STAIR_RISE = 0.12
#: How far ahead (behind) of the swing's time its early (late) motion runs, at most 1
#: (monotone): see ``_stair_swing``.
STAIR_LEAD = 1.0
#: m the most a pivot step (a turn in place) lifts the foot over the way between its
#: footprints (``_low_swing``).
PIVOT_LIFT = 0.04


def swing_targets(planted: np.ndarray, A0: np.ndarray, R0: np.ndarray, ankle: np.ndarray,
                  rot: np.ndarray, ground_z=None) -> tuple[np.ndarray, np.ndarray]:
    """Ankle positions (F, 3) and foot rotations (F, 3, 3) for every frame of one foot:
    ``ankle``/``rot`` where ``planted``; elsewhere the clip's own (``A0``, ``R0``) plus a
    correction eased (smoothstep) from the last planted frame's to the next one's, held
    before the first and after the last planted frame. With ``planted`` (K, F) and the
    arrays (K, F, ...), K feet at once: each foot's frames read only its own (one set of
    array operations for all, and one ground query)."""
    planted = np.asarray(planted, bool)
    if planted.ndim == 1:
        A, R = swing_targets(planted[None], A0[None], R0[None], ankle[None], rot[None], ground_z)
        return A[0], R[0]
    K, F = planted.shape
    out_a, out_r = np.array(A0, float, copy=True), np.array(R0, float, copy=True)
    feet = np.flatnonzero(planted.any(axis=1))  # (a foot never planted keeps its clip's)
    if not len(feet):
        return out_a, out_r
    n = len(feet) * F
    P = planted[feet].ravel()
    A0f, R0f = np.asarray(A0, float)[feet].reshape(n, 3), np.asarray(R0, float)[feet].reshape(n, 3, 3)
    ankle_f, rot_f = np.asarray(ankle, float)[feet].reshape(n, 3), np.asarray(rot, float)[feet].reshape(n, 3, 3)
    idx = np.flatnonzero(P)
    off = np.zeros((n, 3))
    turn = np.zeros((n, 3))
    off[idx] = ankle_f[idx] - A0f[idx]
    # (rotations of rigid bones: no orthogonalisation, which costs an SVD a frame)
    turn[idx] = Rotation.from_matrix(rot_f[idx] @ np.transpose(R0f[idx], (0, 2, 1)), assume_valid=True).as_rotvec()
    f = np.arange(F)
    prev, nxt = (np.stack(x) for x in zip(*(planted_either_side(planted[k]) for k in feet)))  # (each foot's own)
    prev_c = np.where(prev < 0, nxt, prev)
    nxt_c = np.where(nxt >= F, prev, nxt)
    span = np.maximum(nxt_c - prev_c, 1)
    x = ((f - prev_c) / span).ravel()
    base = (np.arange(len(feet)) * F)[:, None]  # (each foot's frames in the stacked rows)
    prev_g, nxt_g = (prev_c + base).ravel(), (nxt_c + base).ravel()
    u = smoothstep(x)[:, None]
    o = (1 - u) * off[prev_g] + u * off[nxt_g]
    tv = (1 - u) * turn[prev_g] + u * turn[nxt_g]
    A = A0f + o
    R = Rotation.from_rotvec(tv).as_matrix() @ R0f
    # (Easing the foot onto its footprint in world space over the last frames before a
    # strike, and off it after a liftoff, was tried: it holds the foot back while the
    # clip's foot rushes on, then lets it go faster than any clip: more pops, not fewer.)
    A[idx], R[idx] = ankle_f[idx], rot_f[idx]
    swing = ~P & ((prev >= 0) & (nxt < F)).ravel()
    if swing.any() and ground_z is not None:
        # (only a swing between footprints more than CLIMB_MIN apart in height is retimed:
        # the others' ground is never asked)
        edge = np.zeros(n, bool)
        ask = swing & (np.abs(A[nxt_g, 2] - A[prev_g, 2]) > CLIMB_MIN)
        if ask.any():
            edge[ask] = _over_edge(A, prev_g[ask], nxt_g[ask], ground_z)
        A = _stair_swing(A, edge, prev_g, nxt_g, x)
    out_a[feet], out_r[feet] = A.reshape(len(feet), F, 3), R.reshape(len(feet), F, 3, 3)
    return out_a, out_r


def _over_edge(A: np.ndarray, a: np.ndarray, b: np.ndarray, ground_z) -> np.ndarray:
    """(n,) whether the ground from ankle target ``A[a]`` to ``A[b]`` (``a``, ``b`` (n,):
    a swinging frame's last and next planted frames) has a step's edge
    (``surface.largest_step_along``: a stair's nosing, a kerb; not a slope, nor a gap), by
    ``ground_z`` (points -> heights). Each swing's way is sampled once, however many
    frames it lasts, by its own length (``surface.largest_step_along``: a jump's long
    way does not make every step's dense)."""
    pairs, inv = np.unique(np.c_[a, b], axis=0, return_inverse=True)
    pa, pb = A[pairs[:, 0]], A[pairs[:, 1]]
    # (``ground_z`` looks 0.3 m up and down; no ground under a sample is no edge)
    edge = largest_step_along(ground_z, pa, pb, 0.5 * (pa[:, 2] + pb[:, 2]), missing=0.0) > CLIMB_MIN
    return edge[np.ravel(inv)]


def _stair_swing(A: np.ndarray, swing: np.ndarray, a: np.ndarray, b: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Ankle targets ``A`` (F, 3) retimed on swings between footprints at different
    heights (``swing`` (F,), from planted frame ``a`` to ``b``, ``x`` the share of the
    swing done): up a step the foot rises early and goes forward late, down one it goes
    forward early and comes down late, each along the path it had (the clip's swing):
    it clears the nosing it passes over instead of sweeping into the riser, or dropping
    off the edge, in the last frames. Fully so from STAIR_RISE m of height change,
    not at all under CLIMB_MIN."""
    F = len(A)
    dz = A[b, 2] - A[a, 2]
    w = np.clip((np.abs(dz) - CLIMB_MIN) / (STAIR_RISE - CLIMB_MIN), 0.0, 1.0) * swing
    if not w.any():
        return A
    # the shares of the swing done by the horizontal and the vertical motion: up, the
    # rise ahead (at the liftoff's own pace) and the way forward behind; down, the way
    # forward ahead and the drop behind (at the strike's own pace). Each leaves or
    # arrives at the clip's own pace: the way forward lagging to the strike (1.6 times
    # the clip's speed there) snapped CMU's knee straight stepping up onto a platform.
    up = dz > 0
    k, mid = STAIR_LEAD, x * (1.0 - x)
    h = np.where(up, x - k * (1.0 - x) * mid, x + k * x * mid)  # (at the strike's (up) or liftoff's (down) own pace)
    v = np.where(up, x + k * x * mid, x - k * (1.0 - x) * mid)
    span = b - a

    def at(share):  # A at the fractional frames a + share * span (linear between frames)
        f = np.clip(a + share * span, 0, F - 1)
        i = np.minimum(np.floor(f).astype(int), F - 2)
        t = (f - i)[:, None]
        return (1 - t) * A[i] + t * A[i + 1]

    h, v = at(h), at(v)
    # never past the footprint it goes to, nor back behind the one it leaves (a clip's
    # foot reaches out and settles back at the strike: on a stair, onto the next riser)
    d = A[b, :2] - A[a, :2]
    p = np.einsum("fi,fi->f", h[:, :2] - A[a, :2], d) / np.maximum(np.einsum("fi,fi->f", d, d), 1e-12)
    h[:, :2] -= (p - np.clip(p, 0.0, 1.0))[:, None] * d
    out = A.copy()
    out[:, :2] += w[:, None] * (h[:, :2] - A[:, :2])
    out[:, 2] += w * (v[:, 2] - A[:, 2])
    return out


def _all_frame_targets(world: np.ndarray, legs: _Legs, tg: FootTargets, ground_z=None
                       ) -> tuple[np.ndarray, np.ndarray]:
    """Every frame's ankle targets (2, F, 3) and foot rotations (2, F, 3, 3), world: on the
    footprint while planted, the clip's own swing (the foot bones in ``world``) plus a
    correction easing from one footprint's to the next's in between (``swing_targets``;
    ``ground_z`` finds the swings up or down a step)."""
    Wf = np.stack([world[:, legs.foot[k]] for k in range(2)])  # (2, F, 4, 4)
    return swing_targets(tg.weight >= 1.0, Wf[..., :3, 3], Wf[..., :3, :3], tg.ankle, tg.foot_rot, ground_z)


def _low_swing(ankle: np.ndarray, planted: np.ndarray, still: np.ndarray) -> np.ndarray:
    """One foot's ankle targets (F, 3) with each swing's rise over the straight way
    between its footprints' heights scaled down so that it rises at most PIVOT_LIFT, as
    far as ``still`` (F,) 0..1 (a turn in place: a pivot step barely lifts the foot; the
    walk's swing, played on the spot, marches). Unchanged where ``still`` is 0."""
    F = len(planted)
    f = np.arange(F)
    prev, nxt = planted_either_side(planted)
    swing = ~planted & (prev >= 0) & (nxt < F)
    w = np.clip(np.asarray(still, float), 0.0, 1.0) * swing
    if not w.any():
        return ankle
    a, b = np.where(swing, prev, 0), np.where(swing, nxt, 0)
    x = (f - a) / np.maximum(b - a, 1)
    rise = ankle[:, 2] - ((1 - x) * ankle[a, 2] + x * ankle[b, 2])
    top = np.zeros(F)
    np.maximum.at(top, a, np.where(swing, rise, 0.0))  # each swing's highest rise, at its liftoff frame
    scale = np.minimum(1.0, PIVOT_LIFT / np.maximum(top[a], 1e-9))
    out = ankle.copy()
    out[:, 2] -= np.where(swing, w * (1.0 - scale) * np.maximum(rise, 0.0), 0.0)
    return out
