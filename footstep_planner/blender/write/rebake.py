"""Re-baking only the re-planned span: the old bake's keys are read before the new bake
replaces it, and the new bake's keys are spliced into them (``core.solve.splice``) so that
every frame outside the span (and a short blend either side) keeps its old key exactly.

A bake's action records its footprints' final places and the frames each foot strikes,
stands and lifts off there (``record``). A re-bake maps its footprints onto the old ones
through the re-planned region (from the first re-planned span's start to the last's
end, or to the goal), pins the footprints outside it to the old bake's places before its
IK, fades between the bakes only while the kept footprint's foot stands and the other
swings, and records its own for the next.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...core.solve.splice import SpanMap, splice_curve
from .keys import fill_keys

PLANTED = "footstep_planted_frames"  # per footprint: strike, stance, liftoff (scene frames)
FOOTPRINTS = "footstep_footprints"  # per footprint: x, y, z, heading (the feet's final places)

Channel = tuple[str, str, int]  # (slot identifier, data path, array index)


@dataclass
class Keys:
    """One F-Curve's keys: frames, values (both as stored, single precision) and
    interpolation per key."""

    frames: np.ndarray
    values: np.ndarray
    interpolation: np.ndarray

    @property
    def per_frame(self) -> bool:
        """One key on every whole frame from the first to the last."""
        f = self.frames
        return len(f) > 1 and np.array_equal(f, np.arange(f[0], f[0] + len(f), dtype=f.dtype))


def _read(fc) -> Keys:
    n = len(fc.keyframe_points)
    co = np.empty(2 * n, np.float32)
    fc.keyframe_points.foreach_get("co", co)
    interp = np.empty(n, np.int32)
    fc.keyframe_points.foreach_get("interpolation", interp)
    return Keys(co[0::2].copy(), co[1::2].copy(), interp)


def _channelbags(act):
    for layer in act.layers:
        for strip in layer.strips:
            yield from strip.channelbags


def channel_keys(act) -> dict[Channel, Keys]:
    """Every F-Curve of a (slotted) action, by slot, path and index."""
    return {(cb.slot.identifier, fc.data_path, fc.array_index): _read(fc) for cb in _channelbags(act)
            for fc in cb.fcurves}


def splice_action(act, old: dict[Channel, Keys], span: SpanMap) -> int:
    """Splice ``act``'s keys (the new bake) into the ``old`` bake's, channel by channel
    (those keyed on every frame in both); returns how many channels were spliced."""
    n = 0
    for cb in _channelbags(act):
        for fc in cb.fcurves:
            before = old.get((cb.slot.identifier, fc.data_path, fc.array_index))
            new = _read(fc)
            if before is None or not before.per_frame or not new.per_frame:
                continue
            frames, values = splice_curve(int(before.frames[0]), before.values, int(new.frames[0]), new.values,
                                          span)
            fill_keys(fc, frames, values, int(new.interpolation[len(new.interpolation) // 2]))
            n += 1
    return n


def fit_strips(ob, act) -> None:
    """The planner's NLA strips playing ``act`` cover its keys again after a splice."""
    lo, hi = (float(v) for v in act.frame_range)
    for track in ob.animation_data.nla_tracks:
        for strip in track.strips:
            if strip.action == act:
                strip.action_frame_start, strip.action_frame_end = lo, hi
                strip.frame_end = strip.frame_start + (hi - lo)


def record(act, planted, footprints, frame_start: int, fps: float) -> None:
    """Record on a bake's action its footprints' final places and the scene frames each
    foot strikes, stands and lifts off there (what a re-bake splices against)."""
    pos, head = footprints
    act[PLANTED] = [float(frame_start + t * fps) for row in planted for t in row]
    act[FOOTPRINTS] = [float(v) for p, h in zip(pos, head) for v in (*p[:3], h)]


def recorded(act) -> tuple[np.ndarray, np.ndarray] | None:
    """(planted frames (N, 3), footprints (N, 4)) a bake recorded, or None."""
    if act.get(PLANTED) is None or act.get(FOOTPRINTS) is None:
        return None
    return np.array(act[PLANTED], float).reshape(-1, 3), np.array(act[FOOTPRINTS], float).reshape(-1, 4)


__all__ = ["FOOTPRINTS", "PLANTED", "Keys", "channel_keys", "fit_strips", "record", "recorded",
           "splice_action"]
