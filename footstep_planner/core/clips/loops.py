"""Loops: clips one gait cycle (or one action) long, made to repeat (a Mixamo walk, a game
character's run), recognised and tiled so that the analysis reads them round their seam.

*Recognising* one (``find_loop``): its last pose matches its first. Files are made two
ways: the last frame duplicates the first (a period of N - 1 frames), or the last frame
is the one before the first (a period of N frames). The pose is compared by the bones'
rotations (the hips' taken relative to the root, so the heading does not count) and the
heel and toe points in the root's frame; the two ways are told apart by which seam error
is smaller: the first frame against the last (a duplicate), or the first against the
frame the clip would have next, continuing its own frame-to-frame change at both ends
(``_seam``). Either counts as a loop when its error is within ``SEAM_ROTATION`` (bones)
and ``SEAM_FEET`` (feet), or within ``SEAM_STEPS`` of the clip's own frame-to-frame change
there, whichever is more: the frames of a 24 fps clip change more than a capture's seam
mismatch, those of a 120 fps capture much less. The root repeats up to a planar rigid
motion: a travelling loop moves on by its displacement and turns by its heading change
once a period (``Loop.shift``, ``Loop.turn``).

*Tiling* (``tile``): ``copies`` periods of the loop end to end, each carried by the
period's rigid motion, so the root motion accumulates; the last sample closes the last
period. A seam that does not quite match (motion capture cut where it repeats best) would
make the feet jump at every seam of the tiled clip: the feet's horizontal mismatch there
(in the root's frame) is spread linearly over the period instead, half each way, as the
playback spreads the pose's (``tracks.ClipTrack.sample_pose``); their heights are
kept (a ramp would tilt a planted foot's flat stretch, where the analysis finds its
stance). The bones' rotations and the hips in the root frame are tiled as they are (the
analysis only compares them).

Times: the tiled clip's sample ``i`` is the loop's sample ``i mod period_frames``, at
the loop's rate; a time ``t`` of the tiled clip is ``t mod period`` in the loop's own
(``fold``). Never reads or changes Blender data.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from .clip import ClipMotion

#: rad: a loop's seam may mismatch by this mean bone rotation (the whole pose) ...
SEAM_ROTATION = np.radians(4.0)
#: ... and its feet (heel and toe points in the root's frame) by this, m (a human's:
#: times the clip's ``ClipMotion.body_scale``) ...
SEAM_FEET = 0.05
#: ... or by this many of the clip's own frame-to-frame changes at its ends, if more.
SEAM_STEPS = 1.0
#: A clip of fewer frames is never taken for a loop (its ends are its middle).
MIN_FRAMES = 6


@dataclass(frozen=True)
class Loop:
    """A loop found in a clip (``find_loop``)."""

    frames: int  # samples in one period: N - 1 when the last duplicates the first, else N
    period: float  # s, one period
    duplicate_end: bool  # the clip's last sample repeats its first
    rotation_error: float  # rad, mean bone rotation mismatch at the seam
    feet_error: float  # m, mean heel and toe mismatch at the seam (root frame)
    turn: float  # rad, the root's heading change over a period (+ left)
    shift: np.ndarray  # (2,) m, the root's move over a period, in its frame at the clip's start
    end_pos: np.ndarray  # (2,) the root's ground position one period after the clip's start
    end_heading: float  # rad, its heading there (unwrapped, as ``root_heading``)
    feet_seam: np.ndarray  # (2, 2, 3) m: (heel, toe) of each foot, the seam's jump (root frame)

    def to_dict(self, fps: float) -> dict:
        """The report's figures: period in frames and seconds, how the file closes, the
        seam errors (degrees, millimetres), the travel and turn per period."""
        return {"period_frames": self.frames, "period": round(self.period, 4),
                "last_frame": "repeats the first" if self.duplicate_end else "precedes the first",
                "seam_error_deg": round(float(np.degrees(self.rotation_error)), 2),
                "seam_feet_mm": round(1e3 * self.feet_error, 1),
                "travel": round(float(np.linalg.norm(self.shift)), 4),
                "turn_deg": round(float(np.degrees(self.turn)), 2), "fps": fps}


def _features(m: ClipMotion, idx: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(rotations (k, B, 3, 3): the bones', the hips' relative to the root; feet (k, 4, 3):
    heel and toe of each foot in the root's frame) at the clip's samples ``idx`` (k,)."""
    rot = np.array(m.local_rot[idx], dtype=np.float64)
    rot[:, m.hips_index] = m.hips_in_root[idx, :3, :3] / np.linalg.norm(
        m.hips_in_root[idx, :3, :3], axis=-2, keepdims=True)
    psi = m.root_heading[idx]
    pts = np.concatenate([m.heel[:, idx], m.toe[:, idx]], axis=0) - m.root_pos[idx][None]  # (4, k, 3)
    c, s = np.cos(psi), np.sin(psi)
    local = pts.copy()
    local[..., 0] = c * pts[..., 0] + s * pts[..., 1]
    local[..., 1] = -s * pts[..., 0] + c * pts[..., 1]
    return rot, local.swapaxes(0, 1)


def _rot_norm(d: np.ndarray) -> np.ndarray:
    """(...,) mean over the bones of ``d`` (..., B, 3, 3), a difference of rotation
    matrices, as an angle: |dR|_F / sqrt(2) is the angle for small ones."""
    return np.linalg.norm(d, axis=(-2, -1)).mean(axis=-1) / np.sqrt(2.0)


def _feet_norm(d: np.ndarray) -> np.ndarray:
    """(...,) mean over the four foot points of the length of ``d`` (..., 4, 3)."""
    return np.linalg.norm(d, axis=-1).mean(axis=-1)


def _seam(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(duplicate, next): the seam's mismatch of a feature ``x`` (8, ...) at the samples
    0, 1, 2, 3, N-4, N-3, N-2, N-1 if the last sample duplicates the first (first minus
    last), and if it precedes the first (first minus the sample the clip would have next:
    the last plus the mean of its frame-to-frame change before the last and after the
    first)."""
    first, last = x[0], x[7]
    nxt = last + 0.5 * ((x[7] - x[6]) + (x[1] - x[0]))
    return first - last, first - nxt


def find_loop(m: ClipMotion) -> Loop | None:
    """The loop ``m`` is (see the module's notes), or None: its last pose does not match
    its first, or it has fewer than ``MIN_FRAMES`` samples."""
    n = m.n
    if n < MIN_FRAMES:
        return None
    idx = np.array([0, 1, 2, 3, n - 4, n - 3, n - 2, n - 1])
    rot, feet = _features(m, idx)
    # the clip's own frame-to-frame change at its ends: the median of its three steps at each
    steps = [j for j in range(7) if j != 3]
    rot_step = float(np.median(_rot_norm(rot[[j + 1 for j in steps]] - rot[steps])))
    feet_step = float(np.median(_feet_norm(feet[[j + 1 for j in steps]] - feet[steps])))
    rd, rn = (float(_rot_norm(d)) for d in _seam(rot))
    fd_v, fn_v = _seam(feet)
    fd, fn = float(_feet_norm(fd_v)), float(_feet_norm(fn_v))
    tol_r = max(SEAM_ROTATION, SEAM_STEPS * rot_step)
    tol_f = max(SEAM_FEET * m.body_scale, SEAM_STEPS * feet_step)
    dup = rd / max(rot_step, 1e-9) + fd / max(feet_step, 1e-9) <= rn / max(rot_step, 1e-9) + fn / max(feet_step, 1e-9)
    r_err, f_err = (rd, fd) if dup else (rn, fn)
    if r_err > tol_r or f_err > tol_f:
        return None
    frames = n - 1 if dup else n
    end_pos, end_heading = _period_end(m, dup)
    c, s = np.cos(m.root_heading[0]), np.sin(m.root_heading[0])
    d = end_pos - m.root_pos[0, :2]
    return Loop(frames=frames, period=frames / m.fps, duplicate_end=bool(dup), rotation_error=r_err,
                feet_error=f_err, turn=float(end_heading - m.root_heading[0]),
                shift=np.array([c * d[0] + s * d[1], -s * d[0] + c * d[1]]), end_pos=end_pos,
                end_heading=float(end_heading), feet_seam=(fd_v if dup else fn_v).reshape(2, 2, 3))


def _period_end(m: ClipMotion, dup: bool) -> tuple[np.ndarray, float]:
    """(ground position (2,), heading) of the root one period after the clip's start: its
    last sample's (``dup``), else one step beyond it, the step the mean (in the root's
    frame) of the clip's last and first steps."""
    p, psi = m.root_pos[:, :2], m.root_heading
    if dup:
        return p[-1].copy(), float(psi[-1])

    def local(i: int) -> np.ndarray:
        c, s = np.cos(psi[i]), np.sin(psi[i])
        d = p[i + 1] - p[i]
        return np.array([c * d[0] + s * d[1], -s * d[0] + c * d[1]])

    step = 0.5 * (local(m.n - 2) + local(0))
    c, s = np.cos(psi[-1]), np.sin(psi[-1])
    turn = 0.5 * ((psi[-1] - psi[-2]) + (psi[1] - psi[0]))
    return p[-1] + np.array([c * step[0] - s * step[1], s * step[0] + c * step[1]]), float(psi[-1] + turn)


def tile(m: ClipMotion, loop: Loop, copies: int) -> ClipMotion:
    """``copies`` periods of loop ``m`` end to end plus the sample that closes the last
    (see the module's notes): copies * loop.frames + 1 samples at the clip's rate, its
    name, first frame and rest data; the root motion accumulated period by period."""
    P = loop.frames
    i = np.r_[np.tile(np.arange(P), copies), 0]
    c = np.r_[np.repeat(np.arange(copies), P), copies]
    phase = np.r_[np.tile(np.arange(P), copies), P] / P
    root = m.root_pos[i]
    psi = m.root_heading[i]
    # the feet's seam mismatch spread over each period, in the root's frame
    corr = (phase - 0.5)[None, None, :, None] * loop.feet_seam[:, :, None, :]  # (2 feet, heel/toe, n, 3)
    cs, sn = np.cos(psi), np.sin(psi)
    world = np.zeros_like(corr)  # (heights kept: a ramp would tilt a planted foot's flat stretch)
    world[..., 0] = cs * corr[..., 0] - sn * corr[..., 1]
    world[..., 1] = sn * corr[..., 0] + cs * corr[..., 1]
    base = replace(m, times=np.arange(len(i)) / m.fps, root_pos=root, root_heading=psi,
                   hips_in_root=m.hips_in_root[i], local_rot=m.local_rot[i],
                   heel=m.heel[:, i] + world[:, 0], toe=m.toe[:, i] + world[:, 1])
    yaw, shift = _copy_motions(m, loop, copies)
    return base.moved(yaw[c], shift[c])


def _copy_motions(m: ClipMotion, loop: Loop, copies: int) -> tuple[np.ndarray, np.ndarray]:
    """(yaw (copies + 1,), shift (copies + 1, 2)): the planar rigid motion that carries
    the loop's period 0 onto period k (``ClipMotion.moved``'s terms): x -> R(k turn)
    (x - p0) + q_k, q_k the root's position after k periods."""
    p0 = m.root_pos[0, :2]
    k = np.arange(copies + 1)
    yaw = k * loop.turn
    q = np.empty((copies + 1, 2))
    q[0] = p0
    ct, st = np.cos(loop.turn), np.sin(loop.turn)
    for j in range(copies):  # (a few periods)
        d = q[j] - p0
        q[j + 1] = np.array([ct * d[0] - st * d[1], st * d[0] + ct * d[1]]) + loop.end_pos
    c, s = np.cos(yaw), np.sin(yaw)
    shift = q - np.stack([c * p0[0] - s * p0[1], s * p0[0] + c * p0[1]], axis=1)
    return yaw, shift


def fold(t, loop: Loop):
    """Times ``t`` (s) of a tiled clip as times in the loop's own period, [0, period)."""
    return np.mod(np.asarray(t, float), loop.period)
