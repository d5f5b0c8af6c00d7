"""Curves over the frames that the IK's parts (``ik``) share: the smoothstep, each frame's
planted frames either side, the frames' rate, and the envelopes a correction comes and
goes by (``ease_peaks``: the least one no steeper than a rate; ``lower_smoothly``: the
largest need nearby, smoothed).
"""

from __future__ import annotations

import numpy as np
from scipy.ndimage import gaussian_filter1d, maximum_filter1d

#: Frames per second assumed for a single frame (no spacing to measure).
DEFAULT_FPS = 30.0


def smoothstep(u: np.ndarray) -> np.ndarray:
    u = np.clip(u, 0.0, 1.0)
    return u * u * (3.0 - 2.0 * u)


def planted_either_side(planted: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(prev, nxt) (F,) each frame's last planted frame at or before it (-1 before the
    first) and first at or after it (F after the last), of a foot ``planted`` (F,)."""
    F = len(planted)
    f = np.arange(F)
    return (np.maximum.accumulate(np.where(planted, f, -1)),
            np.minimum.accumulate(np.where(planted, f, F)[::-1])[::-1])


def _frame_rate(t: np.ndarray) -> float:
    """Frames per second of the evenly spaced frame times ``t`` (F,) s; ``DEFAULT_FPS``
    for a single frame."""
    return 1.0 / (t[1] - t[0]) if len(t) > 1 else DEFAULT_FPS


def ease_peaks(v: np.ndarray, rate: float) -> np.ndarray:
    """(F,) the least envelope over ``v`` (F,) (>= 0) that changes by at most ``rate`` per
    frame: each peak comes and goes along a cone (a loop over the cone's half width, not
    over frames)."""
    out = np.array(v, float)
    if not out.any() or rate <= 0:
        return out
    for d in range(1, int(np.ceil(out.max() / rate)) + 1):
        out[d:] = np.maximum(out[d:], v[:-d] - rate * d)
        out[:-d] = np.maximum(out[:-d], v[d:] - rate * d)
    return out


def lower_smoothly(need: np.ndarray, win: int, mode: str = "reflect", edge: str = "reflect") -> np.ndarray:
    """(F,) a drop of the hips that covers ``need`` (F,) (m, >= 0) and comes and goes
    smoothly: the largest need within ``win`` frames either side, Gaussian-smoothed
    (sigma win / 2), never under the need itself. ``mode`` and ``edge`` are the maximum
    and the Gaussian filters' boundary modes ("wrap" for a loop)."""
    drop = gaussian_filter1d(maximum_filter1d(need, 2 * win + 1, mode=mode), max(win / 2.0, 0.5), mode=edge)
    return np.maximum(drop, need)
