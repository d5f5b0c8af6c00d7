"""A sampled clip: root motion separated from the pose, and the heel and toe points.

Conventions: armature space of the clip's rig (Z up, metres); the clip's ground is the
plane z = 0. Heading (yaw) is a rotation about +Z in radians, 0 when the character faces
its rest-pose forward (for most rigs -Y), positive when turned to the character's left
(counter-clockwise seen from above). Foot index 0 is the left foot, 1 the right.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy.interpolate import CubicSpline

from .body import body_scale
from .rig import Rig, forward_kinematics

SIDES = ("l", "r")
FOOT_NAMES = ("L", "R")


@dataclass(frozen=True)
class ClipMotion:
    """One clip sampled at ``fps``: everything the analysis and the planner read of it."""

    name: str
    fps: float
    frame0: float  # scene frame of sample 0
    times: np.ndarray  # (N,) seconds since sample 0
    root_pos: np.ndarray  # (N, 3) ground-projected hips position (z = 0)
    root_heading: np.ndarray  # (N,) unwrapped yaw of the character, radians
    hips_in_root: np.ndarray  # (N, 4, 4) the hips' matrix in the root frame
    local_rot: np.ndarray  # (N, B, 3, 3) bone basis rotations (scale removed), the planner's hierarchy
    heel: np.ndarray  # (2, N, 3) heel point of each foot, armature space
    toe: np.ndarray  # (2, N, 3) toe (ball) point of each foot
    heel_local: np.ndarray  # (2, 4) heel point in the foot bone's frame (homogeneous)
    toe_local: np.ndarray  # (2, 4)
    rest_forward: np.ndarray  # (2,) the rig's rest-pose forward direction (x, y): heading 0
    hips_index: int  # index of the hips bone in local_rot
    source_fps: float | None = None
    frame_rate: float | None = None  # scene frames per second (default: fps)
    body_scale: float = 1.0  # the rig's size over a human's (``core.clips.body.body_scale``)
    stand_height: float | None = None  # m: the rig's hips over its feet in its rest pose (standing)

    @property
    def n(self) -> int:
        return len(self.times)

    @property
    def duration(self) -> float:
        return float(self.times[-1] - self.times[0]) if self.n else 0.0

    def frame_of(self, t):
        """Scene frame at clip time ``t`` (seconds)."""
        return self.frame0 + np.asarray(t) * (self.frame_rate or self.fps)

    def root_matrices(self) -> np.ndarray:
        """(N, 4, 4) root frames: translation root_pos, rotation root_heading about Z."""
        return root_frames(self.root_pos, self.root_heading)

    def moved(self, yaw: np.ndarray, shift: np.ndarray) -> "ClipMotion":
        """The clip carried by a planar rigid motion per sample: turned by ``yaw`` (N,)
        radians about the armature's Z axis, then moved by ``shift`` (N, 2) m in XY. The
        root, its heading and the heel and toe points move; the pose (bone rotations,
        the hips in the root frame) is the clip's own."""
        yaw = np.asarray(yaw, dtype=np.float64)
        return replace(self, root_pos=_turn_shift(self.root_pos, yaw, shift),
                       root_heading=self.root_heading + yaw,
                       heel=_turn_shift(self.heel, yaw, shift), toe=_turn_shift(self.toe, yaw, shift))

    def resample(self, fps: float) -> "ClipMotion":
        """The same clip at another rate: cubic splines for positions and headings, and the
        nearest sample for bone rotations (only used for pose comparisons)."""
        t_new = np.arange(0.0, self.duration + 0.5 / fps, 1.0 / fps)
        t_new = t_new[t_new <= self.duration + 1e-9]
        n, m = self.n, len(t_new)
        # (one spline through every column at once: each column's is the one it would have
        # alone, to the bit, at a quarter of the cost of four)
        cols = np.concatenate([self.root_pos, self.root_heading[:, None],
                               np.moveaxis(self.heel, 1, 0).reshape(n, 6), np.moveaxis(self.toe, 1, 0).reshape(n, 6)],
                              axis=1)
        out = CubicSpline(self.times, cols, axis=0)(t_new)
        feet = lambda a: np.ascontiguousarray(np.moveaxis(a.reshape(m, 2, 3), 0, 1))  # noqa: E731
        nearest = np.clip(np.rint(t_new * self.fps).astype(int), 0, self.n - 1)
        return replace(
            self,
            fps=float(fps),
            times=t_new,
            root_pos=out[:, :3].copy(),
            root_heading=out[:, 3].copy(),
            hips_in_root=self.hips_in_root[nearest],
            local_rot=self.local_rot[nearest],
            heel=feet(out[:, 4:10]),
            toe=feet(out[:, 10:16]),
        )


def _turn_shift(p: np.ndarray, yaw: np.ndarray, shift: np.ndarray) -> np.ndarray:
    """Points (..., N, 3) turned by ``yaw`` (N,) about Z, then moved by ``shift`` (N, 2)."""
    c, s = np.cos(yaw), np.sin(yaw)
    shift = np.asarray(shift, dtype=np.float64)
    out = np.array(p, dtype=np.float64, copy=True)
    out[..., 0] = c * p[..., 0] - s * p[..., 1] + shift[:, 0]
    out[..., 1] = s * p[..., 0] + c * p[..., 1] + shift[:, 1]
    return out


def root_frames(pos: np.ndarray, heading: np.ndarray) -> np.ndarray:
    c, s = np.cos(heading), np.sin(heading)
    m = np.zeros((len(heading), 4, 4))
    m[:, 0, 0], m[:, 0, 1], m[:, 1, 0], m[:, 1, 1] = c, -s, s, c
    m[:, 2, 2] = m[:, 3, 3] = 1.0
    m[:, :3, 3] = pos
    return m


def yaw_of(vec_xy: np.ndarray, forward: np.ndarray) -> np.ndarray:
    """Yaw (radians) that turns the horizontal ``forward`` onto each vector (..., >=2)."""
    return np.arctan2(vec_xy[..., 1], vec_xy[..., 0]) - np.arctan2(forward[1], forward[0])


def clip_motion(rig: Rig, name: str, basis: np.ndarray, fps: float, frame0: float = 1.0,
                source_fps: float | None = None, frame_rate: float | None = None) -> ClipMotion:
    """Derive a ClipMotion from pose bases (N, B, 4, 4) sampled at ``fps``.

    Root motion: the hips' head dropped to the ground, and the yaw of the character's
    forward direction carried by the hips. Heel and toe points follow Johansen: the ankle
    and the ball of each foot projected onto the ground at the foot's stance pose (the
    frame where both are lowest), then carried rigidly with the foot bone. The drop is at
    most ``MAX_SOLE_DROP`` of the leg's length. A rig with the soles of its skinned mesh
    (``Rig.sole``, ``core.sole``) has its heel and ball from there instead, the same in
    every clip. ``basis`` is under the rig's planner hierarchy (``core.clips.rig.planner_basis``).
    """
    rig.require_legs()
    basis = np.asarray(basis, dtype=np.float64)
    n = len(basis)
    pose = forward_kinematics(rig, basis)
    hips = rig.role_index("hips")
    fwd = rig.forward_axis()
    fwd_in_hips = np.linalg.inv(rig.rest[hips, :3, :3]) @ fwd
    fwd_now = pose[:, hips, :3, :3] @ fwd_in_hips
    heading = np.unwrap(yaw_of(fwd_now, fwd))
    root_pos = pose[:, hips, :3, 3].copy()
    root_pos[:, 2] = 0.0
    roots = root_frames(root_pos, heading)
    hips_in_root = np.linalg.inv(roots) @ pose[:, hips]

    # The ankle and ball are dropped onto the ground at most this far: a foot's sole lies
    # a few centimetres below them, never a large part of the leg (a floating clip must
    # not be grounded by the projection).
    max_drop = MAX_SOLE_DROP * _hip_to_ankle(rig)
    heel = np.empty((2, n, 3))
    toe = np.empty((2, n, 3))
    heel_local = np.empty((2, 4))
    toe_local = np.empty((2, 4))
    for k, side in enumerate(SIDES):
        foot, _ = rig.foot_chain(side)
        fm = pose[:, foot]
        if rig.sole is not None:  # the mesh's own heel and ball
            heel_local[k], toe_local[k] = rig.sole.local(k)[:2]
            heel[k], toe[k] = (fm @ heel_local[k])[:, :3], (fm @ toe_local[k])[:, :3]
            continue
        ankle = fm[:, :3, 3]
        ball = (fm @ rig.ball_local(side))[:, :3]
        low = np.maximum(ankle[:, 2] - ankle[:, 2].min(), ball[:, 2] - ball[:, 2].min())
        flat = int(np.argmin(low))  # the frame the foot is lowest (flat on the ground)
        inv = np.linalg.inv(fm[flat])
        heel_z = ankle[flat, 2] - min(max(ankle[flat, 2], 0.0), max_drop)
        toe_z = ball[flat, 2] - min(max(ball[flat, 2], 0.0), max_drop)
        heel_local[k] = inv @ np.array([ankle[flat, 0], ankle[flat, 1], heel_z, 1.0])
        toe_local[k] = inv @ np.array([ball[flat, 0], ball[flat, 1], toe_z, 1.0])
        heel[k] = (fm @ heel_local[k])[:, :3]
        toe[k] = (fm @ toe_local[k])[:, :3]

    return ClipMotion(
        name=name, fps=float(fps), frame0=float(frame0), times=np.arange(n) / float(fps),
        root_pos=root_pos, root_heading=heading, hips_in_root=hips_in_root,
        local_rot=_unit_rot(basis[..., :3, :3]), heel=heel, toe=toe, heel_local=heel_local,
        toe_local=toe_local, rest_forward=fwd[:2].copy(), hips_index=hips,
        source_fps=source_fps, frame_rate=frame_rate, body_scale=body_scale(rig), stand_height=_stand_height(rig),
    )


#: The largest drop from ankle or ball to the sole, as a fraction of the leg's length.
MAX_SOLE_DROP = 0.2


def _stand_height(rig: Rig) -> float:
    """m: how high the rig's hips stand over its feet in its rest pose (the hips' head over
    the lower foot's head)."""
    feet = [rig.rest[rig.role_index(f"foot_{side}"), 2, 3] for side in SIDES]
    return float(rig.rest[rig.role_index("hips"), 2, 3] - min(feet))


def _hip_to_ankle(rig: Rig) -> float:
    """Rest distance from thigh head to foot head, the longer leg (straight across the
    knee: shorter than ``body.leg_length``)."""
    out = 0.0
    for side in SIDES:
        a = rig.rest[rig.role_index(f"thigh_{side}"), :3, 3]
        b = rig.rest[rig.role_index(f"foot_{side}"), :3, 3]
        out = max(out, float(np.linalg.norm(a - b)))
    return out


def _unit_rot(m: np.ndarray) -> np.ndarray:
    """Strip scale from rotation-scale blocks (..., 3, 3)."""
    return m / np.linalg.norm(m, axis=-2, keepdims=True)
