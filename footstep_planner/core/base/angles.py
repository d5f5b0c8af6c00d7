"""Angles: the one ``wrap`` and the one ``yaw`` of the package.

A heading is a yaw in radians about +Z, counter-clockwise, measured from the rig's forward
direction (the planner's frame); ``yaw(forward)`` is the world yaw of that forward, so a
heading h faces the world yaw h + yaw(forward).
"""

from __future__ import annotations

import numpy as np


def wrap(a):
    """Angle(s) ``a`` (rad, scalar or array) wrapped to [-pi, pi), as float64."""
    return (np.asarray(a, dtype=float) + np.pi) % (2.0 * np.pi) - np.pi


def yaw(forward) -> float:
    """The world yaw (rad, about +Z from +X) of a direction ``forward`` (x, y, ...)."""
    return float(np.arctan2(forward[1], forward[0]))


__all__ = ["wrap", "yaw"]
