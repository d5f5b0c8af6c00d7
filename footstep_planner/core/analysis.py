"""Clip analysis after Johansen (2008): when and where each foot is planted, and what
the clip does (speed, stride, cycle, curvature, gait, start/stop, jumps).

All times are seconds from the clip's first sample; frames are scene frames. Foot index 0
is the left foot. Curvature tau = 1/r is signed, positive turning left. The clip is first
resampled (cubic) to ``Settings.analysis_rate`` so the figures do not depend on the rate
the clip was sampled at.

Contact events of one stance, in time order (Johansen's names)::

    strike  the foot first touches the ground (heel or toe)
    land    the foot is fully landed (heel and toe down)
    stance  the foot stands most firmly (heel and toe both lowest)
    lift    the foot begins to lift (the first of heel and toe rises)
    liftoff the foot has left the ground

The foot bears weight ("contact") from strike to liftoff.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.ndimage import gaussian_filter1d

from .clip import FOOT_NAMES, ClipMotion
from .settings import Settings
from .errors import FootstepError


class AnalysisError(FootstepError):
    """A clip that cannot be analysed; the message names the clip."""


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


@dataclass
class ClipAnalysis:
    name: str
    fps: float
    frames: int
    duration: float
    gait: str  # "walk", "run" or "stand"
    kind: str  # "cycle", "start", "stop", "jump" or "idle"
    starts_at_rest: bool
    ends_at_rest: bool
    entry_gait: str
    exit_gait: str
    speed: float  # m/s over the best cycle (0 for a clip with no cycle)
    stride: float | None  # m, same-foot footprint to footprint
    cycle: float | None  # s, period of the gait cycle
    cadence: float | None  # steps per minute
    tau: float  # 1/m, signed, positive turning left
    best_cycle: tuple[float, float] | None  # (start, end) s
    loop_error: float | None  # mean bone rotation mismatch over the best cycle, radians
    is_loop: bool
    stances: list[Stance]
    flights: list[tuple[float, float]]
    jump_flights: list[tuple[float, float]]
    balance: np.ndarray = field(repr=False)  # (2, N) toe weight per clip sample
    contact: np.ndarray = field(repr=False)  # (2, N) bool per clip sample
    motion: ClipMotion = field(repr=False, default=None)

    def footprints(self) -> list[Footprint]:
        return [s.footprint for s in sorted(self.stances, key=lambda s: s.stance)]

    def contact_intervals(self, foot: int) -> list[tuple[float, float]]:
        return [(s.strike, s.liftoff) for s in self.stances if s.foot == foot]

    def to_dict(self) -> dict:
        m = self.motion
        fr = lambda t: _r(float(m.frame_of(t)), 2)  # noqa: E731
        feet = {}
        for k, foot in enumerate(FOOT_NAMES):
            feet[foot] = {
                "contacts": [[fr(s.strike), fr(s.liftoff)] for s in self.stances if s.foot == k],
                "events": [{"strike": fr(s.strike), "land": fr(s.land), "stance": fr(s.stance),
                            "lift": fr(s.lift), "liftoff": fr(s.liftoff)}
                           for s in self.stances if s.foot == k],
                "stance_time": _r(float(np.mean([s.liftoff - s.strike for s in self.stances
                                                 if s.foot == k and not (s.open_start or s.open_end)]
                                                or [np.nan]))),
            }
        return {
            "name": self.name, "fps": _r(self.fps), "frames": self.frames,
            "duration": _r(self.duration), "source_fps": m.source_fps,
            "kind": self.kind, "gait": self.gait, "start": self.starts_at_rest,
            "stop": self.ends_at_rest, "entry_gait": self.entry_gait, "exit_gait": self.exit_gait,
            "speed": _r(self.speed), "stride": _r(self.stride), "cycle": _r(self.cycle),
            "cadence": _r(self.cadence, 1), "tau": _r(self.tau),
            "best_cycle": None if self.best_cycle is None else [fr(t) for t in self.best_cycle],
            "loop_error_deg": None if self.loop_error is None else _r(np.degrees(self.loop_error), 2),
            "is_loop": self.is_loop,
            "flights": [[fr(a), fr(b), _r(b - a)] for a, b in self.flights],
            "jumps": [[fr(a), fr(b), _r(b - a)] for a, b in self.jump_flights],
            "feet": feet,
            "footprints": [f.to_dict(m) for f in self.footprints()],
        }


def _r(v, nd=4):
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


def _crossing(y: np.ndarray, i: int, toward: int, thr: float) -> float:
    """Sub-sample time where ``y`` crosses ``thr`` between sample ``i`` (above) and its
    neighbour ``i + toward`` (below)."""
    j = i + toward
    if not 0 <= j < len(y) or y[i] == y[j]:
        return float(i)
    return i + toward * float(np.clip((y[i] - thr) / (y[i] - y[j]), 0.0, 1.0))


def _flip(x: float | None, n: int) -> float | None:
    return None if x is None else (n - 1) - x


# ----------------------------------------------------------------------------------

def analyze_clip(motion: ClipMotion, settings: Settings | None = None) -> ClipAnalysis:
    """Analyse one clip. Raises AnalysisError (naming the clip) when no foot ever touches
    the ground, or a locomotion clip is too short to hold one gait cycle."""
    s = settings or Settings()
    name = motion.name
    if motion.n < 4 or motion.duration <= 0:
        raise AnalysisError(f"clip {name!r} is too short to analyse ({motion.n} frames)")
    rate = max(float(s.analysis_rate), motion.fps)
    dense = motion if abs(rate - motion.fps) < 1e-9 else motion.resample(rate)
    t = dense.times
    n = len(t)
    dt = 1.0 / rate

    root_v = np.gradient(dense.root_pos[:, :2], dt, axis=0)
    body_speed = np.linalg.norm(root_v, axis=1)
    body_speed_s = _smooth(body_speed, int(round(0.1 / dt)))

    contact = np.zeros((2, n), bool)
    balance = np.zeros((2, n))
    stances: list[Stance] = []
    lowest = []
    for k in range(2):
        foot = _foot_stances(dense, k, body_speed_s, s)
        balance[k] = foot.balance
        lowest.append(foot.lowest)
        for st in foot.stances:
            contact[k] |= (t >= st.strike - 1e-9) & (t <= st.liftoff + 1e-9)
        stances += foot.stances
    if not stances:
        raise AnalysisError(
            f"clip {name!r}: no foot ever touches the ground (the lowest heel or toe is "
            f"{min(lowest):.3f} m above the clip's ground at z = 0, or never stands still)")
    stances.sort(key=lambda st: st.stance)

    # flights: inside the clip, neither foot bears weight
    flights = _gaps([(st.strike, st.liftoff) for st in stances], 0.0, (n - 1) * dt)
    flights = [f for f in flights if f[1] - f[0] >= 0.02]
    durations = np.array([b - a for a, b in flights])
    typical = float(np.median(durations)) if len(durations) else 0.0
    jumps = [f for f in flights
             if f[1] - f[0] >= s.jump_min_flight and (f[1] - f[0] >= 2.0 * typical or len(flights) <= 2)]
    # rest at the ends: slow body, both feet down
    rest_n = max(1, int(round(s.rest_time / dt)))
    both = contact[0] & contact[1]
    at_rest = (body_speed_s < s.rest_speed) & both
    starts_at_rest = bool(n > rest_n and at_rest[:rest_n].all())
    ends_at_rest = bool(n > rest_n and at_rest[-rest_n:].all())
    moving = ~(at_rest & _edge_runs(at_rest))
    travel = float(np.linalg.norm(dense.root_pos[-1, :2] - dense.root_pos[0, :2]))

    in_jump = np.zeros(n, bool)
    for a, b in jumps:
        in_jump[int(round(a / dt)):int(round(b / dt)) + 1] = True
    loco = moving & ~in_jump

    def gait_of(mask):
        """Walk: a foot is always down; run: the steps have flight phases. Decided by the
        share of the steps inside ``mask`` that are followed by a flight."""
        if mask.sum() * dt < 0.15:
            return None
        if np.mean(body_speed_s[mask]) < 2 * s.rest_speed:
            return "stand"
        inside = lambda t_: mask[min(int(round(t_ / dt)), n - 1)]  # noqa: E731
        steps = sum(1 for st in stances if inside(st.stance))
        air = sum(1 for a, b in flights if inside(0.5 * (a + b)) and (a, b) not in jumps)
        if steps < 2:
            return "run" if air else "walk"
        return "run" if air >= s.run_flight_share * (steps - 1) else "walk"

    if jumps:
        kind = "jump"
    elif starts_at_rest and ends_at_rest:
        kind = "idle" if travel < 0.5 else "start"
    elif starts_at_rest:
        kind = "start"
    elif ends_at_rest:
        kind = "stop"
    else:
        kind = "cycle"
    gait = gait_of(loco) or "stand"
    if jumps:
        ja, jb = int(round(jumps[0][0] / dt)), int(round(jumps[-1][1] / dt))
        pre = loco.copy()
        pre[ja:] = False
        post = loco.copy()
        post[:jb + 1] = False
        entry_gait = "stand" if starts_at_rest else (gait_of(pre) or gait)
        exit_gait = "stand" if ends_at_rest else (gait_of(post) or gait)
    else:
        entry_gait = "stand" if starts_at_rest else gait
        exit_gait = "stand" if ends_at_rest else gait

    # cycles: consecutive strikes (or liftoffs) of one foot inside the locomotion
    windows = []
    for k in range(2):
        mine = [st for st in stances if st.foot == k]
        for key in ("strike", "liftoff"):
            ev = [getattr(st, key) for st in mine
                  if not (st.open_start if key == "strike" else st.open_end)]
            for a, b in zip(ev[:-1], ev[1:]):
                ia, ib = int(round(a / dt)), int(round(b / dt))
                if loco[ia:ib + 1].all():
                    windows.append((k, key, a, b))
    if not windows:
        if kind == "cycle":
            raise AnalysisError(
                f"clip {name!r} is too short for a gait cycle: no foot steps twice in its "
                f"{motion.duration:.2f} s")
        best = None
        cycle = stride = cadence = None
        speed = float(np.mean(body_speed[loco])) if loco.any() else 0.0
        tau = 0.0
        loop_error = None
    else:
        cycle = float(np.mean([b - a for _, _, a, b in windows]))
        total_turn = abs(dense.root_heading[loco][-1] - dense.root_heading[loco][0]) if loco.any() else 0.0
        turns = np.array([_heading_at(dense, b) - _heading_at(dense, a) for _, _, a, b in windows])
        errs = np.array([_pose_error(motion, a, b) for _, _, a, b in windows])
        cand = np.arange(len(windows))
        if total_turn > np.radians(20):
            cand = cand[np.abs(turns) >= 0.6 * np.abs(turns).max()]
        bi = int(cand[np.argmin(errs[cand])])
        _, _, a, b = windows[bi]
        best = (a, b)
        loop_error = float(errs[bi])
        dpsi = turns[bi]
        chord = float(np.linalg.norm(_pos_at(dense, b) - _pos_at(dense, a)))
        arc = chord if abs(dpsi) < 1e-6 else chord * (0.5 * dpsi) / np.sin(0.5 * dpsi)
        speed = arc / (b - a)
        tau = 0.0 if chord < 1e-6 else float(2.0 * np.sin(0.5 * dpsi) / chord)
        cadence = 120.0 / cycle
        strides = []
        for k in range(2):
            fps_ = [st.footprint for st in stances if st.foot == k]
            for f0, f1 in zip(fps_[:-1], fps_[1:]):
                ia, ib = int(round(f0.time / dt)), int(round(f1.time / dt))
                if loco[ia:ib + 1].all():
                    strides.append(np.linalg.norm(f1.position[:2] - f0.position[:2]))
        stride = float(np.median(strides)) if strides else speed * cycle
    is_loop = bool(bool(windows) and _pose_error(motion, 0.0, motion.duration) < np.radians(4) and
        abs(_heading_rate_gap(dense)) < 0.2)

    # back to the clip's own samples
    idx = np.clip(np.rint(motion.times * rate).astype(int), 0, n - 1)
    return ClipAnalysis(
        name=name, fps=motion.fps, frames=motion.n, duration=motion.duration, gait=gait,
        kind=kind, starts_at_rest=starts_at_rest, ends_at_rest=ends_at_rest,
        entry_gait=entry_gait, exit_gait=exit_gait, speed=speed, stride=stride, cycle=cycle,
        cadence=cadence, tau=tau, best_cycle=best, loop_error=loop_error, is_loop=is_loop,
        stances=stances, flights=flights, jump_flights=jumps, balance=balance[:, idx],
        contact=contact[:, idx], motion=motion)


@dataclass
class _Foot:
    stances: list[Stance]
    balance: np.ndarray  # (N,) toe weight
    lowest: float  # lowest of heel and toe, m


def _foot_stances(dense: ClipMotion, k: int, body_speed: np.ndarray, s: Settings) -> _Foot:
    """The stances of foot ``k`` on the densely resampled clip (Johansen's rules)."""
    t = dense.times
    n = len(t)
    dt = t[1] - t[0]
    heel, toe = dense.heel[k], dense.toe[k]
    hh, ht = heel[:, 2], toe[:, 2]
    # Johansen's balance: the toe's weight grows as the heel rises above the toe
    b = np.clip(0.5 + (hh - ht) / s.balance_band, 0.0, 1.0)
    hc = np.minimum(hh, ht)
    # velocity of the part that is down: the heel's and toe's velocities blended by the
    # balance (differentiating the blended point would add the roll-off itself)
    sig = s.derivative_smoothing / dt
    v_heel = gaussian_filter1d(heel[:, :2], sig, axis=0, order=1, mode="nearest") / dt
    v_toe = gaussian_filter1d(toe[:, :2], sig, axis=0, order=1, mode="nearest") / dt
    vc = v_heel + b[:, None] * (v_toe - v_heel)
    sc = np.linalg.norm(vc, axis=1)
    out = _Foot([], b, float(hc.min()))

    # seeds: near the clip's ground (or the foot's lowest level, for feet that sink
    # below it) and slow
    ground = min(float(np.percentile(hc, 2)), 0.0)
    down = (hc < ground + s.contact_height) & (sc < s.contact_speed)
    runs = _clean_runs(down, int(round(0.06 / dt)), max(2, int(round(0.04 / dt))))
    if not runs:
        return out
    # the firm part of each stance: heel and toe both near their lowest, the foot slow.
    # Johansen's searches start from its edges, so a heel wobbling while the foot pivots
    # on its ball (sharp turns) does not end the stance; the stance time lies inside it.
    low = np.maximum(hh, ht)
    firm, ts = [], []
    for a, e in runs:
        i0 = a + int(np.argmin(low[a:e]))
        ok = (low[a:e] <= low[i0] + s.firm_height) & (sc[a:e] < s.firm_speed)
        idx = np.flatnonzero(ok) + a
        if len(idx):
            firm.append((int(idx[0]), int(idx[-1])))
            i0 = int(idx[np.argmin(low[idx])])
        else:
            firm.append((i0, i0))
        ts.append(i0)

    curves = [(y, gaussian_filter1d(y, sig, order=1, mode="nearest"),
               gaussian_filter1d(y, sig, order=2, mode="nearest")) for y in (hh, ht)]
    reverse = [(y[::-1], -d[::-1], dd[::-1]) for y, d, dd in curves]
    found = []  # [stance, strike, land, lift, liftoff, open_start, open_end], in samples
    for j, i0 in enumerate(ts):
        fa, fb = firm[j]
        nxt = firm[j + 1][0] if j + 1 < len(ts) else n
        prv = firm[j - 1][1] if j > 0 else -1
        rises = [x for x in (_rise_index(*c, fb, nxt, s) for c in curves) if x is not None]
        touches = [x for x in (_flip(_rise_index(*c, n - 1 - fa, n - 1 - prv, s), n)
                               for c in reverse) if x is not None]
        # Johansen's horizontal check: the foot has left (not yet reached) the ground
        # where its speed departs from its speed while firmly planted
        thr = max(s.slip_tolerance * body_speed[i0], s.slip_min_speed)
        dev = np.linalg.norm(vc - np.median(vc[fa:fb + 1], axis=0), axis=1)
        fwd = np.flatnonzero(dev[fb:nxt] > thr)
        bwd = np.flatnonzero(dev[prv + 1:fa + 1] > thr)
        slip_f = _crossing(dev, fb + fwd[0], -1, thr) if len(fwd) else None
        slip_b = _crossing(dev, prv + 1 + bwd[-1], +1, thr) if len(bwd) else None
        lift, liftoff = (min(rises), max(rises)) if rises else (None, None)
        if slip_f is not None and (liftoff is None or slip_f < liftoff):
            liftoff = slip_f
            lift = slip_f if lift is None else min(lift, slip_f)
        strike, land = (min(touches), max(touches)) if touches else (None, None)
        if slip_b is not None and (strike is None or slip_b > strike):
            strike = slip_b
            land = slip_b if land is None else max(land, slip_b)
        found.append([i0, 0.0 if strike is None else strike, 0.0 if land is None else land,
                      float(n - 1) if lift is None else lift,
                      float(n - 1) if liftoff is None else liftoff,
                      strike is None, liftoff is None])
    # a foot that never left the ground between two stances stood all along: merge
    merged = []
    for st in found:
        if merged and (merged[-1][6] or st[1] <= merged[-1][4]):
            merged[-1][3], merged[-1][4], merged[-1][6] = st[3], st[4], st[6]
        else:
            merged.append(st)

    fwd_angle = np.arctan2(dense.rest_forward[1], dense.rest_forward[0])
    for i0, strike, land, lift, liftoff, o_s, o_e in merged:
        lo, hi = int(np.ceil(min(land, i0))), int(np.floor(max(lift, i0)))
        heel_p = np.median(heel[lo:hi + 1], axis=0)
        toe_p = np.median(toe[lo:hi + 1], axis=0)
        d = toe_p - heel_p
        heading = float((np.arctan2(d[1], d[0]) - fwd_angle + np.pi) % (2 * np.pi) - np.pi)
        si = int(np.clip(round(strike), 0, n - 1))
        part = None if o_s else ("heel" if hh[si] <= ht[si] else "toe")
        fp = Footprint(k, float(t[i0]), 0.5 * (heel_p + toe_p), heading, heel_p, toe_p, part)
        out.stances.append(Stance(k, float(t[i0]), strike * dt, land * dt, lift * dt,
                                  liftoff * dt, o_s, o_e, fp))
    return out


def _gaps(intervals, lo, hi):
    """Interior gaps (a, b) of the union of closed intervals within [lo, hi]."""
    out, end = [], None
    for a, b in sorted(intervals):
        if end is not None and a > end:
            out.append((end, a))
        end = b if end is None else max(end, b)
    return [(a, b) for a, b in out if a > lo and b < hi]


def _smooth(x: np.ndarray, width: int) -> np.ndarray:
    if width <= 1:
        return x
    k = np.ones(width) / width
    return np.convolve(np.pad(x, (width // 2, width - 1 - width // 2), mode="edge"), k, "valid")


def _edge_runs(mask: np.ndarray) -> np.ndarray:
    """Only the runs of ``mask`` touching either end of the clip."""
    out = np.zeros_like(mask)
    for a, b in _runs(mask):
        if a == 0 or b == len(mask):
            out[a:b] = True
    return out


def _heading_at(m: ClipMotion, t: float) -> float:
    return float(np.interp(t, m.times, m.root_heading))


def _pos_at(m: ClipMotion, t: float) -> np.ndarray:
    return np.array([np.interp(t, m.times, m.root_pos[:, i]) for i in range(2)])


def _pose_error(m: ClipMotion, a: float, b: float) -> float:
    """Mean rotation angle between the bone poses at times a and b (root motion removed)."""
    ia = int(np.clip(round(a * m.fps), 0, m.n - 1))
    ib = int(np.clip(round(b * m.fps), 0, m.n - 1))
    trace = np.einsum("bij,bij->b", m.local_rot[ia], m.local_rot[ib])  # trace(Ra^T Rb)
    ang = np.arccos(np.clip((trace - 1) / 2, -1, 1))
    # the hips' rotation relative to the root replaces its own (heading-carrying) rotation
    ha, hb = m.hips_in_root[ia, :3, :3], m.hips_in_root[ib, :3, :3]
    ang[m.hips_index] = np.arccos(np.clip((np.trace(ha.T @ hb) - 1) / 2, -1, 1))
    return float(ang.mean())


def _heading_rate_gap(m: ClipMotion) -> float:
    v = np.gradient(m.root_heading, m.times)
    return float(v[-1] - v[0])
