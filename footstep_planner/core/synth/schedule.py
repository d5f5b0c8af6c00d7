"""The schedule of a footstep path (thesis 3.4): for every output frame, each clip's
weight (the weights sum to 1), the clip time it is played at, and how fast that clip
time advances; the plan's steps (``PlanStep``) it is built from (``build_schedule``), and
the special clips (a jump, a start or stop clip) played across their steps.

Normalized time ``u`` counts footsteps: u = j at the stance of footprint j of the plan,
linear in time in between. Cyclic clips are played in phase: phase 0 is a left-foot
stance, 1/2 the next right-foot stance, 1 the left again; each clip's time is warped
piecewise-linearly between its own stance times, so blended clips put their feet down
together (Kovar and Gleicher's registration, keyed at footsteps as in Johansen).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from .standing import END_FADE, Standing, _smoothstep, _standing_warp, rest_times
from .tracks import FRAME_EPS, MIN_RAMP, MIN_DURATION, BlendError, ClipTrack


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
    lam = _play_specials(steps, tracks, StepTiming(walk, u, footprint_times, dur, windows),
                         clips[:len(clips) - bool(standing)], len(cyc), transition, clip_time, clip_rate)
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
    if (dur <= MIN_DURATION).any():
        j = int(np.argmax(dur <= MIN_DURATION))
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


class StepTiming(NamedTuple):
    """When a schedule's steps and frames fall (``_play_specials``).

    ``t``: (F,) s, each frame's (walk) time. ``u``: (F,) footsteps, each frame's
    normalized time. ``footprint_times``: (N,) s, each footprint's stance time on ``t``.
    ``dur``: (N-1,) s, each step's duration. ``windows``: step index -> (take-off,
    landing) clip times (s) of the special clip it plays."""

    t: np.ndarray
    u: np.ndarray
    footprint_times: np.ndarray
    dur: np.ndarray
    windows: dict


def _play_specials(steps: list[PlanStep], tracks: dict[str, ClipTrack], timing: StepTiming, clips: list[str],
                   nc: int, transition: float, clip_time: np.ndarray, clip_rate: np.ndarray) -> np.ndarray:
    """The special clips' weights (F, len(clips) - nc), each clip's the largest of its
    steps' ramps, at the frames and steps of ``timing``; fills their columns of
    ``clip_time`` and ``clip_rate`` (F, C) in place where a step's ramp is the clip's
    weight (``_special_timing``), its clip time clamped to the clip and its rate 0
    outside it."""
    t, u, footprint_times, dur, windows = timing
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
