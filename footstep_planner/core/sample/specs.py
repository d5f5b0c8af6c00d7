"""What the sample character's clips (``gait``) are made from: a gait's parameters
(``Gait``; the mannequin's ``WALK`` and ``RUN``), one clip of the library (``ClipSpec``:
a gait on a path, and what happens along it), and what generating it gives (``GaitStance``:
one foot's stance, ``GaitClip``: the pose bases and what they were made from).

Lengths m, times s, angles radians, at the mannequin's scale. Never imports bpy.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

SIDES = ("l", "r")


@dataclass(frozen=True)
class Gait:
    """The parameters of one gait (lengths m, times s, angles radians)."""

    name: str
    speed: float
    cycle: float  # two steps
    duty: float  # share of the cycle a foot is down
    passing: float  # share of the stance before the hips pass over the ankle
    width: float  # each footprint's distance from the path
    toe_out: float
    strike_pitch: float  # toes up at the strike
    toeoff_pitch: float  # heel up at toe off
    heel_rocker: float  # share of the stance pivoting on the heel
    toe_rocker: float  # share of the stance pivoting on the ball
    clearance: float  # the ankle's lift at mid swing
    height: float  # mean hips-head height
    bob: float  # its amplitude
    sway: float  # hips over the standing foot
    lean: float  # forward
    pelvis_yaw: float
    pelvis_roll: float
    arm_swing: float
    elbow: float  # mean elbow bend
    elbow_swing: float
    turn_lean: float = 1.0  # share of the centripetal lean (a walker leans less)


WALK = Gait("walk", speed=1.35, cycle=1.07, duty=0.61, passing=0.4, width=0.085, toe_out=np.radians(6),
            strike_pitch=np.radians(16), toeoff_pitch=np.radians(45), heel_rocker=0.16,
            toe_rocker=0.42, clearance=0.045, height=0.885, bob=0.02, sway=0.025,
            lean=np.radians(3), pelvis_yaw=np.radians(5), pelvis_roll=np.radians(3),
            arm_swing=np.radians(18), elbow=np.radians(18), elbow_swing=np.radians(10),
            turn_lean=0.5)
RUN = Gait("run", speed=3.2, cycle=0.73, duty=0.36, passing=0.32, width=0.055, toe_out=np.radians(3),
           strike_pitch=np.radians(6), toeoff_pitch=np.radians(38), heel_rocker=0.12,
           toe_rocker=0.5, clearance=0.16, height=0.82, bob=0.025, sway=0.012,
           lean=np.radians(9), pelvis_yaw=np.radians(7), pelvis_roll=np.radians(3),
           arm_swing=np.radians(32), elbow=np.radians(80), elbow_swing=np.radians(15))


@dataclass(frozen=True)
class ClipSpec:
    """One clip of the library: a gait on a path, and what happens along it."""

    name: str
    gait: Gait
    kind: str = "cycle"  # cycle, start, stop, idle or jump
    tau: float = 0.0  # path curvature, 1/m, positive left
    cycles: int = 2  # length of a cycle clip (it loops)
    jump_flight: float = 0.3  # jump: time in the air, s
    speed: float | None = None  # overrides the gait's
    lead: int = 0  # the foot whose stance comes first in the cycle (0 left, 1 right)

    @property
    def v(self) -> float:
        return self.speed if self.speed is not None else self.gait.speed


@dataclass
class GaitStance:
    """One stance of a foot in a generated clip: its times and (once placed) its
    footprint."""

    foot: int
    strike: float  # s; -inf when down at the clip's start
    liftoff: float  # s; +inf when still down at its end
    center: float  # s, the hips over the ankle
    pos: np.ndarray = field(default=None)  # (2,) heel ground point
    heading: float = 0.0
    clearance: float = 0.0  # the swing into this stance


@dataclass
class GaitClip:
    """A generated clip: pose bases and what it was made from."""

    spec: ClipSpec
    fps: float
    basis: np.ndarray  # (F, B, 4, 4)
    stances: list[GaitStance]
    hips_drop: np.ndarray  # (F,) m lowered to keep the legs in reach
