"""Synthetic gaits with a known truth, for testing the clip analysis.

``synthetic_gait`` builds a :class:`ClipMotion` directly (numpy only, no rig, no Blender):
a body moving at constant speed along a circular arc (or a straight line) and two feet
that alternate between fixed footprints, with a smooth swing and a little heel-toe roll.
It returns the clip and a ``truth`` dict with what the analysis should find.

Conventions are those of ``footstep_planner.core.clips.clip``: Z up, metres, seconds; heading
is the yaw about +Z relative to ``rest_forward`` = (0, -1), positive turned left; the
character's left is +X at heading 0. Foot 0 is the left foot.

Timing of one foot's stance (truth)::

    strike   heel touches down (the horizontal swing ends here)
    land     toe touches down          = strike + roll
    lift     heel leaves the ground    = liftoff - roll
    liftoff  toe leaves (the horizontal swing starts here)

Outside its airborne interval a point's height is exactly 0 (plus optional noise).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from footstep_planner.core.clips.clip import ClipMotion

REST_FORWARD = np.array([0.0, -1.0])


def _bump(u: np.ndarray) -> np.ndarray:
    """A smooth hump on [0, 1]: 0 with zero slope at both ends, 1 in the middle."""
    return 0.5 * (1.0 - np.cos(2.0 * np.pi * np.clip(u, 0.0, 1.0)))


def _ease(u: np.ndarray) -> np.ndarray:
    """Cosine ease 0 -> 1 on [0, 1] (zero velocity at both ends)."""
    return 0.5 * (1.0 - np.cos(np.pi * np.clip(u, 0.0, 1.0)))


def _dir(heading: np.ndarray) -> np.ndarray:
    """(…, 2) horizontal forward direction at absolute heading (rest forward -Y)."""
    heading = np.asarray(heading, dtype=float)
    return np.stack([np.sin(heading), -np.cos(heading)], axis=-1)


def _left(heading: np.ndarray) -> np.ndarray:
    """(…, 2) the character's left at absolute heading (+X at heading 0)."""
    heading = np.asarray(heading, dtype=float)
    return np.stack([np.cos(heading), np.sin(heading)], axis=-1)


def _wrap(a):
    return (np.asarray(a) + np.pi) % (2 * np.pi) - np.pi


class _Path:
    """Arc of signed curvature ``kappa`` through the origin heading along -Y, then rotated
    by ``rotation`` about Z and shifted by ``offset``. Defined for any arc length s."""

    def __init__(self, kappa: float, rotation: float, offset):
        self.k = float(kappa)
        self.rot = float(rotation)
        self.off = np.asarray(offset, dtype=float).reshape(2)
        c, s = np.cos(self.rot), np.sin(self.rot)
        self.R = np.array([[c, -s], [s, c]])

    def heading(self, s):
        return self.rot + self.k * np.asarray(s, dtype=float)

    def point(self, s) -> np.ndarray:
        s = np.asarray(s, dtype=float)
        k = self.k
        if abs(k) < 1e-12:
            local = np.stack([0.5 * k * s * s, -s], axis=-1)
        else:
            local = np.stack([(1.0 - np.cos(k * s)) / k, -np.sin(k * s) / k], axis=-1)
        return local @ self.R.T + self.off


def synthetic_gait(speed=1.2, stride=1.4, curvature=0.0, duty=0.62, fps=120.0, cycles=4,
                   step_height=0.15, foot_length=0.22, width=0.18, rotation=0.0,
                   offset=(0.0, 0.0), start_still=0.0, end_still=0.0, name="synth",
                   noise=0.0, hnoise=0.0, seed=0, roll=0.06, toe_height=None):
    """A synthetic two-footed gait and its truth.

    speed        m/s of the body along its path; stride: m the body travels per cycle.
    curvature    signed 1/m of the path, positive turning left (0 = straight).
    duty         share of the cycle each foot bears weight (> 0.5 walk, < 0.5 run).
    cycles       gait cycles of motion (may be fractional).
    rotation, offset   a rigid motion of the whole clip (radians about Z, metres in XY).
    start_still, end_still   s of standing (both feet down, body still) before / after.
    noise, hnoise   std of Gaussian noise (m) added to the heel/toe heights / horizontals.
    roll         s between heel and toe events (heel rises first, lands first).
    toe_height   the toe's swing height (default: step_height).

    Returns (ClipMotion, truth); truth holds "stances" (per foot, in time order, each a
    dict strike/land/lift/liftoff/time/position/heading/heel/toe/open_start/open_end),
    "footprints" (all stances sorted by time), "flights", "T"/"cycle", "stride" (median
    same-foot footprint distance), "path_stride", "speed", "curvature", "gait", "duty",
    "t_move" (start, end of the body's motion) and "duration".
    """
    speed, stride, duty, fps = float(speed), float(stride), float(duty), float(fps)
    assert speed > 0 and stride > 0 and 0 < duty < 1 and fps > 0
    T = stride / speed
    M = float(cycles) * T
    t0 = float(start_still)
    t1 = t0 + M
    D = t1 + float(end_still)
    L = speed * M
    n = int(np.floor(D * fps + 1e-9)) + 1
    t = np.arange(n) / fps
    path = _Path(curvature, rotation, offset)
    toe_height = step_height if toe_height is None else toe_height
    r = min(float(roll), 0.25 * duty * T)

    # --- body ------------------------------------------------------------------------
    s_body = speed * np.clip(t - t0, 0.0, M)
    root_pos = np.zeros((n, 3))
    root_pos[:, :2] = path.point(s_body)
    root_heading = path.heading(s_body)

    def s_print(c):
        s = speed * (c - t0)
        if start_still > 0:
            s = max(s, 0.0)
        if end_still > 0:
            s = min(s, L)
        return s

    # --- foot schedules --------------------------------------------------------------
    stances: list[list[dict]] = [[], []]
    i_lo = int(np.floor(-t0 / T)) - 3
    i_hi = int(np.ceil((D - t0) / T)) + 3
    for k in range(2):
        phase = 0.0 if k == 0 else 0.5
        raw = []
        for i in range(i_lo, i_hi + 1):
            c = t0 + (i + phase) * T
            raw.append({"time": c, "strike": c - 0.5 * duty * T,
                        "liftoff": c + 0.5 * duty * T, "s": s_print(c)})
        # stances on the same footprint (the still phases) merge into one
        merged = []
        for st in raw:
            if merged and abs(st["s"] - merged[-1]["s"]) < 1e-12:
                merged[-1]["liftoff"] = st["liftoff"]
                continue
            merged.append(dict(st))
        # the first step after the start still begins when the body starts to move;
        # the last step before the end still ends when it stops
        for a, b in zip(merged[:-1], merged[1:]):
            if start_still > 0 and a["liftoff"] < t0 < b["strike"]:
                a["liftoff"] = t0
            if end_still > 0 and a["liftoff"] < t1 < b["strike"]:
                b["strike"] = t1
        for st in merged:
            h = float(path.heading(st["s"]))
            centre = path.point(st["s"]) + (0.5 * width if k == 0 else -0.5 * width) * _left(h)
            d = _dir(h)
            st["heading_abs"] = h
            st["position"] = np.array([centre[0], centre[1], 0.0])
            st["heel"] = np.array([*(centre - 0.5 * foot_length * d), 0.0])
            st["toe"] = np.array([*(centre + 0.5 * foot_length * d), 0.0])
            st["land"] = st["strike"] + r
            st["lift"] = st["liftoff"] - r
        stances[k] = merged

    # --- foot curves -----------------------------------------------------------------
    heel = np.zeros((2, n, 3))
    toe = np.zeros((2, n, 3))
    for k in range(2):
        sts = stances[k]
        centre = np.full((n, 2), np.nan)
        head = np.full(n, np.nan)
        hh = np.zeros(n)
        ht = np.zeros(n)
        for st in sts:
            m = (t >= st["strike"]) & (t <= st["liftoff"])
            centre[m] = st["position"][:2]
            head[m] = st["heading_abs"]
        for a, b in zip(sts[:-1], sts[1:]):
            ta, tb = a["liftoff"], b["strike"]
            m = (t > ta) & (t < tb)
            w = _ease((t[m] - ta) / (tb - ta))[:, None]
            centre[m] = (1 - w) * a["position"][:2] + w * b["position"][:2]
            head[m] = a["heading_abs"] + w[:, 0] * (b["heading_abs"] - a["heading_abs"])
            # heel airborne (ta - r, tb), toe airborne (ta, tb + r)
            mh = (t > ta - r) & (t < tb)
            hh[mh] = step_height * _bump((t[mh] - (ta - r)) / (tb - ta + r))
            mt = (t > ta) & (t < tb + r)
            ht[mt] = toe_height * _bump((t[mt] - ta) / (tb - ta + r))
        assert np.isfinite(centre).all() and np.isfinite(head).all()
        d = _dir(head)
        heel[k, :, :2] = centre - 0.5 * foot_length * d
        toe[k, :, :2] = centre + 0.5 * foot_length * d
        heel[k, :, 2] = hh
        toe[k, :, 2] = ht
    if noise or hnoise:
        rng = np.random.default_rng(seed)
        for arr in (heel, toe):
            arr[..., 2] += rng.normal(0.0, noise, arr.shape[:2]) if noise else 0.0
            arr[..., :2] += rng.normal(0.0, hnoise, arr.shape[:2] + (2,)) if hnoise else 0.0

    motion = ClipMotion(
        name=name, fps=fps, frame0=1.0, times=t, root_pos=root_pos,
        root_heading=root_heading, hips_in_root=np.tile(np.eye(4), (n, 1, 1)),
        local_rot=np.tile(np.eye(3), (n, 1, 1, 1)),
        heel=heel, toe=toe,
        heel_local=np.array([[0.0, 0.0, 0.0, 1.0]] * 2),
        toe_local=np.array([[0.0, 0.1, 0.0, 1.0]] * 2),
        rest_forward=REST_FORWARD.copy(), hips_index=0,
    )

    # --- truth -----------------------------------------------------------------------
    out_stances: list[list[dict]] = [[], []]
    for k in range(2):
        for st in stances[k]:
            if st["liftoff"] < 0 or st["strike"] > D:
                continue
            out_stances[k].append({
                "foot": k, "time": st["time"], "strike": st["strike"], "land": st["land"],
                "lift": st["lift"], "liftoff": st["liftoff"],
                "open_start": st["strike"] <= 0.0, "open_end": st["liftoff"] >= D,
                "position": st["position"], "heading": float(_wrap(st["heading_abs"])),
                "heel": st["heel"], "toe": st["toe"],
            })
    dists = [float(np.linalg.norm(b["position"][:2] - a["position"][:2]))
             for k in range(2) for a, b in zip(out_stances[k][:-1], out_stances[k][1:])
             if abs(a["time"] - b["time"] - (-T)) < 1e-9]
    every = sorted(out_stances[0] + out_stances[1], key=lambda st: st["time"])
    flights = []
    end = None
    for st in sorted(every, key=lambda st: st["strike"]):
        if end is not None and st["strike"] > end and 0 < end and st["strike"] < D:
            flights.append((end, st["strike"]))
        end = st["liftoff"] if end is None else max(end, st["liftoff"])
    truth = {
        "stances": out_stances, "footprints": every, "flights": flights,
        "T": T, "cycle": T, "speed": speed, "curvature": float(curvature),
        "stride": float(np.median(dists)) if dists else None, "path_stride": stride,
        "gait": "walk" if duty > 0.5 else "run", "duty": duty, "roll": r,
        "t_move": (t0, t1), "duration": float(t[-1]),
    }
    return motion, truth


def mirror_clip(motion: ClipMotion, name: str | None = None) -> ClipMotion:
    """The clip mirrored in the plane x = 0 (which holds rest_forward = -Y): x -> -x,
    left and right feet swapped, headings negated."""
    assert abs(motion.rest_forward[0]) < 1e-12, "mirror_clip assumes rest_forward along Y"
    flip = np.array([-1.0, 1.0, 1.0])
    return replace(
        motion, name=name or motion.name,
        root_pos=motion.root_pos * flip, root_heading=-motion.root_heading,
        heel=(motion.heel * flip)[::-1].copy(), toe=(motion.toe * flip)[::-1].copy(),
        heel_local=motion.heel_local[::-1].copy(), toe_local=motion.toe_local[::-1].copy(),
    )


def raise_feet(motion: ClipMotion, dz: float) -> ClipMotion:
    """The clip with every heel and toe ``dz`` metres higher."""
    up = np.array([0.0, 0.0, dz])
    return replace(motion, heel=motion.heel + up, toe=motion.toe + up)
