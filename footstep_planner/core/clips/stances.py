"""When and where each foot of a clip is planted, after Johansen (2008): the analysis's
(``analysis``) first reading.

Here: a stance's contact events and footprint (``Stance``, ``Footprint``; the events as
``analysis`` names them); the clip resampled to ``Settings.analysis_rate`` with its
body's speed (``_Dense``, ``_resample``); and each foot's stances found on it
(``_foot_stances``: the foot near the ground and slow, its firm part, Johansen's vertical
rules for strike, land, lift and liftoff searched from there, cut short where the foot
slips), with the helpers on 1-D signals they use. Times are seconds from the clip's first
sample; foot 0 is the left.

Pure numpy/scipy: never imports bpy.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.ndimage import gaussian_filter1d

from .clip import FOOT_NAMES, ClipMotion
from ..base.settings import Settings


@dataclass
class Footprint:
    foot: int  # 0 left, 1 right
    time: float  # stance time, s
    position: np.ndarray  # (3,) midpoint of heel and toe on the ground
    heading: float  # yaw of heel -> toe, radians (0 = the rig's rest forward)
    heel: np.ndarray  # (3,)
    toe: np.ndarray  # (3,)
    strike_part: str | None  # "heel" or "toe": which touched first (None: down at clip start)

    def to_dict(self, motion: ClipMotion) -> dict:
        return {
            "foot": FOOT_NAMES[self.foot], "time": _r(self.time),
            "frame": _r(float(motion.frame_of(self.time)), 2),
            "position": [_r(v) for v in self.position], "heading": _r(self.heading),
            "heel": [_r(v) for v in self.heel], "toe": [_r(v) for v in self.toe],
            "strike": self.strike_part,
        }


@dataclass
class Stance:
    foot: int
    stance: float
    strike: float  # equals the clip start when the foot is already down there
    land: float
    lift: float
    liftoff: float  # equals the clip end when the foot is still down there
    open_start: bool  # already down when the clip starts
    open_end: bool  # still down when the clip ends
    footprint: Footprint


def _r(v, nd=4):
    """``v`` rounded to ``nd`` decimals for a report; None for None or not finite."""
    if v is None:
        return None
    v = float(v)
    return None if not np.isfinite(v) else round(v, nd)


# ----------------------------------------------------------------------------------
# helpers on 1-D signals

def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """(start, stop) index pairs of the True runs of ``mask`` (stop exclusive)."""
    m = np.concatenate([[False], np.asarray(mask, bool), [False]])
    d = np.flatnonzero(np.diff(m.astype(np.int8)))
    return list(zip(d[0::2], d[1::2]))


def _clean_runs(mask: np.ndarray, max_gap: int, min_len: int) -> list[tuple[int, int]]:
    """The True runs of ``mask`` (``_runs``) with gaps of at most ``max_gap`` samples
    closed, then runs shorter than ``min_len`` samples dropped."""
    runs = _runs(mask)
    merged: list[list[int]] = []
    for a, b in runs:
        if merged and a - merged[-1][1] <= max_gap:
            merged[-1][1] = b
        else:
            merged.append([a, b])
    return [(a, b) for a, b in merged if b - a >= min_len]


def _peak(values: np.ndarray, i: int) -> float:
    """Sub-sample position of a peak at index ``i`` (parabola through three samples)."""
    if 0 < i < len(values) - 1:
        a, b, c = values[i - 1], values[i], values[i + 1]
        den = a - 2 * b + c
        if den < 0:
            return i + float(np.clip(0.5 * (a - c) / den, -0.5, 0.5))
    return float(i)


def _rise_index(y: np.ndarray, d1: np.ndarray, d2: np.ndarray, i0: int, i1: int,
                s: Settings) -> float | None:
    """Johansen's rules, searching forward from the stance index ``i0`` (exclusive bound
    ``i1``): the point where the curve starts to rise from the ground. None when the
    curve does not rise above ``min_step_height`` before ``i1``."""
    seg = y[i0:i1]
    if len(seg) < 3:
        return None
    y0 = seg[0]
    top = seg.max()
    if top - y0 < s.min_step_height:
        return None
    reach = np.flatnonzero(seg >= y0 + s.lift_fraction * (top - y0))
    te = int(reach[0]) if len(reach) else len(seg) - 1
    # rules 2-4 inside [i0, i0 + te]: steepest rise of the slope, above the ground
    # (not below the stance height), where the curve is not going down
    idx = np.arange(i0, i0 + te + 1)
    ok = (y[idx] >= min(y0, 0.0)) & (d1[idx] >= 0)
    if not ok.any():
        return float(i0 + te)
    cand = idx[ok]
    best = int(cand[np.argmax(d2[cand])])
    return _peak(d2, best)


def _crossing(y: np.ndarray, i: int, toward: int, thr: float, first: int = 0) -> float:
    """Sub-sample time where ``y`` crosses ``thr`` between sample ``i`` (above) and its
    neighbour ``i + toward`` (below); ``y`` may be a window of a longer signal starting
    at its sample ``first``, which the time is then counted in."""
    j = i + toward
    if not 0 <= j < len(y) or y[i] == y[j]:
        return float(first + i)
    return (first + i) + toward * float(np.clip((y[i] - thr) / (y[i] - y[j]), 0.0, 1.0))


def _flip(x: float | None, n: int) -> float | None:
    """Sample position ``x`` of a signal of ``n`` samples run backward, as a position in
    the forward signal (None stays None)."""
    return None if x is None else (n - 1) - x


# ----------------------------------------------------------------------------------
# the clip at the analysis rate

@dataclass
class _Dense:
    """The clip resampled to the analysis rate, and its body's speed."""

    motion: ClipMotion  # the resampled clip: times (n,) s, 0 to (n - 1) * dt
    rate: float  # samples per second: the analysis rate, or the clip's own if higher
    dt: float  # 1 / rate, s
    n: int  # samples
    body_speed: np.ndarray  # (n,) m/s of the root in the ground plane (XY)
    body_speed_s: np.ndarray  # (n,) m/s, the same as a 0.1 s moving average


def _resample(motion: ClipMotion, s: Settings) -> _Dense:
    """The clip at ``s.analysis_rate`` samples per second (cubic; kept as it is when its
    own rate is that or higher), with its root's horizontal speed, raw and smoothed."""
    rate = max(float(s.analysis_rate), motion.fps)
    dense = motion if abs(rate - motion.fps) < 1e-9 else motion.resample(rate)
    dt = 1.0 / rate
    root_v = np.gradient(dense.root_pos[:, :2], dt, axis=0)
    body_speed = np.linalg.norm(root_v, axis=1)
    return _Dense(dense, rate, dt, len(dense.times), body_speed,
                  _smooth(body_speed, int(round(0.1 / dt))))


def _smooth(x: np.ndarray, width: int) -> np.ndarray:
    """Moving average of ``x`` (N,) over ``width`` samples, edges padded by repetition;
    ``x`` itself for a width of 1 or less."""
    if width <= 1:
        return x
    k = np.ones(width) / width
    return np.convolve(np.pad(x, (width // 2, width - 1 - width // 2), mode="edge"), k, "valid")


# ----------------------------------------------------------------------------------
# one foot

@dataclass
class _Foot:
    """What the analysis of one foot gives."""

    stances: list[Stance]
    balance: np.ndarray  # (N,) toe weight
    lowest: float  # lowest of heel and toe, m


@dataclass
class _FootSignals:
    """One foot's curves on the dense clip: N samples ``dt`` s apart, metres, m/s."""

    heel: np.ndarray  # (N, 3) heel point
    toe: np.ndarray  # (N, 3) toe (ball) point
    heel_z: np.ndarray  # (N,) heel height
    toe_z: np.ndarray  # (N,) toe height
    balance: np.ndarray  # (N,) toe weight in [0, 1]: 0.5 + (heel_z - toe_z) / balance band
    lower_z: np.ndarray  # (N,) the lower of heel and toe
    upper_z: np.ndarray  # (N,) the higher of heel and toe: low only with both down
    velocity: np.ndarray  # (N, 2) horizontal velocity of the part that is down
    speed: np.ndarray  # (N,) its norm
    sigma: float  # derivative smoothing, samples
    dt: float  # s between samples


@dataclass
class _Events:
    """One stance's contact events, in dense samples (fractional but ``stance``)."""

    stance: int  # the foot stands most firmly
    strike: float  # first touch (0 with open_start)
    land: float  # fully landed
    lift: float  # begins to lift
    liftoff: float  # has left the ground (N - 1 with open_end)
    open_start: bool  # no strike found: already down when the clip starts
    open_end: bool  # no liftoff found: still down when the clip ends


def _foot_stances(dense: ClipMotion, k: int, body_speed: np.ndarray, s: Settings) -> _Foot:
    """The stances of foot ``k`` on the densely resampled clip (Johansen's rules);
    ``body_speed`` (N,) m/s is the smoothed body speed."""
    sig = _foot_signals(dense, k, s)
    out = _Foot([], sig.balance, float(sig.lower_z.min()))
    runs = _seed_runs(sig, s)
    if not runs:
        return out
    firm, ts = _firm_parts(sig, runs, s)
    heights = _height_curves(sig)
    events = [_stance_events(sig, heights, firm, j, i0, body_speed, s) for j, i0 in enumerate(ts)]
    for ev in _merge_standing(events):
        out.stances.append(_stance_of(dense, k, sig, ev))
    return out


def _foot_signals(dense: ClipMotion, k: int, s: Settings) -> _FootSignals:
    """Heights, balance and the planted part's velocity of foot ``k``."""
    t = dense.times
    dt = t[1] - t[0]
    heel, toe = dense.heel[k], dense.toe[k]
    hh, ht = heel[:, 2], toe[:, 2]
    # Johansen's balance: the toe's weight grows as the heel rises above the toe
    b = np.clip(0.5 + (hh - ht) / s.balance_band, 0.0, 1.0)
    # velocity of the part that is down: the heel's and toe's velocities blended by the
    # balance (differentiating the blended point would add the roll-off itself)
    sigma = s.derivative_smoothing / dt
    v_heel = gaussian_filter1d(heel[:, :2], sigma, axis=0, order=1, mode="nearest") / dt
    v_toe = gaussian_filter1d(toe[:, :2], sigma, axis=0, order=1, mode="nearest") / dt
    vc = v_heel + b[:, None] * (v_toe - v_heel)
    return _FootSignals(heel, toe, hh, ht, b, np.minimum(hh, ht), np.maximum(hh, ht), vc,
                        np.linalg.norm(vc, axis=1), sigma, dt)


def _seed_runs(sig: _FootSignals, s: Settings) -> list[tuple[int, int]]:
    """(start, stop) sample runs where the foot is near the clip's ground (or the foot's
    lowest level, for feet that sink below it) and slow: gaps up to 0.06 s closed, runs
    under 0.04 s (2 samples) dropped."""
    dt = sig.dt
    ground = min(float(np.percentile(sig.lower_z, 2)), 0.0)
    down = (sig.lower_z < ground + s.contact_height) & (sig.speed < s.contact_speed)
    return _clean_runs(down, int(round(0.06 / dt)), max(2, int(round(0.04 / dt))))


def _firm_parts(sig: _FootSignals, runs: list[tuple[int, int]], s: Settings
                ) -> tuple[list[tuple[int, int]], list[int]]:
    """(firm, ts) per seed run: ``firm`` the (first, last) sample (inclusive) of the
    firm part of the stance (heel and toe both near their lowest, the foot slow), ``ts``
    the stance sample inside it. Johansen's searches start from the firm part's edges,
    so a heel wobbling while the foot pivots on its ball (sharp turns) does not end the
    stance."""
    low = sig.upper_z
    firm, ts = [], []
    for a, e in runs:
        i0 = a + int(np.argmin(low[a:e]))
        ok = (low[a:e] <= low[i0] + s.firm_height) & (sig.speed[a:e] < s.firm_speed)
        idx = np.flatnonzero(ok) + a
        if len(idx):
            firm.append((int(idx[0]), int(idx[-1])))
            i0 = int(idx[np.argmin(low[idx])])
        else:
            firm.append((i0, i0))
        ts.append(i0)
    return firm, ts


def _height_curves(sig: _FootSignals) -> tuple[list, list]:
    """(forward, backward): for the heel and the toe height, (y, dy, d2y) per sample
    (Gaussian derivatives, ``sig.sigma``), and the same curves run backward in time."""
    curves = [(y, gaussian_filter1d(y, sig.sigma, order=1, mode="nearest"),
               gaussian_filter1d(y, sig.sigma, order=2, mode="nearest"))
              for y in (sig.heel_z, sig.toe_z)]
    reverse = [(y[::-1], -d[::-1], dd[::-1]) for y, d, dd in curves]
    return curves, reverse


def _stance_events(sig: _FootSignals, heights: tuple[list, list], firm: list[tuple[int, int]],
                   j: int, i0: int, body_speed: np.ndarray, s: Settings) -> _Events:
    """The events of the ``j``-th stance (stance sample ``i0``): Johansen's vertical
    rules searched from its firm part's edges up to the neighbouring firm parts, cut
    short where the foot slips (``_slips``)."""
    n = len(sig.heel_z)
    fa, fb = firm[j]
    nxt = firm[j + 1][0] if j + 1 < len(firm) else n
    prv = firm[j - 1][1] if j > 0 else -1
    forward, backward = heights
    slip_b, slip_f = _slips(sig, body_speed[i0], fa, fb, prv, nxt, s)
    lift, liftoff = _leaving(forward, fb, nxt, slip_f, s)
    strike, land = _arriving(backward, fa, prv, n, slip_b, s)
    return _Events(i0, 0.0 if strike is None else strike, 0.0 if land is None else land,
                   float(n - 1) if lift is None else lift,
                   float(n - 1) if liftoff is None else liftoff, strike is None, liftoff is None)


def _slips(sig: _FootSignals, body_speed: float, fa: int, fb: int, prv: int, nxt: int,
           s: Settings) -> tuple[float | None, float | None]:
    """(before, after): Johansen's horizontal check. The foot has not yet reached
    (``before``, searched back from ``fa`` to ``prv``) or has left (``after``, from
    ``fb`` to ``nxt``) the ground where its velocity departs from its median velocity
    over the firm part [fa, fb] by more than ``s.slip_tolerance`` times the body speed
    (m/s), at least ``s.slip_min_speed``. Fractional samples; None: no such point."""
    vc = sig.velocity
    thr = max(s.slip_tolerance * body_speed, s.slip_min_speed)
    lo, hi = max(prv, 0), min(nxt + 1, len(vc))  # (the search, and the samples beside it)
    dev = np.linalg.norm(vc[lo:hi] - np.median(vc[fa:fb + 1], axis=0), axis=1)
    fwd = np.flatnonzero(dev[fb - lo:nxt - lo] > thr)
    bwd = np.flatnonzero(dev[prv + 1 - lo:fa + 1 - lo] > thr)
    slip_f = _crossing(dev, fb - lo + fwd[0], -1, thr, lo) if len(fwd) else None
    slip_b = _crossing(dev, prv + 1 - lo + bwd[-1], +1, thr, lo) if len(bwd) else None
    return slip_b, slip_f


def _leaving(curves: list, fb: int, nxt: int, slip: float | None, s: Settings
             ) -> tuple[float | None, float | None]:
    """(lift, liftoff) in fractional samples: the first and last of heel and toe to rise
    after ``fb`` (before ``nxt``), liftoff no later than ``slip``. None: the foot does
    not leave."""
    rises = [x for x in (_rise_index(*c, fb, nxt, s) for c in curves) if x is not None]
    lift, liftoff = (min(rises), max(rises)) if rises else (None, None)
    if slip is not None and (liftoff is None or slip < liftoff):
        liftoff = slip
        lift = slip if lift is None else min(lift, slip)
    return lift, liftoff


def _arriving(reverse: list, fa: int, prv: int, n: int, slip: float | None, s: Settings
              ) -> tuple[float | None, float | None]:
    """(strike, land) in fractional samples: the first and last of heel and toe to come
    down before ``fa`` (after ``prv``; the rise rules run backward in time), strike no
    earlier than ``slip``. None: the foot was down all along."""
    touches = [x for x in (_flip(_rise_index(*c, n - 1 - fa, n - 1 - prv, s), n)
                           for c in reverse) if x is not None]
    strike, land = (min(touches), max(touches)) if touches else (None, None)
    if slip is not None and (strike is None or slip > strike):
        strike = slip
        land = slip if land is None else max(land, slip)
    return strike, land


def _merge_standing(events: list[_Events]) -> list[_Events]:
    """A foot that never left the ground between two stances stood all along: such
    stances become one (the first's stance, strike and land; the last's lift and
    liftoff). Modifies the merged records in place."""
    merged: list[_Events] = []
    for ev in events:
        if merged and (merged[-1].open_end or ev.strike <= merged[-1].liftoff):
            merged[-1].lift, merged[-1].liftoff, merged[-1].open_end = ev.lift, ev.liftoff, ev.open_end
        else:
            merged.append(ev)
    return merged


def _stance_of(dense: ClipMotion, k: int, sig: _FootSignals, ev: _Events) -> Stance:
    """The Stance of foot ``k`` with events ``ev`` (samples converted to seconds) and its
    footprint: heel and toe at their medians from landing (or the stance, if earlier)
    to lifting (or the stance, if later)."""
    t = dense.times
    n = len(t)
    lo, hi = int(np.ceil(min(ev.land, ev.stance))), int(np.floor(max(ev.lift, ev.stance)))
    heel_p = np.median(sig.heel[lo:hi + 1], axis=0)
    toe_p = np.median(sig.toe[lo:hi + 1], axis=0)
    d = toe_p - heel_p
    fwd_angle = np.arctan2(dense.rest_forward[1], dense.rest_forward[0])
    heading = float((np.arctan2(d[1], d[0]) - fwd_angle + np.pi) % (2 * np.pi) - np.pi)
    si = int(np.clip(round(ev.strike), 0, n - 1))
    part = None if ev.open_start else ("heel" if sig.heel_z[si] <= sig.toe_z[si] else "toe")
    fp = Footprint(k, float(t[ev.stance]), 0.5 * (heel_p + toe_p), heading, heel_p, toe_p, part)
    dt = sig.dt
    return Stance(k, float(t[ev.stance]), ev.strike * dt, ev.land * dt, ev.lift * dt,
                  ev.liftoff * dt, ev.open_start, ev.open_end, fp)
