"""The keys of an imported clip: its F-curves walked (``_fcurves``), the frames they key
(``_key_frames``), keys moved in time or value (``_retime``, ``_map_keys``), and new F-curves
written whole: a bone's rotation in its rotation mode (``_write_rotation``), one channel keyed,
or past ``SAMPLED_FRAMES`` kept as samples (``_curve``).
"""

from __future__ import annotations

import numpy as np

from ..write.keys import fill_keys, new_fcurve


def _fcurves(act):
    for layer in act.layers:
        for strip in layer.strips:
            for cb in strip.channelbags:
                yield cb, cb.fcurves


def _key_frames(act) -> np.ndarray:
    """Sorted distinct frames (rounded to 1e-6) keyed or sampled on any F-curve of
    ``act``."""
    frames = set()
    for _, curves in _fcurves(act):
        for fc in curves:
            points = fc.keyframe_points if len(fc.keyframe_points) else fc.sampled_points
            co = np.empty(len(points) * 2, np.float32)  # (as Blender holds them: read at once)
            points.foreach_get("co", co)
            frames.update(np.round(co[0::2], 6).tolist())
    return np.array(sorted(frames))


def _retime(act, keyed_fps: float, fps: float) -> None:
    """Move ``act``'s keys (keyed at ``keyed_fps`` frames per second) to the scene's
    ``fps``, the first key at frame 1."""
    first = min((fc.keyframe_points[0].co[0] for _, curves in _fcurves(act) for fc in curves
                 if len(fc.keyframe_points)), default=1.0)
    k = fps / keyed_fps
    for _, curves in _fcurves(act):
        for fc in curves:
            _map_keys(fc, lambda x, y: (1.0 + (x - first) * k, y))
    if act.use_frame_range:
        act.frame_start, act.frame_end = (1.0 + (f - first) * k for f in (act.frame_start, act.frame_end))


def _map_keys(fc, fn) -> None:
    """Replace each key (and handle) point (x, y) of F-curve ``fc`` by ``fn(x, y)``."""
    n = len(fc.keyframe_points)
    if not n:
        return
    for attr in ("co", "handle_left", "handle_right"):
        xy = np.empty(2 * n, np.float32)  # (single precision, as Blender holds keys: read and written at once)
        fc.keyframe_points.foreach_get(attr, xy)
        x, y = fn(xy[0::2].astype(np.float64), xy[1::2].astype(np.float64))
        xy[0::2], xy[1::2] = x, y
        fc.keyframe_points.foreach_set(attr, xy)
    fc.update()


def _write_rotation(cbag, base, group, mode, rot, frames):
    """Key ``rot`` (F rotations) at ``frames`` (F,) on the rotation channels of the pose
    bone at data path ``base`` in rotation mode ``mode``: quaternions (w first, signs
    kept continuous), axis-angle, or Euler angles (unwrapped) of that order."""
    if mode == "QUATERNION":
        q = rot.as_quat()[:, [3, 0, 1, 2]]
        flip = np.cumsum(np.r_[False, np.einsum("ij,ij->i", q[1:], q[:-1]) < 0]) % 2 == 1
        q[flip] *= -1
        for i in range(4):
            _curve(cbag, f"{base}.rotation_quaternion", i, group, frames, q[:, i])
    elif mode == "AXIS_ANGLE":
        rv = rot.as_rotvec()
        ang = np.linalg.norm(rv, axis=1)
        axis = np.where(ang[:, None] > 1e-12, rv / np.maximum(ang, 1e-12)[:, None], [0, 1, 0])
        vals = np.column_stack([ang, axis])
        for i in range(4):
            _curve(cbag, f"{base}.rotation_axis_angle", i, group, frames, vals[:, i])
    else:  # Euler 'XYZ' etc.: Blender's order is scipy's extrinsic lower-case order
        e = np.unwrap(rot.as_euler(mode.lower()), axis=0)
        for i in range(3):
            _curve(cbag, f"{base}.rotation_euler", i, group, frames, e[:, _euler_slot(mode, i)])


def _euler_slot(mode: str, axis: int) -> int:
    """Column of scipy's ``as_euler(mode.lower())`` that holds the angle about ``axis``."""
    return mode.lower().index("xyz"[axis])


#: A clip of more frames than this is kept as sampled F-curve points (Blender's baked
#: samples, one a scene frame: 16 bytes where a keyframe takes 72), so a 100,000 frame clip
#: of 31 joints takes 200 MB, not 900 (a channel that never changes: two keys). It plays and
#: analyses as the keys would; the Graph Editor's Channel > Samples to Keys makes keys to edit.
SAMPLED_FRAMES = 10_000


def _curve(cbag, path, index, group, frames, values):
    """A new F-curve ``path[index]`` in channel group ``group`` of ``cbag``, keyed
    ``values`` (F,) at ``frames`` (F,) with linear interpolation; past
    ``SAMPLED_FRAMES``, those keys sampled at every scene frame they span."""
    sampled = len(frames) > SAMPLED_FRAMES
    if sampled:  # the keys' line at the whole frames (they are those frames at the file's rate)
        whole = np.arange(np.ceil(frames[0] - 1e-6), np.floor(frames[-1] + 1e-6) + 1)
        frames, values = whole, np.interp(whole, frames, values).astype(np.float32)
        if values.min() == values.max():  # a still channel: two keys hold it
            sampled, frames, values = False, frames[[0, -1]], values[[0, -1]]
    fc = new_fcurve(cbag, path, index, group)
    fill_keys(fc, frames, values)
    if sampled:
        fc.convert_to_samples(int(frames[0]), int(frames[-1]) + 1)
