"""Body offsets for the foot IK (thesis 3.8.1) and their hierarchical B-spline (Lee and Shin 1999).

**Body offset.** At every frame where a foot is planted, the body ("root": position
``p`` (3,) in metres, heading ``psi`` in radians, a yaw about +Z, positive
counter-clockwise) is moved and turned so that the planted foot's IK point, ``p_loc`` in
the body frame and ``p + Rz(psi) p_loc`` in the world, reaches its target ``p_ik``. One
iteration (``torque_step``), with the lever arm ``r = Rz(psi) p_loc`` and the error
``F = p_ik - (p + r)``:

* ``p <- p + alpha F``;
* ``psi <- psi + beta T_z`` (``turn="thesis"``, the default: the thesis's
  ``q <- exp(beta T) q``, beta in 1/m^2), or ``psi <- psi + beta T_z / max(|r_h|^2,
  LEVER_EPS^2)`` (``turn="normalised"``), with ``T = r x F`` (right-handed),
  ``T_z = r_x F_y - r_y F_x``, and ``r_h = (r_x, r_y)`` the horizontal lever arm.

The default keeps the thesis's scale on purpose: a foot is 0.1 to 0.3 m from the body's
axis, so ``beta T_z`` turns the body by a few thousandths of a radian per centimetre of
error and the translation does the work (a real body does not swivel to reach a foot).
The normalised turn, below, fixes the error across the lever arm by turning alone and
swings the body by tenths of a radian on real walks.

The torque sign: ``r x F`` is the torque of the force F pulling at the foot, and it turns
the foot towards the target. The thesis prints ``F x r`` (the Unity, left-handed
convention); in a right-handed world that turns the foot away (``test_offsets`` pins
that one iteration reduces the pull). The rotation: the thesis writes
``q <- exp(beta T) q`` with the full 3-D torque; our body turns about +Z only (its tilt
belongs to the pose), so only ``T_z`` is used. The normalisation by ``|r_h|^2`` is our
reading of beta: turning by ``dpsi`` moves the foot by ``dpsi (ez x r)``, and
``T_z = (ez x r) . F``, so ``T_z / |r_h|^2`` is the turn that exactly removes the part of F
along the turning direction ``ez x r`` (to first order). beta = 1 therefore means "turn
all the way", whatever the lever arm; in the thesis's own units beta would depend on the
lever arm (metres squared). The turn asked for a given error grows as ``1 / |r_h|``: with
the defaults a foot 0.1 m to the side that is 1 cm short turns the body by about 0.07 rad
(the translation takes the other third). ``LEVER_EPS`` (0.05 m) caps that: a foot nearer
the body's vertical axis turns it only ``(|r_h| / LEVER_EPS)^2`` of the way, and the
translation does the rest (the convergence below still holds).

Linearised, one iteration maps the error ``F`` to ``(1 - alpha) F - beta P F``, with ``P``
the projection on ``ez x r``: the component along ``ez x r`` is multiplied by
``1 - alpha - beta``, the rest by ``1 - alpha``. With the defaults alpha = 1/2, beta = 1
both factors have magnitude 1/2: each iteration halves a small error and 10 iterations
reduce it about a thousandfold. It converges for ``0 < alpha < 2`` and
``0 < alpha + beta < 2``. The thesis's sign (``F x r``) gives the factor
``1 - alpha + beta`` = 3/2 along ``ez x r``: the error grows. A planted foot drives the
vertical part of F through the translation alone.

When both feet are planted, by default (``both="average"``) the iteration runs for each
foot from the same start, and the final positions and headings are averaged (thesis). Each
foot alone has a one-parameter family of solutions and each run ends on its own, so the
average does *not* put both feet on consistent targets (targets that one body move would
meet): linearised, a run takes ``beta / (alpha + beta)`` = 2/3 of the error along
``ez x r`` as a turn and the rest as a move; with the feet side by side a forward error
becomes opposite turns that cancel in the average, and 2/3 of it is left; a pure turn
error keeps 1/3. The option ``both="joint"`` (ours, not the thesis's) lets both feet act
at once: ``p <- p + alpha (F_0 + F_1) / 2``,
``psi <- psi + beta (T_z0 + T_z1) / max(|r_h0|^2 + |r_h1|^2, 2 LEVER_EPS^2)``. Linearised,
its step matrix has eigenvalues ``alpha`` and
``((alpha + beta) +- sqrt((alpha - beta)^2 + 4 alpha beta kappa)) / 2`` with
``kappa = |r_h0 + r_h1|^2 / (2 (|r_h0|^2 + |r_h1|^2))`` in [0, 1], all in (0, alpha + beta]:
it converges on consistent targets (feet apart: kappa < 1), and otherwise to the
least-squares compromise in that metric. The offsets are ``p^f - p`` (F, 3) and
``psi^f - psi`` (F,), NaN at frames where no foot is planted.

**Hierarchical B-spline.** The offsets known at the constrained frames become a smooth
function of time by the multilevel B-spline approximation (MBA) of Lee, Wolberg and Shin
(1997), as Lee and Shin (1999) use it for motion editing: uniform cubic B-splines in one
variable (time, seconds), vector-valued. Level 0 has knot spacing ``coarse`` (default
1 s); each next level halves the spacing; the last level is the first whose spacing is at
most ``fine`` (so the finest spacing lies in (fine/2, fine]). Each level fits the current
residual at the data times by the B-spline approximation (BA): a data point at lattice
parameter ``i + u`` (u in [0, 1)) has weights ``w_k = B_k(u)`` on control points
``i .. i+3`` and proposes ``phi_k = w_k d / sum_l w_l^2`` to each; a control point takes
the average of its proposals weighted by ``w_k^2``; control points without data are 0. The
level's spline is added to the total and subtracted from the residual. Coarse levels
spread each correction over about two coarse spacings either side (the motion
"anticipates" a step), fine levels reach the values at the data.

Edges: a level's knots run from ``t_range[0]`` (default the data's start) in steps of its
spacing until they cover ``t_range`` and the data, with one control point beyond each end,
as in the BA; control points outside that lattice are 0. A control point takes data from
two spacings either side and reaches two spacings either side, so each level is exactly 0
farther than four of its spacings from every datum. The approximation is the sum of the
levels: away from the data it decays to 0 (in a long flight the offset fades out
smoothly, over the coarse level's reach of a few seconds, instead of holding its last
value). This is accepted: a body offset is a local correction. The sum is C2 everywhere.

Accuracy: BA is an approximation and does not reproduce even constants exactly on one
level (a data point proposes ``w_k d / sum w^2``, not d); the residual shrinks level by
level. With the finest spacing near two frames, dense smooth data (constants and lines
included) is met to about 1e-3 of its range inside a run of data and to a few 1e-3 at the
first and last frames of a run, where the control points see data from one side only.
Offsets of a few centimetres are met to a fraction of a millimetre; the bone IK (3.8.2)
places the feet exactly.

Everything is vectorised over frames and data points (``np.bincount``); the only Python
loops are over iterations, feet and levels.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = [
    "LEVER_EPS",
    "MultilevelBSpline",
    "body_offsets",
    "bspline_weights",
    "fit_multilevel",
    "ik_error",
    "joint_step",
    "level_spacings",
    "smooth_offsets",
    "torque_step",
]

#: Smallest horizontal lever arm (m) the turn is normalised by: a foot nearer the body's
#: vertical axis turns the body only part of the way (``(|r_h| / LEVER_EPS)^2``), so a
#: foot almost under the body cannot ask for a huge turn.
LEVER_EPS = 0.05


# ----------------------------------------------------------------------------- body offset

def _rotate_z(v: np.ndarray, psi: np.ndarray) -> np.ndarray:
    """``Rz(psi) v`` for v (..., 3) and psi (...)."""
    c, s = np.cos(psi), np.sin(psi)
    x, y = v[..., 0], v[..., 1]
    return np.stack([c * x - s * y, s * x + c * y, v[..., 2]], axis=-1)


def ik_error(p, psi, p_loc, p_ik) -> np.ndarray:
    """``F = p_ik - (p + Rz(psi) p_loc)`` (..., 3), metres: the way from the IK point to its
    target. p, p_loc, p_ik (..., 3); psi (...)."""
    p, psi, p_loc, p_ik = (np.asarray(a, float) for a in (p, psi, p_loc, p_ik))
    return p_ik - (p + _rotate_z(p_loc, psi))


def torque_step(p, psi, p_loc, p_ik, alpha: float = 0.5, beta: float = 1.0, turn: str = "thesis"
                ) -> tuple[np.ndarray, np.ndarray]:
    """One iteration for one foot (module docstring). p, p_loc, p_ik (F, 3) metres (or any
    (..., 3)), psi (F,) radians. Returns the new (p (F, 3), psi (F,)); inputs unchanged.

    ``r = Rz(psi) p_loc``, ``F = p_ik - (p + r)``, ``T_z = (r x F)_z``;
    ``p + alpha F`` and ``psi + beta T_z / max(|r_h|^2, LEVER_EPS^2)``."""
    p, psi, p_loc, p_ik = (np.asarray(a, float) for a in (p, psi, p_loc, p_ik))
    r = _rotate_z(p_loc, psi)
    f = p_ik - (p + r)
    tz = r[..., 0] * f[..., 1] - r[..., 1] * f[..., 0]
    lever2 = np.maximum(r[..., 0] ** 2 + r[..., 1] ** 2, LEVER_EPS ** 2) if turn == "normalised" else 1.0
    return p + alpha * f, psi + beta * tz / lever2


def joint_step(p, psi, p_loc, p_ik, alpha: float = 0.5, beta: float = 1.0, turn: str = "thesis"
               ) -> tuple[np.ndarray, np.ndarray]:
    """One iteration with both feet pulling at once (``both="joint"``, module docstring).
    p (F, 3), psi (F,), p_loc and p_ik (2, F, 3). Returns the new (p (F, 3), psi (F,))."""
    p, psi, p_loc, p_ik = (np.asarray(a, float) for a in (p, psi, p_loc, p_ik))
    r = _rotate_z(p_loc, psi[None])
    f = p_ik - (p[None] + r)
    tz = (r[..., 0] * f[..., 1] - r[..., 1] * f[..., 0]).sum(axis=0)
    lever2 = (np.maximum((r[..., 0] ** 2 + r[..., 1] ** 2).sum(axis=0), 2 * LEVER_EPS ** 2)
              if turn == "normalised" else 2.0)
    return p + alpha * f.mean(axis=0), psi + beta * tz / lever2


def body_offsets(p: np.ndarray, psi: np.ndarray, p_loc: np.ndarray, p_ik: np.ndarray,
                 planted: np.ndarray, alpha: float = 0.5, beta: float = 1.0,
                 iterations: int = 10, both: str = "average", turn: str = "thesis"
                 ) -> tuple[np.ndarray, np.ndarray]:
    """Thesis 3.8.1 at every frame (module docstring).

    p (F, 3) body positions, metres; psi (F,) headings, radians about +Z; p_loc (2, F, 3)
    the IK point of each foot (0 left, 1 right) in the body frame; p_ik (2, F, 3) its
    targets in the world; planted (2, F) bool. Returns (dp (F, 3), dpsi (F,)): the offsets
    ``p^f - p`` and ``psi^f - psi`` at frames where a foot is planted, NaN elsewhere.
    ``iterations`` steps per foot. Frames with both feet planted: ``both="average"``
    (thesis) averages the results of the two feet's separate runs; ``both="joint"``
    iterates ``joint_step``. Targets of unplanted feet are not read (they may be NaN)."""
    p = np.asarray(p, float)
    psi = np.asarray(psi, float)
    p_loc = np.asarray(p_loc, float)
    p_ik = np.asarray(p_ik, float)
    planted = np.asarray(planted, bool)
    n = len(psi)
    if p.shape != (n, 3) or psi.shape != (n,) or p_loc.shape != (2, n, 3) \
            or p_ik.shape != (2, n, 3) or planted.shape != (2, n):
        raise ValueError("body_offsets: expected p (F, 3), psi (F,), p_loc and p_ik (2, F, 3), "
                         f"planted (2, F); got {p.shape}, {psi.shape}, {p_loc.shape}, "
                         f"{p_ik.shape}, {planted.shape}")
    if iterations < 0:
        raise ValueError("body_offsets: iterations must be >= 0")
    if both not in ("average", "joint"):
        raise ValueError(f"body_offsets: both must be 'average' or 'joint'; got {both!r}")
    sum_p = np.zeros((n, 3))
    sum_psi = np.zeros(n)
    count = planted.sum(axis=0)
    runs = planted.copy()
    if both == "joint":
        idx = np.flatnonzero(count == 2)
        runs[:, idx] = False
        fp, fpsi = p[idx], psi[idx]
        for _ in range(iterations):
            fp, fpsi = joint_step(fp, fpsi, p_loc[:, idx], p_ik[:, idx], alpha, beta, turn)
        # these frames have count 2: the division below gives the joint result back
        sum_p[idx] += 2 * (fp - p[idx])
        sum_psi[idx] += 2 * (fpsi - psi[idx])
    # each foot's frames run on their own; the two feet's rows side by side in one array
    # (a step reads each row alone)
    foot, idx = np.nonzero(runs)
    fp, fpsi = p[idx], psi[idx]
    loc, target = p_loc[foot, idx], p_ik[foot, idx]
    for _ in range(iterations):
        fp, fpsi = torque_step(fp, fpsi, loc, target, alpha, beta, turn)
    for k in range(2):
        at = foot == k
        sum_p[idx[at]] += fp[at] - p[idx[at]]
        sum_psi[idx[at]] += fpsi[at] - psi[idx[at]]
    with np.errstate(invalid="ignore", divide="ignore"):
        dp = np.where(count[:, None] > 0, sum_p / count[:, None], np.nan)
        dpsi = np.where(count > 0, sum_psi / count, np.nan)
    return dp, dpsi


# ----------------------------------------------------------------------------- B-splines

def bspline_weights(u: np.ndarray) -> np.ndarray:
    """Uniform cubic B-spline basis ``B_0..B_3`` at u in [0, 1]: (..., 4), summing to 1."""
    u = np.asarray(u, float)
    v = 1.0 - u
    u2 = u * u
    u3 = u2 * u  # (products: a power of 3 costs six times as much)
    w = np.empty(u.shape + (4,))
    w[..., 0], w[..., 1], w[..., 2], w[..., 3] = v * v * v, 3 * u3 - 6 * u2 + 4, -3 * u3 + 3 * u2 + 3 * u + 1, u3
    w /= 6.0
    return w


def level_spacings(coarse: float, fine: float) -> np.ndarray:
    """Knot spacings (s) of the levels: ``coarse``, halved each level, down to the first
    spacing that is at most ``fine`` (a single level when fine >= coarse)."""
    if not (coarse > 0 and fine > 0 and np.isfinite(coarse) and np.isfinite(fine)):
        raise ValueError("knot spacings must be positive and finite; "
                         f"got coarse={coarse}, fine={fine}")
    n = max(0, int(np.ceil(np.log2(coarse / fine) - 1e-9)))
    return coarse / 2.0 ** np.arange(n + 1)


@dataclass
class MultilevelBSpline:
    """Sum of uniform cubic B-splines. ``levels``: per level ``(t0, spacing, control points
    (K, D))``; control point j sits at time ``t0 + (j - 1) spacing``; the spline at
    ``t = t0 + (i + u) spacing`` is ``sum_k B_k(u) c[i + k]``, control points outside
    0..K-1 being 0."""

    levels: list = field(default_factory=list)
    dim: int = 1

    def __call__(self, t: np.ndarray) -> np.ndarray:
        """Values (F, D) at times t (F,) seconds."""
        t = np.asarray(t, float).reshape(-1)
        out = np.zeros((len(t), self.dim))
        for t0, h, c in self.levels:
            out += _evaluate(t0, h, c, t)
        return out


def _locate(t0: float, h: float, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    s = (t - t0) / h
    i = np.floor(s)
    return i.astype(np.int64), s - i


def _evaluate(t0: float, h: float, c: np.ndarray, t: np.ndarray) -> np.ndarray:
    i, u = _locate(t0, h, t)
    return _evaluate_at(i, bspline_weights(u), c)


_FOUR = np.arange(4)


def _evaluate_at(i: np.ndarray, w: np.ndarray, c: np.ndarray) -> np.ndarray:
    """The level of control points c (K, D) at points in intervals i (M,) with basis
    weights w (M, 4) (``_locate``, ``bspline_weights``): (M, D)."""
    j = i[:, None] + _FOUR  # (M, 4)
    w = np.where((j >= 0) & (j < len(c)), w, 0.0)
    # (np.take: a fancy index of these shapes costs eight times as much)
    return np.einsum("fk,fkd->fd", w, np.take(c, np.clip(j, 0, len(c) - 1), axis=0))


def _fit_at(i: np.ndarray, u: np.ndarray, w: np.ndarray, m: int, d: np.ndarray) -> np.ndarray:
    """BA of the data d (M, D) at points located in intervals i (M,) at u (``_locate``),
    with their basis weights w (M, 4), on a lattice of m intervals: control points
    (m + 3, D)."""
    k_count = m + 3
    # a point on the last knot belongs to the last interval (u = 1): same value, in range
    last = i >= m
    if last.any():
        u = np.where(last, u + (i - (m - 1)), u)
        i = np.where(last, m - 1, i)
        w = np.where(last[:, None], bspline_weights(u), w)
    j = (i[:, None] + _FOUR).ravel()  # (M * 4,)
    w2 = w * w
    # each point's share of each of its control points: w2 * phi, phi = w d / sum(w2)
    share = (w2 * w / (w2 @ np.ones(4))[:, None]).ravel()
    den = np.bincount(j, weights=w2.ravel(), minlength=k_count)
    num = np.stack([np.bincount(j, weights=share * np.repeat(d[:, k], 4), minlength=k_count)
                    for k in range(d.shape[1])], axis=1)
    out = np.zeros_like(num)
    return np.divide(num, den[:, None], out=out, where=den[:, None] > 0)


def fit_multilevel(t_data: np.ndarray, values: np.ndarray, coarse: float = 1.0,
                   fine: float = 1 / 15, t_range: tuple[float, float] | None = None
                   ) -> MultilevelBSpline:
    """MBA (module docstring) of values (M, D) (or (M,), taken as D = 1) at times t_data
    (M,) seconds. Knot spacings from ``level_spacings(coarse, fine)``; each level's
    lattice starts at ``t_range[0]`` and covers ``t_range`` and the data (default: the
    data's span). With no data the spline is 0."""
    t_data = np.asarray(t_data, float).reshape(-1)
    values = np.asarray(values, float)
    if values.ndim == 1:
        values = values[:, None]
    if values.ndim != 2 or len(values) != len(t_data):
        raise ValueError(f"fit_multilevel: values must be (M, D) for {len(t_data)} times; "
                         f"got {values.shape}")
    if not (np.isfinite(t_data).all() and np.isfinite(values).all()):
        raise ValueError("fit_multilevel: times and values must be finite")
    spacings = level_spacings(coarse, fine)
    dim = values.shape[1]
    if len(t_data) == 0:
        return MultilevelBSpline([], dim)
    levels, _ = _fit_levels(t_data, values, spacings, t_range)
    return MultilevelBSpline(levels, dim)


def _fit_levels(t_data: np.ndarray, values: np.ndarray, spacings: np.ndarray,
                t_range: tuple[float, float] | None, t_all: np.ndarray | None = None,
                data_at: np.ndarray | None = None, keep: tuple[int, ...] = ()) -> tuple[list, list]:
    """MBA's levels (``fit_multilevel``) of values (M, D) at t_data (M,); with ``t_all``
    (F,) of which the data's times are ``t_all[data_at]``, also, for each count in
    ``keep``, the sum of the first that many levels at every ``t_all`` (F, D), each
    level's basis found once for the fit and the values."""
    lo, hi = float(t_data.min()), float(t_data.max())
    if t_range is not None:
        lo, hi = min(lo, float(t_range[0])), max(hi, float(t_range[1]))
    residual = values.copy()
    levels = []
    out = None if t_all is None else np.zeros((len(t_all), values.shape[1]))
    kept = {}
    for level, h in enumerate(spacings):
        m = max(1, int(np.ceil((hi - lo) / h - 1e-9)))
        if t_all is None:
            i, u = _locate(lo, h, t_data)
            w = bspline_weights(u)
        else:
            i_all, u_all = _locate(lo, h, t_all)
            w_all = bspline_weights(u_all)
            i, u, w = i_all[data_at], u_all[data_at], w_all[data_at]
        c = _fit_at(i, u, w, m, residual)
        levels.append((lo, float(h), c))
        if t_all is None:
            residual -= _evaluate_at(i, w, c)
        else:
            value = _evaluate_at(i_all, w_all, c)
            residual -= value[data_at]
            out += value
            if level + 1 in keep:
                kept[level + 1] = out.copy()
    return levels, [kept[k] for k in keep]


def smooth_offsets(t: np.ndarray, dp: np.ndarray, dpsi: np.ndarray, coarse: float = 1.0,
                   fine: float | None = None, also_fine: float | None = None):
    """The offsets of ``body_offsets`` at every frame. t (F,) frame times, seconds,
    increasing; dp (F, 3) metres and dpsi (F,) radians, NaN where unknown. Returns
    (dp (F, 3), dpsi (F,)): the multilevel B-spline of the known offsets evaluated at every
    frame, known frames included (so the result is smooth; it matches the known values to
    the accuracy of the finest level). ``fine`` defaults to two frame steps (the median
    step). With no known frame the offsets are 0.

    With ``also_fine`` (s), also the offsets (F, 4: dp's and dpsi's columns) as
    ``smooth_offsets(t, dp, dpsi, coarse, also_fine)`` would give them, from the same fit
    (each column is fitted on its own, level by level, and the two fits' levels are one
    halving series from ``coarse``): returns (dp, dpsi, those offsets)."""
    t = np.asarray(t, float).reshape(-1)
    dp = np.asarray(dp, float)
    dpsi = np.asarray(dpsi, float)
    n = len(t)
    if dp.shape != (n, 3) or dpsi.shape != (n,):
        raise ValueError(f"smooth_offsets: expected dp (F, 3) and dpsi (F,) for {n} frames; "
                         f"got {dp.shape}, {dpsi.shape}")
    if fine is None:
        step = float(np.median(np.diff(t))) if n > 1 else coarse
        fine = 2.0 * step if step > 0 else coarse
    known = np.flatnonzero(np.isfinite(dp).all(axis=1) & np.isfinite(dpsi))
    if n == 0 or not len(known):
        out = np.zeros((n, 4))
        return (out[:, :3], out[:, 3]) if also_fine is None else (out[:, :3], out[:, 3], out.copy())
    if not np.isfinite(t[known]).all():
        raise ValueError("smooth_offsets: the frame times must be finite")
    spacings = level_spacings(coarse, fine)
    other = None if also_fine is None else level_spacings(coarse, also_fine)
    longest = spacings if other is None or len(other) <= len(spacings) else other
    # (fit_multilevel's spline, evaluated at every frame as it is fitted)
    _, sums = _fit_levels(t[known], np.c_[dp[known], dpsi[known]], longest, (float(t.min()), float(t.max())), t, known,
                          keep=(len(spacings), len(longest) if other is None else len(other)))
    out = sums[0]
    return (out[:, :3], out[:, 3]) if also_fine is None else (out[:, :3], out[:, 3], sums[1])
