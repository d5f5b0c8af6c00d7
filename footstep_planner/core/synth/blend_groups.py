"""Blend groups over a planned motion (thesis Granberg 2017, section 3.7), per frame.

Pure numpy/scipy, vectorized over the F frames of a plan (F may be thousands).

Conventions: Blender world, right-handed, Z up, metres, seconds. Only the horizontal
(x, y) part of a trajectory matters here. Curvature ``tau = 1/r`` is in 1/m and signed:
POSITIVE when the path turns LEFT (counter-clockwise seen from above, +Z). ``u`` is
normalized time in footsteps: ``u = j`` at the stance of footprint ``j`` of the plan,
linear in between (so ``sigma = 2`` means "two steps").

Turning (3.7.1)
    :func:`curvature` estimates tau at each frame from the circle through three points of
    the body trajectory ``dt`` seconds apart; :func:`smooth_signal` low-passes it with a
    cubic smoothing spline; :func:`group_weights` turns tau into the weights of a turning
    group's clips (the array form of ``library.TurnGroup.weights``).

Speed (3.7.2)
    :func:`speed_parameter` gives the walk/run parameter ``s`` in [0, 1] (0 walk, 1 run)
    from pinned values; :func:`mix_speed` combines the walk and run groups' weights.

Smoothing strength: ``width`` (seconds) is the bandwidth ``b`` of the smoothing spline's
equivalent kernel (Silverman 1984). ``scipy.interpolate.make_smoothing_spline`` minimizes
``sum_i w_i (y_i - f(t_i))^2 + lam * integral f''(t)^2 dt``. On samples ``h`` seconds apart
with unit weights the sum approximates ``(1/h) * integral (y - f)^2 dt``, and away from the
ends the fit is the linear filter with frequency response ``H(omega) = 1 / (1 + (b omega)^4)``,
``b = (lam h)^(1/4)`` (omega in rad/s). Hence ``lam = width**4 / h``; for uneven spacing
each sample is weighted by its share of the time axis over the mean share, the same mapping.
A sinusoid of period ``P`` keeps the fraction ``1 / (1 + (2 pi width / P)^4)`` of its
amplitude (measured within 0.005 at 24 to 120 Hz; pinned in tests/core/synth/test_blend_groups.py)::

    P / width:   1       2      2 pi    4 pi    30
    kept:        0.0006  0.010  0.50    0.94    0.998

i.e. the half-amplitude period is ``2 pi width``; a step-frequency sway (period 1 s) under
``width = 1 s`` is divided by about 1600, while a period of 30 widths keeps 99.8 %.
Constants and straight lines are kept exactly (zero penalty). The kernel decays like
``exp(-|s| / (sqrt(2) width))`` at a lag of ``s`` seconds, so within a few ``width`` of the
ends the natural-spline boundary (f'' = 0 there) shows.
"""

from __future__ import annotations

import numpy as np
from scipy.interpolate import make_smoothing_spline

__all__ = [
    "curvature", "circumcurvature", "smooth_signal", "group_weights", "speed_parameter",
    "mix_speed",
]

_COINCIDENT = 1e-9
"""Points closer than this fraction of the triangle's longest side count as coincident."""
_COLLINEAR = 1e-12
"""A turn whose |sin(angle)| is at most this counts as straight (tau = 0)."""
_MIN_SPLINE_SAMPLES = 5
"""make_smoothing_spline needs at least this many samples."""
_MAX_WIDTH_SPANS = 8.0
"""smooth_signal treats a width above this many times the signal's duration as this."""
_SAMPLES_PER_WIDTH = 256
"""smooth_signal fits bin means when the samples are denser than this per width."""
_GAP = 1e-12
"""Clips whose taus differ by less than this (1/m) are one bracket (as TurnGroup.weights)."""


# ----------------------------------------------------------------------------- helpers

def _vector(name: str, x, allow_empty: bool = True) -> np.ndarray:
    """``x`` as a finite float (N,) array (a new array; the input is never modified)."""
    a = np.array(x, dtype=float, copy=True)
    if a.ndim != 1:
        raise ValueError(f"{name} must be one-dimensional, got shape {a.shape}")
    if not allow_empty and a.size == 0:
        raise ValueError(f"{name} must not be empty")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} must be finite")
    return a


def _points(name: str, x) -> np.ndarray:
    """``x`` as a finite float (N, >=2) array of points (a new array)."""
    a = np.array(x, dtype=float, copy=True)
    if a.ndim != 2 or a.shape[1] < 2:
        raise ValueError(f"{name} must have shape (F, >=2), got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} must be finite")
    return a


def _times(t: np.ndarray, n: int, name: str = "t") -> None:
    if t.shape[0] != n:
        raise ValueError(f"{name} has {t.shape[0]} samples, expected {n}")
    if np.any(np.diff(t) <= 0.0):
        raise ValueError(f"{name} must be strictly increasing")


def _positive(name: str, value: float, allow_zero: bool = False) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number, got {value!r}") from None
    if not np.isfinite(v) or v < 0.0 or (v == 0.0 and not allow_zero):
        bound = ">= 0" if allow_zero else "> 0"
        raise ValueError(f"{name} must be finite and {bound}, got {value!r}")
    return v


# ----------------------------------------------------------------------------- turning

def circumcurvature(a, b, c) -> np.ndarray:
    """Signed curvature of the circle through points a, b, c (each (F, >=2)); 0 when collinear.

    Only x and y (the first two columns) are used. Returns (F,) in 1/m:
    ``2 * cross(b - a, c - b) / (|b - a| |c - b| |c - a|)``, positive when a -> b -> c
    turns left (counter-clockwise seen from +Z). It is 0 when the points are collinear
    (|sin| of the turn at b <= 1e-12) or when two of them coincide (closer than 1e-9 of the
    triangle's longest side; then no unique circle passes through them).
    """
    a, b, c = _points("a", a), _points("b", b), _points("c", c)
    if not (a.shape[0] == b.shape[0] == c.shape[0]):
        raise ValueError(f"a, b, c must have the same number of points, got "
                         f"{a.shape[0]}, {b.shape[0]}, {c.shape[0]}")
    ab = b[:, :2] - a[:, :2]
    bc = c[:, :2] - b[:, :2]
    ca = a[:, :2] - c[:, :2]
    lab, lbc, lca = np.hypot(*ab.T), np.hypot(*bc.T), np.hypot(*ca.T)
    cross = ab[:, 0] * bc[:, 1] - ab[:, 1] * bc[:, 0]
    longest = np.maximum(np.maximum(lab, lbc), lca)
    shortest = np.minimum(np.minimum(lab, lbc), lca)
    ok = (shortest > _COINCIDENT * longest) & (np.abs(cross) > _COLLINEAR * lab * lbc)
    den = np.where(ok, lab * lbc * lca, 1.0)
    return np.where(ok, 2.0 * cross / den, 0.0)


def curvature(pos: np.ndarray, t: np.ndarray, dt: float) -> np.ndarray:
    """Signed three-point circumcircle curvature (F,) of a trajectory pos (F, >=2) sampled at times t (F,).

    ``pos`` (F, >=2) in metres (x, y used), ``t`` (F,) strictly increasing seconds, ``dt``
    > 0 seconds. At frame ``i`` the estimate is :func:`circumcurvature` of the trajectory
    (linearly interpolated) at ``tc - dt, tc, tc + dt`` where the window centre ``tc`` is
    ``t[i]`` clamped into ``[t[0] + dt, t[-1] - dt]``: near the ends the window is shifted
    into the trajectory's range rather than cut, so it still spans three distinct points
    (the end frames repeat the first/last full-window estimate). When ``2 dt`` exceeds the
    trajectory's duration, every frame uses its first, middle-time and last points. One
    frame, a standing body or a straight path gives 0. The estimate is meaningless when the
    body goes (nearly) all the way round a circle within ``2 dt``. Between frames the path
    is taken as straight chords, so on an arc sampled every ``h`` seconds the relative error
    is at most about ``(h / (2 dt))^2`` (0.2 % at 24 fps with ``dt = 0.5``; none when ``dt``
    is a whole number of frames).
    Returns (F,) in 1/m, positive turning left.
    """
    pos = _points("pos", pos)
    if pos.shape[0] == 0:
        raise ValueError("pos must hold at least one point")
    t = _vector("t", t)
    _times(t, pos.shape[0])
    dt = _positive("dt", dt)
    if pos.shape[0] == 1:
        return np.zeros(1)
    t0, t1 = t[0], t[-1]
    half = min(dt, 0.5 * (t1 - t0))
    tc = np.clip(t, t0 + half, t1 - half)

    def at(times: np.ndarray) -> np.ndarray:
        times = np.clip(times, t0, t1)  # rounding only
        return np.stack([np.interp(times, t, pos[:, k]) for k in range(2)], axis=1)

    return circumcurvature(at(tc - half), at(tc), at(tc + half))


def smooth_signal(t: np.ndarray, y: np.ndarray, width: float) -> np.ndarray:
    """Low-pass smoothing spline of y(t) evaluated back at t; width in seconds (0: y unchanged).

    ``t`` (F,) strictly increasing seconds, ``y`` (F,) any unit, ``width`` >= 0 seconds:
    the equivalent-kernel bandwidth of the cubic smoothing spline (``make_smoothing_spline``
    with ``lam = width**4 / h``, ``h`` the mean sample spacing, samples weighted by their
    share of the time axis; see the module docstring for the frequency response).
    Constants and linear functions come back unchanged. With ``width == 0`` or fewer than 5
    samples (too few for the spline) a copy of ``y`` is returned. Returns (F,).

    Conditioning (scipy's system degrades as ``(width / spacing)^4``): the weighted
    least-squares line is taken out first and added back (exact, since the spline keeps
    lines), samples denser than 256 per ``width`` are fitted as weighted bin means, and a
    ``width`` above 8 times the duration acts as 8 times the duration (the first bending
    mode then keeps < 1e-6 of itself: the result is the least-squares line). Against the
    exact spline this changes the result by less than 1e-4 of max|y| while ``width`` is
    below the duration, and by up to about 2e-3 when it is several times longer.
    """
    y = _vector("y", y)
    t = _vector("t", t)
    _times(t, y.shape[0])
    width = _positive("width", width, allow_zero=True)
    n = y.shape[0]
    if width == 0.0 or n < _MIN_SPLINE_SAMPLES:
        return y
    x = t - t[0]  # the fit is shift invariant; a time axis from 0 keeps the basis well scaled
    span = x[-1]
    # Past a few times the duration the fit is the least-squares line already (the first
    # bending mode keeps < 1e-6 of itself at 8 x the duration): cap, for conditioning.
    b = min(width, _MAX_WIDTH_SPANS * span)
    edges = np.concatenate(([0.0], 0.5 * (x[1:] + x[:-1]), [span]))
    w = np.diff(edges) / (span / (n - 1))  # share of the time axis over the mean share
    # The spline reproduces straight lines exactly, so fit only what is left after the
    # weighted least-squares line: rounding errors then scale with the curved part alone.
    xm = np.dot(w, x) / w.sum()
    ym = np.dot(w, y) / w.sum()
    slope = np.dot(w, (x - xm) * (y - ym)) / np.dot(w, (x - xm) ** 2)
    line = ym + slope * (x - xm)
    rest = y - line
    step = b / _SAMPLES_PER_WIDTH
    if span / (n - 1) < step:
        # Denser than needed: fit weighted bin means (bins of width / 256). The spline keeps
        # nothing of that fast a wiggle (< 1e-11), so the fit barely changes, and the linear
        # system stays well conditioned (its condition grows as (width / spacing)^4).
        idx = np.floor(x / step).astype(np.intp)
        wsum = np.bincount(idx, w)
        keep = wsum > 0.0
        wk = wsum[keep]
        xk = np.bincount(idx, w * x)[keep] / wk
        yk = np.bincount(idx, w * rest)[keep] / wk
    else:
        xk, yk, wk = x, rest, w
    scale = wk.mean()
    spline = make_smoothing_spline(xk, yk, w=wk / scale, lam=b**4 / (span / (n - 1)) / scale)
    return line + np.asarray(spline(x), dtype=float)


def group_weights(taus: np.ndarray, tau: np.ndarray) -> np.ndarray:
    """(F, C) blend weights for clips with sorted curvatures taus (C,) at curvatures tau (F,).

    ``taus`` (C >= 1,) in 1/m, non-decreasing (duplicates allowed), ``tau`` (F,) in 1/m.
    Thesis 3.7.1, the per-frame array form of ``library.TurnGroup.weights`` (identical
    values): ``tau <= taus[0]`` gives clip 0 everything, else ``tau >= taus[-1]`` gives the
    last clip everything; otherwise the first bracket ``taus[i] <= tau <= taus[i+1]`` in
    order is linearly interpolated (clip i gets ``1 - w``, clip i + 1 gets ``w``), a bracket
    narrower than 1e-12 giving clip i everything. Rows sum to 1, entries are in [0, 1] and
    at most two adjacent entries of a row are non-zero.
    """
    taus = _vector("taus", taus, allow_empty=False)
    tau = _vector("tau", tau)
    if np.any(np.diff(taus) < 0.0):
        raise ValueError("taus must be sorted (non-decreasing)")
    f, c = tau.shape[0], taus.shape[0]
    out = np.zeros((f, c))
    rows = np.arange(f)
    below = tau <= taus[0]
    above = ~below & (tau >= taus[-1])
    inside = ~below & ~above
    out[below, 0] = 1.0
    out[above, c - 1] = 1.0
    if np.any(inside):
        r = rows[inside]
        x = tau[inside]
        j = np.searchsorted(taus, x, side="left")  # first clip with taus[j] >= x; 1 <= j < c
        lo, hi = taus[j - 1], taus[j]
        gap = hi - lo
        narrow = gap < _GAP
        wgt = np.where(narrow, 0.0, (x - lo) / np.where(narrow, 1.0, gap))
        out[r, j - 1] = 1.0 - wgt
        out[r, j] += wgt
    return out


# ----------------------------------------------------------------------------- speed

def speed_parameter(u: np.ndarray, pins_u, pins_s, sigma: float = 2.0) -> np.ndarray:
    """The walk/run parameter s (F,) at normalized times u (F,), from pins (thesis 3.7.2).

    ``u`` (F,) in footsteps (any order), ``pins_u`` (P >= 1,) non-decreasing footsteps,
    ``pins_s`` (P,) values in [0, 1] (0 walk, 1 run, e.g. 0.5 a jog), ``sigma`` > 0 steps.
    Between consecutive pins ``(u1, s1)``, ``(u2, s2)``, ``u1 < u2``, with ``d1 = u - u1``,
    ``d2 = u2 - u``::

        lin  = (s1 d2 + s2 d1) / (d1 + d2)
        s = lin                                              if d1 + d2 < 2 sigma (s1 + s2)
        s = max(0, s1 (sigma - d1) / sigma, s2 (sigma - d2) / sigma)   otherwise

    i.e. when there is time the gait ramps down to a walk over ``sigma`` steps after a pin
    and back up over ``sigma`` steps before the next one, else it is interpolated linearly.
    One guard (not in the thesis): in the second case ``s`` is also capped at ``lin``. That
    changes nothing when the pins are at least ``sigma`` apart, and on shorter sections
    it stops the ramp of one pin from reaching past the other pin, which would make ``s``
    jump there (e.g. ``s1 = 0, s2 = 0.1`` half a ``sigma`` apart).

    Before the first pin and after the last, ``s`` holds that pin's value. Several pins at
    the same ``u`` make a step: the earliest (in the given order) ends the section before,
    the latest starts the section after, and at exactly that ``u`` the latest holds (``s``
    is right-continuous). So ``s`` equals each pin's value at its ``u`` whenever the pin is
    the last one given at that ``u``. Returns (F,) in [0, 1].
    """
    u = _vector("u", u)
    pu = _vector("pins_u", pins_u, allow_empty=False)
    ps = _vector("pins_s", pins_s, allow_empty=False)
    if pu.shape != ps.shape:
        raise ValueError(f"pins_u and pins_s differ in length ({pu.shape[0]} vs {ps.shape[0]})")
    if np.any(np.diff(pu) < 0.0):
        raise ValueError("pins_u must be sorted (non-decreasing)")
    if np.any((ps < 0.0) | (ps > 1.0)):
        raise ValueError("pins_s must lie in [0, 1]")
    sigma = _positive("sigma", sigma)
    p = pu.shape[0]
    k = np.searchsorted(pu, u, side="right") - 1  # last pin with pins_u <= u
    s = np.where(k < 0, ps[0], ps[p - 1])
    inside = (k >= 0) & (k < p - 1)  # then pu[k] <= u < pu[k + 1]
    if np.any(inside):
        ki = k[inside]
        x = u[inside]
        u1, u2, s1, s2 = pu[ki], pu[ki + 1], ps[ki], ps[ki + 1]
        d1, d2 = x - u1, u2 - x
        length = u2 - u1  # > 0
        lin = (s1 * d2 + s2 * d1) / length
        ramps = np.maximum(0.0, np.maximum(s1 * (sigma - d1), s2 * (sigma - d2)) / sigma)
        slow = np.minimum(lin, ramps)
        s[inside] = np.where(length < 2.0 * sigma * (s1 + s2), lin, slow)
    return np.clip(s, 0.0, 1.0)


def mix_speed(s: np.ndarray, w_walk: np.ndarray, w_run: np.ndarray) -> np.ndarray:
    """(F, Cw + Cr) = [(1 - s) * w_walk, s * w_run].

    ``s`` (F,) in [0, 1] (0 walk, 1 run), ``w_walk`` (F, Cw) and ``w_run`` (F, Cr) the
    walk and run groups' weights per frame (e.g. from :func:`group_weights`). The walk
    clips' columns come first. Rows sum to 1 when the inputs' rows do.
    """
    s = _vector("s", s)
    if np.any((s < 0.0) | (s > 1.0)):
        raise ValueError("s must lie in [0, 1]")
    ww = np.asarray(w_walk, dtype=float)
    wr = np.asarray(w_run, dtype=float)
    for name, w in (("w_walk", ww), ("w_run", wr)):
        if w.ndim != 2 or w.shape[0] != s.shape[0]:
            raise ValueError(f"{name} must have shape ({s.shape[0]}, C), got {w.shape}")
        if not np.all(np.isfinite(w)):
            raise ValueError(f"{name} must be finite")
    return np.concatenate(((1.0 - s)[:, None] * ww, s[:, None] * wr), axis=1)
