"""The footprint vocabulary every stage shares: a planned footprint (``PathFootprint``),
the labels a path's own footprints carry besides the clips' names (``START_LABEL``,
``STAND_LABEL``, ``PIVOT``), and the standing pair (``STAND_HALF_WIDTH``, ``beside_position``).

The bottom of the core beside ``base``: it imports no stage, so the search, the synthesis
and the performance read one definition. Pure numpy, never bpy.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: The label of the first footprint of a searched path (where the character stands).
START_LABEL = "start"

#: The label of the standing foot a standing path begins with (``standing_path``).
STAND_LABEL = "stand"

#: The label of a pivot step (a footprint a turn in place sets down).
PIVOT = "pivot"

#: m: the feet of a standing character lie this far either side of its middle.
STAND_HALF_WIDTH = 0.1


@dataclass(frozen=True)
class PathFootprint:
    """A footprint of a planned path: the foot (0 left, 1 right) planted there, where and
    turned how, when, and the step (its clip, or blend) that carried the foot there."""

    foot: int  # 0 left, 1 right
    position: np.ndarray  # (3,) on the surface
    heading: float  # yaw relative to the rig's rest forward
    time: float  # s since the start
    label: str  # the clip (or "group@tau") that carried the foot here; "start" at first
    gait: str
    jump: bool = False
    # set square and whole on a stair's tread, or whole on a stepping stone, by the search: kept where planned
    tread: bool = False
    # the walk/run blend (0 walk, 1 run) the step to it is played at, where a jog laid it (``perform.stride``)
    speed: float | None = None


def beside_position(fp, foot: int, forward, width: float, stand=None, at: float = 0.0):
    """Where ``foot`` stands beside footprint ``fp`` (the other foot): where the standing
    clip ``stand`` puts it (its feet's heel/toe midpoints at clip time ``at``: its start
    by default), turned to ``fp``'s heading; without one ``width`` m to its side."""
    ang = fp.heading + np.arctan2(forward[1], forward[0])
    if stand is not None:
        smp = stand.sample(np.array([at]))
        mid = 0.5 * (smp["heel"][:, 0] + smp["toe"][:, 0])  # (2, 3) root frame
        d = mid[foot] - mid[1 - foot]
        c = ang - np.arctan2(stand.rest_forward[1], stand.rest_forward[0])
        if np.hypot(d[0], d[1]) > 0.5 * width:
            return np.asarray(fp.position, float) + [np.cos(c) * d[0] - np.sin(c) * d[1],
                                                     np.sin(c) * d[0] + np.cos(c) * d[1], 0.0]
    left = np.array([-np.sin(ang), np.cos(ang), 0.0])
    sign = 1.0 if foot == 0 else -1.0
    return sign * width * left + np.asarray(fp.position, float)


__all__ = ["PIVOT", "STAND_LABEL", "STAND_HALF_WIDTH", "START_LABEL", "PathFootprint", "beside_position"]


@dataclass(frozen=True, eq=False)
class Leg:
    """What a leg's ends are, as a synthesis plays a path (``pipeline.synthesize``): where
    it ends, whether it starts and stops from standing, and how long it stands there.

    ``goal``: (2,) or (3,) world m, where the body ends (the path's end is eased onto it),
    None to end where the path does. ``goal_heading``: rad from the world forward, the
    heading the last two (standing) feet face, None for the path's own. ``standing``: the
    character starts from standing on the path's first footprint and stops to standing.
    ``start_other``: the other standing foot at the start (a ``PathFootprint``), None for
    one beside the first. ``pace``: a number, or one per step of the path, by which the
    walking steps are played faster (None: 1). ``lead`` and ``hold``: s of standing before
    the first step and after the last (None: the settings')."""

    goal: np.ndarray | None = None
    goal_heading: float | None = None
    standing: bool = False
    start_other: PathFootprint | None = None
    pace: object = None
    lead: float | None = None
    hold: float | None = None
