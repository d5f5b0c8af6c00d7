"""Writing keys: one home for making F-Curves in a slotted action's channel bag
(``new_fcurve``, the same on Blender 4.5 LTS and 5.x), writing their keys whole
(``fill_keys``) and the interpolation constants. Every writer (the bake, the re-bake,
Rigify's controls, imported clips, the sample clips, the tests) keys through here.

Blender 5.0 gave ``ActionChannelbagFCurves.new`` a ``group_name`` argument; on 4.5 it
takes the data path and the array index only, and a curve is put into its channel group
afterwards (the group made in the channel bag when it is not there yet).
"""

from __future__ import annotations

import bpy
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


def _new_takes_group() -> bool:
    """Whether this Blender's ``ActionChannelbagFCurves.new`` takes ``group_name`` (5.0+)."""
    fn = bpy.types.ActionChannelbagFCurves.bl_rna.functions["new"]
    return "group_name" in fn.parameters.keys()


#: True on Blender 5.0 and later, False on 4.4 and 4.5 (read once: the API is fixed per build)
NEW_TAKES_GROUP = _new_takes_group()


def channel_group(cbag, name: str):
    """Channel group ``name`` of channel bag ``cbag``, made when it has none of that name."""
    for g in cbag.groups:
        if g.name == name:
            return g
    return cbag.groups.new(name)


def new_fcurve(cbag, data_path: str, index: int = 0, group: str | None = None):
    """A new F-Curve ``data_path[index]`` in channel bag ``cbag``, in channel group
    ``group`` (made when missing; None or "" for no group). Raises RuntimeError, as
    Blender does, when that curve already exists."""
    if NEW_TAKES_GROUP:
        if group:
            return cbag.fcurves.new(data_path, index=index, group_name=group)
        return cbag.fcurves.new(data_path, index=index)
    fc = cbag.fcurves.new(data_path, index=index)
    if group:
        fc.group = channel_group(cbag, group)
    return fc


__all__ = ["CONSTANT", "LINEAR", "NEW_TAKES_GROUP", "channel_group", "fill_keys", "new_fcurve"]
