"""Playing a schedule of clips with blend weights (thesis 3.4): the playback.

*Playback* integrates the blended root motion of a schedule (``schedule.Schedule``, its
clips' ``tracks.ClipTrack``) over the frames and keeps the *blend point* still when the
weights change. The root moves on the ground plane: playback is horizontal (x, y);
heights come later from the footprints. Conventions as in ``tracks``.

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

from dataclasses import dataclass

import numpy as np

from .schedule import Schedule
from .tracks import ClipTrack, _rot2


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
