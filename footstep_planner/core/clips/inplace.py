"""In-place clips: root motion reconstructed from the planted feet.

Clips downloaded "in place" (Mixamo's usual form) keep the hips over one spot while the
feet step: a planted foot slides backwards under the body at the walking speed instead of
standing still. Johansen's Locomotion System works with such cycles by taking the body's
motion from its feet; this module does the same for a ClipMotion, so that the analysis
reads it exactly as a travelling clip.

*Recognising* one (``check_in_place``): a foot steps (its lower point rises at least
``Settings.min_step_height``), the ground point of a low foot (heel and toe blended by
Johansen's balance, within ``Settings.contact_height`` of the clip's ground) moves at
``MIN_SLIDE`` or more (median over the low samples) and the root at under ``ROOT_SHARE``
of that (mean). A travelling clip's low feet stand still while its root moves; an idle's
(and a jump on the spot's) feet stand still and so does its root: neither is in place.

*Planted* (``slide_weights``): the usual test (a foot low and slow) fails, the planted
foot slides. A foot is planted while it is low, moves backwards under the body (within
``SLIDE_ANGLE`` of the clip's slide direction, the feet's median velocity while flat) or
stands, and its velocity relative to the root stays within ``Settings.slip_tolerance``
of that at its flattest (Johansen's horizontal check), for ``MIN_PLANT`` or more. The
analysis then finds the stances with Johansen's rules on the clip so reconstructed and
reconstructs again from them (``stance_weights``: strike to liftoff).

*Reconstruction* (``reconstruct``): the whole clip (root, heel and toe points) is
carried by a planar rigid motion C(t), a yaw theta and a translation, such that the
planted foot stands still in the world. For the foot's ground point p (clip space)::

    d theta / dt = - (the planted foot's turning rate)       (a planted foot does not turn)
    d c / dt     = - R(theta) (dp/dt + d theta/dt J p)        (nor slide)

with J the quarter turn about +Z. Only the steady part of a stance counts
(``_steady``): its velocity within ``STEADY_TOLERANCE`` of the stance's median, and
from the inner part of its flat stretch outwards no faster a change than
``MAX_ACCELERATION`` (a body does not accelerate like that, a foot leaving or reaching
the ground does). With both feet planted their
velocities are averaged; where none is (a run's flights, a walk's stance edges, the
clip's ends) the velocity in the root's frame is interpolated linearly between the
stances on either side (held before the first and after the last). The yaw comes from
the feet only in a clip whose yaw was removed with its travel (``_yaw_rate``): a foot's
heading also wobbles as it rolls, so only feet that turn one way in every stance count.
The bone rotations and the hips in the root frame stay: the pose is the clip's own.

Limits: the body's motion while no foot is planted cannot be known from the feet (a
jogger's hips move faster in flight than over the planted foot), and real feet creep a
little while planted (3-4 % of the speed in the CMU walks): a reconstructed speed is
that much under the travelling original's.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.ndimage import gaussian_filter1d

from .clip import ClipMotion
from ..base.settings import Settings

#: The least median speed (m/s) of a low foot's ground point for an in-place clip.
MIN_SLIDE = 0.3
#: An in-place clip's root moves at under this share of its low feet's median speed.
ROOT_SHARE = 0.25
#: A planted foot moves within this angle (radians) of the clip's slide direction.
SLIDE_ANGLE = np.radians(60)
#: A foot is planted for at least this long (s).
MIN_PLANT = 0.06
#: Gaussian width (s) of the derivative of the feet's velocities the root follows: small,
#: so a stance's edges carry little of the swing (integrated, the noise averages out).
VELOCITY_SMOOTHING = 0.01
#: The root follows a planted foot's velocity (relative to it) where that stays within
#: STEADY_TOLERANCE of its median over the stance's flat part (at least
#: Settings.slip_min_speed), and at the stance's edges only as far as it changes by less
#: than MAX_ACCELERATION m/s^2 (about 1 g).
STEADY_TOLERANCE = 0.1
MAX_ACCELERATION = 10.0
#: ... the edges being the stance's samples outside its flat part, and this much (s) of
#: the flat part's own ends.
CORE_EDGE = 0.03
#: The root turns with its planted feet (a clip whose yaw was removed with its travel)
#: when its own heading turns by at most ROOT_TURN radians over the clip and its stances
#: (three or more, of MIN_TURN_STANCE s or more) all turn one way, their median at least
#: MIN_TURN_RATE rad/s; the yaw rate is smoothed over YAW_SMOOTHING s (Gaussian width).
ROOT_TURN = np.radians(15)
MIN_TURN_STANCE = 0.1
MIN_TURN_RATE = 0.02
YAW_SMOOTHING = 0.5


@dataclass(frozen=True)
class InPlaceCheck:
    """What ``check_in_place`` measured on a clip."""

    in_place: bool
    slide: float  # m/s, median speed of the low feet's ground points in the clip's space
    root_speed: float  # m/s, mean speed of the root
    steps: bool  # a foot rises at least min_step_height


@dataclass
class _FeetSignals:
    """Both feet on the dense clip: ground points, their velocities and headings."""

    point: np.ndarray  # (2, n, 2) ground point (heel and toe by the balance), armature XY
    velocity: np.ndarray  # (2, n, 2) its velocity without the heel-toe roll, m/s
    heading: np.ndarray  # (2, n) unwrapped heel-to-toe heading, radians
    lower_z: np.ndarray  # (2, n) the lower of heel and toe
    low: np.ndarray  # (2, n) bool: within contact_height of the clip's ground


def dense_motion(motion: ClipMotion, s: Settings) -> ClipMotion:
    """The clip at the analysis rate (as the analysis resamples it)."""
    rate = max(float(s.analysis_rate), motion.fps)
    return motion if abs(rate - motion.fps) < 1e-9 else motion.resample(rate)


def _signals(dense: ClipMotion, s: Settings, sigma: float | None = None) -> _FeetSignals:
    """Johansen's ground point of each foot (heel and toe blended by the balance), its
    velocity (the heel's and toe's blended: no roll; Gaussian derivative of width
    ``sigma`` s, default ``Settings.derivative_smoothing``, at least a sample), its
    heading, and its lowness."""
    dt = dense.times[1] - dense.times[0]
    sig_v = max((s.derivative_smoothing if sigma is None else sigma) / dt, 1.0)  # >= 1 sample: unbiased
    heel, toe = dense.heel, dense.toe
    b = np.clip(0.5 + (heel[..., 2] - toe[..., 2]) / s.balance_band, 0.0, 1.0)[..., None]
    d = lambda x, sg: gaussian_filter1d(x, sg, axis=1, order=1, mode="nearest") / dt  # noqa: E731
    v = d(heel[..., :2], sig_v) + b * (d(toe[..., :2], sig_v) - d(heel[..., :2], sig_v))
    point = heel[..., :2] + b * (toe[..., :2] - heel[..., :2])
    ht = toe[..., :2] - heel[..., :2]
    phi = np.unwrap(np.arctan2(ht[..., 1], ht[..., 0]), axis=1)
    lower = np.minimum(heel[..., 2], toe[..., 2])
    ground = np.minimum(np.percentile(lower, 2, axis=1), 0.0)[:, None]
    return _FeetSignals(point, v, phi, lower, lower < ground + s.contact_height)


def check_in_place(motion: ClipMotion, s: Settings | None = None,
                   dense: ClipMotion | None = None) -> InPlaceCheck:
    """Is ``motion`` an in-place clip (its feet step and slide under a root that stays)?
    ``dense``: the clip already at the analysis rate (``dense_motion``), if at hand."""
    s = s or Settings()
    dense = dense_motion(motion, s) if dense is None else dense
    sig = _signals(dense, s)
    steps = bool((np.ptp(sig.lower_z, axis=1) >= s.min_step_height).any())
    root_v = np.gradient(dense.root_pos[:, :2], dense.times, axis=0)
    root_speed = float(np.mean(np.linalg.norm(root_v, axis=1)))
    low_speed = np.linalg.norm(sig.velocity, axis=2)[sig.low]
    slide = float(np.median(low_speed)) if low_speed.size else 0.0
    in_place = steps and slide >= s.length(MIN_SLIDE) and root_speed < ROOT_SHARE * slide
    return InPlaceCheck(bool(in_place), slide, root_speed, steps)


def _to_root(dense: ClipMotion, vec: np.ndarray) -> np.ndarray:
    """Horizontal vectors (2, n, 2) of the clip's space in its root's frame."""
    c, sn = np.cos(dense.root_heading), np.sin(dense.root_heading)
    return np.stack([c * vec[..., 0] + sn * vec[..., 1], -sn * vec[..., 0] + c * vec[..., 1]], axis=-1)


def slide_weights(dense: ClipMotion, s: Settings) -> tuple[np.ndarray, np.ndarray]:
    """(planted, core), (2, n) bool per dense sample: the foot is planted in an in-place
    clip (see the module's notes): low, moving backwards under the body (along the
    clip's slide direction) or standing, at a steady velocity relative to the root;
    core: the part of it where the foot is also flat (heel and toe near their lowest)."""
    sig = _signals(dense, s)
    dt = dense.times[1] - dense.times[0]
    rel_v = _relative_velocity(dense, sig)
    speed = np.linalg.norm(rel_v, axis=2)
    upper = np.maximum(dense.heel[..., 2], dense.toe[..., 2])
    planted = np.zeros(speed.shape, bool)
    core = np.zeros(speed.shape, bool)
    # the slide direction: the median velocity of the feet while flat on the ground
    flat = sig.low & (upper < np.percentile(upper, 2, axis=1)[:, None] + s.firm_height)
    sliding = flat & (speed >= s.length(MIN_SLIDE))
    if not sliding.any():
        return planted, core
    ref = np.median(rel_v[sliding], axis=0)
    e = ref / max(float(np.linalg.norm(ref)), 1e-9)
    along = (rel_v @ e >= np.cos(SLIDE_ANGLE) * speed) | (speed < s.slip_min_speed)
    min_len = max(2, int(round(MIN_PLANT / dt)))
    for k in range(2):
        for a, b in _runs(sig.low[k] & along[k]):
            # Johansen's horizontal check about the flattest sample of the run
            i0 = a + int(np.argmin(upper[k, a:b]))
            firm = upper[k, a:b] <= upper[k, i0] + s.firm_height
            v0 = np.median(rel_v[k, a:b][firm], axis=0)
            tol = max(s.slip_tolerance * float(np.linalg.norm(v0)), s.slip_min_speed)
            ok = np.linalg.norm(rel_v[k, a:b] - v0, axis=1) < tol
            lo, hi = i0 - a, i0 - a + 1
            if not ok[lo]:
                continue
            while lo > 0 and ok[lo - 1]:
                lo -= 1
            while hi < b - a and ok[hi]:
                hi += 1
            if hi - lo >= min_len:
                planted[k, a + lo:a + hi] = True
                core[k, a + lo:a + hi] = firm[lo:hi]
    return planted, core


def _relative_velocity(dense: ClipMotion, sig: _FeetSignals) -> np.ndarray:
    """(2, n, 2) velocity of each foot's ground point relative to the root, in the root's
    frame."""
    dt = dense.times[1] - dense.times[0]
    root_v = np.gradient(dense.root_pos[:, :2], dt, axis=0)
    omega = np.gradient(dense.root_heading, dt)
    rel_p = sig.point - dense.root_pos[None, :, :2]
    rel_v = sig.velocity - root_v[None] - omega[None, :, None] * np.stack([-rel_p[..., 1], rel_p[..., 0]], -1)
    return _to_root(dense, rel_v)


def stance_weights(times: np.ndarray, stances) -> tuple[np.ndarray, np.ndarray]:
    """(planted, core), (2, n) bool per sample of ``times``, from stances (objects with
    foot, strike, land, lift, liftoff in seconds): planted from strike to liftoff, core
    from land to lift."""
    planted = np.zeros((2, len(times)), bool)
    core = np.zeros((2, len(times)), bool)
    for st in stances:
        planted[st.foot] |= (times >= st.strike - 1e-9) & (times <= st.liftoff + 1e-9)
        core[st.foot] |= (times >= min(st.land, st.stance) - 1e-9) & (times <= max(st.lift, st.stance) + 1e-9)
    return planted, core & planted


def _integral(y: np.ndarray, t: np.ndarray) -> np.ndarray:
    """The running integral of samples ``y`` (N, ...) over times ``t`` (N,), by trapezoids,
    0 at ``t[0]`` (scipy's ``cumulative_trapezoid(..., axis=0, initial=0)``, whose module
    alone takes half a second to import in every process that analyses a clip)."""
    dt = np.diff(t).reshape((-1,) + (1,) * (np.ndim(y) - 1))
    return np.concatenate([np.zeros((1,) + np.shape(y)[1:]), np.cumsum(0.5 * (y[1:] + y[:-1]) * dt, axis=0)])


def reconstruct(motion: ClipMotion, planted: np.ndarray, core: np.ndarray,
                dense: ClipMotion, s: Settings) -> ClipMotion | None:
    """``motion`` carried so that its planted feet stand still (see the module's notes):
    ``planted`` (2, n) bool per sample of ``dense`` (the clip at the analysis rate) says
    when each foot is planted, ``core`` when it stands flat (its reference velocity).
    None when no foot is ever steadily planted."""
    sig = _signals(dense, s, VELOCITY_SMOOTHING)
    t = dense.times
    dt = t[1] - t[0]
    planted, core = np.asarray(planted, bool), np.asarray(core, bool)
    w = _steady(planted, core, _to_root(dense, -sig.velocity), dt, s)
    if not w.any():
        return None
    omega = _yaw_rate(dense, sig, planted & _runs_with(planted, w))
    # what the root does if a planted foot stands still: its velocity in the root's own
    # frame (the rigid motion's velocity turned by the root's heading)
    jp = np.stack([-sig.point[..., 1], sig.point[..., 0]], axis=-1)
    local_k = _to_root(dense, -(sig.velocity + omega[None, :, None] * jp))
    if omega.any():  # steady in the turning frame
        w = _steady(planted, core, local_k, dt, s)
        if not w.any():
            return None
    local = np.stack([_blend(t, w, local_k[..., i]) for i in range(2)], axis=-1)
    theta = _integral(omega, t)
    heading = dense.root_heading + theta
    c, sn = np.cos(heading), np.sin(heading)
    vel = np.stack([c * local[:, 0] - sn * local[:, 1], sn * local[:, 0] + c * local[:, 1]], axis=-1)
    # C(t): the yaw theta, and the shift that takes the root (turned by theta) onto the
    # path its velocity integrates to; at the clip's own samples
    path = dense.root_pos[0, :2] + _integral(vel, t)
    ct, st_ = np.cos(theta), np.sin(theta)
    r = dense.root_pos[:, :2]
    shift = path - np.stack([ct * r[:, 0] - st_ * r[:, 1], st_ * r[:, 0] + ct * r[:, 1]], axis=-1)
    tt = motion.times
    shift = np.stack([np.interp(tt, t, shift[:, i]) for i in range(2)], axis=-1)
    return motion.moved(np.interp(tt, t, theta), shift)


def _steady(planted: np.ndarray, core: np.ndarray, local_k: np.ndarray, dt: float,
            s: Settings) -> np.ndarray:
    """``planted`` (2, n) bool kept only where the root's velocity ``local_k`` (2, n, 2)
    the planted foot implies is steady: within ``STEADY_TOLERANCE`` of its median over
    the run's ``core`` (at least ``Settings.slip_min_speed``), and from the core's inner
    part (``CORE_EDGE`` in from its ends) outwards only as far as it changes by less than
    ``MAX_ACCELERATION``."""
    out = np.zeros_like(planted)
    acc = np.linalg.norm(gaussian_filter1d(local_k, 1.0, axis=1, order=1, mode="nearest"), axis=2) / dt
    for k in range(2):
        for a, b in _runs(planted[k]):
            c = core[k, a:b]
            ref = c if c.any() else np.ones(b - a, bool)
            v0 = np.median(local_k[k, a:b][ref], axis=0)
            tol = max(STEADY_TOLERANCE * float(np.linalg.norm(v0)), s.slip_min_speed)
            ok = np.linalg.norm(local_k[k, a:b] - v0, axis=1) < tol
            idx = np.flatnonzero(ref)
            # grow from the core's inner part: its edges, found on a clip reconstructed
            # from less, may hold some of the swing
            edge = int(round(CORE_EDGE / dt))
            lo, hi = int(idx[0]) + edge, int(idx[-1]) + 1 - edge
            if hi <= lo:
                lo = (int(idx[0]) + int(idx[-1])) // 2
                hi = lo + 1
            calm = acc[k, a:b] < s.length(MAX_ACCELERATION)
            while lo > 0 and ok[lo - 1] and calm[lo - 1]:
                lo -= 1
            while hi < b - a and ok[hi] and calm[hi]:
                hi += 1
            out[k, a + lo:a + hi] = ok[lo:hi]
    return out


def _blend(t: np.ndarray, w: np.ndarray, x: np.ndarray) -> np.ndarray:
    """(n,) the feet's values ``x`` (2, n): the mean over the planted feet (``w`` (2, n)
    bool), interpolated linearly between planted samples elsewhere (held before the
    first and after the last)."""
    nw = w.sum(axis=0)
    has = nw > 0
    return np.interp(t, t[has], (w[:, has] * x[:, has]).sum(axis=0) / nw[has])


def _yaw_rate(dense: ClipMotion, sig: _FeetSignals, planted: np.ndarray) -> np.ndarray:
    """(n,) the yaw rate (rad/s) the root gets from its planted feet (``planted`` (2, n)
    bool): minus each stance's turning rate (its heading's least-squares slope),
    interpolated between the stances and smoothed over ``YAW_SMOOTHING``. Zero unless
    every stance turns the same way (their median at least ``MIN_TURN_RATE``) and the
    root's own heading does not turn (``ROOT_TURN``): a foot's heading also wobbles as it
    rolls (left and right feet the other way), and a clip that kept its hips' yaw turns
    already."""
    t = dense.times
    out = np.zeros(len(t))
    if abs(dense.root_heading[-1] - dense.root_heading[0]) > ROOT_TURN:
        return out
    dt = t[1] - t[0]
    rates = np.zeros(planted.shape)
    counted = np.zeros(planted.shape, bool)
    per_stance = []
    for k in range(2):
        for a, b in _runs(planted[k]):
            if (b - a) * dt >= MIN_TURN_STANCE:
                rates[k, a:b] = -np.polyfit(t[a:b], sig.heading[k, a:b], 1)[0]
                counted[k, a:b] = True
                per_stance.append(rates[k, a])
    if len(per_stance) < 3:
        return out
    med = float(np.median(per_stance))
    if abs(med) < MIN_TURN_RATE or not np.all(np.sign(per_stance) == np.sign(med)):
        return out
    return gaussian_filter1d(_blend(t, counted, rates), YAW_SMOOTHING / dt, mode="nearest")


def _runs_with(mask: np.ndarray, some: np.ndarray) -> np.ndarray:
    """(2, n) bool: the runs of ``mask`` (2, n) that hold a True of ``some``."""
    out = np.zeros_like(mask)
    for k in range(len(mask)):
        for a, b in _runs(mask[k]):
            out[k, a:b] = some[k, a:b].any()
    return out


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """(start, stop) index pairs of the True runs of ``mask`` (stop exclusive)."""
    m = np.concatenate([[False], np.asarray(mask, bool), [False]])
    d = np.flatnonzero(np.diff(m.astype(np.int8)))
    return list(zip(d[0::2], d[1::2]))
