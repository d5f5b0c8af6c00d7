"""Standing at a path's ends (issue 14): the ``Standing`` a schedule starts and stops in,
its time warp (the walk held while the character stands, sped up from rest and slowed
down to rest: ``_standing_warp``), where a start or stop clip sets off and comes to rest
(``rest_times``), and the standing clip made from a walk for a library without an idle
clip (``standing_track``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .tracks import FRAME_EPS, MIN_RAMP, MIN_DURATION, BlendError, ClipTrack


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
    if span <= MIN_DURATION:
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
