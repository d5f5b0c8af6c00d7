"""Foot targets (step 1 of ``ik``): each footprint planted from its strike to its liftoff,
the foot keeping its clip's own roll, turned onto the footprint's heading and tilted onto
its surface, pinned at the heel or the toe, whichever is nearer the ground
(``foot_targets``, giving ``FootTargets``), from the feet's own points (``FootPoints``) and
the footprints (``Footprints``). The body's planned motion the IK starts from is a
``BodyMotion``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from ..clips.rig import Rig
from .easing import _frame_rate
from .legs import SIDES, min_rotation

#: The ankle target blends the heel- and the toe-pinned solutions while the heel and toe
#: heights differ by less than this share of ``Settings.balance_band``.
PIN_BAND_SHARE = 0.25
#: frames: a strike or liftoff this close to a frame counts as on it.
FRAME_EPS = 1e-6


@dataclass
class FootTargets:
    """Per foot and frame: IK weight, pinned point, ankle target and foot rotation."""

    weight: np.ndarray  # (2, F) 0 free .. 1 planted
    footprint: np.ndarray  # (2, F) int index of the footprint, -1 when free
    pin: np.ndarray  # (2, F, 3) world target of the pinned point (heel or toe)
    pin_local: np.ndarray  # (2, F, 3) the pinned point in the foot bone's frame
    foot_rot: np.ndarray  # (2, F, 3, 3) world target rotation of the foot bone
    ankle: np.ndarray  # (2, F, 3) world target of the foot bone's head


@dataclass(frozen=True)
class FootPoints:
    """Each foot's (left, right) heel and ball on its sole, in its foot bone's frame
    (homogeneous), as the walk clip has them (``ClipMotion.heel_local``, ``toe_local``)."""

    heel_local: np.ndarray  # (2, 4)
    toe_local: np.ndarray  # (2, 4) its ball (the "toe" end a planted foot is pinned at)


@dataclass(frozen=True)
class Footprints:
    """The footprints the feet are pinned to, each (N) with its foot, its planted times
    (from the synthesis) and its place on the surface."""

    feet: np.ndarray  # (N,) int the foot of each footprint, 0 left, 1 right
    planted: list  # per footprint (strike, stance, liftoff) s
    pos: np.ndarray  # (N, 3) m its centre
    heading: np.ndarray  # (N,) rad from the world direction of heading 0
    normal: np.ndarray  # (N, 3) unit, the surface's


@dataclass(frozen=True)
class BodyMotion:
    """The body's motion as the synthesis planned it, per frame (F), before the IK moves it.

    t: (F,) s, each frame's time.
    pos: (F, 3) m, the armature object's world position.
    heading: (F,) rad, its heading: a yaw about +Z from the world direction of heading 0.
    spin: rad, the world yaw of heading 0 minus the rig's rest forward's yaw, so the
        object's world yaw is ``spin + heading``.
    """

    t: np.ndarray
    pos: np.ndarray
    heading: np.ndarray
    spin: float


def _tilt(normal: np.ndarray) -> np.ndarray:
    """(N, 3, 3) least rotations taking +Z onto each surface normal."""
    up = np.tile([0.0, 0.0, 1.0], (len(normal), 1))
    return min_rotation(up, np.asarray(normal, float))


def foot_targets(rig: Rig, points: FootPoints, world: np.ndarray, t: np.ndarray, footprints: Footprints,
                 forward: np.ndarray, band: float) -> FootTargets:
    """The targets of both feet (see the module docstring). ``world`` (F, B, 4, 4) is the
    unadjusted pose in the world; ``points`` each foot's heel and toe in its foot bone's
    frame; ``t`` (F,) the frame times, s; ``footprints`` the footprints, their feet and
    planted times; ``forward`` (2,) the world direction of heading 0; ``band`` m, the
    heel/toe balance band (``Settings.balance_band``)."""
    heel_local, toe_local = points.heel_local, points.toe_local
    feet, planted, pos, heading, normal = (footprints.feet, footprints.planted, footprints.pos, footprints.heading,
                                           footprints.normal)
    F = len(t)
    fps = _frame_rate(t)
    weight = np.zeros((2, F))
    index = np.full((2, F), -1)
    pin = np.zeros((2, F, 3))
    pin_local = np.zeros((2, F, 3))
    rot = np.zeros((2, F, 3, 3))
    ankle = np.zeros((2, F, 3))
    yaw_fp = np.asarray(heading) + np.arctan2(forward[1], forward[0])  # (N,) world yaw of each footprint
    tilt = _tilt(normal)
    for k, side in enumerate(SIDES):
        Wf = world[:, rig.foot_chain(side)[0]]
        rot[k] = Wf[:, :3, :3]
        heel_w = (Wf @ heel_local[k])[:, :3]  # the clip's heel and toe, world
        toe_w = (Wf @ toe_local[k])[:, :3]
        weight[k], index[k] = _planted_frames(np.asarray(feet) == k, planted, fps, F)
        on = np.flatnonzero(index[k] >= 0)
        if not len(on):
            continue
        j = index[k, on]  # the footprint of each planted frame
        heel_l, toe_l = heel_local[k, :3], toe_local[k, :3]
        rot[k, on] = _laid_on_footprints(rot[k, on], toe_w[on] - heel_w[on], j, yaw_fp, tilt)
        heel_t, toe_t = _footprint_ends(j, pos, yaw_fp, tilt, heel_l, toe_l)
        ankle[k, on], pin[k, on], pin_local[k, on] = _pinned(heel_w[on, 2] - toe_w[on, 2], band, rot[k, on],
                                                             heel_t[j], toe_t[j], heel_l, toe_l)
    return FootTargets(weight, index, pin, pin_local, rot, ankle)


def _planted_frames(mine: np.ndarray, planted: list, fps: float, F: int) -> tuple[np.ndarray, np.ndarray]:
    """Whose footprint each frame of one foot belongs to: ((F,) weight, 1.0 from strike to
    liftoff of one of its footprints, else 0.0; (F,) int index of that footprint, -1 when
    none). ``mine`` (N,) bool marks the foot's footprints; ``planted`` per footprint
    (strike, stance, liftoff) s; frames at ``fps``, the strike's frame rounded up and the
    liftoff's down (within ``FRAME_EPS`` of a frame counts as on it). A later footprint
    overrides an earlier one where their ranges meet."""
    weight = np.zeros(F)
    index = np.full(F, -1)
    for j in np.flatnonzero(mine):
        strike, _, liftoff = planted[j]
        fr = np.arange(max(0, int(np.ceil(strike * fps - FRAME_EPS))),
                       min(F, int(np.floor(liftoff * fps + FRAME_EPS)) + 1))
        weight[fr] = 1.0
        index[fr] = j
    return weight, index


def _laid_on_footprints(rot: np.ndarray, heel_to_toe: np.ndarray, j: np.ndarray, yaw_fp: np.ndarray,
                        tilt: np.ndarray) -> np.ndarray:
    """(n, 3, 3) world rotations of a planted foot at n frames: the clip's own ``rot``
    (n, 3, 3) keeps its pitch and roll (heel strike, flat, toe off), but its heading is
    footprint ``j``'s (n,) for the whole stance (a planted foot does not turn with the
    body) and it is tilted onto the surface: tilt_j Rz(yaw_fp_j - yaw(f)) R0(f), where
    yaw(f) is the world yaw (rad) of the clip's heel-to-toe vector ``heel_to_toe`` (n, 3),
    ``yaw_fp`` (N,) the footprints' world yaws and ``tilt`` (N, 3, 3) +Z onto their normals."""
    yaw_now = np.arctan2(heel_to_toe[:, 1], heel_to_toe[:, 0])
    turn = Rotation.from_euler("z", (yaw_fp[j] - yaw_now)[:, None]).as_matrix()
    return tilt[j] @ turn @ rot


def _footprint_ends(j: np.ndarray, pos: np.ndarray, yaw_fp: np.ndarray, tilt: np.ndarray,
                    heel_local: np.ndarray, toe_local: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """World heel and toe targets (N, 3) of the footprints among ``j`` (rows of the
    others are zero): half the foot's length (heel to toe, from ``heel_local``,
    ``toe_local`` (3,) in the foot bone's frame) behind and ahead of each footprint's
    centre ``pos`` (N, 3) m, along its world yaw ``yaw_fp`` (N,) rad, tilted by ``tilt``
    (N, 3, 3) onto the surface."""
    length = float(np.linalg.norm(toe_local - heel_local))
    js = np.unique(j)
    yaw = yaw_fp[js]
    u = tilt[js] @ np.c_[np.cos(yaw), np.sin(yaw), np.zeros(len(js))][..., None]
    heel_t = np.zeros((len(pos), 3))
    toe_t = np.zeros((len(pos), 3))
    heel_t[js] = pos[js] - 0.5 * length * u[..., 0]
    toe_t[js] = pos[js] + 0.5 * length * u[..., 0]
    return heel_t, toe_t


def _pinned(heel_above_toe: np.ndarray, band: float, rot: np.ndarray, heel_t: np.ndarray,
            toe_t: np.ndarray, heel_local: np.ndarray, toe_local: np.ndarray
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Johansen: the pinned point is the heel or the toe, whichever is lower. At n planted
    frames, from the clip's heel height over its toe ``heel_above_toe`` (n,) m, the foot's
    target rotation ``rot`` (n, 3, 3) and the footprint's heel and toe ``heel_t``, ``toe_t``
    (n, 3): the ankle target (n, 3), the pinned point's target (n, 3) and the pinned
    point in the foot bone's frame (n, 3) (of ``heel_local``, ``toe_local`` (3,)).

    The ankle target blends the heel-pinned and the toe-pinned solutions while their
    heights differ by less than a quarter of ``band`` (m): the two agree while the foot
    lies flat, and a blend over a wider band slides the pinned end (a 10 degree roll puts
    the two solutions 3 cm apart)."""
    bal = np.clip(heel_above_toe / max(PIN_BAND_SHARE * band, 1e-6) + 0.5, 0.0, 1.0)[:, None]
    a_heel = heel_t - np.einsum("fij,j->fi", rot, heel_local)
    a_toe = toe_t - np.einsum("fij,j->fi", rot, toe_local)
    toe_down = bal[:, 0] > 0.5
    return ((1 - bal) * a_heel + bal * a_toe, np.where(toe_down[:, None], toe_t, heel_t),
            np.where(toe_down[:, None], toe_local, heel_local))
