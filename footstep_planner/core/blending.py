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

The blend point (derived here; the thesis's formulas are garbled, see
``../shared/docs/pipeline-notes.md``): when the weights change from w to w' at frame k,
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

from .analysis import ClipAnalysis
from .errors import FootstepError


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

    @property
    def n(self) -> int:
        return len(self.vel)

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
    stances = sorted(((s.foot, float(s.stance)) for s in a.stances), key=lambda x: x[1])
    phase = _phase_times(a) if a.kind == "cycle" else None
    return ClipTrack(name=a.name, kind=a.kind, gait=a.gait, entry_gait=a.entry_gait,
                     exit_gait=a.exit_gait, rate=float(dense.fps), duration=dense.duration,
                     vel=vel, yaw_rate=yaw_rate, heel=heel, toe=toe, contact_point=cpt,
                     contact=con, hips_in_root=dense.hips_in_root, phase_times=phase,
                     rest_forward=np.asarray(m.rest_forward, float), stances=stances,
                     pose_rate=float(m.fps), quat=_quats(m.local_rot), hips=m.hips_in_root)


def _quats(rot: np.ndarray) -> np.ndarray:
    """(N, B, 3, 3) rotation matrices -> (N, B, 4) unit quaternions (x, y, z, w), each
    bone's sequence kept on one hemisphere (no sign flips between samples)."""
    from scipy.spatial.transform import Rotation

    n, b = rot.shape[:2]
    q = Rotation.from_matrix(rot.reshape(-1, 3, 3)).as_quat().reshape(n, b, 4)
    flip = np.cumprod(np.where(np.einsum("nbk,nbk->nb", q[1:], q[:-1]) < 0, -1.0, 1.0), axis=0)
    q[1:] *= flip[..., None]
    return q


def _phase_times(a: ClipAnalysis) -> np.ndarray:
    """The clip times that key a cyclic clip's phase (``ClipTrack.phase_times``): a left
    stance, the next right one and the next left one, the first such triple in the
    clip's best cycle (else anywhere). Only whole stances count (a stance cut by the
    clip's start or end has a stance time that is merely where the clip begins or ends):
    a clip that holds no whole left-right-left triple is keyed on a right-left-right one.
    Cut stances are the last resort."""
    lo = a.best_cycle[0] - 1e-6 if a.best_cycle else 0.0
    whole = sorted(((s.foot, float(s.stance)) for s in a.stances if not (s.open_start or s.open_end)),
                   key=lambda x: x[1])
    every = sorted(((s.foot, float(s.stance)) for s in a.stances), key=lambda x: x[1])
    for stances in (whole, every):
        for first in (0, 1):
            triples = _triples(stances, first)
            if triples:
                good = [t for t in triples if t[0] >= lo]
                t0, t1, t2 = (good or triples)[0]
                if first == 0:
                    return np.array((t0, t1, t2), dtype=np.float64)
                # right r0, left l1, right r2: phase 0 at l1, 1/2 at r2 (one cycle on from r0)
                return np.array((t1, t2, t0, t1), dtype=np.float64)
    raise BlendError(f"clip {a.name!r} has no left-right-left footstep sequence to loop")


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

    @property
    def n(self) -> int:
        return len(self.t)

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


def build_schedule(steps: list[PlanStep], tracks: dict[str, ClipTrack], cyclic: list[str],
                   fps: float, transition: float, loco_weights=None,
                   step_durations: np.ndarray | None = None) -> Schedule:
    """The frames of a footstep path of len(steps) + 1 footprints.

    ``cyclic`` names the cyclic clips (the columns of each step's ``weights``). Each
    locomotion step lasts the weighted mean of its clips' step durations (or
    ``step_durations``); a special step lasts as long as its clip takes from take-off
    to landing. Locomotion weights are the steps' weights with linear ramps of
    ``transition`` seconds centred on footprint times, or ``loco_weights(u)`` (a callable
    returning (F, C) rows) when given. A special clip ramps in over ``transition``
    before its take-off and out after its landing, played at its own speed there.
    """
    nstep = len(steps)
    if nstep == 0:
        raise BlendError("a path of one footprint has no motion to play")
    cyc = [tracks[c] for c in cyclic]
    nc = len(cyc)
    feet = np.array([s.foot for s in steps] + [1 - steps[-1].foot])
    specials = sorted({s.special for s in steps if s.special})
    clips = list(cyclic) + specials

    # locomotion weights per step (specials take their neighbours' weights)
    w_step = np.full((nstep, nc), np.nan)
    for j, s in enumerate(steps):
        if s.special is None:
            w = np.asarray(s.weights, float)
            if w.shape != (nc,) or abs(w.sum() - 1.0) > 1e-6 or (w < -1e-12).any():
                raise BlendError(f"step {j}: weights must be {nc} non-negative numbers summing to 1")
            w_step[j] = w
    have = ~np.isnan(w_step[:, 0]) if nc else np.zeros(nstep, bool)
    if nc and not have.any():
        raise BlendError("the path has no walking or running step to play between its special clips")
    if nc:
        idx = np.where(have, np.arange(nstep), -1)
        idx = np.maximum.accumulate(idx)
        first = int(np.argmax(have))
        idx[idx < 0] = first
        w_step = w_step[idx]

    # durations: cyclic steps the weighted mean of their clips', specials their clip's own
    step_feet = feet[:-1]
    dur = (w_step * step_durations_of(cyc)[step_feet]).sum(axis=1) if nc else np.zeros(nstep)
    windows = {}
    for j, s in enumerate(steps):
        if s.special:
            a, b = special_window(tracks[s.special], s.foot)
            windows[j] = (a, b)
            dur[j] = b - a
    if step_durations is not None:
        loco = np.array([s.special is None for s in steps])
        dur[loco] = np.asarray(step_durations, float)[loco]
    if (dur <= 1e-6).any():
        j = int(np.argmax(dur <= 1e-6))
        raise BlendError(f"step {j} has no duration: its clips put both feet down at once")
    T = np.concatenate([[0.0], np.cumsum(dur)])
    nf = int(np.ceil(T[-1] * fps - 1e-9)) + 1  # the last frame reaches the last footprint
    t = np.arange(nf) / fps
    u = np.interp(t, T, np.arange(nstep + 1))
    u = np.where(t > T[-1], nstep + (t - T[-1]) / dur[-1], u)  # under a frame past the end
    step_of = np.minimum(u.astype(np.int64), nstep - 1)
    du_dt = 1.0 / dur[step_of]

    # cyclic clips: phase from u; the left foot's stances at whole phases
    off = 0.0 if feet[0] == 0 else 1.0
    phase = 0.5 * (u + off)
    C = len(clips)
    clip_time = np.zeros((nf, C))
    clip_rate = np.zeros((nf, C))
    for c, tr in enumerate(cyc):
        ct, slope = tr.clip_time_of_phase(phase)
        clip_time[:, c] = ct
        clip_rate[:, c] = slope * 0.5 * du_dt

    # locomotion weights
    if nc:
        if loco_weights is not None:
            W = np.asarray(loco_weights(u), float)
        else:
            W = _ramped(t, T, w_step, transition)
    else:
        W = np.zeros((nf, 0))

    # special clips: their own time, ramps outside their step
    lam = np.zeros((nf, len(specials)))
    for j, s in enumerate(steps):
        if not s.special:
            continue
        c = clips.index(s.special)
        k = c - nc
        a, b = windows[j]
        t0, t1 = T[j], T[j + 1]
        tr = tracks[s.special]
        ct = np.where(t < t0, a + (t - t0), np.where(t > t1, b + (t - t1), a + (u - j) * (b - a)))
        rate = np.where((t < t0) | (t > t1), 1.0, (b - a) / dur[j])
        tr_ = max(transition, 1e-6)
        ramp = np.clip(np.minimum((t - (t0 - tr_)) / tr_, ((t1 + tr_) - t) / tr_), 0.0, 1.0)
        ramp[(t >= t0) & (t <= t1)] = 1.0
        mine = ramp > lam[:, k]
        lam[mine, k] = ramp[mine]
        clip_time[mine, c] = np.clip(ct[mine], 0.0, tr.duration)
        inside = (ct[mine] >= 0.0) & (ct[mine] <= tr.duration)
        clip_rate[mine, c] = np.where(inside, rate[mine], 0.0)
    total = lam.sum(axis=1)
    over = total > 1.0
    lam[over] /= total[over, None]
    total = np.minimum(total, 1.0)
    weights = np.concatenate([W * (1.0 - total)[:, None], lam], axis=1) if C else np.zeros((nf, 0))
    if not nc:
        weights[:, nc:] /= np.maximum(weights[:, nc:].sum(axis=1, keepdims=True), 1e-12)
    return Schedule(t=t, u=u, clips=clips, weights=weights, clip_time=clip_time,
                    clip_rate=clip_rate, footprint_times=T, feet=feet, fps=float(fps))


def _ramped(t: np.ndarray, T: np.ndarray, w_step: np.ndarray, transition: float) -> np.ndarray:
    """Piecewise-constant step weights (step j over [T_j, T_j+1)) filtered by a box of
    ``transition`` seconds: linear ramps centred on the footprint times."""
    h = 0.5 * max(transition, 0.0)
    if h <= 1e-6:  # no ramp (below a microsecond the filter would divide by ~0)
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
    S = schedule
    rest_fwd = next(iter(tracks.values())).rest_forward if tracks else np.array([0.0, -1.0])
    F, dt = S.n, 1.0 / S.fps
    W = S.weights
    vel = np.zeros((F, 2))  # blended with this frame's weights
    yaw = np.zeros(F)
    vel_old = np.zeros((F, 2))  # the same samples blended with the previous frame's weights
    yaw_old = np.zeros(F)
    pts = {k: np.zeros((2, F, 3)) for k in ("heel", "toe", "contact_point")}
    pts_old = {k: np.zeros((2, F, 3)) for k in ("heel", "toe", "contact_point")}
    contact = np.zeros((2, F))
    Wprev = np.vstack([W[:1], W[:-1]])
    for c, name in enumerate(S.clips):
        on = np.flatnonzero((W[:, c] > 0) | (Wprev[:, c] > 0))  # only where the clip plays
        if not len(on):
            continue
        smp = tracks[name].sample(S.clip_time[on, c])
        w, wp, r = W[on, c], Wprev[on, c], S.clip_rate[on, c]
        vel[on] += (w * r)[:, None] * smp["vel"]
        yaw[on] += w * r * smp["yaw_rate"]
        vel_old[on] += (wp * r)[:, None] * smp["vel"]
        yaw_old[on] += wp * r * smp["yaw_rate"]
        for k in pts:
            pts[k][:, on] += w[None, :, None] * smp[k]
            pts_old[k][:, on] += wp[None, :, None] * smp[k]
        contact[:, on] += w[None, :] * smp["contact"]

    # Phase one: the motion from frame k-1 to k under frame k-1's weights (trapezoid;
    # rotation first, then translation). A weight change at frame k only moves the
    # feet in the root frame; phase two (the blend point) answers for that.
    heading = np.concatenate([[0.0], np.cumsum(0.5 * (yaw_old[1:] + yaw[:-1]) * dt)])
    hmid = 0.5 * (heading[1:] + heading[:-1])
    step = np.zeros((F, 2))
    step[1:] = _rot2(hmid, 0.5 * (vel_old[1:] + vel[:-1])) * dt

    # blend point: velocities of the feet under the old weights, jumps from the new ones
    cp, cpo = pts["contact_point"], pts_old["contact_point"]
    world_new = _rot2(heading[None, :], cp)[..., :2]
    world_old = _rot2(heading[None, :], cpo)[..., :2]
    v = np.zeros((2, F, 2))
    v[:, 1:] = (step[None, 1:] + world_old[:, 1:] - world_new[:, :-1]) / dt
    jump = world_new - world_old  # (2, F, 2)
    alpha = blend_point_alpha(v[0], v[1])
    corr = -(alpha[:, None] * jump[1] + (1.0 - alpha)[:, None] * jump[0])
    corr[0] = 0.0
    root2 = np.cumsum(step + corr, axis=0)
    root = np.c_[root2, np.zeros(F)]

    world = {k: _rot2(heading[None, :], pts[k]) + root[None] for k in pts}
    # the footprints left: heel/toe midpoint and direction at each stance time
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
    out = Playback(t=S.t, root=root, heading=heading, heel=world["heel"], toe=world["toe"],
                   contact_point=world["contact_point"], contact=contact, blend_alpha=alpha,
                   correction=corr, footprints=fp, footprint_heading=fh)
    if start is not None:
        spin = 0.0 if forward is None else float(
            np.arctan2(forward[1], forward[0]) - np.arctan2(rest_fwd[1], rest_fwd[0]))
        out = place(out, *start, spin=spin)
    return out


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
