"""A sample clip's body over its feet, and its legs (``gait``'s steps 4 and 5): the
hips' height (bobbing, a jump's ballistic flight, an idle's dips), sway over the standing
foot, rotation with the legs and lean (forward with speed and acceleration, into turns),
lowered smoothly where a leg could not reach its foot (``_hips_bases``); the legs solved
with ``legs.two_bone`` (knee forward) so the feet take their tracks (``_legs``), the toes
bent (``_toes``), the spine, arms and elbows swinging against the legs (``_upper_body``).

Armature space of the mannequin: Z up, metres, heading 0 faces -Y; foot 0 is the left.
Never imports bpy.
"""

from __future__ import annotations

import numpy as np
from scipy.ndimage import gaussian_filter1d
from scipy.spatial.transform import Rotation

from ..solve.easing import lower_smoothly, smoothstep
from ..solve.legs import chain_bases, leg_lengths, reach_need, two_bone
from ..clips.rig import Rig, forward_kinematics
from .course import G, _Course, _lean, _left, _yaw_matrices
from .specs import SIDES, ClipSpec, Gait

#: The legs are kept within this share of their length (the knee never locks).
REACH = 0.975
#: Idle: the sway signal's amplitude (of the walk's +-1), one sway over the clip ...
IDLE_SWAY_SIGNAL = 0.6
#: ... the hips' sway at its peak (m, mannequin scale) ...
IDLE_SWAY = 0.03
#: ... and half the depth of the hips' dip (m, mannequin scale), twice over the clip.
IDLE_DIP = 0.004
#: m the hips crouch before a jump's take-off and after its landing (mannequin scale) ...
JUMP_DIP = 0.06
#: ... over this many seconds either side.
JUMP_CROUCH = 0.25
#: Forward lean (radians) per m/s^2 of acceleration ...
ACCEL_LEAN = 0.03
#: ... the speed smoothed over this (s, the Gaussian's sigma) first.
ACCEL_SMOOTH = 0.15
#: s either side of a frame whose foot is out of reach over which the hips come down.
REACH_WINDOW = 0.12


def _idle_sway(t) -> np.ndarray:
    """The idle clip's sway signal (F,): one slow sway over the clip, IDLE_SWAY_SIGNAL at
    its peaks (the walk's is +-1)."""
    return IDLE_SWAY_SIGNAL * np.sin(2 * np.pi * t / t[-1])


def _hips_height(course: _Course, sigma, spec: ClipSpec, stand_height: float, size: float) -> np.ndarray:
    """(F,) m the hips' height: the gait's, bobbing with the sway signal ``sigma`` (F,)
    (walking highest at mid-stance, running lowest), eased from ``stand_height`` by the
    share of full speed; an idle clip's dips twice by up to 2 IDLE_DIP (times ``size``)."""
    g, t = spec.gait, course.t
    if spec.kind == "idle":
        return stand_height - IDLE_DIP * size * (1 - np.cos(4 * np.pi * t / t[-1]))
    bob = (-1.0 if g.name == "run" else 1.0) * g.bob * (2 * sigma ** 2 - 1)
    return stand_height + (g.height - stand_height + bob) * course.ramp


def _jump_flight(course: _Course, height, foot_m, size: float) -> np.ndarray:
    """(F,) m the hips' height ``height`` (F,) with the jump's flight a ballistic arc
    (``_ballistic``, a JUMP_DIP crouch either side, times ``size``); the swinging feet of
    ``foot_m`` (2, F, 4, 4) rise with the body (in place)."""
    t = course.t
    flying = _ballistic(t, height, course.stances, dip=JUMP_DIP * size)
    rise = np.maximum(flying - height, 0.0)
    for k in range(2):
        down = np.zeros(len(t), bool)
        for st in course.stances:
            down |= (st.foot == k) & (t >= st.strike) & (t <= st.liftoff)
        foot_m[k, ~down, 2, 3] += rise[~down]
    return flying


def _body_frame(course: _Course, sigma, lift, height, spec: ClipSpec, size: float, fps: float
                ) -> tuple[np.ndarray, np.ndarray]:
    """The hips' armature-space position (F, 3) m and rotation (F, 3, 3): on the path,
    swaying over the standing foot (the sway signal ``sigma`` (F,)) at ``height`` (F,);
    turned to the heading less the pelvis's rotation with the legs (``lift`` (F,)),
    leaning forward with speed and acceleration (ACCEL_LEAN, the speed smoothed over
    ACCEL_SMOOTH s), into turns, and listing with the sway."""
    g, t, v, ramp = spec.gait, course.t, course.v, course.ramp
    sway = (g.sway if spec.kind != "idle" else IDLE_SWAY * size) * sigma * np.maximum(ramp, spec.kind == "idle")
    pos = np.c_[course.root + sway[:, None] * _left(course.heading), height]
    accel_lean = np.gradient(gaussian_filter1d(v, ACCEL_SMOOTH * fps, mode="nearest"), t) * ACCEL_LEAN
    pitch = g.lean * ramp + accel_lean
    roll = _lean(spec, v) - g.pelvis_roll * sigma * ramp
    yaw = course.heading - g.pelvis_yaw * lift * ramp
    return pos, _yaw_matrices(yaw) @ Rotation.from_euler("YX", np.c_[roll, pitch]).as_matrix()


def _hips_bases(rig: Rig, pos, R_body, foot_m, loop: bool, fps: float) -> tuple[np.ndarray, np.ndarray]:
    """(pose bases (F, B, 4, 4), the others at rest, with the hips at ``pos`` (F, 3) m
    turned by ``R_body`` (F, 3, 3) and lowered where a leg could not reach its foot
    (``foot_m`` (2, F, 4, 4)); that drop (F,) m (``_reach_drop``))."""
    F = len(pos)
    basis = np.tile(np.eye(4), (F, len(rig.names), 1, 1))
    hips = rig.role_index("hips")
    rest_h = rig.rest[hips]
    arm_h = np.tile(np.eye(4), (F, 1, 1))
    arm_h[:, :3, :3] = R_body @ rest_h[:3, :3]
    arm_h[:, :3, 3] = pos
    drop = _reach_drop(rig, pos, R_body, foot_m, loop, fps)
    arm_h[:, 2, 3] -= drop
    basis[:, hips] = np.linalg.inv(rest_h)[None] @ arm_h
    return basis, drop


def _reach_drop(rig: Rig, pos, R_body, foot_m, loop: bool, fps: float) -> np.ndarray:
    """(F,) m to lower the hips (at ``pos`` (F, 3), turned by ``R_body`` (F, 3, 3)) so
    each ankle of ``foot_m`` (2, F, 4, 4) lies within REACH of its leg's length, coming
    and going smoothly over REACH_WINDOW s; wrapping around for a ``loop`` (its last
    frame is its first)."""
    hips = rig.role_index("hips")
    thigh = [rig.role_index(f"thigh_{x}") for x in SIDES]
    need = np.zeros(len(pos))
    for k in range(2):
        H = pos + np.einsum("fij,j->fi", R_body, rig.rest[thigh[k], :3, 3] - rig.rest[hips, :3, 3])
        need = np.maximum(need, reach_need(H, foot_m[k, :, :3, 3], REACH * sum(leg_lengths(rig, SIDES[k]))))
    win = max(1, int(round(REACH_WINDOW * fps)))
    if loop:
        drop = lower_smoothly(np.maximum(need[:-1], 0.0), win, mode="wrap", edge="wrap")
        return np.maximum(np.r_[drop, drop[:1]], need)
    drop = lower_smoothly(np.maximum(need, 0.0), win, edge="nearest")
    return np.maximum(drop, need)


def _legs(rig: Rig, basis, foot_m, heading) -> None:
    """Solve both legs of pose bases ``basis`` (F, B, 4, 4) in place (``two_bone``, the
    knee forward along ``heading`` (F,)) so the feet take ``foot_m`` (2, F, 4, 4)."""
    feet = [rig.foot_chain(x)[0] for x in SIDES]
    pose = forward_kinematics(rig, basis, bones=feet)
    fwd = np.c_[np.sin(heading), -np.cos(heading), np.zeros(len(heading))]
    for k, side in enumerate(SIDES):
        th, sh, ft = rig.role_index(f"thigh_{side}"), rig.role_index(f"shin_{side}"), feet[k]
        L1, L2 = leg_lengths(rig, side)
        Wt, Ws, Wf = pose[:, th], pose[:, sh], pose[:, ft]
        r1, r2 = two_bone(Wt[:, :3, 3], Ws[:, :3, 3], Wf[:, :3, 3], foot_m[k, :, :3, 3], L1, L2, fwd)
        arm = {th: r1 @ Wt[:, :3, :3], sh: r2 @ r1 @ Ws[:, :3, :3], ft: foot_m[k, :, :3, :3]}
        chain_bases(rig, [th, sh, ft], pose[:, rig.parents[th], :3, :3], arm, basis)


def _toes(rig: Rig, basis, toe_bend) -> None:
    """The toes of pose bases ``basis`` (F, B, 4, 4) bent up by ``toe_bend`` (2, F)
    radians (in place; about the foot's width) as the heel rises."""
    F = toe_bend.shape[1]
    for k, side in enumerate(SIDES):
        toe = rig.foot_chain(side)[1]
        if toe is not None:
            R = rig.rest[toe, :3, :3]
            D = Rotation.from_rotvec(np.c_[-toe_bend[k], np.zeros(F), np.zeros(F)]).as_matrix()
            basis[:, toe, :3, :3] = R.T @ D @ R


def _sway_signal(t, stances) -> np.ndarray:
    """+1 at the left foot's mid-stances, -1 at the right's, cosine in between (0 where
    both feet stand)."""
    knots = sorted((st.center, st.foot) for st in stances if np.isfinite(st.strike) and np.isfinite(st.liftoff))
    if len(knots) < 2:
        return np.zeros(len(t))
    tk = np.array([k[0] for k in knots])
    val = np.array([1.0 if k[1] == 0 else -1.0 for k in knots])
    i = np.clip(np.searchsorted(tk, t) - 1, 0, len(tk) - 2)
    u = np.clip((t - tk[i]) / (tk[i + 1] - tk[i]), 0.0, 1.0)
    w = 0.5 - 0.5 * np.cos(np.pi * u)
    out = (1 - w) * val[i] + w * val[i + 1]
    # outside the knots (standing), fade to 0
    out = np.where(t < tk[0], val[0] * smoothstep(1 - (tk[0] - t) / 0.5), out)
    out = np.where(t > tk[-1], val[-1] * smoothstep(1 - (t - tk[-1]) / 0.5), out)
    return out


def _leg_forward(foot_m, root, heading, g, spec) -> np.ndarray:
    """How far the left foot is ahead of the right, along the heading, in half strides
    (about -1 .. 1): drives the pelvis's rotation and the arms."""
    fwd = np.c_[np.sin(heading), -np.cos(heading)]
    ahead = [np.einsum("fi,fi->f", foot_m[k, :, :2, 3] - root, fwd) for k in range(2)]
    half = max(0.5 * spec.v * g.cycle * 0.5, 0.05)
    return np.clip((ahead[0] - ahead[1]) / (2 * half), -1.5, 1.5)


def _ballistic(t, height, stances, dip: float = JUMP_DIP) -> np.ndarray:
    """(F,) the hips' height ``height`` (F,) m at times ``t`` (F,) s with the longest
    flight (no foot down in ``stances``) replaced by a ballistic arc (gravity) that meets
    the height profile at take-off and landing, and a crouch ``dip`` m deep over
    JUMP_CROUCH s before the take-off and after the landing (then Gaussian-smoothed,
    sigma one frame)."""
    down = np.zeros(len(t), bool)
    for st in stances:
        down |= (t >= st.strike) & (t <= st.liftoff)
    air = np.flatnonzero(~down)
    if not len(air):
        return height
    runs = np.split(air, np.flatnonzero(np.diff(air) > 1) + 1)
    r = max(runs, key=len)
    a, b = r[0] - 1, r[-1] + 1
    ta, tb = t[a], t[b]
    za, zb = height[a], height[b]
    vz = (zb - za) / (tb - ta) + 0.5 * G * (tb - ta)
    out = height.copy()
    tt = t[a:b + 1] - ta
    out[a:b + 1] = za + vz * tt - 0.5 * G * tt ** 2
    # ease the stances either side into the arc's take-off and landing speeds: a crouch
    # before the take-off and after the landing
    w = JUMP_CROUCH
    pre = (t > ta - w) & (t <= ta)
    post = (t >= tb) & (t < tb + w)
    out[pre] -= dip * np.sin(np.pi * (t[pre] - (ta - w)) / w) ** 2
    out[post] -= dip * np.sin(np.pi * (t[post] - tb) / w) ** 2
    return gaussian_filter1d(out, 1.0, mode="nearest")


def _upper_body(rig: Rig, basis, lift, sigma, ramp, g: Gait, spec: ClipSpec, t) -> None:
    """Spine counter-rotation, a level head, arm swing against the legs, bent elbows."""
    names = set(rig.names)

    def put(bone, rotvec):
        if bone not in names:
            return
        b = rig.index(bone)
        R = rig.rest[b, :3, :3]
        D = Rotation.from_rotvec(rotvec).as_matrix()
        basis[:, b, :3, :3] = R.T @ D @ R

    F = len(t)
    z = np.zeros(F)
    counter = g.pelvis_yaw * lift * ramp * 0.55
    for bone in ("spine.001", "spine.002", "spine.003"):
        put(bone, np.c_[z, z, counter])
    roll = _lean(spec, ramp * spec.v)
    put("spine.004", np.c_[-0.5 * g.lean * ramp, -0.25 * roll, z])
    put("spine.005", np.c_[-0.3 * g.lean * ramp, -0.25 * roll, z])
    breathe = 0.015 * np.sin(2 * np.pi * t / 3.2) if spec.kind == "idle" else z
    put("spine.002", np.c_[breathe, z, counter])
    for k, side in enumerate(("L", "R")):
        sgn = 1.0 if k == 0 else -1.0
        swing = g.arm_swing * sgn * lift * ramp
        # the arms hang a little out from the body
        put(f"upper_arm.{side}", np.c_[swing + 0.05 * ramp, -sgn * np.radians(6) * np.ones(F), z])
        elbow = np.radians(12) + (g.elbow - np.radians(12) + g.elbow_swing * (-sgn * lift)) * ramp
        put(f"forearm.{side}", np.c_[-elbow, z, z])
