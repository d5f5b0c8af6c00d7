"""What a plan needs, gathered once: the ``Planner`` and the character's clips, library,
forward and rig (``PlanSetup``), the foot's rectangle from the clips (``foot_shape``) and
both feet standing side by side on the ground (``standing_footprints``).

Reads: the clip analyses, the rig, a ``Planner``. Returns: plain values. The Blender
layer reads the scene into these (``blender/planning.plan_setup``). Never imports bpy.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..clips.analysis import ClipAnalysis
from ..clips.library import Library
from ..clips.rig import Rig
from ..footprint import STAND_HALF_WIDTH, START_LABEL, PathFootprint
from .navgraph import PlanError, Planner
from .surface import FootShape

#: m of toes the foot's rectangle reaches ahead of the ball; a longer toe bone's tip is
#: ``FootShape.tip``.
TOE_ROOM = 0.07


@dataclass
class PlanSetup:
    planner: Planner
    analyses: list[ClipAnalysis]
    library: Library
    forward: np.ndarray  # world (x, y) of heading 0
    rig: Rig | None = None
    start: list | None = None  # the standing footprints the plan left from
    #: clip name -> ClipTrack of every clip of the library, made by the first synthesis that
    #: needs them (``perform.run.legs``) and kept for the next one of this setup (read only)
    tracks: dict | None = None


def foot_shape(analyses, rig: Rig | None = None, scale: float = 1.0) -> FootShape:
    """The foot's rectangle from the clips' heel and toe points (ball of the foot), with
    room for the heel behind the ankle and the toes ahead of the ball; with the ``rig``,
    the toe tip where its toe bones reach further (``FootShape.tip``: a long toe that
    must stay out of a riser). The room and the width are a human's times the body's
    ``scale`` (``Settings.body_scale``)."""
    lengths = [np.linalg.norm(f.toe[:2] - f.heel[:2]) for a in analyses for f in a.footprints()]
    half = 0.5 * float(np.median(lengths)) if lengths else 0.08 * scale
    toes = [float(np.linalg.norm(rig.tails[t] - rig.rest[t, :3, 3])) for t in
            (rig.foot_chain(side)[1] for side in "lr") if t is not None] if rig is not None else []
    room = TOE_ROOM * scale
    tip = half + max(toes) if toes and max(toes) > room else 0.0
    sole = getattr(rig, "sole", None)
    if sole is not None:  # (the mesh's own heel and toe tip: the rectangle is the foot's, and a little room)
        along = sole.ball - sole.heel
        reach = max(float(np.max(np.einsum("ki,ki->k", sole.tip - sole.ball, along)
                                  / np.maximum(np.linalg.norm(along, axis=1), 1e-9))), 0.0)
        front = min(reach, room)  # (the toes beyond that may hang over a nosing, going down: ``tip``)
        return FootShape(back=half + 0.01 * scale, front=half + front, half_width=0.05 * scale,
                         tip=half + reach if reach > room else 0.0, scale=scale)
    return FootShape(back=half + 0.04 * scale, front=half + room, half_width=0.05 * scale, tip=tip, scale=scale)


#: m: with ``Settings.straightens`` (the default) the least and most of the standing feet's
#: distance either side of the body (``footprint.STAND_HALF_WIDTH``) as the walk's stance
#: width sets it.
STAND_HALF_WIDTH_RANGE = (0.05, 0.15)


def check_size(ground, leg: float, what: str) -> None:
    """PlanError naming ``what`` (the character) when its legs, ``leg`` m long as its rig
    and object scale make them, are longer than the traversable surfaces of ``ground``
    span (their bounding box's larger side): a rig in centimetres (or another unit) under
    an object scale of 1 stands a hundred times a human's height over a human's scene,
    and every step would then miss the floor; the message says so, not that the start
    is off the floor."""
    verts = ground.mesh.verts[np.unique(ground.mesh.tris)] if len(ground.mesh.tris) else None
    if verts is None:
        return
    span = float(np.ptp(verts[:, :2], axis=0).max())
    if leg > span > 0.0:
        raise PlanError(
            f"{what} has legs {leg:.3g} m long, longer than the traversable surfaces span "
            f"({span:.3g} m): its size is wrong for this scene. If its rig is in centimetres "
            "(or another unit), scale its object to metres (0.01 for centimetres) or rescale "
            "the rig; else scale the scene to the character")


def standing_footprints(position, heading: float, setup: PlanSetup, what: str,
                        width: float | None = None) -> list[PathFootprint]:
    """Both feet side by side, ``width`` either side of ``position`` (3,), turned
    ``heading`` (the planner's frame), dropped onto the ground; PlanError naming ``what``
    when there is no traversable surface under a foot. The width is STAND_HALF_WIDTH,
    or with ``Settings.straightens`` (the default) half the walk's stance width
    (``StepSet.stance_width``, within STAND_HALF_WIDTH_RANGE) and each foot turned out as
    the walk turns it out (``StepSet.toe_out``): the first step then leaves straight, not
    askew, along the line through ``position``, not beside it."""
    ang = heading + np.arctan2(setup.forward[1], setup.forward[0])
    left = np.array([-np.sin(ang), np.cos(ang), 0.0])
    p = np.asarray(position, float)[:3]
    cfg = setup.planner.settings
    toe = setup.planner.steps.toe_out() if cfg.straightens else 0.0
    out = []
    width = _stand_width(setup) if width is None else width
    for k, sign in ((0, 1), (1, -1)):
        q = p + sign * width * left
        hit = setup.planner.ground.ray_down(np.array([[q[0], q[1], q[2] + cfg.length(0.5)]]), cfg.length(3.0))
        if not hit.hit[0]:
            raise PlanError(f"{what} stands at ({p[0]:.2f}, {p[1]:.2f}, {p[2]:.2f}), not above a traversable "
                            "surface: move it onto a traversable mesh, or pick a Start")
        out.append(PathFootprint(k, np.array([q[0], q[1], hit.z[0]]), heading + sign * toe, 0.0, START_LABEL, "walk"))
    return out


def _stand_width(setup: PlanSetup) -> float:
    """m either side of the middle a standing foot stands (``standing_footprints``)."""
    cfg = setup.planner.settings
    width = cfg.length(STAND_HALF_WIDTH)
    if cfg.straightens and setup.planner.steps.stance_width() > 0:
        lo, hi = (cfg.length(w) for w in STAND_HALF_WIDTH_RANGE)
        width = float(np.clip(0.5 * setup.planner.steps.stance_width(), lo, hi))
    return width


def standing_with(first: PathFootprint, setup: PlanSetup, what: str) -> list[PathFootprint]:
    """Both feet standing as ``standing_footprints`` stands them, one of them ``first``
    exactly (an edited plan's first footprint: it leaves from where its bake did, wherever
    the character's object stands now): the other beside it."""
    cfg = setup.planner.settings
    sign = 1.0 if first.foot == 0 else -1.0
    heading = first.heading - sign * (setup.planner.steps.toe_out() if cfg.straightens else 0.0)
    ang = heading + np.arctan2(setup.forward[1], setup.forward[0])
    left = np.array([-np.sin(ang), np.cos(ang), 0.0])
    pair = standing_footprints(np.asarray(first.position, float) - sign * _stand_width(setup) * left, heading,
                               setup, what)
    pair[first.foot] = first
    return pair


__all__ = ["STAND_HALF_WIDTH_RANGE", "TOE_ROOM", "PlanSetup", "check_size", "foot_shape",
           "standing_footprints", "standing_with"]
