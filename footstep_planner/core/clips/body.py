"""The character's size: how many times a human's (``Settings.body_scale``), read from its rig.

Every length the planner names (its settings and the constants beside its code) is a
human's, for legs of ``settings.REFERENCE_LEG``; a character of another size is planned with
them scaled (``Settings.for_body``), and the IK, whose lengths are its own, solves a
character at a human's size and scales the result back (``scaled_rig``, ``scaled_bases``).
Reads a ``Rig``; returns numbers and scaled copies; never changes what it is given.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from .rig import Rig
from ..base.settings import REFERENCE_LEG

SIDES = ("l", "r")


def leg_length(rig: Rig) -> float:
    """m: the rest length of the longer leg, thigh head to knee to ankle (the heads of the
    thigh, the shin and the foot)."""
    out = 0.0
    for side in SIDES:
        heads = [rig.rest[rig.role_index(f"{part}_{side}"), :3, 3] for part in ("thigh", "shin", "foot")]
        out = max(out, float(np.linalg.norm(heads[1] - heads[0]) + np.linalg.norm(heads[2] - heads[1])))
    return out


#: A rig whose legs are within HUMAN_BAND (a share, either way) of REFERENCE_LEG is a human's
#: size: its scale is 1, so every human-sized character is planned with the lengths as they
#: were tuned (the search's paths hinge on them); beyond EXACT_BAND its scale is its own;
#: between, the one eases into the other (continuous in the rig's size).
HUMAN_BAND = 0.05
EXACT_BAND = 0.10


def body_scale(rig: Rig) -> float:
    """The rig's size over a human's: its leg length (``leg_length``) over REFERENCE_LEG,
    taken as 1 within HUMAN_BAND of it and eased into from there to EXACT_BAND."""
    return size_scale(leg_length(rig) / REFERENCE_LEG)


def size_scale(ratio: float) -> float:
    """The body scale of a rig whose legs are ``ratio`` times REFERENCE_LEG (see
    HUMAN_BAND): 1 near 1, ``ratio`` itself far from it, continuous between."""
    r = abs(float(np.log(ratio)))
    a, b = np.log1p(HUMAN_BAND), np.log1p(EXACT_BAND)
    eff = 0.0 if r <= a else r if r >= b else (r - a) * b / (b - a)
    return float(np.exp(np.sign(np.log(ratio)) * eff))


def scaled_rig(rig: Rig, k: float) -> Rig:
    """``rig`` made ``k`` times as big: every rest translation and tail times ``k`` (the
    bones' axes kept), so forward kinematics of bases whose translations are scaled alike
    (``scaled_bases``) gives every bone ``k`` times as far from the armature's origin."""
    rest = np.array(rig.rest, float, copy=True)
    rest[:, :3, 3] *= k
    rest_rel = np.array(rig.rest_rel, float, copy=True)
    rest_rel[:, :3, 3] *= k
    extra = {}
    if rig.armature_rest_rel is not None:
        own = np.array(rig.armature_rest_rel, float, copy=True)
        own[:, :3, 3] *= k
        extra["armature_rest_rel"] = own
    if rig.sole is not None:
        extra["sole"] = replace(rig.sole, heel=rig.sole.heel * k, ball=rig.sole.ball * k, tip=rig.sole.tip * k)
    return replace(rig, rest=rest, tails=np.asarray(rig.tails, float) * k, rest_rel=rest_rel, **extra)


def scaled_bases(basis: np.ndarray, k: float) -> np.ndarray:
    """Pose bases (..., 4, 4) with their translations times ``k`` (their rotations kept)."""
    out = np.array(basis, float, copy=True)
    out[..., :3, 3] *= k
    return out


def scaled_points(local: np.ndarray, k: float) -> np.ndarray:
    """Homogeneous points (..., 4) (or plain ones (..., 3)) with their coordinates times
    ``k`` (a homogeneous 1 kept)."""
    out = np.array(local, float, copy=True)
    out[..., :3] *= k
    return out
