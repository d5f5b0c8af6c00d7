"""The pose of every frame of a synthesis: the clips' bone rotations blended per frame
(``pose``), standing feet laid flat (``flat_feet``), then the feet pinned to the
footprints on the surface by the IK (``ik``): thesis 3.8, as ``solve``.

Reads: a ``Synthesis`` and the ``PlanSetup`` it was planned with. Returns: ``Solved`` (the
IK's per-frame bases and body, and the seconds each part took). Never imports bpy.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from ..base.settings import Settings
from ..base.timing import StageTimer, collection_paused
from ..clips.rig import Rig, forward_kinematics
from ..plan.setup import PlanSetup
from ..plan.surface import SupportLimits, footprint_support, ground_heights
from ..synth.pipeline import Synthesis
from .ik import IKResult, solve_ik
from .legs import body_frames
from .pose import blend_pose, pose_bases
from .targets import BodyMotion, FootPoints, Footprints
from .toes import toe_tip


@dataclass
class Solved:
    """The IK's result, with the seconds of the pose blend and of the IK."""

    ik: IKResult
    spin: float
    pose_seconds: float
    ik_seconds: float


def solved_world(rig: Rig, solved: Solved) -> np.ndarray:
    """(F, B, 4, 4) the bones' world matrices (metres) of the IK's result: what its bake
    plays (the body on the object, turned by the spin; the bones' bases under it)."""
    ik = solved.ik
    return body_frames(ik.body_pos, solved.spin + ik.body_heading)[:, None] @ forward_kinematics(rig, ik.basis)


def body_spin(forward, analyses) -> float:
    """World yaw of heading 0 minus the rig's rest forward's yaw: the armature object's
    yaw is this plus the body heading."""
    rest = analyses[0].motion.rest_forward
    return float(np.arctan2(forward[1], forward[0]) - np.arctan2(rest[1], rest[0]))


def walk_motion(analyses):
    """The clip whose heel and toe points stand for the character's (its first cycle)."""
    return next((a for a in analyses if a.kind == "cycle"), analyses[0]).motion


def flat_feet(rig: Rig, basis: np.ndarray, weight: np.ndarray, heel_local: np.ndarray,
              toe_local: np.ndarray) -> np.ndarray:
    """Pose bases (F, B, 4, 4) with each foot turned about its ankle, as far as ``weight``
    (F,) 0..1 (the standing clip's), until its heel and ball (``heel_local``, ``toe_local``
    (2, 4) in the foot bones' frames) lie level: a standing character stands on flat feet
    (the IK keeps a planted foot's own pitch)."""
    on = np.flatnonzero(np.asarray(weight) > 1e-6)
    if not len(on):
        return basis
    basis = np.array(basis, float, copy=True)
    feet = [rig.foot_chain(side)[0] for side in ("l", "r")]
    world = forward_kinematics(rig, basis[on], bones=feet)
    for k, f in enumerate(feet):
        W = world[:, f, :3, :3]
        d = W @ (np.asarray(toe_local[k][:3], float) - np.asarray(heel_local[k][:3], float))  # heel to ball
        level = d * [1.0, 1.0, 0.0]
        axis = np.cross(d, level)
        norm = np.linalg.norm(axis, axis=1, keepdims=True)
        axis = np.where(norm > 1e-12, axis / np.maximum(norm, 1e-12), [1.0, 0.0, 0.0])
        pitch = np.abs(np.arctan2(d[:, 2], np.linalg.norm(level, axis=1)))
        turn = Rotation.from_rotvec(axis * (pitch * weight[on])[:, None]).as_matrix()
        basis[on, f, :3, :3] = basis[on, f, :3, :3] @ (W.transpose(0, 2, 1) @ turn @ W)
    return basis


@collection_paused()
def solve(syn: Synthesis, setup: PlanSetup, settings: Settings) -> Solved:
    """Thesis 3.8: the clips' bone rotations blended per frame, then the feet pinned to
    the footprints (on the surface, along its normal) by the IK."""
    timer = StageTimer()
    walk = walk_motion(setup.analyses)
    with timer("pose_blend"):
        quat, hips = blend_pose(syn.posed_schedule(), syn.tracks)
        basis = flat_feet(setup.rig, pose_bases(setup.rig, quat, hips), syn.stand_weight(), walk.heel_local,
                          walk.toe_local)
    pl = setup.planner
    pos, head = syn.footprints
    sup = footprint_support(pl.ground, pl.obstacles, pos, head, setup.forward, pl.foot,
                            SupportLimits(clearance=pl.clearance))
    normal = np.where(np.isfinite(sup.normal), sup.normal, [0.0, 0.0, 1.0])
    spin = body_spin(setup.forward, setup.analyses)

    look = pl.settings.length(0.3)

    def ground_z(points):
        return ground_heights(pl.ground, np.asarray(points, float) + [0.0, 0.0, look], 2 * look)

    with timer("ik"):
        ik = solve_ik(setup.rig, basis, BodyMotion(syn.final.schedule.t, syn.body_position, syn.body_heading, spin),
                      FootPoints(walk.heel_local, walk.toe_local),
                      Footprints(syn.final.schedule.feet, syn.planted(), pos, head, normal), setup.forward,
                      settings.for_body(pl.settings.body_scale), ground_z=ground_z, still=syn.flat)
    return Solved(ik, spin, timer.seconds["pose_blend"], timer.seconds["ik"])


def toe_tips(rig: Rig, world: np.ndarray, heel_local: np.ndarray, toe_local: np.ndarray) -> np.ndarray:
    """(2, F, 3) each foot's toe tip in the world (``core.solve.toes.toe_tip``: the toe bone's end,
    bent as it is, or the mesh's tip) of bone matrices ``world`` (F, B, 4, 4)."""
    out = []
    for k, side in enumerate(("l", "r")):
        foot, toe = rig.foot_chain(side)
        local = toe_tip(rig, side, world[:, foot], world[:, toe] if toe is not None else None,
                        heel_local[k, :3], toe_local[k, :3])
        out.append(np.einsum("fij,fj->fi", world[:, foot, :3, :3], local) + world[:, foot, :3, 3])
    return np.stack(out)


__all__ = ["Solved", "body_spin", "flat_feet", "solve", "toe_tips", "walk_motion"]
