"""Body trajectory: carry the body motion of a clip over to other footprints.

Granberg 2017, section 3.6 "Body trajectory" and appendix A.1. A clip played without
adjustment plants the *original* footprints O; the planner wants the *desired* footprints
D (same count, same times). The body's motion relative to the path through the midpoints
of consecutive footprints is kept, and that path is swapped for the desired one.

Conventions: Blender's world (right-handed, Z up), metres, seconds. A heading is a yaw
in radians about +Z, positive counter-clockwise (turning left), measured from the rig's
forward direction; headings are unwrapped (continuous, may leave [-pi, pi]). "The frame
of heading h" is the rotation R(h) about Z: it turns (x, y) and leaves z alone.

Shapes: N footprints (positions (N, 3), headings (N,), times (N,) in seconds,
non-decreasing); F frames (times t (F,), positions (F, 3), headings (F,)). Everything is
vectorised over frames and over footprints: no Python loop per frame or per segment.

The midpoint path M(t) is a centripetal Catmull-Rom spline (alpha = 1/2 on chord lengths,
the non-uniform curve of Barry and Goldman, evaluated here as the equal cubic Hermite
form; not the uniform matrix printed in the thesis, which is not centripetal). It passes
through the k-th midpoint at the k-th midpoint time. Between knots, time is mapped onto
the knot parameter by a monotone C1 cubic (Fritsch-Carlson slopes) instead of a linear
map per segment: the path's *shape* is exactly the centripetal curve (no loops or cusps)
and the velocity is continuous across knots, which a per-segment linear map only gives
where the knot intervals happen to be proportional to the time intervals (see
``centripetal_catmull_rom(..., smooth_timing=False)`` for that literal variant). Both
maps agree in the end segments' velocity at the ends, where the path goes on linearly.
"""

from __future__ import annotations

import numpy as np
from scipy.interpolate import BPoly, CubicHermiteSpline, PchipInterpolator
from ..base.angles import wrap

__all__ = [
    "centripetal_catmull_rom",
    "midpoints",
    "footprint_spline",
    "body_offset",
    "transfer_body",
]


# ----------------------------------------------------------------------------- helpers

def _rotate(v: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Rows of ``v`` (F, 3) turned by R(angle) (F,) about Z; z is kept. A new array."""
    c, s = np.cos(angle), np.sin(angle)
    out = np.empty_like(v)
    out[:, 0] = c * v[:, 0] - s * v[:, 1]
    out[:, 1] = s * v[:, 0] + c * v[:, 1]
    out[:, 2] = v[:, 2]
    return out


def _safe_div(num: np.ndarray, den: np.ndarray) -> np.ndarray:
    """num / den with 0 where den == 0 (den >= 0; broadcast over num's last axis)."""
    ok = den > 0.0
    return num / np.where(ok, den, 1.0)[..., None] * ok[..., None]


def _array(name: str, a, shape: tuple) -> np.ndarray:
    """``a`` as a finite float64 array of ``shape`` (None: any length), else ValueError.
    It may share memory with ``a``: callers only read it, inputs are never modified."""
    arr = np.asarray(a, dtype=np.float64)
    if arr.ndim != len(shape) or any(
            want is not None and got != want for got, want in zip(arr.shape, shape)):
        want = "(" + ", ".join("n" if w is None else str(w) for w in shape) + \
               ("," if len(shape) == 1 else "") + ")"
        raise ValueError(f"{name} must have shape {want}, got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} has non-finite values")
    return arr


def _same_length(**arrays: np.ndarray) -> int:
    """The common length of the named ``arrays``; ValueError listing them if they differ."""
    lengths = {k: len(v) for k, v in arrays.items()}
    if len(set(lengths.values())) > 1:
        listed = ", ".join(f"{k} {n}" for k, n in lengths.items())
        raise ValueError(f"lengths differ: {listed}")
    return next(iter(lengths.values()))


def _footprints(position, heading, times, who: str = "footprint"):
    """(positions (N, 3), headings (N,), times (N,)) as checked float arrays; ValueError
    (naming ``who``) for bad shapes or values, none at all, times that decrease, or more
    than two footprints at one time."""
    p = _array(f"{who} position", position, (None, 3))
    h = _array(f"{who} heading", heading, (None,))
    tt = _array(f"{who} times", times, (None,))
    n = _same_length(**{f"{who} position": p, f"{who} heading": h, f"{who} times": tt})
    if n == 0:
        raise ValueError(f"no {who}s")
    if np.any(np.diff(tt) < 0.0):
        raise ValueError(f"{who} times must be non-decreasing")
    if n > 2 and np.any(tt[2:] <= tt[:-2]):
        raise ValueError(f"{who} times: at most two footprints may share a time "
                         "(the midpoint times must increase)")
    return p, h, tt


def _monotone_slopes(h: np.ndarray, secant: np.ndarray) -> np.ndarray:
    """Knot slopes (n,) of a monotone C1 cubic through non-decreasing data with interval
    widths ``h`` (n-1,) and secant slopes ``secant`` (n-1,) >= 0: at interior knots
    scipy's PCHIP slopes (the Fritsch-Carlson / Brodlie weighted harmonic mean of the two
    secants, 0 if either is 0); at the two ends the end secant, not PCHIP's three-point
    end rule, so that the path's velocity at its ends is the end segment's mean velocity
    (which ``_extend_linearly`` carries on). Every slope is at most 3x the secants beside
    it, which keeps the cubic monotone."""
    x = np.concatenate([[0.0], np.cumsum(h)])
    y = np.concatenate([[0.0], np.cumsum(h * secant)])
    out = PchipInterpolator(x, y).derivative()(x) if len(h) > 1 else np.empty(2)
    out[0], out[-1] = secant[0], secant[-1]
    return out


# ----------------------------------------------------------------------------- spline

def centripetal_catmull_rom(points: np.ndarray, knot_times: np.ndarray, t: np.ndarray,
                            alpha: float = 0.5, *, smooth_timing: bool = True) -> np.ndarray:
    """The Catmull-Rom spline through ``points`` (n, D), passing through point k at
    ``knot_times[k]`` (n,) seconds, strictly increasing; evaluated at times ``t`` (F,),
    any order. Returns (F, D).

    Knot parameter: s_0 = 0, s_{k+1} = s_k + |p_{k+1} - p_k| ** alpha (alpha = 1/2:
    centripetal, 0: uniform, 1: chordal; a zero-length chord always gets a zero
    interval). The ends are extended by reflection, p_{-1} = 2 p_0 - p_1 and
    p_n = 2 p_{n-1} - p_{n-2}. Each segment is the Barry-Goldman pyramid written as a
    cubic Hermite in s whose tangent at p_k is

        T_k = (p_k - p_{k-1}) / d_{k-1} - (p_{k+1} - p_{k-1}) / (d_{k-1} + d_k)
              + (p_{k+1} - p_k) / d_k,        d_k = s_{k+1} - s_k,

    with every term over a zero interval taken as 0 (its limit for alpha < 1): points
    that coincide give a segment that stays at that point, and no division by zero.

    Time to knot parameter: with ``smooth_timing`` (default) s(t) is the monotone C1
    cubic Hermite interpolant of (knot_times, s) with Fritsch-Carlson slopes inside and
    the end secants at the ends (``_monotone_slopes``), so the curve is C1 in time and
    exactly the centripetal curve in shape; with ``smooth_timing=False`` the map is linear
    within each segment (velocity continuous across a knot only where d_k / dt_k is the
    same on both sides). Either way ds/dt at the ends is the end segment's d / dt.

    Outside [knot_times[0], knot_times[-1]] the curve goes on linearly with its velocity
    at the end point (continuous in position and velocity there). One point: constant.
    """
    P, kt, tq = _spline_inputs(points, knot_times, t, alpha)
    if len(P) == 1:
        return np.repeat(P, len(tq), axis=0)
    dt = np.diff(kt)
    if np.any(dt <= 0.0):
        raise ValueError("knot_times must be strictly increasing")
    T, dseg = _tangents(P, alpha)
    k, tau = _segment_of(kt, dt, tq)
    if smooth_timing:
        u, ds_end = _smooth_fraction(dt, dseg, k, tau)
    else:
        u, ds_end = tau, np.array([dseg[0] / dt[0], dseg[-1] / dt[-1]])
    out = _hermite(P, T, dseg, k, u)
    return _extend_linearly(out, tq, kt, T, ds_end)


def _spline_inputs(points, knot_times, t, alpha: float
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(points (n, D), knot_times (n,), t (F,)) as finite float arrays; ValueError for a
    bad shape, a non-finite value, ``alpha`` outside [0, 1] or no points."""
    P = _array("points", points, (None, None))
    kt = _array("knot_times", knot_times, (len(P),))
    tq = _array("t", t, (None,))
    if not 0.0 <= alpha <= 1.0:
        raise ValueError(f"alpha must be in [0, 1], got {alpha}")
    if len(P) == 0:
        raise ValueError("no points")
    return P, kt, tq


def _tangents(P: np.ndarray, alpha: float) -> tuple[np.ndarray, np.ndarray]:
    """(T (n, D), d (n-1,)): the tangents dC/ds at the n >= 2 points ``P`` (the
    Barry-Goldman T_k of ``centripetal_catmull_rom``, on the ends extended by
    reflection) and the knot intervals d_k = |p_{k+1} - p_k| ** alpha of the segments
    (0 for a zero-length chord)."""
    ext = np.concatenate([2.0 * P[:1] - P[1:2], P, 2.0 * P[-1:] - P[-2:-1]])  # (n+2, D)
    chord = np.diff(ext, axis=0)  # (n+1, D): chord j joins ext[j] and ext[j+1]
    length = np.linalg.norm(chord, axis=1)
    d = np.where(length > 0.0, length ** alpha, 0.0)  # (n+1,) knot intervals
    a, b = chord[:-1], chord[1:]  # (n, D): the chords before and after each point
    da, db = d[:-1], d[1:]
    T = _safe_div(a, da) - _safe_div(a + b, da + db) + _safe_div(b, db)  # (n, D) dC/ds
    return T, d[1:-1]


def _segment_of(kt: np.ndarray, dt: np.ndarray, tq: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(k (F,) int, tau (F,)): the segment [kt[k], kt[k+1]] holding each time ``tq``
    (clamped to the knots' range; ``dt`` (n-1,) the segments' lengths, s) and the
    fraction of it elapsed, in [0, 1]."""
    tc = np.clip(tq, kt[0], kt[-1])
    k = np.clip(np.searchsorted(kt, tc, side="right") - 1, 0, len(kt) - 2)
    tau = (tc - kt[k]) / dt[k]
    return k, tau


def _smooth_fraction(dt: np.ndarray, dseg: np.ndarray, k: np.ndarray, tau: np.ndarray
                     ) -> tuple[np.ndarray, np.ndarray]:
    """(u (F,), ds_end (2,)): the fraction u = (s(t) - s_k) / d_k of segment ``k``'s
    knot interval reached at time fraction ``tau`` (F,), for s(t) the cubic Hermite
    (scipy's ``CubicHermiteSpline``) with monotone slopes (``_monotone_slopes``) through
    the knots (0 on a zero interval); and ds/dt (1/s) at the first and last knot."""
    rate = _monotone_slopes(dt, dseg / dt)  # (n,) ds/dt at the knots
    kt = np.concatenate([[0.0], np.cumsum(dt)])
    s = np.concatenate([[0.0], np.cumsum(dseg)])
    s_t = CubicHermiteSpline(kt, s, rate)(kt[k] + tau * dt[k])
    ok = dseg[k] > 0.0
    u = np.where(ok, (s_t - s[k]) / np.where(ok, dseg[k], 1.0), 0.0)
    return u, rate[[0, -1]]


def _hermite(P: np.ndarray, T: np.ndarray, dseg: np.ndarray, k: np.ndarray, u: np.ndarray
             ) -> np.ndarray:
    """(F, D) the cubic Hermite of segment ``k`` (F,) from P[k] to P[k+1], tangents
    T * d_k (``dseg`` (n-1,)), at fractions ``u`` (F,) clipped to [0, 1]: scipy's
    ``BPoly`` over the segment index, each segment the cubic Bezier with control points
    P[k], P[k] + T[k] d_k / 3, P[k+1] - T[k+1] d_k / 3, P[k+1] (a Hermite with one
    tangent per knot can't be a ``CubicHermiteSpline``: the tangent in u jumps at a knot
    where d_k changes, and a zero-length chord has d_k = 0)."""
    dk = dseg[:, None] / 3.0
    c = np.stack([P[:-1], P[:-1] + dk * T[:-1], P[1:] - dk * T[1:], P[1:]])  # (4, n-1, D)
    return BPoly(c, np.arange(len(P), dtype=float))(k + np.clip(u, 0.0, 1.0))


def _extend_linearly(out: np.ndarray, tq: np.ndarray, kt: np.ndarray, T: np.ndarray,
                     ds_end: np.ndarray) -> np.ndarray:
    """``out`` (F, D), changed in place and returned, continued linearly before the
    first and after the last knot time with the end velocities dC/ds * ds/dt (``T`` at
    the ends times ``ds_end`` (2,))."""
    v0, v1 = T[0] * ds_end[0], T[-1] * ds_end[1]
    out += np.minimum(tq - kt[0], 0.0)[:, None] * v0
    out += np.maximum(tq - kt[-1], 0.0)[:, None] * v1
    return out


# ----------------------------------------------------------------------------- footprints

def midpoints(position, heading, times) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Midpoints of consecutive footprints (N, 3), (N,) radians, (N,) seconds:
    (m (N-1, 3), m_heading (N-1,), m_time (N-1,)).

    m_i = (p_i + p_{i+1}) / 2, m_time_i = (t_i + t_{i+1}) / 2 and m_heading_i the mid
    angle h_i + wrap(h_{i+1} - h_i) / 2 (slerp at 1/2 about Z), then unwrapped along i
    (a no-op for unwrapped footprint headings that turn less than pi per footprint) so
    that the sequence is continuous even if the footprint headings were wrapped. Fewer
    than two footprints: empty arrays.
    """
    p, h, tt = _footprints(position, heading, times)
    m = 0.5 * (p[:-1] + p[1:])
    mt = 0.5 * (tt[:-1] + tt[1:])
    mq = h[:-1] + 0.5 * wrap(h[1:] - h[:-1])
    if len(mq) > 1:
        mq = np.unwrap(mq)
    return m, mq, mt


def footprint_spline(position, heading, times, t) -> tuple[np.ndarray, np.ndarray]:
    """The midpoint path of footprints (N, 3), (N,) radians, (N,) seconds at frame times
    t (F,) seconds: M(t) (F, 3) metres and M_q(t) (F,) radians.

    M is the centripetal Catmull-Rom spline through the midpoints at the midpoint times
    (``centripetal_catmull_rom``), linear beyond the first and last midpoint times. M_q
    interpolates the mid headings linearly in time between consecutive midpoint times
    (slerp about Z of the unwrapped angles) and is constant outside them. (M_q uses the
    time fraction of the segment; M's knot parameter is a monotone cubic of time, which
    has no meaning on a zero-length chord, where the character turns on the spot.)
    One midpoint: constant. One footprint: the footprint itself, constant.
    """
    p, h, tt = _footprints(position, heading, times)
    tq = _array("t", t, (None,))
    if len(p) == 1:
        return np.repeat(p, len(tq), axis=0), np.full(len(tq), h[0])
    m, mq, mt = midpoints(p, h, tt)
    return centripetal_catmull_rom(m, mt, tq), np.interp(tq, mt, mq)


def body_offset(position, heading, times, body_pos, body_heading, t
                ) -> tuple[np.ndarray, np.ndarray]:
    """The body relative to the midpoint path of the footprints (N, 3), (N,), (N,):
    D_p(t) = R(-M_q(t)) (body_pos - M(t)) (F, 3) metres, in the path's frame (z kept),
    and D_q(t) = body_heading - M_q(t) (F,) radians, for body_pos (F, 3), body_heading
    (F,) at frame times t (F,)."""
    bp = _array("body_pos", body_pos, (None, 3))
    bq = _array("body_heading", body_heading, (None,))
    tq = _array("t", t, (None,))
    _same_length(body_pos=bp, body_heading=bq, t=tq)
    M, Mq = footprint_spline(position, heading, times, tq)
    return _rotate(bp - M, -Mq), bq - Mq


def transfer_body(orig_pos, orig_heading, desired_pos, desired_heading, times,
                  body_pos, body_heading, t) -> tuple[np.ndarray, np.ndarray]:
    """Thesis 3.6: the desired body trajectory from the original one.

    Footprints: original and desired positions (N, 3) metres and headings (N,) radians,
    shared times (N,) seconds. Body: the original trajectory R^O (F, 3) and Q^O (F,) at
    frame times t (F,). With D_p, D_q the body's offset from the original midpoint path
    (``body_offset``) and M^D, M_q^D the desired path (``footprint_spline``), returns

        R^D(t) = M^D(t) + R(M_q^D(t)) D_p(t)   (F, 3) metres,
        Q^D(t) = M_q^D(t) + D_q(t)             (F,) radians (unwrapped as Q^O is).
    """
    po, ho, tt = _footprints(orig_pos, orig_heading, times, "original footprint")
    pd, hd, _ = _footprints(desired_pos, desired_heading, times, "desired footprint")
    _same_length(orig_pos=po, desired_pos=pd)
    Dp, Dq = body_offset(po, ho, tt, body_pos, body_heading, t)
    MD, MqD = footprint_spline(pd, hd, tt, t)
    return MD + _rotate(Dp, MqD), MqD + Dq
