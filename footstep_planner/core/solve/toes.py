"""Toe bend and tip (step 5 of ``ik``): the points of a foot that must clear the ground
(``sole_points``: its heel, its ball and its toe tip, ``toe_tip``); a planted foot's toe
bent up so that its tip does not sink into the footprint (``toe_bend``), or a foot
without a toe bone lifted onto its tip (``_tip_lift``).
"""

from __future__ import annotations

import numpy as np

from ..clips.rig import Rig
from .easing import DEFAULT_FPS, ease_peaks
from .legs import SIDES
from .lift import LIFT_RATE, TIP_SINK, _plane_z

#: rad, the most a planted foot's toe is bent up beyond its clip's bend to keep its tip
#: out of the footprint (within a person's toes' bend at push-off: a long step's toe-off,
#: held on its footprint, rolls the foot 40 degrees and more onto its ball; at 30 its tip
#: sank 19 mm, CMU's run-up on the Jumps scene).
MAX_TOE_BEND = np.radians(45.0)
#: rad/s at most that extra bend comes and goes (a toe that flicks pops; slower, it bends
#: up half a second ahead of a 45 degree toe-off, the toes lifting from a flat foot).
TOE_BEND_RATE = np.radians(90.0)


def sole_points(rig: Rig, pose: np.ndarray, side: str, heel_local: np.ndarray, toe_local: np.ndarray) -> list:
    """The points of one foot that must clear the ground while it swings, each as ((F, 3)
    in the foot bone's frame, (F,) m its height over the floor in the clip: its clearance
    on flat ground): its heel and ball (``heel_local``/``toe_local`` (3,), on the sole)
    and its toe tip (``toe_tip``), in ``pose`` (F, B, 4, 4, armature space, the clip's
    floor at z = 0)."""
    foot, toe = rig.foot_chain(side)
    F = len(pose)
    locs = [np.broadcast_to(heel_local, (F, 3)), np.broadcast_to(toe_local, (F, 3)),
            toe_tip(rig, side, pose[:, foot], pose[:, toe] if toe is not None else None, heel_local, toe_local)]
    return [(loc, np.einsum("fj,fj->f", pose[:, foot, 2, :3], loc) + pose[:, foot, 2, 3]) for loc in locs]


def toe_tip(rig: Rig, side: str, foot_m: np.ndarray, toe_m: np.ndarray | None, heel_local: np.ndarray,
            toe_local: np.ndarray) -> np.ndarray:
    """(F, 3) the toe tip of one foot in its foot bone's frame: ahead of the ball on the
    sole (``toe_local`` (3,)) by the toe bone's length, along the sole (from
    ``heel_local``), bent as the toe bone is bent from its rest in ``foot_m``/``toe_m``
    (F, 4, 4) (the foot's and the toe's matrices in any one space; without a toe bone
    (None) the foot's tail stands for the tip, unbent, on the sole). A rig with the soles
    of its skinned mesh (``Rig.sole``) has the mesh's tip, bent about the toe bone's head."""
    foot, toe = rig.foot_chain(side)
    if rig.sole is not None:
        tip = rig.sole.tip[SIDES.index(side)]
        if toe is None or toe_m is None:
            return np.tile(tip, (len(foot_m), 1))
        rel = np.linalg.inv(rig.rest[foot]) @ rig.rest[toe]
        bend = np.swapaxes(foot_m[:, :3, :3], 1, 2) @ toe_m[:, :3, :3] @ rel[:3, :3].T
        return rel[:3, 3] + bend @ (tip - rel[:3, 3])
    ahead = toe_local - heel_local
    ahead = ahead / max(float(np.linalg.norm(ahead)), 1e-9)
    if toe is None or toe_m is None:
        tail = (np.linalg.inv(rig.rest[foot]) @ np.append(rig.tails[foot], 1.0))[:3]
        length = max(float((tail - rig.ball_local(side)[:3]) @ ahead), 0.0)
        return np.tile(toe_local + length * ahead, (len(foot_m), 1))
    length = float(np.linalg.norm(rig.tails[toe] - rig.rest[toe, :3, 3]))
    rest = (np.linalg.inv(rig.rest[foot]) @ rig.rest[toe])[:3, :3]
    # (the pose's matrices are rigid: the rotation between them needs no general inverse,
    # which costs a LAPACK call per frame)
    bend = np.swapaxes(foot_m[:, :3, :3], 1, 2) @ toe_m[:, :3, :3] @ rest.T
    return toe_local + length * (bend @ ahead)


def toe_bend(ankle: np.ndarray, rot: np.ndarray, planted: np.ndarray, tip: tuple, toe_local: np.ndarray,
             planes, fps: float = DEFAULT_FPS) -> np.ndarray:
    """(F,) rad to bend one foot's toe up, beyond its clip's bend (at most ``MAX_TOE_BEND``),
    so that its toe tip (``tip``: ((F, 3) in the foot bone's frame, (F,) m its height over
    the clip's floor), from ``sole_points``) goes no deeper into the footprint it stands on
    while ``planted`` (F,) than it goes into the clip's floor (at most TIP_SINK): a foot rolled up on its ball
    (the clip's toe-off held on a footprint, a roll for reach, a slope) would sink its
    toes. The foot at ``ankle`` (F, 3) turned by ``rot`` (F, 3, 3); the toe bends about the
    ball (``toe_local`` (3,)); ``planes`` from ``_swing_planes``. Eased in and out at
    ``TOE_BEND_RATE`` (``ease_peaks``; frames at ``fps``)."""
    bend = np.zeros(len(ankle))
    on = np.flatnonzero(planted)
    if planes is None or not len(on):
        return bend
    pt = ankle[on] + np.einsum("fij,fj->fi", rot[on], tip[0][on])
    ball = ankle[on] + rot[on] @ toe_local
    (pa, _), (na, _), _, _ = planes
    depth = _plane_z(pa[on], na[on], pt[:, :2]) - pt[:, 2] - np.clip(-tip[1][on], 0.0, TIP_SINK)
    length = np.maximum(np.linalg.norm(pt - ball, axis=1), 1e-6)
    bend[on] = np.minimum(np.arcsin(np.clip(depth / length, 0.0, 1.0)), MAX_TOE_BEND)
    return ease_peaks(bend, TOE_BEND_RATE / fps)


def _tip_lift(ankle: np.ndarray, lift: np.ndarray, rot: np.ndarray, planted: np.ndarray, tip: tuple, planes,
              fps: float) -> np.ndarray:
    """(F,) ``lift`` raised, while ``planted`` (F,), by as much as a foot that has no toe
    bone (its toes are its own, rigid) would sink its toe tip (``tip`` from
    ``sole_points``) more than TIP_SINK into the footprint it stands on: such a foot at its
    clip's toe-off stands on its tip, not its ball. Eased in and out at LIFT_RATE."""
    on = np.flatnonzero(planted)
    if planes is None or not len(on):
        return lift
    pt = ankle[on] + lift[on, None] * [0.0, 0.0, 1.0] + np.einsum("fij,fj->fi", rot[on], tip[0][on])
    (pa, _), (na, _), _, _ = planes
    need = np.zeros(len(ankle))
    need[on] = np.maximum(_plane_z(pa[on], na[on], pt[:, :2]) - pt[:, 2] - TIP_SINK, 0.0)
    if not need.any():
        return lift
    return lift + ease_peaks(need, LIFT_RATE)
