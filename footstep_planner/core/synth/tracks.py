"""Clip tracks (thesis 3.4): a clip prepared for playback, and the loop of a cyclic clip.

A *track* is a clip prepared for playback: its root velocity and yaw rate in the root's
own frame, and its foot points in the root frame, sampled densely in clip time, with its
pose (bone quaternions and the hips) at the clip's own samples. A cyclic clip is keyed on
a left-right-left triple of stances (its phase, ``_phase_times``) and loops round its seam
(``loop_seam``), the seam's pose mismatch spread over the cycle (``_seam_closing``).
Also the error and the tolerances the schedule and the playback share (``BlendError``,
MIN_DURATION, FRAME_EPS, MIN_RAMP).

Conventions: world is Z up, metres, seconds; a heading is a yaw about +Z in radians,
positive counter-clockwise, relative to the rig's rest forward (the convention of
``clip.ClipMotion.root_heading``). Foot index 0 is left.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..base import quat as quaternions
from ..clips.analysis import ClipAnalysis
from ..base.errors import FootstepError


class BlendError(FootstepError):
    """A clip that cannot be played as asked; the message names it."""


#: s: a step or span shorter than this has no duration (both feet down at once).
MIN_DURATION = 1e-6


#: frames: a schedule that ends within this of a frame ends on that frame.
FRAME_EPS = 1e-9


#: s: the shortest weight ramp (a shorter one would divide by about 0).
MIN_RAMP = 1e-6


@dataclass(frozen=True)
class ClipTrack:
    """A clip ready for playback, sampled at ``rate`` Hz in clip time."""

    name: str
    kind: str  # "cycle" or a special kind ("jump", ...)
    gait: str
    entry_gait: str
    exit_gait: str
    rate: float
    duration: float
    vel: np.ndarray  # (n, 2) root velocity in the root frame, m/s of clip time
    yaw_rate: np.ndarray  # (n,) rad/s of clip time
    heel: np.ndarray  # (2, n, 3) heel points in the root frame
    toe: np.ndarray  # (2, n, 3)
    contact_point: np.ndarray  # (2, n, 3) heel/toe by Johansen's balance, root frame
    contact: np.ndarray  # (2, n) 1.0 while the foot bears weight
    hips_in_root: np.ndarray  # (n, 4, 4)
    # cyclic: clip times keying the phase: (a, b, c), a left, the next right and the next
    # left stance; or (a, b, b2, c): phases 0 to 1/2 play a..b, phases 1/2 to 1 play b2..c
    # (a cycle keyed on a right-left-right triple: a = c = the left, b2 one cycle before b)
    phase_times: np.ndarray | None
    rest_forward: np.ndarray = field(default_factory=lambda: np.array([0.0, -1.0]))  # heading 0
    # the pose, at the clip's own samples (``pose_rate`` Hz): bone rotations as unit
    # quaternions in scipy's (x, y, z, w) order, and the hips' matrix in the root frame
    pose_rate: float = 0.0
    quat: np.ndarray | None = field(repr=False, default=None)  # (m, B, 4)
    hips: np.ndarray | None = field(repr=False, default=None)  # (m, 4, 4)
    stances: list = field(default_factory=list)  # (foot, stance time) in time order
    # cyclic: the loop's seam (``loop_seam``): the clip times (s, e), one cycle apart, the
    # phase jumps from e back to s; the rotation (B, 3) (rotation vectors) taking each
    # bone's pose at e onto its pose at s; and the hips' (6,): rotation vector, then shift
    seam: tuple | None = None
    seam_rot: np.ndarray | None = field(repr=False, default=None)
    seam_hips: np.ndarray | None = field(repr=False, default=None)

    @property
    def n(self) -> int:
        return len(self.vel)

    def seam_share(self, t: np.ndarray) -> np.ndarray:
        """(F,) the share of the loop's seam mismatch the pose at clip times ``t`` (F,) is
        turned by: -1/2 at the cycle's start s (and before), rising linearly to +1/2 at its
        end e (and after); 0 without a seam."""
        t = np.asarray(t, float)
        if self.seam is None:
            return np.zeros(t.shape)
        s, e = self.seam
        return np.clip((t - s) / max(e - s, MIN_DURATION), 0.0, 1.0) - 0.5

    def sample_pose(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The pose at clip times ``t`` (F,): (bone quaternions (F, B, 4) scipy order, the
        hips' position (F, 3) and quaternion (F, 4) in the root frame), interpolated
        linearly between the clip's samples (``quat``, ``hips``) and, for a cyclic clip,
        with the loop's seam closed: every bone turned by its share (``seam_share``) of the
        rotation from its pose at the cycle's end to that at its start, the hips shifted
        likewise, so the pose the phase's wrap from e to s joins is continuous (a cycle of
        motion capture never ends exactly in the pose it began with; the mismatch is spread
        over the whole cycle, the slowest change that closes it)."""
        t = np.asarray(t, float)
        q, hp, hq = _raw_pose(self.quat, self.hips, self.pose_rate, t)
        if self.seam is None or self.seam_rot is None or not len(t):
            return q, hp, hq
        from scipy.spatial.transform import Rotation

        w = self.seam_share(t)
        F, B = q.shape[:2]
        turn = Rotation.from_rotvec((w[:, None, None] * self.seam_rot[None]).reshape(-1, 3)).as_quat()
        q = quaternions.multiply(turn, q.reshape(-1, 4)).reshape(F, B, 4)
        if self.seam_hips is not None:
            hq = (Rotation.from_rotvec(w[:, None] * self.seam_hips[None, :3]) * Rotation.from_quat(hq)).as_quat()
            hp = hp + w[:, None] * self.seam_hips[None, 3:]
        return q, hp, hq

    def sample_hips(self, t: float) -> np.ndarray:
        """(4, 4) the hips' matrix in the root frame at clip time ``t`` (the nearest sample)."""
        return self.hips_in_root[int(np.clip(round(t * self.rate), 0, len(self.hips_in_root) - 1))]

    def step_duration(self, foot: int) -> float:
        """Cyclic clips: seconds from a stance of ``foot`` to the other foot's stance."""
        a, b, b2, c = self._keys()
        return float(b - a if foot == 0 else c - b2)

    def _keys(self):
        k = self.phase_times
        return (k[0], k[1], k[1], k[2]) if len(k) == 3 else tuple(k)

    def clip_time_of_phase(self, phase: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Cyclic clips: (clip time, d clip time / d phase) at phases (any real)."""
        a, b, b2, c = self._keys()
        f = np.mod(phase, 1.0)
        first = f < 0.5
        t = np.where(first, a + (b - a) * 2.0 * f, b2 + (c - b2) * 2.0 * (f - 0.5))
        slope = np.where(first, 2.0 * (b - a), 2.0 * (c - b2))
        return t, slope

    def sample(self, t: np.ndarray) -> dict:
        """Linear interpolation of the track at clip times ``t`` (F,), clamped to the clip."""
        x = np.clip(np.asarray(t, dtype=np.float64) * self.rate, 0.0, self.n - 1.0)
        i0 = np.minimum(x.astype(np.int64), self.n - 2) if self.n > 1 else np.zeros(len(x), np.int64)
        fr = x - i0
        i1 = np.minimum(i0 + 1, self.n - 1)
        lerp = lambda a, axis=0: (np.take(a, i0, axis=axis) * (1 - _bc(fr, a.ndim, axis))  # noqa: E731
                                  + np.take(a, i1, axis=axis) * _bc(fr, a.ndim, axis))
        return {"vel": lerp(self.vel), "yaw_rate": lerp(self.yaw_rate), "heel": lerp(self.heel, 1),
                "toe": lerp(self.toe, 1), "contact_point": lerp(self.contact_point, 1),
                "contact": lerp(self.contact, 1)}


def _bc(fr: np.ndarray, ndim: int, axis: int) -> np.ndarray:
    """Broadcast the (F,) interpolation fraction along ``axis`` of an ndim array."""
    shape = [1] * ndim
    shape[axis] = len(fr)
    return fr.reshape(shape)


def _rot2(h: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rotate the x, y of vectors v (..., >=2) by yaw h (broadcast); other components kept."""
    c, s = np.cos(h), np.sin(h)
    out = np.array(v, dtype=np.float64, copy=True)
    out[..., 0] = c * v[..., 0] - s * v[..., 1]
    out[..., 1] = s * v[..., 0] + c * v[..., 1]
    return out


def make_track(a: ClipAnalysis, rate: float = 120.0) -> ClipTrack:
    """Prepare an analysed clip for playback (resampled to at least ``rate`` Hz)."""
    m = a.motion
    if m is None:
        raise BlendError(f"clip {a.name!r} has no motion to play")
    dense = m if m.fps >= rate - 1e-9 else m.resample(rate)
    n, dt = dense.n, 1.0 / dense.fps
    if n < 2:
        raise BlendError(f"clip {a.name!r} is too short to play ({n} samples)")
    psi = dense.root_heading
    vel_w = np.gradient(dense.root_pos[:, :2], dt, axis=0)
    vel = _rot2(-psi, vel_w)
    yaw_rate = np.gradient(psi, dt)
    to_root = lambda p: _rot2(-psi[None, :], p - dense.root_pos[None, :, :] * [1, 1, 0])  # noqa: E731
    heel, toe = to_root(dense.heel), to_root(dense.toe)
    src = m.times
    bal = np.stack([np.interp(dense.times, src, a.balance[k]) for k in range(2)])
    con = np.stack([np.interp(dense.times, src, a.contact[k].astype(float)) for k in range(2)])
    cpt = heel + bal[..., None] * (toe - heel)
    stances = sorted(((st.foot, float(st.stance)) for st in a.stances), key=lambda x: x[1])
    quat = _quats(m.local_rot)
    phase = _phase_times(a, quat) if a.kind == "cycle" else None
    seam, seam_rot, seam_hips = None, None, None
    if phase is not None:
        seam = loop_seam(phase)
        seam_rot, seam_hips = _seam_closing(quat, m.hips_in_root, float(m.fps), seam)
    return ClipTrack(name=a.name, kind=a.kind, gait=a.gait, entry_gait=a.entry_gait,
                     exit_gait=a.exit_gait, rate=float(dense.fps), duration=dense.duration,
                     vel=vel, yaw_rate=yaw_rate, heel=heel, toe=toe, contact_point=cpt,
                     contact=con, hips_in_root=dense.hips_in_root, phase_times=phase,
                     rest_forward=np.asarray(m.rest_forward, float), stances=stances,
                     pose_rate=float(m.fps), quat=quat, hips=m.hips_in_root,
                     seam=seam, seam_rot=seam_rot, seam_hips=seam_hips)


def _unit3(m: np.ndarray) -> np.ndarray:
    """Matrices (..., 3, 3) with each column scaled to unit length (a clip's hips matrix
    may carry a scale)."""
    return m / np.linalg.norm(m, axis=-2, keepdims=True)


def _raw_pose(quat: np.ndarray, hips: np.ndarray, rate: float, t: np.ndarray
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(quats (F, B, 4), hips position (F, 3), hips quat (F, 4)) of a clip's pose
    samples ``quat`` (m, B, 4), ``hips`` (m, 4, 4) at ``rate`` Hz, at clip times t (F,):
    linear interpolation between the samples, quaternions normalised."""
    m = len(quat)
    x = np.clip(np.asarray(t, float) * rate, 0.0, m - 1.0)
    i0 = np.minimum(x.astype(np.int64), max(m - 2, 0))
    i1 = np.minimum(i0 + 1, m - 1)
    fr = (x - i0)[:, None]
    q = quat[i0] * (1 - fr[..., None]) + quaternions.align(quat[i1], quat[i0]) * fr[..., None]
    q /= np.linalg.norm(q, axis=-1, keepdims=True)
    hp = hips[i0, :3, 3] * (1 - fr) + hips[i1, :3, 3] * fr
    hq0 = quaternions.rotations(_unit3(hips[i0, :3, :3])).as_quat()
    hq1 = quaternions.align(quaternions.rotations(_unit3(hips[i1, :3, :3])).as_quat(), hq0)
    hq = hq0 * (1 - fr) + hq1 * fr
    return q, hp, hq / np.linalg.norm(hq, axis=-1, keepdims=True)


def loop_seam(phase_times: np.ndarray) -> tuple[float, float]:
    """(s, e): the clip times a cyclic clip keyed on ``phase_times`` (``ClipTrack``) plays
    from and to, one cycle apart; its phase wraps from e back to s (keys (a, b, c): a and
    c; keys (a, b, b2, c): b2 and b, the phase's jump at 1/2)."""
    k = np.asarray(phase_times, float)
    return (float(k[0]), float(k[2])) if len(k) == 3 else (float(k[2]), float(k[1]))


def _seam_closing(quat: np.ndarray, hips: np.ndarray, rate: float, seam: tuple[float, float]
                  ) -> tuple[np.ndarray, np.ndarray]:
    """(rotation vectors (B, 3) taking each bone's pose at the seam's end onto its pose
    at its start, the hips' (6,): the same of their rotation, then their shift from end to
    start) of pose samples ``quat`` (m, B, 4), ``hips`` (m, 4, 4) at ``rate`` Hz."""
    from scipy.spatial.transform import Rotation

    q, hp, hq = _raw_pose(quat, hips, rate, np.asarray(seam, float))
    B = q.shape[1]
    rot = (Rotation.from_quat(q[0]) * Rotation.from_quat(q[1]).inv()).as_rotvec().reshape(B, 3)
    hrot = (Rotation.from_quat(hq[0]) * Rotation.from_quat(hq[1]).inv()).as_rotvec()
    return rot, np.r_[hrot, hp[0] - hp[1]]


def _quats(rot: np.ndarray) -> np.ndarray:
    """(N, B, 3, 3) rotation matrices -> (N, B, 4) unit quaternions (x, y, z, w), each
    bone's sequence kept on one hemisphere (no sign flips between samples)."""
    n, b = rot.shape[:2]
    return quaternions.continuous(quaternions.rotations(rot.reshape(-1, 3, 3)).as_quat().reshape(n, b, 4))


def _phase_times(a: ClipAnalysis, quat: np.ndarray | None = None) -> np.ndarray:
    """The clip times that key a cyclic clip's phase (``ClipTrack.phase_times``): a left
    stance, the next right one and the next left one, the first such triple in the
    clip's best cycle (else anywhere). Only whole stances count (a stance cut by the
    clip's start or end has a stance time that is merely where the clip begins or ends):
    a clip that holds no whole left-right-left triple is keyed on a right-left-right one.
    Cut stances are the last resort. With the clip's pose ``quat`` (N, B, 4) the key one
    cycle on from the first is moved, within its stance, to where the pose best repeats
    the first key's (``_loop_end``): that is where the loop closes."""
    lo = a.best_cycle[0] - 1e-6 if a.best_cycle else 0.0
    whole = sorted(((st.foot, float(st.stance)) for st in a.stances if not (st.open_start or st.open_end)),
                   key=lambda x: x[1])
    every = sorted(((st.foot, float(st.stance)) for st in a.stances), key=lambda x: x[1])
    for stances in (whole, every):
        for first in (0, 1):
            triples = _triples(stances, first)
            if triples:
                good = [t for t in triples if t[0] >= lo]
                t0, t1, t2 = (good or triples)[0]
                if quat is not None:
                    t2 = _loop_end(a, quat, first, t0, t1, t2)
                if first == 0:
                    return np.array((t0, t1, t2), dtype=np.float64)
                # right r0, left l1, right r2: phase 0 at l1, 1/2 at r2 (one cycle on from r0)
                return np.array((t1, t2, t0, t1), dtype=np.float64)
    raise BlendError(f"clip {a.name!r} has no left-right-left footstep sequence to loop")


#: rad: a bone's pose mismatch counts up to this in ``_loop_end`` (noisy fingers and the
#: ends of a capture do not outweigh the legs).
LOOP_MATCH_CAP = np.radians(30.0)


#: m: the loop's end is sought where the stance's foot lies flat: its higher end (heel or
#: toe) within this of its lowest in the stance (its 10th percentile: noise has outliers).
LOOP_FLAT = 0.005


def _loop_end(a: ClipAnalysis, quat: np.ndarray, foot: int, t0: float, t1: float, t2: float) -> float:
    """The clip time, within the stance of ``foot`` at ``t2`` (its land to its lift, after
    the other foot's stance at ``t1``, where the foot lies flat: ``LOOP_FLAT``), where the pose (``quat`` (N, B, 4) at the clip's
    rate; the hips by their matrix in the root frame) best repeats the pose at ``t0``: the
    mean over the bones of their rotation from one to the other (each capped at
    ``LOOP_MATCH_CAP``) is least there; ``t2`` itself on a tie or without such a stance.

    A foot lying flat holds its heel and toe at (nearly) the same height for a good part of
    its stance, so the stance time the analysis gives (the lowest sample) falls anywhere in
    that plateau, wherever the noise (or a file's float rounding, or a resampling's ripple)
    puts it: two stances of one foot a cycle apart are then a few frames more or less than
    a cycle apart, and the loop keyed on them jumps by a few frames of motion at its seam
    (20 to 30 degrees at the swinging knee). Where the pose repeats is where one cycle
    ends."""
    st = next((x for x in a.stances if x.foot == foot and abs(float(x.stance) - t2) < 1e-9), None)
    m = a.motion
    if st is None or m is None or st.open_start or st.open_end:
        return t2
    step = 0.25 / m.fps
    lo, hi = max(float(st.land), t1 + step), min(float(st.lift), float(m.duration))
    if hi <= lo:
        return t2
    cand = np.unique(np.r_[np.arange(lo, hi + 1e-9, step), t2])
    # only where the foot lies flat (its higher end within LOOP_FLAT of its lowest there):
    # the key is where the foot stands on its footprint
    upper = np.maximum(np.interp(cand, m.times, m.heel[foot, :, 2]), np.interp(cand, m.times, m.toe[foot, :, 2]))
    cand = cand[(upper <= np.percentile(upper, 10) + LOOP_FLAT * m.body_scale) | (cand == t2)]
    q, _, hq = _raw_pose(quat, m.hips_in_root, float(m.fps), np.r_[t0, cand])
    ang = 2.0 * np.arccos(np.clip(np.abs(np.einsum("bk,fbk->fb", q[0], q[1:])), 0.0, 1.0))
    ang[:, m.hips_index] = 2.0 * np.arccos(np.clip(np.abs(hq[1:] @ hq[0]), 0.0, 1.0))
    err = np.minimum(ang, LOOP_MATCH_CAP).mean(axis=1)
    best = np.flatnonzero(err <= err.min() + 1e-12)
    return float(cand[best[np.argmin(np.abs(cand[best] - t2))]])


def _triples(stances, first: int) -> list:
    """(t0, t1, t2): stances of feet first, other, first, alternating, in time order."""
    out = []
    for i, (f0, t0) in enumerate(stances):
        if f0 != first:
            continue
        rest = stances[i + 1:]
        r = next(((f, t) for f, t in rest if f != first), None)
        if r is None:
            continue
        again = next(((f, t) for f, t in rest if f == first and t > r[1]), None)
        if again is None:
            continue
        if any(f == first and t0 < t < r[1] for f, t in rest):
            continue
        out.append((t0, r[1], again[1]))
    return out
