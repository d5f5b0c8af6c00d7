"""Feet on the footprints (thesis 3.8): body offset, then each leg solved in closed form.

1. **Targets.** Every footprint is planted from its strike to its liftoff (from the
   synthesis). While planted, the foot keeps the clip's own roll (heel strike,
   flat, toe off) turned by one rotation per footprint that lays the clip's stance
   onto the footprint: its heading and the surface's normal (slopes). The pinned point
   is the heel or the toe, whichever is nearer the ground (Johansen), blended over
   ``balance_band`` so the switch is smooth; the other end follows the roll.
2. **Body offset** (3.8.1, ``offsets.py``): the body is pulled and turned so the pinned
   points reach their targets, and the offsets are spread over time by a multilevel
   B-spline, so the body anticipates each step.
3. **Reach.** Where a target is out of the leg's reach the hips are lowered (smoothly,
   ahead of time) instead of popping the knee straight, but on level ground at most
   ``HIPS_DROP_MAX`` (3 cm) below the clip's height with the body offset's own lowering
   counted (more where the ground under a planted foot lies below the clip's floor).
   Beyond that the planted foot rolls about its pinned point, the free end rising (the
   heel behind the body, the toe ahead), up to ``MAX_ROLL``; only what the roll cannot
   reach lowers the hips further (a foot that missed its footprint would slide).
4. **Swing.** Between two stances of a foot, the correction that put the foot on the
   first footprint (the ankle's offset and the foot's turn from the clip's own) eases
   into the one the next footprint needs (smoothstep): the foot leaves and lands on its
   footprints with the clip's own swing, never released or caught in a hurry. Over
   uneven ground its heel, ball and toe tip (``sole_points``) keep the clearance they
   have over the footprints' planes (the flat-ground swing laid on the slopes): where
   the ground rises above those planes (a hill between footprints, a slope steepening
   ahead, a step's edge) the ankle is lifted, ahead of time, never through the surface.
5. **Legs** (3.8.2): with the body fixed, the ankle goes to its target and the knee
   stays in the plane of the clip's own knee (the swivel closest to the clip: the only
   free variable, solved in closed form); the thigh and the shin turn by the least
   rotation, so their twist is the clip's; the knee bends only the clip's way and never
   past straight. The foot takes its target rotation.

Conventions: world Z up, metres, seconds; quaternions (x, y, z, w) (scipy); headings
are yaws about +Z relative to the world forward; ``spin`` is the world yaw of heading 0
minus the rig's rest forward's yaw, so the armature object's yaw is ``spin + heading``.
Arrays are per frame (F) and vectorized over frames.

The steps' parts: ``targets`` (1), ``offsets`` (2), ``reach`` (3), ``swing`` and ``lift``
(4), ``legs`` and ``toes`` (5), and ``easing``, the curves over frames they share. This
module runs them in order (``solve_ik``), a character of another size than a human's
solved at a human's.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace

import numpy as np
from scipy.ndimage import gaussian_filter1d, maximum_filter1d

from ..clips.body import scaled_bases, scaled_points, scaled_rig
from .offsets import body_offsets, smooth_offsets
from ..clips.rig import Rig, forward_kinematics
from ..base.settings import Settings
from ..base.timing import StageTimer
from .easing import _frame_rate, planted_either_side
from .legs import MAX_REACH, SIDES, _Legs, _legs_in_world, _solve_legs, body_frames
from .lift import _ground_lift, _kept_over_footprints_need, _swing_planes
from .reach import _drop_budget, _reach_drop, _swing_within_reach
from .swing import CLIMB_MIN, _all_frame_targets, _low_swing
from .targets import BodyMotion, FootPoints, Footprints, FootTargets, foot_targets
from .toes import _tip_lift, sole_points, toe_bend, toe_tip

#: s: the finest level of the body's height offset (3.8.1) where the feet stand at
#: different heights (``_on_steps``): it changes between stances over about this long.
BODY_RISE_FINE = 0.25


@dataclass
class IKResult:
    body_pos: np.ndarray  # (F, 3)
    body_heading: np.ndarray  # (F,)
    basis: np.ndarray  # (F, B, 4, 4) pose bases after IK
    targets: FootTargets
    hips_drop: np.ndarray  # (F,) m the hips were lowered to keep the legs in reach
    body_offset: tuple[np.ndarray, np.ndarray]  # (dp (F, 3), dpsi (F,)) from 3.8.1
    seconds: dict = field(default_factory=dict)  # s each part took (targets, body_offset, reach, legs, total)

    @property
    def frames(self) -> int:
        return len(self.body_heading)


def solve_ik(rig: Rig, basis: np.ndarray, body: BodyMotion, points: FootPoints, footprints: Footprints,
             forward: np.ndarray, settings: Settings | None = None, ground_z=None,
             still: np.ndarray | None = None) -> IKResult:
    """Thesis 3.8 on a synthesized motion. ``basis`` (F, B, 4, 4) the blended pose
    (``pose.pose_bases``), the body on ``body`` (its times, position, heading and
    ``spin``, ``BodyMotion``); ``points`` the feet's heel
    and ball in their bones' frames; ``footprints`` and their planted ranges from the
    synthesis. ``ground_z(points (M, 3)) -> heights (M,)`` (NaN where there is no
    surface) lets a swinging foot clear the ground: where the heel or the toe would pass
    under the surface, the ankle is lifted by that much. ``still``
    (F,) 0..1: how far the body keeps its place over the ground where the synthesis put
    it, the body offset moving it only up and down there (a turn in place: the legs
    reach the pivot steps, the body stays over its spot).
    Returns the adjusted body and pose bases.

    A character of another size than a human's (``Settings.body_scale``) is solved at a
    human's size (every length it is given divided by its scale, this module's own
    lengths as they are) and the result scaled back."""
    settings = settings or Settings()
    k = settings.body_scale
    if abs(k - 1.0) > 1e-12:
        return _solved_at_human_size(rig, basis, body, points, footprints, forward, settings, ground_z, still)
    t, body_pos, body_heading, spin = body.t, body.pos, body.heading, body.spin
    heel_local, toe_local = points.heel_local, points.toe_local
    timer = StageTimer()
    t0 = time.perf_counter()
    with timer("targets"):
        legs = _Legs.of(rig)
        pose = forward_kinematics(rig, basis, bones=list(legs.foot) + list(legs.toe_bones))
        yaw = spin + np.asarray(body_heading, float)
        tg = foot_targets(rig, points, _legs_in_world(pose, legs, body_pos, yaw), t, footprints, forward,
                          settings.balance_band)
        sole = [sole_points(rig, pose, SIDES[k], heel_local[k, :3], toe_local[k, :3]) for k in range(2)]
    with timer("body_offset"):  # 3.8.1
        body_pos, yaw, offset = _offset_body(pose, legs, tg, t, body_pos, yaw, settings, still)
        world = _legs_in_world(pose, legs, body_pos, yaw)
    with timer("reach"):
        budget = _drop_budget(np.asarray(body_pos, float)[:, 2] - offset[0][:, 2], tg, offset[0][:, 2],
                              _frame_rate(t))
        drop = _reach_drop(world, legs, tg, _frame_rate(t), budget, heel_local[:, :3], toe_local[:, :3])
        body_pos = body_pos - drop[:, None] * [0.0, 0.0, 1.0]
        world[:, legs.chain, 2, 3] -= drop[:, None]
    with timer("legs"):  # 3.8.2
        ankle_t, rot_t, lift, bend = _leg_targets(rig, world, legs, tg, sole, toe_local, footprints, ground_z, still,
                                                  _frame_rate(t))
        basis = _solve_legs(rig, basis, pose, world, legs, ankle_t, rot_t, lift, yaw,
                            (bend, toe_local[:, :3] - heel_local[:, :3]))
    timer.seconds["total"] = time.perf_counter() - t0
    return IKResult(body_pos, yaw - spin, basis, tg, drop, offset, timer.seconds)


def _leg_targets(rig: Rig, world: np.ndarray, legs: _Legs, tg: FootTargets, sole: list, toe_local: np.ndarray,
                 footprints: Footprints, ground_z, still: np.ndarray | None, fps: float
                 ) -> tuple[np.ndarray, np.ndarray, list, list]:
    """What the legs are solved to (steps 4 and 5), with the body and the hips placed
    (the legs' bones in ``world``): every frame's ankle targets (2, F, 3) and foot
    rotations (2, F, 3, 3) (planted on the footprints ``tg``, the swings between them,
    pivot steps kept low as far as ``still``, kept over a footprint where the ground
    ``ground_z`` would lift the foot too fast), the lift of each ankle over the ground
    (2 x (F,) m; a foot without a toe bone lifted onto its tip), swinging ankles drawn
    into reach, and each toe's bend (2 x (F,) rad) so its tip stays out of the
    footprint. ``sole`` each foot's ``sole_points``, ``toe_local`` (2, 4) its ball;
    frames at ``fps``."""
    planes = [_swing_planes(tg.footprint[k], np.asarray(footprints.pos, float), np.asarray(footprints.normal, float))
              for k in range(2)]
    ankle_t, rot_t = _all_frame_targets(world, legs, tg, ground_z)
    if still is not None:
        ankle_t = np.stack([_low_swing(ankle_t[k], tg.weight[k] >= 1.0, still) for k in range(2)])
    need = [None, None]
    for k in range(2):
        ankle_t[k], rot_t[k], need[k] = _kept_over_footprints_need(
            ankle_t[k], rot_t[k], tg.weight[k] >= 1.0, sole[k], planes[k], ground_z, fps,
            world[:, legs.thigh[k], :3, 3], MAX_REACH * (legs.thigh_len[k] + legs.shin_len[k]))
    lift = [_ground_lift(ankle_t[k], rot_t[k], tg.weight[k] >= 1.0, sole[k], planes[k], ground_z, fps,
                         need[k]) for k in range(2)]
    for k in range(2):
        ankle_t[k] = _swing_within_reach(ankle_t[k], lift[k], tg.weight[k] < 1.0, world[:, legs.thigh[k], :3, 3],
                                         legs.thigh_len[k] + legs.shin_len[k], fps)
    bend = [toe_bend(ankle_t[k] + lift[k][:, None] * [0.0, 0.0, 1.0], rot_t[k], tg.weight[k] >= 1.0,
                     sole[k][2], toe_local[k, :3], planes[k], fps) for k in range(2)]
    for k in range(2):  # (a foot without a toe bone stands on its tip: lifted, not bent)
        if rig.foot_chain(SIDES[k])[1] is None:
            lift[k] = _tip_lift(ankle_t[k], lift[k], rot_t[k], tg.weight[k] >= 1.0, sole[k][2], planes[k], fps)
    return ankle_t, rot_t, lift, bend


def _solved_at_human_size(rig: Rig, basis, body: BodyMotion, points: FootPoints, footprints: Footprints,
                          forward, settings: Settings, ground_z, still) -> IKResult:
    """``solve_ik`` of a character ``k = settings.body_scale`` times a human's size: solved
    on everything divided by ``k`` (the settings at a human's size), its lengths
    multiplied back."""
    k = settings.body_scale
    inv = 1.0 / k
    gz = None if ground_z is None else (lambda p: np.asarray(ground_z(np.asarray(p, float) * k), float) * inv)
    r = solve_ik(scaled_rig(rig, inv), scaled_bases(basis, inv), replace(body, pos=np.asarray(body.pos, float) * inv),
                 FootPoints(scaled_points(points.heel_local, inv), scaled_points(points.toe_local, inv)),
                 replace(footprints, pos=np.asarray(footprints.pos, float) * inv), forward, settings.for_body(1.0),
                 gz, still)
    tg = r.targets
    targets = FootTargets(tg.weight, tg.footprint, tg.pin * k, tg.pin_local * k, tg.foot_rot, tg.ankle * k)
    dp, dpsi = r.body_offset
    return IKResult(r.body_pos * k, r.body_heading, scaled_bases(r.basis, k), targets, r.hips_drop * k,
                    (dp * k, dpsi), r.seconds)


def _offset_body(pose: np.ndarray, legs: _Legs, tg: FootTargets, t: np.ndarray, body_pos: np.ndarray,
                 yaw: np.ndarray, settings: Settings, still: np.ndarray | None = None):
    """Thesis 3.8.1: the body (object position ``body_pos`` (F, 3) m, world yaw ``yaw``
    (F,) rad) pulled and turned so the pinned points (where fully planted) reach their
    targets, the offsets spread over time (``offsets.smooth_offsets``; zero when no frame
    is planted; held over its place as far as ``still`` (F,)). ``pose`` (F, B, 4, 4)
    armature space, ``t`` (F,) s. Returns (body
    position (F, 3), yaw (F,), (dp (F, 3), dpsi (F,)))."""
    F = len(t)
    # the pinned points in armature space: that is the body frame turned by the object's
    # yaw, so it is p_loc in a frame turned by the body heading's world yaw
    p_loc = np.zeros((2, F, 3))
    for k in range(2):
        p_loc[k] = (pose[:, legs.foot[k]] @ np.c_[tg.pin_local[k], np.ones(F)][..., None])[:, :3, 0]
    planted_mask = tg.weight >= 1.0 - 1e-9
    dp, dpsi = body_offsets(np.asarray(body_pos, float), yaw, p_loc, tg.pin, planted_mask,
                            alpha=settings.ik_alpha, beta=settings.ik_beta, iterations=settings.ik_iterations)
    if np.isfinite(dpsi).any():
        # where the feet stand at different heights (stairs, a kerb) the height offset on
        # a coarser finest level: the stances' offsets differ by centimetres, fitted two
        # frames apart the body jolts (elsewhere, a take-off's push needs the fine fit)
        w = _on_steps(tg, _frame_rate(t))
        if w.any():
            dp, dpsi, rise = smooth_offsets(t, dp, dpsi, also_fine=BODY_RISE_FINE)
            dp[:, 2] += w * (rise[:, 2] - dp[:, 2])
        else:
            dp, dpsi = smooth_offsets(t, dp, dpsi)
    else:
        dp, dpsi = np.zeros((F, 3)), np.zeros(F)
    if still is not None:  # (held over its place as far as ``still``: up and down only)
        dp[:, :2] *= 1.0 - np.clip(np.asarray(still, float), 0.0, 1.0)[:, None]
    return np.asarray(body_pos, float) + dp, yaw + dpsi, (dp, dpsi)


def _on_steps(tg: FootTargets, fps: float) -> np.ndarray:
    """(F,) 0..1: how far each frame lies where the two feet's last footprints differ in
    height by more than CLIMB_MIN (on stairs, at a kerb), eased over BODY_RISE_FINE."""
    F = tg.weight.shape[1]
    z = np.zeros((2, F))
    for k in range(2):
        on = tg.weight[k] >= 1.0 - 1e-9
        if not on.any():
            return np.zeros(F)
        last = planted_either_side(on)[0]
        last = np.where(last < 0, np.flatnonzero(on)[0], last)
        z[k] = tg.pin[k, last, 2]
    win = max(1, int(round(BODY_RISE_FINE * fps)))
    step = (np.abs(z[0] - z[1]) > CLIMB_MIN).astype(float)
    return np.clip(gaussian_filter1d(maximum_filter1d(step, 2 * win + 1), win / 2.0), 0.0, 1.0)


# (``body_frames`` and ``toe_tip``, of the parts, are imported from here across the package)
__all__ = ["BodyMotion", "IKResult", "body_frames", "solve_ik", "toe_tip"]
