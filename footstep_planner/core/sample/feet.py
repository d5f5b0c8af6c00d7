"""A sample clip's feet (``gait``'s step 3): each foot planted and rolling through its
stances (heel strike with the toes up, pivoting on the back of the heel to flat, flat, the
heel rising as the foot pivots on its ball to toe off; the pivots exact, so nothing
slides), and swinging between them on a smoothstep with clearance; the toes bent to stay
flat on the ground while the heel is up (``_feet``).

Armature space of the mannequin: Z up, metres, heading 0 faces -Y; foot 0 is the left.
Never imports bpy.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from ..solve.easing import smoothstep
from ..clips.rig import Rig
from .course import _Course, _yaw_matrices
from .specs import SIDES, Gait, GaitStance

#: The back of the heel is this far behind the ankle, m.
HEEL_BACK = 0.045


@dataclass(frozen=True)
class _FootRest:
    """One foot bone at rest, and the ground points its roll pivots about (armature
    space, m; the rest foot stands flat on z = 0)."""

    rest: np.ndarray  # (4, 4) the foot bone's rest matrix
    heel_g: np.ndarray  # (3,) the ground under the ankle
    ball_g: np.ndarray  # (3,) the ground under the ball joint
    ball_j: np.ndarray  # (3,) the ball joint (the toe bone's head)
    heel_back: np.ndarray  # (3,) the back of the heel on the ground: the heel rocker's pivot

    @classmethod
    def of(cls, rig: Rig, side: str, heel_back_m: float) -> "_FootRest":
        """The foot of ``side`` ("l" or "r"), its heel ``heel_back_m`` m behind the ankle
        (away from the ball)."""
        rest_foot = rig.rest[rig.foot_chain(side)[0]]
        heel_g = rest_foot[:3, 3] * [1, 1, 0]
        ball_j = rig.ball_local(side)[:3] @ rest_foot[:3, :3].T + rest_foot[:3, 3]
        ball_g = ball_j * [1, 1, 0]
        # the heel rocker pivots on the back of the heel, behind the ankle: the ankle rises
        # as the toes do (it is lowest with the foot flat, where the analysis finds its stance)
        heel_back = heel_g + heel_back_m * (heel_g - ball_g) / np.linalg.norm(heel_g - ball_g)
        return cls(rest_foot, heel_g, ball_g, ball_j, heel_back)


def _feet(rig: Rig, course: _Course, g: Gait, size: float) -> tuple[np.ndarray, np.ndarray]:
    """Both feet's tracks (``_foot_track``): armature-space foot matrices (2, F, 4, 4) and
    toe bends (2, F) radians; foot 0 is the left."""
    F = len(course.t)
    foot_m = np.zeros((2, F, 4, 4))
    toe_bend = np.zeros((2, F))
    for i, side in enumerate(SIDES):
        foot = _FootRest.of(rig, side, HEEL_BACK * size)
        foot_m[i], toe_bend[i] = _foot_track(course.t, [st for st in course.stances if st.foot == i], foot, g,
                                             course.cycle)
    return foot_m, toe_bend


#: The swing's lift u (1 - u)^2 (peaking early, at u = 1/3) times this peaks at 1.
SWING_LIFT_NORM = 6.75
#: Share of the swing over which the toes ease back from toe off to straight.
TOE_EASE = 0.6


def _foot_track(t, stances, foot: _FootRest, g: Gait, T: float):
    """(F, 4, 4) armature-space matrices of one foot bone at frame times ``t`` (F,) s:
    planted and rolling during its ``stances`` (time order), swinging in between; and (F,)
    how far the toes bend up (radians) to stay flat on the ground while the heel is up
    (easing back early in the swing). ``T`` s the cycle (a stance open at a clip's end
    rolls as if it lasted the gait's duty share of it)."""
    out = np.zeros((len(t), 4, 4))
    bend = np.zeros(len(t))
    nominal = g.duty * T
    for st in stances:
        m = (t >= st.strike) & (t <= st.liftoff)
        if m.any():
            out[m] = _rolling(st, t[m], foot, g, nominal)
            bend[m] = np.maximum(_pitch_of(out[m], foot.rest), 0.0)
    for a, b in zip(stances[:-1], stances[1:]):
        m = (t > a.liftoff) & (t < b.strike)
        if m.any():
            out[m], bend[m] = _swing(t[m], a, b, foot, g, nominal)
    return out, bend


def _rolling(st: GaitStance, tq, foot: _FootRest, g: Gait, nominal: float) -> np.ndarray:
    """(n, 4, 4) the foot planted on stance ``st``'s footprint at times ``tq`` (n,) s
    inside it: heel strike with the toes up (the gait's strike pitch), pivoting on the
    back of the heel to flat over its heel-rocker share of the stance; flat; then the
    heel rising (to the toe-off pitch at liftoff), pivoting on the ball over its
    toe-rocker share. A stance open at a clip's end (infinite strike or liftoff) does
    not roll at that end and counts as ``nominal`` s long."""
    a_start = st.strike if np.isfinite(st.strike) else None
    a_end = st.liftoff if np.isfinite(st.liftoff) else None
    dur = (a_end - a_start) if (a_start is not None and a_end is not None) else nominal
    pitch = np.zeros(len(tq))
    pivot = np.zeros((len(tq), 3))
    pivot[:] = foot.heel_back
    toe = np.zeros(len(tq), bool)
    if a_start is not None:
        u = (tq - a_start) / (g.heel_rocker * dur)
        pitch -= np.where(u < 1, g.strike_pitch * (1 - smoothstep(u)), 0.0)
    if a_end is not None:
        u = (tq - (a_end - g.toe_rocker * dur)) / (g.toe_rocker * dur)
        toe = u > 0
        pitch += np.where(toe, g.toeoff_pitch * np.clip(u, 0.0, 1.0) ** 2, 0.0)
        # the foot rolls over the ball: about the ground under its joint, raised so the
        # joint keeps its height (the toes stay flat on the ground)
        pivot[toe] = foot.ball_g
    m = _placed(st, pitch, pivot, foot.rest, foot.heel_g)
    m[toe, 2, 3] += foot.ball_j[2] * (1.0 - np.cos(pitch[toe]))
    return m


def _swing(tq, a: GaitStance, b: GaitStance, foot: _FootRest, g: Gait, nominal: float) -> tuple[np.ndarray, np.ndarray]:
    """The foot between stances ``a`` and ``b`` at times ``tq`` (n,) s: (n, 4, 4) matrices
    moving on a smoothstep from its toe-off pose to its heel-strike pose, lifted by ``b``'s
    clearance (peaking early: the foot leaves briskly, and lands softly), turning
    smoothly, and never with the heel or ball under the ground; and (n,) the toe bend,
    easing back from the toe-off pitch over TOE_EASE of the swing."""
    m0 = _rolling(a, np.array([a.liftoff]), foot, g, nominal)[0]
    m1 = _rolling(b, np.array([b.strike]), foot, g, nominal)[0]
    u = (tq - a.liftoff) / (b.strike - a.liftoff)
    # (a smoothstep, not a minimum-jerk profile: its peak speed is 20 % lower, which
    # spares the thigh a whip through mid swing)
    w = smoothstep(u)
    out = np.zeros((len(tq), 4, 4))
    out[:, :3, 3] = (1 - w)[:, None] * m0[:3, 3] + w[:, None] * m1[:3, 3]
    out[:, 2, 3] += b.clearance * (SWING_LIFT_NORM * u * (1 - u) ** 2)
    rel = Rotation.from_matrix(m0[:3, :3].T @ m1[:3, :3]).as_rotvec()
    out[:, :3, :3] = m0[:3, :3] @ Rotation.from_rotvec(w[:, None] * rel).as_matrix()
    out[:, 3, 3] = 1.0
    out[:, 2, 3] += _under_ground(out, foot)  # the swing's ends are on the ground
    return out, g.toeoff_pitch * (1.0 - smoothstep(u / TOE_EASE))


def _under_ground(m, foot: _FootRest) -> np.ndarray:
    """(n,) m, >= 0: how far the lower of the heel and ball ground points of ``foot``
    lies under z = 0 with the foot bone at ``m`` (n, 4, 4)."""
    lift = np.zeros(len(m))
    for q in (foot.heel_g, foot.ball_g):
        local = np.linalg.inv(foot.rest) @ np.append(q, 1.0)
        z = np.einsum("fij,j->fi", m, local)[:, 2]
        lift = np.maximum(lift, -z)
    return lift


def _pitch_of(m, rest_foot) -> np.ndarray:
    """Heel-up pitch (radians) of foot matrices (F, 4, 4) relative to the rest foot."""
    fwd = np.einsum("fij,j->fi", m[:, :3, :3], rest_foot[:3, :3].T @ [0.0, -1.0, 0.0])
    return np.arctan2(-fwd[:, 2], np.hypot(fwd[:, 0], fwd[:, 1]))


def _placed(st: GaitStance, pitch, pivot, rest_foot, heel_g) -> np.ndarray:
    """(n, 4, 4) the rest foot (``rest_foot`` (4, 4), its ground point under the ankle
    ``heel_g`` (3,)) laid on stance st's footprint (that heel ground point on st.pos,
    turned to st.heading), pitched by ``pitch`` (n,) radians (positive: heel up) about
    ``pivot`` (n, 3) (rest coordinates on the ground)."""
    n = len(pitch)
    Rp = Rotation.from_rotvec(np.c_[pitch, np.zeros(n), np.zeros(n)]).as_matrix()
    Rz = _yaw_matrices(st.heading)[0]
    out = np.tile(np.eye(4), (n, 1, 1))
    out[:, :3, :3] = Rz @ Rp @ rest_foot[:3, :3]
    # x -> P + Rp (x - P), then the heel ground point to st.pos
    local = pivot + np.einsum("fij,fj->fi", Rp, rest_foot[:3, 3] - pivot)
    out[:, :3, 3] = np.einsum("ij,fj->fi", Rz, local - heel_g) + np.r_[st.pos, 0.0]
    return out
