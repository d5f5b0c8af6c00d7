"""A swinging foot over uneven ground (step 4 of ``ik``): its heel, ball and toe tip keep
the clearance they have over the planes of the footprints it swings between
(``_swing_planes``, ``_plane_z``), the ankle lifted where the ground rises above them,
ahead of time and no faster than ``LIFT_RATE`` off a footprint (``_lift_need``,
``_lift_cone``, ``_ground_lift``); where the ground would lift it faster next to a
footprint, the foot is kept over that footprint a little longer
(``_kept_over_footprints``, ``_towards``).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from .easing import DEFAULT_FPS, ease_peaks, lower_smoothly, planted_either_side, smoothstep

#: m a swinging foot keeps above the surface.
GROUND_MARGIN = 0.002
#: frames either side over which a swinging foot's lift over the surface comes and goes
#: (``lower_smoothly``), so it rises ahead of a step's edge ...
LIFT_EASE = 3
#: m per frame: ... but a foot leaving or reaching its footprint is lifted no faster.
LIFT_RATE = 0.02
#: s after a liftoff (and before a strike) over which every point of a swinging foot comes
#: to keep ``GROUND_MARGIN`` over the ground (near a footprint: its clearance over its plane).
LIFT_RAMP = 0.15
#: Shares of the way to its footprint a swinging foot is drawn where the ground would
#: lift it too fast next to one (``_kept_over_footprints``), tried in turn ...
HOME_SHARES = (0.25, 0.5, 0.75, 1.0)
#: ... and the share per frame that draw comes and goes at.
HOME_RATE = 0.34
#: Passes of that draw, each checking the eased draw of the one before.
HOME_PASSES = 3
#: m a swinging foot's heel, ball or toe tip may come nearer the surface than the
#: clearance it keeps before the foot is lifted (rounding, not a dip).
CLEARANCE_TOL = 0.001
#: m: a planted foot's toe tip may sink this far into its footprint (rounding, a soft
#: floor), never further, whatever its clip does (a clip whose toes go through its own
#: floor at toe-off, played on a footprint, would sink them there).
TIP_SINK = 0.008


def _swing_planes(index: np.ndarray, fp_pos: np.ndarray, fp_normal: np.ndarray):
    """The surface one foot's swing is laid over, per frame: the planes of the footprint
    it left and of the one it lands on (``index`` (F,) its footprint while planted, -1 in
    the air; ``fp_pos`` (N, 3) points on them, ``fp_normal`` (N, 3)) and the smoothstep
    share ``u`` (F,) of the second, as ``swing_targets`` eases the foot. Returns (points
    (2, F, 3), normals (2, F, 3), u (F,), frames to the nearest planted frame (F,)), or
    None without a planted frame."""
    F = len(index)
    on = index >= 0
    if not on.any():
        return None
    f = np.arange(F)
    prev, nxt = planted_either_side(on)
    gap = np.minimum(np.where(prev < 0, F, f - prev), np.where(nxt >= F, F, nxt - f))
    prev, nxt = np.where(prev < 0, nxt, prev), np.where(nxt >= F, prev, nxt)
    j = index[np.stack([prev, nxt])]
    return fp_pos[j], fp_normal[j], smoothstep((f - prev) / np.maximum(nxt - prev, 1)), gap


def _plane_z(point: np.ndarray, normal: np.ndarray, xy: np.ndarray) -> np.ndarray:
    """(...,) heights at ``xy`` (..., 2) of the planes through ``point`` (..., 3) with
    ``normal`` (..., 3) (taken no steeper than about 70 degrees)."""
    nz = np.maximum(normal[..., 2], 0.3)
    return point[..., 2] - (normal[..., 0] * (xy[..., 0] - point[..., 0])
                            + normal[..., 1] * (xy[..., 1] - point[..., 1])) / nz


def _lift_need(ankle: np.ndarray, rot: np.ndarray, free: np.ndarray, sole: list, planes, ground_z,
               fps: float) -> np.ndarray:
    """(n,) m each ``free`` frame's foot (targets ``ankle`` (F, 3), ``rot`` (F, 3, 3)) must
    rise for its ``sole`` points to keep their clearance (see ``_ground_lift``), not eased."""
    pts = np.stack([ankle[free] + np.einsum("fij,fj->fi", rot[free], loc[free]) for loc, _ in sole])  # (P, n, 3)
    (pa, pb), (na, nb), u, gap = (x[..., free, :] if x.ndim > 1 else x[free] for x in planes)
    base = (1 - u) * _plane_z(pa, na, pts[..., :2]) + u * _plane_z(pb, nb, pts[..., :2])  # (P, n)
    w = smoothstep(gap / max(LIFT_RAMP * fps, 1.0))
    # the clearance over the planes, never under GROUND_MARGIN (the heel and ball) or, away
    # from the footprints, under the clip's own if that is less (a toe tip a clip sinks, by
    # TIP_SINK at most)
    clip = np.minimum(np.stack([h[free] for _, h in sole]), GROUND_MARGIN)
    above = pts[..., 2] - base
    want = above + w * np.maximum(clip - above, 0.0)
    want = np.maximum(want, np.array([GROUND_MARGIN, GROUND_MARGIN] + [-TIP_SINK] * (len(sole) - 2))[:, None])
    gz = np.asarray(ground_z(pts.reshape(-1, 3)), float).reshape(want.shape)
    depth = gz + want - pts[..., 2] - CLEARANCE_TOL
    return np.maximum(np.where(np.isfinite(depth), depth, 0.0).max(axis=0), 0.0)


def _lift_cone(planted: np.ndarray) -> np.ndarray:
    """(F,) m the most a swinging foot may be lifted at each frame: ``LIFT_RATE`` per
    frame from its last liftoff and to its next strike."""
    F = len(planted)
    f = np.arange(F)
    last, first = planted_either_side(planted)
    last, first = np.where(last < 0, -F, last), np.where(first >= F, 2 * F, first)  # (none: far)
    return LIFT_RATE * np.minimum(f - last, first - f)


def _ground_lift(ankle: np.ndarray, rot: np.ndarray, planted: np.ndarray, sole: list, planes, ground_z,
                 fps: float = DEFAULT_FPS, need: np.ndarray | None = None) -> np.ndarray:
    """(F,) m to lift one swinging foot's ankle (targets ``ankle`` (F, 3), ``rot`` (F, 3, 3))
    so that each of its ``sole`` points (``sole_points``: heel, ball, toe tip) keeps over
    the surface ``ground_z`` (points (M, 3) -> heights (M,), NaN for none; None: no lift)
    the clearance it has over the footprints' planes it swings between (``planes``, from
    ``_swing_planes``: its flat-ground clearance, laid on the slopes), the heel and ball
    ``GROUND_MARGIN`` at least, and from ``LIFT_RAMP`` s after liftoff to as long before
    the strike every point that much (or its clip's own clearance, if less): over a hill
    or a slope steepening ahead the foot rises with the ground. Eased over ``LIFT_EASE``
    frames (``LIFT_RATE`` off a footprint); 0 where ``planted`` (F,). ``need``: the free
    frames' ``_lift_need`` of these targets, when measured already."""
    lift = np.zeros(len(ankle))
    free = np.flatnonzero(~planted)
    if ground_z is None or planes is None or not len(free):
        return lift
    lift[free] = _lift_need(ankle, rot, free, sole, planes, ground_z, fps) if need is None else need
    if lift.any():  # rising ahead of time (a step's edge), never faster than LIFT_RATE off a footprint
        lift = np.maximum(lift, np.minimum(lower_smoothly(lift, LIFT_EASE), _lift_cone(planted)))
        lift[planted] = 0.0
    return lift


def _kept_over_footprints(ankle: np.ndarray, rot: np.ndarray, planted: np.ndarray, sole: list, planes,
                          ground_z, fps: float = DEFAULT_FPS, hip: np.ndarray | None = None,
                          reach: float = np.inf) -> tuple[np.ndarray, np.ndarray]:
    """One foot's swing targets (``ankle`` (F, 3), ``rot`` (F, 3, 3)) kept over the
    footprint it leaves (reaches) where, just after the liftoff (before the strike), the
    ground would need it lifted faster than ``LIFT_RATE`` off a footprint
    (``_lift_cone``): a toe swept into the next riser as the foot leaves a tread, a heel
    still over the landing as it steps down, a clip's foot reaching past its footprint
    and settling back. There the foot's place over the ground and its turn are drawn
    towards the nearer planted frame's, by the least share of ``HOME_SHARES`` that lets
    the lift keep to the cone and keeps the ankle (so lifted) within ``reach`` of the
    ``hip`` (F, 3) (else the largest that keeps it in reach: a foot held back while the
    body climbs on would straighten its knee); the draw eases out at ``HOME_RATE`` per
    frame and is gone by the swing's middle (where the footprint it is drawn to
    changes). The foot rises off (comes down onto) its footprint before it goes on. Its
    height is kept (the lift does the rest). Unchanged elsewhere, and without
    ``ground_z``."""
    return _kept_over_footprints_need(ankle, rot, planted, sole, planes, ground_z, fps, hip, reach)[:2]


def _kept_over_footprints_need(ankle: np.ndarray, rot: np.ndarray, planted: np.ndarray, sole: list, planes,
                               ground_z, fps: float = DEFAULT_FPS, hip: np.ndarray | None = None,
                               reach: float = np.inf):
    """``_kept_over_footprints``, and the lift its targets need at the free frames
    (``_lift_need``) when it measured that of the targets it returns (None else): the
    ground then is not asked twice (``_ground_lift``'s ``need``)."""
    free = np.flatnonzero(~planted)
    if ground_z is None or planes is None or not len(free) or not planted.any():
        return ankle, rot, None
    F = len(planted)
    f = np.arange(F)
    prev, nxt = planted_either_side(planted)
    x = (f - prev) / np.maximum(nxt - prev, 1)
    home = np.where((prev >= 0) & ((x <= 0.5) | (nxt >= F)), prev, nxt)
    # the draw is gone by the middle of a swing between two footprints
    cap = np.where((prev >= 0) & (nxt < F), np.clip(4.0 * np.abs(x - 0.5), 0.0, 1.0), 1.0)
    key = Rotation.from_matrix(rot[home], assume_valid=True)  # (rigid: see swing_targets)
    cone = _lift_cone(planted)
    pull = np.zeros(F)
    out_a, out_r = ankle, rot
    for _ in range(HOME_PASSES):  # each pass checks the eased draw of the one before
        need = _lift_need(out_a, out_r, free, sole, planes, ground_z, fps)
        over = free[need > cone[free] + CLEARANCE_TOL]
        if not len(over):
            return out_a, out_r, need
        want = pull[over].copy()
        done = np.zeros(len(over), bool)
        for s in HOME_SHARES:  # a handful of trial shares, each over every flagged frame at once
            share = np.maximum(pull[over], s)
            trial_a, trial_r = ankle.copy(), rot.copy()
            trial_a[over], trial_r[over] = _towards(ankle[over], rot[over], ankle[home[over]], key[over], share)
            near = np.ones(len(over), bool) if hip is None else \
                np.linalg.norm(trial_a[over] + cone[over, None] * [0.0, 0.0, 1.0] - hip[over], axis=1) <= reach
            ok = (_lift_need(trial_a, trial_r, over, sole, planes, ground_z, fps) <= cone[over] + CLEARANCE_TOL)
            want[~done & near] = share[~done & near]
            done |= ok & near
        grown = pull.copy()
        grown[over] = np.maximum(pull[over], want)
        grown = np.minimum(ease_peaks(grown, HOME_RATE), cap)
        grown[planted] = 0.0
        if np.allclose(grown, pull):  # (the targets the need was measured on)
            return out_a, out_r, need
        pull = grown
        moved = np.flatnonzero(pull > 0)
        out_a, out_r = ankle.copy(), rot.copy()
        out_a[moved], out_r[moved] = _towards(ankle[moved], rot[moved], ankle[home[moved]], key[moved], pull[moved])
    return out_a, out_r, None


def _towards(ankle: np.ndarray, rot: np.ndarray, to_a: np.ndarray, to_r: Rotation, share
             ) -> tuple[np.ndarray, np.ndarray]:
    """Ankle targets (n, 3) and foot rotations (n, 3, 3) drawn by ``share`` (scalar or
    (n,)) towards ``to_a`` (n, 3), ``to_r`` (n rotations) over the ground: the ankle's x
    and y, the rotation (slerp); the height kept."""
    s = np.broadcast_to(np.asarray(share, float), (len(ankle),))
    a = ankle.copy()
    a[:, :2] += s[:, None] * (to_a[:, :2] - a[:, :2])
    delta = (to_r * Rotation.from_matrix(rot, assume_valid=True).inv()).as_rotvec()
    return a, Rotation.from_rotvec(s[:, None] * delta).as_matrix() @ rot
