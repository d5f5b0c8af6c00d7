"""Writing keys: one home for F-Curve keys written whole (``fill_keys``) and the
interpolation constants. Every writer (the bake, the re-bake, Rigify's controls, imported
clips, the sample clips) keys through here.
"""

from __future__ import annotations

import numpy as np


#: Keyframe.interpolation enum values
CONSTANT, LINEAR = 0, 1


def fill_keys(fc, frames, values, interpolation: int = LINEAR) -> None:
    """Replace the keys of the F-Curve ``fc`` by one key per (frame, value), written whole
    with ``foreach_set`` (single precision, as Blender stores keys)."""
    kp = fc.keyframe_points
    if len(kp):
        kp.clear()
    n = len(frames)
    kp.add(n)
    co = np.empty(2 * n, np.float32)
    co[0::2], co[1::2] = frames, values
    kp.foreach_set("co", co)
    kp.foreach_set("interpolation", np.full(n, interpolation, np.int32))
    fc.update()


__all__ = ["CONSTANT", "LINEAR", "fill_keys"]
