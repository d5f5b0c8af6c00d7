"""Quality figures of a baked walk, measured on the baked armature.

The caller evaluates the armature in Blender and passes plain arrays; this module only
measures what an animator would judge: feet that slide, float or sink, footprints and a
goal missed, and pops (sudden frame-to-frame jumps of a bone).

Conventions: Blender world, Z up, metres; frames are indices 0..F-1 at a constant rate.
Foot index 0 is the left foot, 1 the right. Headings are yaw radians about +Z, positive
counter-clockwise. Figures are reported in millimetres where the key ends in ``_mm``,
degrees where it ends in ``_deg`` and metres where it ends in ``_m``.

Inputs:

``heel``, ``toe``
    (2, F, 3) world positions of each foot's heel and toe (ball) points per frame.
``stances``
    a list of dicts, one per planned footprint: ``foot`` (0 | 1), ``start`` (frame of
    strike), ``end`` (frame of liftoff, inclusive), ``stance`` (frame of the stance),
    ``position`` ((3,) desired heel/toe midpoint on the surface, m), ``heading`` (desired
    yaw, rad). Frame indices are clipped to 0..F-1 here as well.
``ground_z``
    (2, F, 2) surface height (m) under the heel (last index 0) and toe (1) of each foot
    per frame; NaN where there is no surface (a gap): such samples are ignored.
``bone_pos``, ``bone_rot``
    (F, B, 3) world positions of the bone heads, (F, B, 4) local rotations relative to
    rest as quaternions (w, x, y, z); the angle measure does not depend on the order.
``body_pos``, ``body_heading``
    (F, 3) and (F,): the character's body frame per frame.

The contact point of a foot (after Johansen 2008) is, per frame, whichever of its heel
and toe is lower (the heel on a tie). The *planted window* of a stance runs from the
first to the last frame in [start, end] at which the contact point is within
``planted_height`` of its lowest height in that stance.

An empty stance list gives an empty per-stance list and 0.0 for the aggregates; a stance
that cannot be measured (non-finite positions, no ground under it) is None in a
per-stance list and left out of the aggregates. Non-finite samples are ignored. Inputs
are never modified. Every function returns plain Python numbers (``quality`` rounds them
and is ready for ``json.dumps``).
"""

from __future__ import annotations

from typing import Mapping, Sequence

import numpy as np

from ..base import quat as quaternions
from ..base.angles import wrap

#: Decimal places of the floats ``quality`` returns (mm to the micrometre, m to the mm).
DIGITS = 3

Stances = Sequence[Mapping]


def _feet(heel, toe) -> tuple[np.ndarray, np.ndarray]:
    h = np.asarray(heel, dtype=float)
    t = np.asarray(toe, dtype=float)
    if h.ndim != 3 or h.shape[0] != 2 or h.shape[2] != 3 or t.shape != h.shape:
        raise ValueError("heel and toe must both be (2, F, 3) arrays")
    return h, t


def _stance(stance: Mapping, n_frames: int) -> tuple[int, int, int]:
    """(foot, start, end) of one stance dict, frames clipped to 0..F-1."""
    foot = int(stance["foot"])
    if foot not in (0, 1):
        raise ValueError(f"stance foot must be 0 or 1, not {stance['foot']!r}")
    hi = max(n_frames - 1, 0)
    start = min(max(int(stance["start"]), 0), hi)
    end = min(max(int(stance["end"]), 0), hi)
    return foot, start, end


def _summary(values: list) -> tuple[float, float]:
    """(mean, max) of the finite entries (None skipped); (0.0, 0.0) when there are none."""
    v = np.array([x for x in values if x is not None], dtype=float)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return 0.0, 0.0
    return float(v.mean()), float(v.max())


def _num(x) -> float | None:
    return float(x) if np.isfinite(x) else None


def contact_point(heel, toe) -> tuple[np.ndarray, np.ndarray]:
    """Per foot and frame the lower of heel and toe (the heel on a tie or when the toe
    height is not finite). Returns (points (2, F, 3) m, which (2, F) int: 0 heel, 1 toe)."""
    h, t = _feet(heel, toe)
    which = (t[..., 2] < h[..., 2]).astype(int)
    point = np.where(which[..., None] == 1, t, h)
    return point, which


def planted_window(point_z, start: int, end: int, planted_height: float = 0.02) -> tuple[int, int] | None:
    """The planted window of one stance: the first and last frame (inclusive) in
    [start, end] at which ``point_z`` (F,) (contact-point height, m) is within
    ``planted_height`` (m) of its lowest finite value there. None when the stance is
    empty or has no finite height."""
    if end < start:
        return None
    z = np.asarray(point_z, dtype=float)[start:end + 1]
    ok = np.isfinite(z)
    if not ok.any():
        return None
    low = z[ok].min()
    idx = np.flatnonzero(ok & (z <= low + planted_height))
    return start + int(idx[0]), start + int(idx[-1])


def foot_skate(heel, toe, stances: Stances, planted_height: float = 0.02) -> dict:
    """Horizontal drift of the contact point over each stance's planted window (mm).

    Between consecutive frames of the window the horizontal distance the contact point
    travels counts only when the same point (heel or toe) is the contact at both frames:
    the jump of a heel-to-toe switch is a pivot, not a slide. Steps with non-finite
    positions are skipped. Returns ``{"per_stance_mm": [...], "mean_mm", "max_mm"}``;
    an empty window counts as 0.0."""
    h, t = _feet(heel, toe)
    point, which = contact_point(h, t)
    n = h.shape[1]
    # (2, F-1) horizontal step of the contact point where it is the same point at both ends
    step = np.linalg.norm(np.diff(point[..., :2], axis=1), axis=-1)
    keep = (which[:, 1:] == which[:, :-1]) & np.isfinite(step)
    step = np.where(keep, step, 0.0)
    run = np.concatenate([np.zeros((2, 1)), np.cumsum(step, axis=1)], axis=1)  # (2, F)
    per = []
    for stance in stances:
        foot, start, end = _stance(stance, n)
        win = planted_window(point[foot, :, 2], start, end, planted_height) if n else None
        per.append(0.0 if win is None else float(run[foot, win[1]] - run[foot, win[0]]) * 1000.0)
    mean, mx = _summary(per)
    return {"per_stance_mm": per, "mean_mm": mean, "max_mm": mx}


def footprint_error(heel, toe, stances: Stances) -> dict:
    """3-D distance (mm) of the heel/toe midpoint at each stance's ``stance`` frame from
    the desired ``position``. Returns ``{"per_stance_mm": [...], "mean_mm", "max_mm"}``."""
    h, t = _feet(heel, toe)
    n = h.shape[1]
    per = []
    for stance in stances:
        foot, _, _ = _stance(stance, n)
        if n == 0:
            per.append(None)
            continue
        k = min(max(int(stance["stance"]), 0), n - 1)
        mid = 0.5 * (h[foot, k] + t[foot, k])
        want = np.asarray(stance["position"], dtype=float).reshape(3)
        per.append(_num(np.linalg.norm(mid - want) * 1000.0))
    mean, mx = _summary(per)
    return {"per_stance_mm": per, "mean_mm": mean, "max_mm": mx}


def penetration(heel, toe, ground_z, tolerance: float = 0.005) -> dict:
    """How far heel and toe points go below the surface, over all frames.

    ``max_mm``: the deepest any heel or toe point is below its ``ground_z`` (positive mm,
    0.0 if never); ``frames_over_tolerance``: frames at which any of the four points is
    more than ``tolerance`` (m) below. NaN ground is ignored."""
    h, t = _feet(heel, toe)
    g = np.asarray(ground_z, dtype=float)
    if g.shape != h.shape[:2] + (2,):
        raise ValueError("ground_z must be (2, F, 2)")
    depth = g - np.stack([h[..., 2], t[..., 2]], axis=-1)  # (2, F, 2), positive below
    depth = np.where(np.isfinite(depth), depth, -np.inf)
    deepest = float(depth.max()) if depth.size else -np.inf
    frames = int(np.count_nonzero((depth > tolerance).any(axis=(0, 2))))
    return {"max_mm": max(deepest, 0.0) * 1000.0, "frames_over_tolerance": frames}


def floating(heel, toe, ground_z, stances: Stances, planted_height: float = 0.02) -> dict:
    """Height (mm) of the contact point above the ground under it (``ground_z`` of the
    chosen heel or toe) during each stance's planted window; per stance the median of the
    finite samples (signed: negative means the planted foot sinks). Returns
    ``{"mean_mm", "max_mm"}`` over the stances that have any ground sample."""
    h, t = _feet(heel, toe)
    g = np.asarray(ground_z, dtype=float)
    if g.shape != h.shape[:2] + (2,):
        raise ValueError("ground_z must be (2, F, 2)")
    point, which = contact_point(h, t)
    n = h.shape[1]
    under = np.take_along_axis(g, which[..., None], axis=-1)[..., 0]  # (2, F)
    lift = point[..., 2] - under
    per = []
    for stance in stances:
        foot, start, end = _stance(stance, n)
        win = planted_window(point[foot, :, 2], start, end, planted_height) if n else None
        if win is None:
            continue
        v = lift[foot, win[0]:win[1] + 1]
        v = v[np.isfinite(v)]
        if v.size:
            per.append(float(np.median(v)) * 1000.0)
    mean, mx = _summary(per)
    return {"mean_mm": mean, "max_mm": mx}


def goal_error(body_pos, body_heading, goal, goal_heading=None) -> dict:
    """Horizontal distance (m) from the last frame's body position to ``goal`` (3,), and
    the absolute heading error (deg, wrapped to [0, 180]) of the last frame's body heading
    from ``goal_heading`` (None without a goal heading). Both None without frames."""
    p = np.asarray(body_pos, dtype=float).reshape(-1, 3)
    hd = np.asarray(body_heading, dtype=float).reshape(-1)
    gp = np.asarray(goal, dtype=float).reshape(3)
    if len(p) == 0:
        return {"distance_m": None, "heading_deg": None}
    dist = _num(np.linalg.norm(p[-1, :2] - gp[:2]))
    head = None
    if goal_heading is not None and len(hd):
        head = _num(np.degrees(abs(wrap(hd[-1] - float(goal_heading)))))
    return {"distance_m": dist, "heading_deg": head}


def _argmax(v: np.ndarray) -> tuple[float, int | None, int | None]:
    """(max, frame of the later of the two frames, bone) of (F-1, B) changes; NaN ignored."""
    if v.size == 0:
        return 0.0, None, None
    w = np.where(np.isfinite(v), v, -np.inf)
    i = int(np.argmax(w))
    if not np.isfinite(w.flat[i]):
        return 0.0, None, None
    f, b = np.unravel_index(i, w.shape)
    return float(w.flat[i]), int(f) + 1, int(b)


def rotation_steps(bone_rot) -> np.ndarray:
    """(F-1, B) angle (rad, 0..pi) between consecutive local rotations of each bone
    ((F, B, 4) quaternions, normalised here; q and -q are the same rotation)."""
    q = np.asarray(bone_rot, dtype=float)
    with np.errstate(invalid="ignore", divide="ignore"):
        q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    a, b = q[:-1], quaternions.align(q[1:], q[:-1])
    # half the rotation angle between them is 2 atan2(|a - b|, |a + b|) (stable near 0)
    return 4.0 * np.arctan2(np.linalg.norm(a - b, axis=-1), np.linalg.norm(a + b, axis=-1))


def in_body_frame(bone_pos, body_pos, body_heading) -> np.ndarray:
    """(F, B, 3) bone heads relative to the body: minus the body position, turned by
    minus the body heading about +Z."""
    p = np.asarray(bone_pos, dtype=float)
    o = np.asarray(body_pos, dtype=float)
    hd = np.asarray(body_heading, dtype=float)
    d = p - o[:, None, :]
    c, s = np.cos(hd)[:, None], np.sin(hd)[:, None]
    return np.stack([c * d[..., 0] + s * d[..., 1], -s * d[..., 0] + c * d[..., 1], d[..., 2]],
                    axis=-1)


def pops(bone_pos, bone_rot, body_pos, body_heading) -> dict:
    """The largest frame-to-frame change of any bone.

    ``max_rotation_deg``: the largest angle between consecutive local rotations;
    ``max_offset_mm``: the largest move of a bone head in the body frame (its world
    motion minus the body's own translation and turn, see ``in_body_frame``). The bone
    index and the frame (the later frame of the pair) come with each; None (and 0.0)
    with fewer than two frames or no bones."""
    p = np.asarray(bone_pos, dtype=float)
    r = np.asarray(bone_rot, dtype=float)
    if p.ndim != 3 or p.shape[2] != 3 or r.shape != p.shape[:2] + (4,):
        raise ValueError("bone_pos must be (F, B, 3) and bone_rot (F, B, 4)")
    if np.shape(body_pos) != (p.shape[0], 3) or np.shape(body_heading) != (p.shape[0],):
        raise ValueError("body_pos must be (F, 3) and body_heading (F,)")
    rot, rot_f, rot_b = _argmax(rotation_steps(r))
    local = in_body_frame(p, body_pos, body_heading)
    off, off_f, off_b = _argmax(np.linalg.norm(np.diff(local, axis=0), axis=-1))
    return {"max_rotation_deg": float(np.degrees(rot)), "rotation_bone": rot_b,
            "rotation_frame": rot_f, "max_offset_mm": off * 1000.0, "offset_bone": off_b,
            "offset_frame": off_f}


def introduced_pops(bone_rot, allowance, margin_deg: float = 2.0) -> dict:
    """Pops the planner made, not the clips: frame-to-frame rotation steps of a bone
    larger than ``allowance`` (B,) radians, the largest step that bone takes in any
    source clip at the same frame rate, by more than ``margin_deg``. (Real capture has
    fast fingers and noisy ends; those are the clip's, and a transition or an IK
    correction that turns a bone faster than any clip does is the planner's.)"""
    steps = rotation_steps(bone_rot)
    if steps.size == 0:
        return {"count": 0, "max_excess_deg": 0.0, "bone": None, "frame": None}
    excess = steps - np.asarray(allowance, float)[None] - np.radians(margin_deg)
    bad = excess > 0
    worst, f, b = _argmax(np.where(bad, excess, 0.0))
    return {"count": int(bad.sum()), "max_excess_deg": float(np.degrees(worst)) if bad.any() else 0.0,
            "bone": b if bad.any() else None, "frame": f if bad.any() else None}


def _clean(x, digits: int = DIGITS):
    """JSON-ready copy: numpy scalars to Python, floats rounded, non-finite to None."""
    if isinstance(x, Mapping):
        return {str(k): _clean(v, digits) for k, v in x.items()}
    if isinstance(x, (list, tuple, np.ndarray)):
        return [_clean(v, digits) for v in x]
    if isinstance(x, (bool, np.bool_)):
        return bool(x)
    if isinstance(x, (int, np.integer)):
        return int(x)
    if isinstance(x, (float, np.floating)):
        return round(float(x), digits) if np.isfinite(x) else None
    return x


def quality(heel, toe, ground_z, stances: Stances, bone_pos, bone_rot, body_pos, body_heading,
            goal, goal_heading=None) -> dict:
    """All the figures in one JSON-ready dict (floats rounded to ``DIGITS`` places):
    ``frames``, ``stances``, ``foot_skate``, ``footprint_error``, ``penetration``,
    ``floating``, ``goal`` and ``pops``, each the dict of the function of that name
    (``goal`` is ``goal_error``)."""
    return _clean({
        "frames": int(np.shape(heel)[1]),
        "stances": len(stances),
        "foot_skate": foot_skate(heel, toe, stances),
        "footprint_error": footprint_error(heel, toe, stances),
        "penetration": penetration(heel, toe, ground_z),
        "floating": floating(heel, toe, ground_z, stances),
        "goal": goal_error(body_pos, body_heading, goal, goal_heading),
        "pops": pops(bone_pos, bone_rot, body_pos, body_heading),
    })
