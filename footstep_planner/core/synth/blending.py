"""Playing a set of clips with blend weights (thesis 3.4): the schedule and the playback.

A *track* is a clip prepared for playback: its root velocity and yaw rate in the root's
own frame, and its foot points in the root frame, sampled densely in clip time. A
*schedule* says, for every output frame, each clip's weight (the weights sum to 1), the
clip time it is played at, and how fast that clip time advances. *Playback* integrates
the blended root motion over the frames and keeps the *blend point* still when the
weights change.

Conventions: world is Z up, metres, seconds; a heading is a yaw about +Z in radians,
positive counter-clockwise, relative to the rig's rest forward (the convention of
``clip.ClipMotion.root_heading``). Foot index 0 is left. The root moves on the ground
plane: playback is horizontal (x, y); heights come later from the footprints.

Normalized time ``u`` counts footsteps: u = j at the stance of footprint j of the plan,
linear in time in between. Cyclic clips are played in phase: phase 0 is a left-foot
stance, 1/2 the next right-foot stance, 1 the left again; each clip's time is warped
piecewise-linearly between its own stance times, so blended clips put their feet down
together (Kovar and Gleicher's registration, keyed at footsteps as in Johansen).

The blend point (derived here: the thesis's formulas swap the feet and lose the |v_L|^2
term): when the weights change from w to w' at frame k,
each foot's root-frame point jumps by d = f(w', t_k) - f(w, t_k). Let v_L, v_R be the
world velocities the feet would have had with the old weights, and p_s = a p_R + (1-a) p_L
the point of the line between the feet that moves least:
a = clamp((|v_L|^2 - v_R . v_L) / |v_R - v_L|^2, 0, 1). Moving the root by
-(a d_R + (1-a) d_L) keeps p_s where the old weights would have put it. A planted foot
(v = 0) is the most stable point, so it does not move when the weights change.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..base import quat as quaternions
from ..clips.analysis import ClipAnalysis
from ..base.errors import FootstepError


class BlendError(FootstepError):
    """A clip that cannot be played as asked; the message names it."""


# ----------------------------------------------------------------------------- tracks

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
        return np.clip((t - s) / max(e - s, MIN_STEP), 0.0, 1.0) - 0.5

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


#: A clip's matrices read from Blender (single precision) are rotations to about 1e-7.
RIGID_TOL = 1e-6


def _rotation_of(m: np.ndarray):
    """scipy Rotations of matrices ``m`` (n, 3, 3): when they are all rotations (to
    RIGID_TOL) taken as they are, else orthogonalised first (scipy's SVD, a LAPACK call a
    matrix, which gives the same rotation for a rotation, to that tolerance)."""
    from scipy.spatial.transform import Rotation

    rigid = bool(len(m)) and np.abs(np.einsum("nji,njk->nik", m, m) - np.eye(3)).max() < RIGID_TOL
    return Rotation.from_matrix(m, assume_valid=rigid)


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
    hq0 = _rotation_of(_unit3(hips[i0, :3, :3])).as_quat()
    hq1 = quaternions.align(_rotation_of(_unit3(hips[i1, :3, :3])).as_quat(), hq0)
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
    from scipy.spatial.transform import Rotation

    n, b = rot.shape[:2]
    return quaternions.continuous(Rotation.from_matrix(rot.reshape(-1, 3, 3)).as_quat().reshape(n, b, 4))


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


# ----------------------------------------------------------------------------- schedule

@dataclass(frozen=True)
class PlanStep:
    """Step j of a footstep path: from footprint j (``foot``) to footprint j + 1."""

    foot: int
    special: str | None  # a special clip played whole across this step (a jump), else None
    weights: np.ndarray | None  # (C,) cyclic clip weights for a locomotion step
    # the special clip's (take-off, landing) clip times across this step; None: its
    # ``special_window`` (a start or stop clip plays one window per step, ``end_windows``)
    window: tuple[float, float] | None = None
    stretch: float = 1.0  # a special step lasts its window's clip time times this


@dataclass
class Schedule:
    """Per output frame: time, normalized time, and for every clip its weight, its clip
    time and the rate of its clip time (d clip time / d t)."""

    t: np.ndarray  # (F,) s
    u: np.ndarray  # (F,) footsteps
    clips: list[str]  # column names
    weights: np.ndarray  # (F, C), rows sum to 1
    clip_time: np.ndarray  # (F, C) s of clip time
    clip_rate: np.ndarray  # (F, C)
    footprint_times: np.ndarray  # (N,) s: stance time of each footprint
    feet: np.ndarray  # (N,) foot of each footprint
    fps: float
    # standing at both ends (``Standing``): the walk's own time at each frame (F,) s, which
    # stands still while the character stands, and the footprints' times (N,) on it
    walk_time: np.ndarray | None = None
    walk_footprint_times: np.ndarray | None = None

    @property
    def n(self) -> int:
        return len(self.t)

    @property
    def walk_t(self) -> np.ndarray:
        """(F,) s: the time the walk has reached at each frame (``t`` without standing)."""
        return self.t if self.walk_time is None else self.walk_time

    @property
    def walk_times(self) -> np.ndarray:
        """(N,) s: the footprints' stance times on ``walk_t``."""
        return self.footprint_times if self.walk_footprint_times is None else self.walk_footprint_times

    def column(self, name: str) -> int:
        return self.clips.index(name)


def special_window(track: ClipTrack, foot: int) -> tuple[float, float]:
    """Clip times (take-off stance, landing stance) of a special clip's step that starts
    from ``foot``: the last stance of that foot before the clip's longest gap between
    consecutive stances, and the next stance after it."""
    st = track.stances
    if len(st) < 2:
        raise BlendError(f"clip {track.name!r} has fewer than two footprints: it cannot carry a step")
    gaps = [(st[i + 1][1] - st[i][1], i) for i in range(len(st) - 1) if st[i][0] == foot]
    if not gaps:
        raise BlendError(f"clip {track.name!r} has no step starting from the {'LR'[foot]} foot")
    _, i = max(gaps)
    return st[i][1], st[i + 1][1]


def step_durations_of(cyc: list[ClipTrack]) -> np.ndarray:
    """(2, C): seconds of a step starting from the left (row 0) or right foot, per clip."""
    return np.array([[tr.step_duration(f) for tr in cyc] for f in (0, 1)]).reshape(2, len(cyc))


#: s: a step shorter than this has no duration (both feet down at once).
MIN_STEP = 1e-6
#: frames: a schedule that ends within this of a frame ends on that frame.
FRAME_EPS = 1e-9
#: s: the shortest weight ramp (a shorter one would divide by about 0).
MIN_RAMP = 1e-6


def build_schedule(steps: list[PlanStep], tracks: dict[str, ClipTrack], cyclic: list[str],
                   fps: float, transition: float, loco_weights=None,
                   step_durations: np.ndarray | None = None, standing: "Standing | None" = None,
                   pace: np.ndarray | None = None) -> Schedule:
    """The frames of a footstep path of len(steps) + 1 footprints.

    ``cyclic`` names the cyclic clips (the columns of each step's ``weights``). Each
    locomotion step lasts the weighted mean of its clips' step durations (or
    ``step_durations``), over its ``pace`` (len(steps),) when given; a special step
    lasts as long as its clip takes from take-off to landing. Locomotion weights are the steps' weights with linear ramps of
    ``transition`` seconds centred on footprint times, or ``loco_weights(u)`` (a callable
    returning (F, C) rows) when given. A special clip ramps in over ``transition``
    before its take-off and out after its landing, played at its own speed there.

    With ``standing`` the path is walked on a time warp (``Standing``): the character
    stands, speeds up from rest, walks, slows down to rest and stands again; the frames'
    times ``t`` are real, the clips' (and ``u``) follow the warped walk time.
    """
    if not steps:
        raise BlendError("a path of one footprint has no motion to play")
    cyc = [tracks[c] for c in cyclic]
    feet = np.array([step.foot for step in steps] + [1 - steps[-1].foot])  # the foot of each footprint
    specials = sorted({step.special for step in steps if step.special})
    clips = list(cyclic) + specials + ([standing.clip] if standing else [])
    w_step = _step_weights(steps, len(cyc))
    dur, windows = _step_durations(steps, tracks, cyc, feet[:-1], w_step, step_durations)
    if pace is not None:  # (walking steps, and a start or stop clip's: a jump's step keeps its clip's time)
        paced = [step.special is None or tracks[step.special].kind in ("start", "stop") for step in steps]
        dur = np.where(paced, dur / np.asarray(pace, float), dur)
    footprint_times = np.concatenate([[0.0], np.cumsum(dur)])
    if standing is None:
        t, u, du_dt = _frame_times(footprint_times, dur, fps)
        walk, sigma = t, np.ones(len(t))
    else:
        warp = _standing_warp(footprint_times, dur, fps, standing,
                              *_clip_ends(steps, tracks, windows, footprint_times, standing))
        t, walk, sigma = warp.t, warp.walk, warp.sigma
        u = np.interp(walk, footprint_times, np.arange(len(footprint_times), dtype=float))
        du_dt = sigma / dur[np.minimum(u.astype(np.int64), len(dur) - 1)]
    clip_time, clip_rate = _cyclic_clip_times(cyc, feet[0], u, du_dt, len(clips))
    W = _locomotion_weights(len(cyc), walk, u, footprint_times, w_step, transition, loco_weights)
    lam = _play_specials(steps, tracks, windows, clips[:len(clips) - bool(standing)], len(cyc), walk, u,
                         footprint_times, dur, transition, clip_time, clip_rate)
    clip_rate[:, len(cyc):] *= sigma[:, None]
    if standing is None:
        return Schedule(t=t, u=u, clips=clips, weights=_all_weights(W, lam, len(cyc)), clip_time=clip_time,
                        clip_rate=clip_rate, footprint_times=footprint_times, feet=feet, fps=float(fps))
    clip_time[:, -1] = standing.clip_time
    # (the standing clip over the specials: a start or stop clip stands under it)
    weights = _all_weights(W, np.c_[lam * (1.0 - warp.stand)[:, None], warp.stand], len(cyc))
    return Schedule(t=t, u=u, clips=clips, weights=weights, clip_time=clip_time, clip_rate=clip_rate,
                    footprint_times=warp.real_time(footprint_times), feet=feet, fps=float(fps),
                    walk_time=walk, walk_footprint_times=footprint_times)


#: s the feet and body take to settle after the walk stops (the IK's corrections ease in
#: over a few frames), before the standing pose holds still for ``Standing.hold``.
STAND_SETTLE = 0.3


@dataclass(frozen=True)
class Standing:
    """Start from standing, stop to standing (issue 14). The schedule's frames begin with
    ``lead`` s of standing in the standing clip ``clip`` (the library's idle clip, or one
    made from the walk: ``standing_track``), held at clip time ``clip_time``. The walk is
    held meanwhile at ``u_start`` footsteps (the first step's foot swinging past the
    standing one); it speeds up from rest while the standing clip hands over to it (in
    ``blend`` of the ramp), walks, and slows down to rest at ``u_back`` footsteps before
    the last footprint (the last step's foot swinging past), the standing clip taking over
    again; after STAND_SETTLE s it holds still for ``hold`` s. Each speed ramp covers
    ``ramp_steps`` footsteps of walking: a smoothstep of the walk's rate over twice their
    time.

    With a ``start`` clip (the library's, its kind "start"; the path's first steps are
    its steps: ``PlanStep.special`` with one of its windows each) the walk does not speed
    up: after the ``lead`` the start clip plays at its own speed from END_FADE s before it
    sets off, keyed to the first footprints as a jump is, while the standing clip hands
    over to it; it then ramps out into the cycles. With a ``stop`` clip the last steps are
    its steps: it plays at its own speed until it has come to rest, the standing clip
    taking over in END_FADE s, and the hold follows."""

    clip: str
    clip_time: float = 0.0
    lead: float = 0.5
    hold: float = 1.0
    ramp_steps: float = 1.5
    blend: float = 0.35
    u_start: float = 1.0
    u_back: float = 1.0
    start: str | None = None
    stop: str | None = None


@dataclass
class _Warp:
    """The frames of a schedule with standing: real times ``t`` (F,) s, the walk's time
    ``walk`` (F,) s and its rate ``sigma`` (F,) (0 standing .. 1 walking), the standing
    clip's weight ``stand`` (F,); the walk moves from ``t_go`` to ``t_stop`` s, speeding
    up over ``ramp`` s (0: at once, a start clip's own) and slowing down over
    ``ramp_out`` s (None: as long; 0: at once, a stop clip's own)."""

    t: np.ndarray
    walk: np.ndarray
    sigma: np.ndarray
    stand: np.ndarray
    t_go: float
    t_stop: float
    ramp: float
    walk0: float
    ramp_out: float | None = None

    def walk_at(self, t: np.ndarray) -> np.ndarray:
        """(len(t),) the walk's time at real times ``t`` (s)."""
        t = np.asarray(t, float)
        r0, r1 = self.ramp, self.ramp if self.ramp_out is None else self.ramp_out
        span = self.t_stop - self.t_go - r0 - r1  # cruising, at the walk's own speed
        up = r0 * _ramp_integral(np.clip((t - self.t_go) / r0, 0.0, 1.0)) if r0 > 0 else 0.0
        down = r1 * (0.5 - _ramp_integral(np.clip((self.t_stop - t) / r1, 0.0, 1.0))) if r1 > 0 else 0.0
        return self.walk0 + up + np.clip(t - self.t_go - r0, 0.0, span) + down

    def real_time(self, walk_times: np.ndarray) -> np.ndarray:
        """(N,) the real times (s) at which the walk reaches ``walk_times``, held within
        [t_go, t_stop] (a footprint the walk never reaches is at its end)."""
        n = max(2048, int((self.t_stop - self.t_go) * 480))
        tt = np.linspace(self.t_go, self.t_stop, n)
        return np.interp(walk_times, self.walk_at(tt), tt)


def _smoothstep(x: np.ndarray) -> np.ndarray:
    return x * x * (3.0 - 2.0 * x)


def _ramp_integral(x: np.ndarray) -> np.ndarray:
    """The integral of the smoothstep from 0 to x (1/2 at x = 1)."""
    return x ** 3 - 0.5 * x ** 4


def _rate_ramp(x: np.ndarray, r: float) -> np.ndarray:
    """A smoothstep from 0 to 1 over ``r`` of ``x`` (a step at 0 when ``r`` is 0)."""
    return _smoothstep(np.clip(x / r, 0.0, 1.0)) if r > 0 else (x >= 0).astype(float)


def _standing_warp(T: np.ndarray, dur: np.ndarray, fps: float, st: Standing, own_start=None,
                   own_stop=None) -> _Warp:
    """The standing schedule's frames (``Standing``) for footprints at walk times ``T``
    (N,) s, steps ``dur`` (N-1,) s long: the walk from ``u_start`` to N-1 - ``u_back``
    footsteps, its rate a smoothstep up over ``ramp`` s and down over as long (each covering
    half its time of walking: ``ramp_steps`` footsteps), ramps shortened on a short path.
    ``own_start`` (the walk time s a start clip begins at, the s the standing clip hands
    over to it in) and ``own_stop`` (the walk time s the walk ends at, the s before it the
    standing clip takes over in): a start or stop clip's (``_clip_ends``), the walk at
    its own speed from or to standing."""
    idx = np.arange(len(T), dtype=float)
    w0 = float(np.interp(min(st.u_start, 0.5 * (len(T) - 1)), idx, T)) if own_start is None else own_start[0]
    w1 = float(np.interp(max(len(T) - 1 - st.u_back, 0.5 * (len(T) - 1)), idx, T)) if own_stop is None \
        else own_stop[0]
    span = w1 - w0
    if span <= MIN_STEP:
        raise BlendError("the path is too short to start and stop walking on it")
    ramp = min(2.0 * st.ramp_steps * float(np.mean(dur)), span)
    r0 = 0.0 if own_start is not None else ramp
    r1 = 0.0 if own_stop is not None else ramp
    hand = max(st.blend * ramp, MIN_RAMP)
    # the standing clip hands over from t_go on (to a start clip: before it, the clip held)
    # and takes over until t_stop (from a stop clip: after it, the clip held)
    hand0, hand1 = (hand if own is None else max(own[1], MIN_RAMP) for own in (own_start, own_stop))
    t_go = max(st.lead, 0.0) + (0.0 if own_start is None else hand0)
    t_stop = t_go + span + 0.5 * (r0 + r1)
    fade0 = t_go if own_start is None else t_go - hand0
    fade1 = t_stop - hand1 if own_stop is None else t_stop
    end = max(t_stop, fade1 + hand1) + STAND_SETTLE + max(st.hold, 0.0)
    t = np.arange(int(np.ceil(end * fps - FRAME_EPS)) + 1) / fps
    sigma = _rate_ramp(t - t_go, r0) * _rate_ramp(t_stop - t, r1)
    stand = (1.0 - _smoothstep(np.clip((t - fade0) / hand0, 0.0, 1.0))
             + _smoothstep(np.clip((t - fade1) / hand1, 0.0, 1.0)))
    warp = _Warp(t, np.empty(0), sigma, np.clip(stand, 0.0, 1.0), t_go, t_stop, r0, w0, r1)
    warp.walk = np.minimum(warp.walk_at(t), w1)  # (the walk's time at the frames)
    return warp


#: s: the standing clip hands over to a start clip (held where it sets off) over this
#: time, and takes over from a stop clip (held where it has come to rest) over as long.
END_FADE = 0.5


def rest_times(track: ClipTrack, speed: float = 0.05, lift: float = 0.001) -> tuple[float, float]:
    """(the clip time s it sets off at, the clip time s it has come to rest at): the first
    and the last sample at which its root moves faster than ``speed`` m/s, or a heel or
    toe stands more than ``lift`` m higher than at the clip's start (at its end) or bears
    no weight (0 and the clip's end for a clip that never stands still)."""
    z = np.concatenate([track.heel[..., 2], track.toe[..., 2]])  # (4, n)
    still = (np.linalg.norm(track.vel, axis=1) <= speed) & (track.contact > 0.5).all(axis=0)
    go = np.flatnonzero(~(still & (z <= z[:, :1] + lift).all(axis=0)))
    rest = np.flatnonzero(~(still & (z <= z[:, -1:] + lift).all(axis=0)))
    return (float(go[0] / track.rate) if len(go) else 0.0,
            float(min((rest[-1] + 1) / track.rate, track.duration)) if len(rest) else track.duration)


def _clip_ends(steps: list[PlanStep], tracks: dict[str, ClipTrack], windows: dict, T: np.ndarray, st: Standing):
    """(own_start, own_stop) of ``_standing_warp`` for a standing schedule whose first
    (last) steps are its ``Standing.start`` (``stop``) clip's, else None: the walk time
    at which the start clip sets off (or its first footprint's, when earlier), the walk
    time at which the stop clip has come to rest (or its last footprint's, when later),
    each with END_FADE s for the standing clip to hand over or take over while the clip
    is held there."""
    own_start = own_stop = None
    if st.start is not None and steps[0].special == st.start:
        go = rest_times(tracks[st.start])[0]
        own_start = (float(T[0] + go - windows[0][0]), END_FADE)
    if st.stop is not None and steps[-1].special == st.stop:
        rest = rest_times(tracks[st.stop])[1]
        own_stop = (float(T[-1] + rest - windows[len(steps) - 1][1]), END_FADE)
    return own_start, own_stop


def standing_track(walk: ClipTrack, name: str) -> ClipTrack:
    """A standing clip made from a walk (for a library with no idle clip): the walk's pose,
    held, where its left foot stands and the right one swings past it (the feet closest
    to side by side about the left foot's stance); the root still, both feet bearing
    weight."""
    a, b, b2, c = walk._keys() if walk.phase_times is not None else (0.0, 0.0, 0.0, 0.0)
    ts = np.linspace(a - 0.3 * (c - b2), a + 0.3 * (b - a), 25)
    ts = np.where(ts < 0.0, ts + (c - a), ts)  # (a cycle back: the clip's keys span one)
    smp = walk.sample(ts)
    mid = 0.5 * (smp["heel"] + smp["toe"])  # (2, n, 3) root frame
    fwd = np.r_[walk.rest_forward, 0.0]
    t0 = float(ts[int(np.argmin(np.abs((mid[1] - mid[0]) @ fwd)))])
    one = walk.sample(np.array([t0, t0]))
    for key in ("heel", "toe"):  # both feet on the ground: the swinging one as low as the standing one
        one[key][1, :, 2] = one[key][0, :, 2]
    quat = hips = None
    if walk.quat is not None:  # the walk's pose there as the walk plays it (its seam closed)
        from scipy.spatial.transform import Rotation

        q, hp, hq = walk.sample_pose(np.array([t0]))
        quat = np.repeat(q, 2, axis=0)
        hips = np.tile(np.eye(4), (2, 1, 1))
        hips[:, :3, :3] = Rotation.from_quat(hq[0]).as_matrix()
        hips[:, :3, 3] = hp[0]
    rate = walk.rate
    return ClipTrack(name=name, kind="idle", gait="stand", entry_gait="stand", exit_gait="stand", rate=rate,
                     duration=1.0 / rate, vel=np.zeros((2, 2)), yaw_rate=np.zeros(2), heel=one["heel"],
                     toe=one["toe"], contact_point=0.5 * (one["heel"] + one["toe"]), contact=np.ones((2, 2)),
                     hips_in_root=np.repeat(walk.sample_hips(t0)[None], 2, axis=0), phase_times=None,
                     rest_forward=walk.rest_forward, pose_rate=rate,
                     quat=quat, hips=hips, stances=[])


def _step_weights(steps: list[PlanStep], nc: int) -> np.ndarray:
    """(len(steps), nc) the cyclic clips' weights of every step: a locomotion step's own
    (checked: nc non-negative numbers summing to 1), a special step the last locomotion
    step's before it (the first one's when none comes before)."""
    nstep = len(steps)
    w_step = np.full((nstep, nc), np.nan)
    for j, step in enumerate(steps):
        if step.special is None:
            w = np.asarray(step.weights, float)
            if w.shape != (nc,) or abs(w.sum() - 1.0) > 1e-6 or (w < -1e-12).any():
                raise BlendError(f"step {j}: weights must be {nc} non-negative numbers summing to 1")
            w_step[j] = w
    if not nc:
        return w_step
    have = ~np.isnan(w_step[:, 0])
    if not have.any():
        raise BlendError("the path has no walking or running step to play between its special clips")
    idx = np.maximum.accumulate(np.where(have, np.arange(nstep), -1))
    idx[idx < 0] = int(np.argmax(have))
    return w_step[idx]


def _step_durations(steps: list[PlanStep], tracks: dict[str, ClipTrack], cyc: list[ClipTrack],
                    step_feet: np.ndarray, w_step: np.ndarray, step_durations: np.ndarray | None
                    ) -> tuple[np.ndarray, dict]:
    """((len(steps),) s each step lasts, {step: (take-off, landing) clip times of its
    special clip}): a locomotion step the weighted mean of its clips' step durations from
    its foot ``step_feet`` (or ``step_durations`` when given), a special step its clip's
    take-off to landing (``special_window``)."""
    dur = (w_step * step_durations_of(cyc)[step_feet]).sum(axis=1) if cyc else np.zeros(len(steps))
    windows = {}
    for j, step in enumerate(steps):
        if step.special:
            a, b = step.window or special_window(tracks[step.special], step.foot)
            windows[j] = (a, b)
            dur[j] = (b - a) * step.stretch
    if step_durations is not None:
        loco = np.array([step.special is None for step in steps])
        dur[loco] = np.asarray(step_durations, float)[loco]
    if (dur <= MIN_STEP).any():
        j = int(np.argmax(dur <= MIN_STEP))
        raise BlendError(f"step {j} has no duration: its clips put both feet down at once")
    return dur, windows


def _frame_times(footprint_times: np.ndarray, dur: np.ndarray, fps: float
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(t (F,) s, u (F,) footsteps, du/dt (F,) footsteps per s) of the frames at ``fps``
    from the first footprint's stance to the last's (the last frame reaches it, under a
    frame past it): u is j at ``footprint_times[j]``, linear in between, and goes on at
    the last step's rate (``dur`` (N-1,) s per step) past the end."""
    nstep = len(dur)
    end = footprint_times[-1]
    t = np.arange(int(np.ceil(end * fps - FRAME_EPS)) + 1) / fps
    u = np.interp(t, footprint_times, np.arange(nstep + 1))
    u = np.where(t > end, nstep + (t - end) / dur[-1], u)
    step_of = np.minimum(u.astype(np.int64), nstep - 1)
    return t, u, 1.0 / dur[step_of]


def _cyclic_clip_times(cyc: list[ClipTrack], first_foot: int, u: np.ndarray, du_dt: np.ndarray, C: int
                       ) -> tuple[np.ndarray, np.ndarray]:
    """(clip time (F, C) s, its rate d clip time / dt (F, C)) with the cyclic clips' columns
    (the first len(cyc)) filled, the others 0: each played in phase, phase = (u + off) / 2
    with off 0 when the first footprint (``first_foot``) is the left, 1 when the right (the
    left foot's stances at whole phases)."""
    phase = 0.5 * (u + (0.0 if first_foot == 0 else 1.0))
    clip_time = np.zeros((len(u), C))
    clip_rate = np.zeros((len(u), C))
    for c, tr in enumerate(cyc):
        ct, slope = tr.clip_time_of_phase(phase)
        clip_time[:, c] = ct
        clip_rate[:, c] = slope * 0.5 * du_dt
    return clip_time, clip_rate


def _locomotion_weights(nc: int, t: np.ndarray, u: np.ndarray, footprint_times: np.ndarray,
                        w_step: np.ndarray, transition: float, loco_weights) -> np.ndarray:
    """(F, nc) the cyclic clips' weights at the frames (times ``t`` s, normalized times
    ``u``): ``loco_weights(u)`` when given, else the steps' weights ``w_step`` ramped over
    ``transition`` s about the footprint times (``_ramped``)."""
    if not nc:
        return np.zeros((len(t), 0))
    if loco_weights is not None:
        return np.asarray(loco_weights(u), float)
    return _ramped(t, footprint_times, w_step, transition)


def _play_specials(steps: list[PlanStep], tracks: dict[str, ClipTrack], windows: dict, clips: list[str],
                   nc: int, t: np.ndarray, u: np.ndarray, footprint_times: np.ndarray, dur: np.ndarray,
                   transition: float, clip_time: np.ndarray, clip_rate: np.ndarray) -> np.ndarray:
    """The special clips' weights (F, len(clips) - nc), each clip's the largest of its
    steps' ramps; fills their columns of ``clip_time`` and ``clip_rate`` (F, C) in place
    where a step's ramp is the clip's weight (``_special_timing``), its clip time clamped
    to the clip and its rate 0 outside it."""
    lam = np.zeros((len(t), len(clips) - nc))
    for j, step in enumerate(steps):
        if not step.special:
            continue
        c = clips.index(step.special)
        k = c - nc
        duration = tracks[step.special].duration
        ct, rate, ramp = _special_timing(t, u, j, windows[j], footprint_times[j], footprint_times[j + 1],
                                         dur[j], transition)
        # a start clip plays from the first frame (the standing clip hands over to it), a
        # stop clip to the last (``Standing``): no ramp before the one, after the other;
        # it ramps out (in) over the step after (before) its steps, played in step there
        kind, T = tracks[step.special].kind, footprint_times
        first = j == 0 or steps[j - 1].special != step.special
        last = j + 1 == len(steps) or steps[j + 1].special != step.special
        if kind == "start" and first:
            ramp[t < T[j]] = 1.0
        if kind == "start" and last and j + 2 < len(T):
            late = t > T[j + 1]
            ramp[late] = 1.0 - _smoothstep(np.clip((t[late] - T[j + 1]) / (T[j + 2] - T[j + 1]), 0.0, 1.0))
        if kind == "stop" and last:
            ramp[t > T[j + 1]] = 1.0
        if kind == "stop" and first and j >= 1:
            early = t < T[j]
            ramp[early] = _smoothstep(np.clip((t[early] - T[j - 1]) / (T[j] - T[j - 1]), 0.0, 1.0))
        _register_special(ct, rate, t, u, j, windows[j], special_neighbours(tracks[step.special], windows[j]),
                          footprint_times, dur)
        mine = ramp > lam[:, k]
        lam[mine, k] = ramp[mine]
        clip_time[mine, c] = np.clip(ct[mine], 0.0, duration)
        inside = (ct[mine] >= 0.0) & (ct[mine] <= duration)
        clip_rate[mine, c] = np.where(inside, rate[mine], 0.0)
    return lam


#: A special clip ramps in and out over this many times the transition time, a smoothstep:
#: its pose can differ much from the cycles' (a leap's arms from a jog's), and a short
#: linear ramp turns those bones faster than either clip does (about one step of running
#: at the usual 0.3 s; the clip is played in step with the cycles there).
SPECIAL_RAMP = 2.0


def _special_timing(t: np.ndarray, u: np.ndarray, j: int, window: tuple[float, float], t0: float, t1: float,
                    dur_j: float, transition: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A special clip across step ``j`` (from time ``t0`` to ``t1`` s, ``dur_j`` s long)
    at the frames (``t`` s, ``u`` footsteps): (clip time (F,) s, its rate (F,), its ramp
    (F,) 0..1). Inside the step its ``window`` (take-off, landing) clip times are
    stretched over the step; outside it the clip plays at its own speed (``_register_special``
    keys it to the steps beside), and its ramp comes in over ``SPECIAL_RAMP`` times
    ``transition`` s before t0 and goes out over as long after t1, a smoothstep."""
    a, b = window
    ct = np.where(t < t0, a + (t - t0), np.where(t > t1, b + (t - t1), a + (u - j) * (b - a)))
    rate = np.where((t < t0) | (t > t1), 1.0, (b - a) / dur_j)
    ramp_s = max(SPECIAL_RAMP * transition, MIN_RAMP)
    ramp = _smoothstep(np.clip(np.minimum((t - (t0 - ramp_s)) / ramp_s, ((t1 + ramp_s) - t) / ramp_s), 0.0, 1.0))
    ramp[(t >= t0) & (t <= t1)] = 1.0
    return ct, rate, ramp


def special_neighbours(track: ClipTrack, window: tuple[float, float]) -> tuple[float | None, float | None]:
    """(the clip's stance before the take-off, its stance after the landing) of a special
    clip's step ``window`` (take-off, landing clip times, ``special_window``): each the
    neighbouring stance of the other foot than the one it comes next to, None where the
    clip has none (it begins with the take-off, ends with the landing, or steps twice on
    one foot there)."""
    st = track.stances
    times = [x[1] for x in st]
    i = int(np.argmin(np.abs(np.subtract(times, window[0]))))
    k = int(np.argmin(np.abs(np.subtract(times, window[1]))))
    before = st[i - 1][1] if i > 0 and st[i - 1][0] != st[i][0] and st[i - 1][1] < window[0] else None
    after = st[k + 1][1] if k + 1 < len(st) and st[k + 1][0] != st[k][0] and st[k + 1][1] > window[1] else None
    return before, after


def _register_special(ct: np.ndarray, rate: np.ndarray, t: np.ndarray, u: np.ndarray, j: int,
                      window: tuple[float, float], neighbours: tuple[float | None, float | None],
                      footprint_times: np.ndarray, dur: np.ndarray) -> None:
    """A special clip's time (``ct``, its rate ``rate`` (F,), changed in place) over the
    steps beside its own step ``j`` (walk times ``t``, normalized times ``u`` (F,)): the
    step before the take-off plays the clip from its stance before the take-off to the
    take-off, the step after the landing from the landing to its next stance
    (``special_neighbours``), each stretched over the plan's step as the cyclic clips are
    (phase keyed at footsteps): its feet come down with theirs while it ramps in and out.
    Played at its own speed there, a run-up of another cadence than the blended cycles'
    swings its arms and legs out of step with them, and the ramp turns them fast between
    the two. Beyond those steps (and where it has no such stance) it plays at its own
    speed, continuing from them."""
    a, b = window
    before, after = neighbours
    n = len(footprint_times)
    if before is not None and j >= 1:
        t_prev, t0 = footprint_times[j - 1], footprint_times[j]
        step = (t >= t_prev) & (t < t0)
        ct[step] = before + (u[step] - (j - 1)) * (a - before)
        rate[step] = (a - before) / dur[j - 1]
        early = t < t_prev
        ct[early] = before + (t[early] - t_prev)
    if after is not None and j + 2 < n:
        t1, t_next = footprint_times[j + 1], footprint_times[j + 2]
        step = (t > t1) & (t <= t_next)
        ct[step] = b + (u[step] - (j + 1)) * (after - b)
        rate[step] = (after - b) / dur[j + 1]
        late = t > t_next
        ct[late] = after + (t[late] - t_next)


def _all_weights(W: np.ndarray, lam: np.ndarray, nc: int) -> np.ndarray:
    """(F, nc + ns) every clip's weight, rows summing to 1: the special clips' ``lam``
    (F, ns) (scaled down, in place, where they sum over 1), the ``nc`` cyclic clips' ``W``
    (F, nc) sharing the rest; without cyclic clips the specials' are normalised."""
    total = lam.sum(axis=1)
    over = total > 1.0
    lam[over] /= total[over, None]
    total = np.minimum(total, 1.0)
    weights = np.concatenate([W * (1.0 - total)[:, None], lam], axis=1)
    if not nc:
        weights[:, nc:] /= np.maximum(weights[:, nc:].sum(axis=1, keepdims=True), 1e-12)
    return weights


def _ramped(t: np.ndarray, T: np.ndarray, w_step: np.ndarray, transition: float) -> np.ndarray:
    """Piecewise-constant step weights (step j over [T_j, T_j+1)) filtered by a box of
    ``transition`` seconds: linear ramps centred on the footprint times."""
    h = 0.5 * max(transition, 0.0)
    if h <= MIN_RAMP:  # no ramp (the filter would divide by about 0)
        j = np.clip(np.searchsorted(T, t, side="right") - 1, 0, len(w_step) - 1)
        return w_step[j]

    def integral(x):
        """Integral of the piecewise-constant weights from T_0 to x (held outside)."""
        x = np.asarray(x)
        j = np.clip(np.searchsorted(T, x, side="right") - 1, 0, len(w_step) - 1)
        cum = np.concatenate([np.zeros((1, w_step.shape[1])),
                              np.cumsum(w_step * np.diff(T)[:, None], axis=0)])
        return cum[j] + w_step[j] * (x - T[j])[:, None]

    return (integral(t + h) - integral(t - h)) / (2 * h)


# ----------------------------------------------------------------------------- playback

@dataclass
class Playback:
    """The motion of a schedule played without adjustment, placed so that its first
    footprint lies on ``start`` (position, heading)."""

    t: np.ndarray  # (F,)
    root: np.ndarray  # (F, 3) body (root) position, z = 0 relative to the start height
    heading: np.ndarray  # (F,) unwrapped
    heel: np.ndarray  # (2, F, 3) world
    toe: np.ndarray  # (2, F, 3)
    contact_point: np.ndarray  # (2, F, 3)
    contact: np.ndarray  # (2, F) blended contact weight in [0, 1]
    blend_alpha: np.ndarray  # (F,) the most-stable-point parameter (0 left foot, 1 right)
    correction: np.ndarray  # (F, 2) blend-point correction applied at each frame
    footprints: np.ndarray  # (N, 3) the footprints the animation leaves (heel/toe midpoint)
    footprint_heading: np.ndarray  # (N,)


def blend_point_alpha(v_left: np.ndarray, v_right: np.ndarray) -> np.ndarray:
    """Parameter a (F,) of the point a p_R + (1 - a) p_L that moves least, for foot
    velocities (F, D): argmin_a |a v_R + (1 - a) v_L|, clamped to [0, 1]; 1/2 when the
    feet move alike."""
    dv = v_right - v_left
    den = np.einsum("ij,ij->i", dv, dv)
    num = -np.einsum("ij,ij->i", v_left, dv)
    with np.errstate(invalid="ignore", divide="ignore"):
        a = np.where(den > 1e-12, num / np.where(den > 1e-12, den, 1.0), 0.5)
    return np.clip(a, 0.0, 1.0)


def playback(schedule: Schedule, tracks: dict[str, ClipTrack],
             start: tuple[np.ndarray, float] | None = None,
             forward: np.ndarray | None = None) -> Playback:
    """Play ``schedule`` (thesis 3.4): integrate the blended root velocity and yaw rate
    frame by frame, with the blend-point correction when weights change. Vectorized:
    the rotation is integrated first, then translations are summed.

    Headings are relative to the clips' rest forward. With ``start`` (position, heading)
    the result is placed by ``place`` in a world whose heading 0 points along
    ``forward`` (default: the clips' rest forward)."""
    rest_fwd = next(iter(tracks.values())).rest_forward if tracks else np.array([0.0, -1.0])
    dt = 1.0 / schedule.fps
    mix = _mix_tracks(schedule, tracks)
    heading, step = _integrate_root(mix, dt)
    alpha, corr = _blend_point_correction(mix, heading, step, dt)
    root = np.c_[np.cumsum(step + corr, axis=0), np.zeros(schedule.n)]
    world = {k: _rot2(heading[None, :], mix.points[k]) + root[None] for k in mix.points}
    fp, fh = _footprints_left(schedule, world, rest_fwd)
    out = Playback(t=schedule.t, root=root, heading=heading, heel=world["heel"], toe=world["toe"],
                   contact_point=world["contact_point"], contact=mix.contact, blend_alpha=alpha,
                   correction=corr, footprints=fp, footprint_heading=fh)
    if start is not None:
        spin = 0.0 if forward is None else float(
            np.arctan2(forward[1], forward[0]) - np.arctan2(rest_fwd[1], rest_fwd[0]))
        out = place(out, *start, spin=spin)
    return out


#: The root-frame points of the feet a playback carries (``ClipTrack`` fields, (2, n, 3)).
FOOT_POINTS = ("heel", "toe", "contact_point")


@dataclass
class _Mix:
    """The clips' samples at every frame of a schedule, blended twice: with the frame's
    own weights, and with the previous frame's (``*_prev``; the first frame's for the
    first) -- the same samples, so the two differ only by the weight change."""

    vel: np.ndarray  # (F, 2) root velocity in the root frame, m/s (clip rates applied)
    yaw_rate: np.ndarray  # (F,) rad/s
    vel_prev: np.ndarray  # (F, 2)
    yaw_rate_prev: np.ndarray  # (F,)
    points: dict  # FOOT_POINTS -> (2, F, 3) root frame, m
    points_prev: dict  # the same, previous frame's weights
    contact: np.ndarray  # (2, F) blended contact weight in [0, 1] (own weights only)


def _mix_tracks(S: Schedule, tracks: dict[str, ClipTrack]) -> _Mix:
    """Blend every clip of schedule ``S`` sampled at its clip times, sampling a clip only
    at the frames where it has weight now or had at the frame before."""
    F = S.n
    W = S.weights
    Wprev = np.vstack([W[:1], W[:-1]])
    mix = _Mix(np.zeros((F, 2)), np.zeros(F), np.zeros((F, 2)), np.zeros(F),
               {k: np.zeros((2, F, 3)) for k in FOOT_POINTS}, {k: np.zeros((2, F, 3)) for k in FOOT_POINTS},
               np.zeros((2, F)))
    for c, name in enumerate(S.clips):
        on = np.flatnonzero((W[:, c] > 0) | (Wprev[:, c] > 0))  # only where the clip plays
        if not len(on):
            continue
        smp = tracks[name].sample(S.clip_time[on, c])
        w, wp, r = W[on, c], Wprev[on, c], S.clip_rate[on, c]
        mix.vel[on] += (w * r)[:, None] * smp["vel"]
        mix.yaw_rate[on] += w * r * smp["yaw_rate"]
        mix.vel_prev[on] += (wp * r)[:, None] * smp["vel"]
        mix.yaw_rate_prev[on] += wp * r * smp["yaw_rate"]
        for k in FOOT_POINTS:
            mix.points[k][:, on] += w[None, :, None] * smp[k]
            mix.points_prev[k][:, on] += wp[None, :, None] * smp[k]
        mix.contact[:, on] += w[None, :] * smp["contact"]
    return mix


def _integrate_root(mix: _Mix, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Phase one: the root's motion from frame k-1 to k under frame k-1's weights
    (trapezoid rule over ``dt`` s; rotation first, then translation). Returns (heading (F,)
    rad from 0 at the first frame, step (F, 2) m: the root's move into each frame in the
    playback's frame, 0 into the first). A weight change at frame k only moves the feet
    in the root frame; phase two (the blend point) answers for that."""
    heading = np.concatenate([[0.0], np.cumsum(0.5 * (mix.yaw_rate_prev[1:] + mix.yaw_rate[:-1]) * dt)])
    hmid = 0.5 * (heading[1:] + heading[:-1])
    step = np.zeros((len(heading), 2))
    step[1:] = _rot2(hmid, 0.5 * (mix.vel_prev[1:] + mix.vel[:-1])) * dt
    return heading, step


def _blend_point_correction(mix: _Mix, heading: np.ndarray, step: np.ndarray, dt: float
                            ) -> tuple[np.ndarray, np.ndarray]:
    """Phase two, the blend point (module docstring): (a (F,) the most stable point's
    parameter, 0 left foot .. 1 right; correction (F, 2) m added to each frame's root
    step, 0 at the first frame) from the feet's contact points' velocities under the old
    weights and their jumps to the new ones, turned by ``heading`` (F,) rad."""
    world_new = _rot2(heading[None, :], mix.points["contact_point"])[..., :2]
    world_old = _rot2(heading[None, :], mix.points_prev["contact_point"])[..., :2]
    v = np.zeros((2, len(heading), 2))
    v[:, 1:] = (step[None, 1:] + world_old[:, 1:] - world_new[:, :-1]) / dt
    jump = world_new - world_old  # (2, F, 2)
    alpha = blend_point_alpha(v[0], v[1])
    corr = -(alpha[:, None] * jump[1] + (1.0 - alpha)[:, None] * jump[0])
    corr[0] = 0.0
    return alpha, corr


def _footprints_left(S: Schedule, world: dict, rest_fwd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The footprints the animation leaves: at each footprint's stance time (schedule
    ``S``), its foot's heel/toe midpoint (N, 3) m and the heel-to-toe direction's
    heading (N,) rad relative to ``rest_fwd`` (2,), from the feet's ``world`` points
    ("heel", "toe" (2, F, 3))."""
    T = S.footprint_times
    mid = 0.5 * (world["heel"] + world["toe"])
    d = world["toe"] - world["heel"]
    fp = np.empty((len(T), 3))
    fh = np.empty(len(T))
    for foot in (0, 1):
        sel = S.feet == foot
        if not sel.any():
            continue
        fp[sel] = np.stack([np.interp(T[sel], S.t, mid[foot, :, i]) for i in range(3)], axis=1)
        dx = np.interp(T[sel], S.t, d[foot, :, 0])
        dy = np.interp(T[sel], S.t, d[foot, :, 1])
        fh[sel] = np.arctan2(dy, dx) - np.arctan2(rest_fwd[1], rest_fwd[0])
    return fp, fh


def place(pb: Playback, position: np.ndarray, heading: float, spin: float = 0.0) -> Playback:
    """The same playback moved rigidly (yaw about Z, then translation) so that its first
    footprint lies at ``position`` with heading ``heading``. ``spin`` is the angle from
    the playback's frame to the world's for heading 0 (world forward minus rest forward)."""
    dh = float(heading) - float(pb.footprint_heading[0])
    rot = lambda p: _rot2(dh + spin, p)  # noqa: E731
    shift = np.asarray(position, float) - rot(pb.footprints[0])
    mv = lambda p: rot(p) + shift  # noqa: E731
    fh = pb.footprint_heading + dh
    return Playback(t=pb.t, root=mv(pb.root), heading=pb.heading + dh, heel=mv(pb.heel),
                    toe=mv(pb.toe), contact_point=mv(pb.contact_point), contact=pb.contact,
                    blend_alpha=pb.blend_alpha, correction=_rot2(dh + spin, pb.correction),
                    footprints=mv(pb.footprints),
                    footprint_heading=np.unwrap(fh))
