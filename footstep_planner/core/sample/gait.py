"""A parametric gait: the sample character's clip library, synthesized and solved with the
project's own IK.

Each clip is built the way a person moves, from the feet up:

1. **Path and timing.** The body travels along a straight line or an arc of curvature
   ``tau`` (1/m, positive turning left) at a speed that may ramp up from standing or down
   to it. Footfalls alternate at the gait's cadence; each foot is down for the gait's duty
   factor of the cycle (walking: both feet down in between; running: flight phases).
2. **Footprints** lie beside the path where the hips are at mid-stance, a step width
   apart, heading along the path (toes a little out).
3. **Feet.** A planted foot rolls: heel strike with the toes up, pivoting on the heel to
   flat, flat, then the heel rises and the foot pivots on its ball until toe off. The
   pivots are exact, so nothing slides. In between, the foot swings on a smooth
   path (smoothstep) with clearance, turning smoothly from its toe-off pose to its heel-strike pose.
4. **Body.** The hips bob (highest at mid-stance when walking, lowest when running), sway
   over the standing foot, rotate with the legs (the chest against them), lean forward
   with speed and into turns (the angle whose tangent is v^2 tau / g), and fly ballistic
   arcs in a jump. Where a leg could not reach its foot the hips are lowered, smoothly.
5. **Legs** are solved with ``ik.two_bone`` (closed form, knee forward), the feet take
   their planned rotations, and the arms swing against the legs.

The result is pose bases (F, B, 4, 4) for ``clip.clip_motion``: the same analysis and
planner then read it as they read motion capture. Conventions: armature space of the
mannequin (Z up, metres, rest forward -Y); heading 0 faces -Y; foot 0 is the left.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
from scipy.ndimage import gaussian_filter1d
from scipy.spatial.transform import Rotation

from ..clips.clip import root_frames
from ..base.errors import FootstepError
from ..solve.ik import chain_bases, leg_lengths, lower_smoothly, reach_need, smoothstep, two_bone
from ..clips.rig import Rig, forward_kinematics


class GaitError(FootstepError):
    """A rig the gait cannot be made for; the message names the armature and bones."""


#: The bones the gait poses by name (Blender's human metarig, Rigify's metarig): legs
#: and hips are required, spine and arms optional.
LEG_BONES = ("spine", "thigh.L", "shin.L", "foot.L", "toe.L", "thigh.R", "shin.R", "foot.R", "toe.R")


def require_metarig(rig: Rig) -> None:
    """Raise GaitError unless ``rig`` has the human metarig's hips and leg bones in those
    roles, with the feet flat on the ground in the rest pose (the gait's feet roll from
    there)."""
    missing = [b for b in LEG_BONES if b not in rig.names]
    roles = {"hips": "spine", "thigh_l": "thigh.L", "shin_l": "shin.L", "foot_l": "foot.L",
             "thigh_r": "thigh.R", "shin_r": "shin.R", "foot_r": "foot.R"}
    wrong = [f"{r} is {rig.roles.roles.get(r)!r}" for r, b in roles.items()
             if b in rig.names and rig.roles.roles.get(r) != b]
    if missing or wrong:
        raise GaitError(
            f"armature {rig.name!r}: the sample clips are made for rigs with the human metarig's "
            f"bone names (the Footstep Mannequin, Rigify's metarig); "
            + (f"it has no {', '.join(missing)}" if missing else f"its roles differ: {', '.join(wrong)}"))
    leg = sum(leg_lengths(rig, "l"))
    for side in "LR":
        foot, toe = rig.rest[rig.index(f"foot.{side}")], rig.rest[rig.index(f"toe.{side}")]
        ankle, ball = foot[2, 3], toe[2, 3]
        if not (abs(ball) < 0.07 * leg and ball < ankle) or abs(toe[2, 1]) > 0.5:
            raise GaitError(f"armature {rig.name!r}: foot.{side} does not stand flat in the rest pose "
                            f"(ankle at {ankle:.3f} m, ball at {ball:.3f} m, toe pointing "
                            f"{np.degrees(np.arcsin(np.clip(toe[2, 1], -1, 1))):+.0f} deg): the "
                            "sample clips need the feet on the ground at z = 0")

G = 9.81
SIDES = ("l", "r")
#: Hips-head height standing (m): the knees a little soft.
STAND_HEIGHT = 0.935
#: Height of the hip joints over the feet when leaning into a turn, m.
LEG_HEIGHT = 0.8
#: The legs are kept within this share of their length (the knee never locks).
REACH = 0.975
#: The back of the heel is this far behind the ankle, m.
HEEL_BACK = 0.045


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


def library_specs() -> list[ClipSpec]:
    """The sample character's library: walk forward and turning left and right at radii of
    0.8 m and 2.5 m, run forward and turning at 4 m, a running jump over 1.2 m, start from
    standing, stop to standing, idle. A right turn is the left turn's mirror image: it
    leads with the right foot."""
    out = [ClipSpec("walk", WALK)]
    for r, tag in ((2.5, "wide"), (0.8, "sharp")):
        for sign, side in ((1, "left"), (-1, "right")):
            # a sharp turn is walked a little slower
            out.append(ClipSpec(f"walk_turn_{side}_{tag}", WALK, tau=sign / r,
                                speed=WALK.speed * (0.93 if r < 1 else 1.0), lead=int(sign < 0)))
    out.append(ClipSpec("run", RUN, cycles=3))
    for sign, side in ((1, "left"), (-1, "right")):
        out.append(ClipSpec(f"run_turn_{side}", RUN, tau=sign / 4.0, cycles=3, speed=3.0, lead=int(sign < 0)))
    out += [ClipSpec("run_jump", RUN, kind="jump"), ClipSpec("walk_start", WALK, kind="start"),
            ClipSpec("walk_stop", WALK, kind="stop"), ClipSpec("idle", WALK, kind="idle")]
    return out


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


# ---------------------------------------------------------------------------- timing

#: s a start clip stands before setting off, and a stop clip after halting.
STAND_TIME = 0.5
#: s from standing to full speed (start clips) and from full speed to standing (stop).
SPEED_RAMP = 1.4
#: Cycles after setting off (start clip) before which each foot's last stance centred is
#: its standing stance, held from the clip's start.
START_STANDS = 0.45
#: Cycles before halting (stop clip) after which each foot's first stance centred is its
#: standing stance, held to the clip's end.
STOP_STANDS = 0.55
#: m the ankle lifts at mid swing in a start clip's first step of each foot (mannequin
#: scale): a step off standing, at walking pace only later, that lifts the foot no more
#: than the walk does is slow and low enough to read as a foot shuffled along the ground
#: (the analysis, as a viewer, tells a step from it by its lift).
FIRST_STEP_CLEARANCE = 0.1
#: s an idle clip lasts.
IDLE_DURATION = 2.4
#: A jump clip lasts this many cycles ...
JUMP_CYCLES = 3
#: ... and this many seconds more (the flight is longer than a running step's).
JUMP_EXTRA = 0.6
#: Cycles: the jump takes off from the first left stance centred after this.
TAKEOFF_AFTER = 1.2
#: m the ankle lifts at mid swing into the landing and the step after it (mannequin
#: scale; the gait's clearance elsewhere).
JUMP_CLEARANCE = 0.3
#: Share of the cycle at which the lead foot's first mid-stance falls (the other foot's
#: half a cycle later).
FIRST_CENTER = 0.25
#: Cycles of stances laid out before the clip's start and after its end (those that
#: touch the clip, and one either side per foot, are kept).
STANCE_MARGIN = 3


def _timeline(spec: ClipSpec, fps: float, size: float = 1.0):
    """(t (F,) s frame times from 0, v (F,) m/s speed along the path at them, the
    stances (time order, unplaced), T s the gait cycle rounded to whole frames so that
    a cycle clip loops). ``size`` scales the jump's clearance (leg length / the
    mannequin's)."""
    g = spec.gait
    T = round(g.cycle * fps) / fps
    D = g.duty * T
    if spec.kind == "idle":
        t = np.arange(round(IDLE_DURATION * fps) + 1) / fps
        return t, np.zeros(len(t)), [GaitStance(k, -np.inf, np.inf, 0.0) for k in range(2)], T
    if spec.kind == "cycle":
        dur = spec.cycles * T
    elif spec.kind in ("start", "stop"):
        dur = STAND_TIME + SPEED_RAMP + 2 * T + STAND_TIME
    else:  # jump
        dur = JUMP_CYCLES * T + JUMP_EXTRA
    t = np.arange(round(dur * fps) + 1) / fps
    dur = t[-1]
    stances = _steady_stances(spec, T, D, dur)
    v = np.full(len(t), spec.v)
    if spec.kind == "start":
        go = STAND_TIME  # standing until then, then SPEED_RAMP s to full speed
        v = spec.v * smoothstep((t - go) / SPEED_RAMP)
        stances = _stand_ends(stances, go + START_STANDS * T, start=True)
        for st in stances[2:4]:  # each foot's first step off its standing stance lifts clear
            st.clearance = max(st.clearance, FIRST_STEP_CLEARANCE * size)
    elif spec.kind == "stop":
        halt = dur - STAND_TIME  # full speed until SPEED_RAMP s before, standing after
        v = spec.v * (1.0 - smoothstep((t - (halt - SPEED_RAMP)) / SPEED_RAMP))
        stances = _stand_ends(stances, halt - STOP_STANDS * T, start=False)
    elif spec.kind == "jump":
        _jump_stances(stances, spec.jump_flight, T, D, size)
    # every stance that touches the clip, and the one before and after it for each foot
    # (the swings at the clip's ends run between them)
    stances = [st for st in stances if st.liftoff > -T and st.strike < dur + T]
    return t, v, stances, T


def _steady_stances(spec: ClipSpec, T: float, D: float, dur: float) -> list[GaitStance]:
    """The stances of steady walking or running (time order) from ``STANCE_MARGIN``
    cycles before the clip to as long after its ``dur`` s: the lead foot's centred at
    FIRST_CENTER T + j T, the other's half a cycle later (cycle ``T`` s), each down for
    ``D`` s. The hips pass over the ankle early in the stance (the gait's ``passing``
    share): the foot lands a little ahead of them, and leaves far behind, on its toes."""
    g = spec.gait
    centers = [(k ^ spec.lead, FIRST_CENTER * T + 0.5 * k * T + j * T)
               for j in range(-STANCE_MARGIN, int(dur / T) + STANCE_MARGIN + 1) for k in (0, 1)]
    centers.sort(key=lambda kc: kc[1])
    P = g.passing * D
    return [GaitStance(k, c - P, c - P + D, c, clearance=g.clearance) for k, c in centers]


def _jump_stances(stances: list[GaitStance], flight: float, T: float, D: float, size: float) -> None:
    """Make a jump of steady ``stances`` (in place): take off from the first left stance
    centred after TAKEOFF_AFTER cycles (``T`` s), fly ``flight`` s, land on the right.
    The stances from the landing on come later by the flight's excess over a steady
    one (T/2 - D; ``D`` s a stance), and the swings into the landing and the step after
    it clear JUMP_CLEARANCE (times ``size``). At 3.2 m/s, 0.3 s in the air carry the
    take-off toe 1.7 m from the landing heel (the toe leaves 0.4 m behind the hips, the
    heel lands 0.3 m ahead)."""
    j0 = next(i for i, st in enumerate(stances) if st.foot == 0 and st.center > TAKEOFF_AFTER * T)
    shift = flight - (T / 2 - D)
    for st in stances[j0 + 1:]:
        st.strike, st.liftoff, st.center = st.strike + shift, st.liftoff + shift, st.center + shift
    stances[j0 + 1].clearance = stances[j0 + 2].clearance = JUMP_CLEARANCE * size


def _stand_ends(stances, when, start):
    """Standing feet at the start (or the end): the last (first) stance of each foot
    centred before (after) ``when`` lasts from the clip's start (to its end); the stances
    beyond are dropped."""
    out = []
    if start:
        keep = {}
        for i, st in enumerate(stances):
            if st.center <= when:
                keep[st.foot] = i
        first = min(keep.values())
        for i, st in enumerate(stances):
            if i in keep.values():
                st.strike = -np.inf
                out.append(st)
            elif i > first and st.center > when:
                out.append(st)
        return out
    ends = {}
    for i, st in enumerate(stances):
        if st.center >= when and st.foot not in ends:
            ends[st.foot] = i
    for i, st in enumerate(stances):
        if i in ends.values():
            st.liftoff = np.inf
            out.append(st)
        elif i < max(ends.values()) and st.center < when:
            out.append(st)
    return out


# ---------------------------------------------------------------------------- generation

#: s the path is extended beyond the clip's ends (at the end speeds), for the stances
#: laid out there.
PATH_PAD = 3.0


def _path_at(tq, t, v, tau):
    """Position (..., 2) and heading (...) at times ``tq`` along an arc of curvature tau
    travelled at speed v(t) (held beyond the clip's ends), starting at the origin with
    heading 0 (facing -Y) at t = 0."""
    dt = t[1] - t[0]
    pad = int(np.ceil(PATH_PAD / dt))
    te = np.r_[t[0] - dt * np.arange(pad, 0, -1), t, t[-1] + dt * np.arange(1, pad + 1)]
    ve = np.r_[np.full(pad, v[0]), v, np.full(pad, v[-1])]
    arc = np.r_[0.0, np.cumsum(0.5 * (ve[1:] + ve[:-1]) * dt)]  # m travelled
    arc -= arc[pad]
    arc_q = np.interp(tq, te, arc)
    heading = tau * arc_q
    if abs(tau) < 1e-9:
        pos = np.stack([np.zeros_like(arc_q), -arc_q], axis=-1)
    else:
        # forward (-Y) turned by the heading is (sin h, -cos h): integrated along the arc
        pos = np.stack([(1.0 - np.cos(heading)) / tau, -np.sin(heading) / tau], axis=-1)
    return pos, heading


def _yaw(h):
    """(N, 3, 3) rotations about +Z by the angles h."""
    h = np.atleast_1d(np.asarray(h, float))
    return root_frames(np.zeros((len(h), 3)), h)[:, :3, :3]


def _left(h):
    """The character's left (armature +X at heading 0) at heading h: (F, 2)."""
    return np.c_[np.cos(h), np.sin(h)]


#: The mannequin's leg (hip joint to knee to ankle, 0.84) and hips-head height, m: the
#: gaits' lengths and heights are the mannequin's, and scale with a rig's legs.
REF_LEG = 0.43 + float(np.hypot(0.41, 0.01))
REF_HIPS = 0.95
#: A rig within this of the mannequin's leg length (ratio) and hips height (m) gets the
#: gaits unscaled.
SAME_SIZE = 1e-4
#: Standing feet: each footprint this far from the path (m, mannequin scale) ...
STAND_WIDTH = 0.1
#: ... and toes this much out (radians).
STAND_TOE_OUT = np.radians(8)
#: Idle: the sway signal's amplitude (of the walk's +-1), one sway over the clip ...
IDLE_SWAY_SIGNAL = 0.6
#: ... the hips' sway at its peak (m, mannequin scale) ...
IDLE_SWAY = 0.03
#: ... and half the depth of the hips' dip (m, mannequin scale), twice over the clip.
IDLE_DIP = 0.004
#: m the hips crouch before a jump's take-off and after its landing (mannequin scale) ...
JUMP_DIP = 0.06
#: ... over this many seconds either side.
JUMP_CROUCH = 0.25
#: Forward lean (radians) per m/s^2 of acceleration ...
ACCEL_LEAN = 0.03
#: ... the speed smoothed over this (s, the Gaussian's sigma) first.
ACCEL_SMOOTH = 0.15
#: s either side of a frame whose foot is out of reach over which the hips come down.
REACH_WINDOW = 0.12


@dataclass
class _Course:
    """A clip's timing and path, frame by frame (armature space, heading 0 facing -Y)."""

    t: np.ndarray  # (F,) s, frame times from 0
    v: np.ndarray  # (F,) m/s, speed along the path
    stances: list  # GaitStance, time order
    cycle: float  # s, the gait's cycle rounded to whole frames
    root: np.ndarray  # (F, 2) m, the path's point (the hips' ground point before sway)
    heading: np.ndarray  # (F,) rad
    ramp: np.ndarray  # (F,) share of full speed, 0 standing .. 1


def generate(rig: Rig, spec: ClipSpec, fps: float = 30.0) -> GaitClip:
    """Generate one clip for ``rig`` at ``fps``: the mannequin, or a rig with the human
    metarig's hips and leg bones (``require_metarig``; spine and arm bones are posed
    where they have the metarig's names too). A rig of other proportions gets the gait
    scaled to its legs: lengths by the ratio of leg lengths (``size``), speeds and times
    by its square root (equal Froude numbers), heights measured down from its hips' rest
    height. The passes follow the module docstring's steps."""
    require_metarig(rig)
    spec, size, stand_height = _fit_to_legs(rig, spec)
    course = _course(spec, fps, size)  # 1. path and timing
    _place_footprints(course, spec, size)  # 2. footprints
    foot_m, toe_bend = _feet(rig, course, spec.gait, size)  # 3. feet: roll and swing
    # 4. body: sway over the standing foot, rotation with the legs, height, lean, reach
    sigma = _idle_sway(course.t) if spec.kind == "idle" else _sway_signal(course.t, course.stances)
    lift = _leg_forward(foot_m, course.root, course.heading, spec.gait, spec)
    height = _hips_height(course, sigma, spec, stand_height, size)
    if spec.kind == "jump":
        height = _jump_flight(course, height, foot_m, size)
    pos, R_body = _body_frame(course, sigma, lift, height, spec, size, fps)
    basis, drop = _hips_bases(rig, pos, R_body, foot_m, spec.kind == "cycle", fps)
    _upper_body(rig, basis, lift, sigma, course.ramp, spec.gait, spec, course.t)
    # 5. legs, then the toes
    _legs(rig, basis, foot_m, course.heading)
    _toes(rig, basis, toe_bend)
    return GaitClip(spec, float(fps), basis, course.stances, drop)


def _fit_to_legs(rig: Rig, spec: ClipSpec) -> tuple[ClipSpec, float, float]:
    """(``spec`` scaled to the rig, size: the rig's leg length over the mannequin's
    (REF_LEG), the hips' standing height m): lengths by size, speeds and times by its
    square root, heights measured down from the rig's hips' rest height; unchanged for
    a rig of the mannequin's size (within SAME_SIZE)."""
    size = sum(leg_lengths(rig, "l")) / REF_LEG
    hips0 = float(rig.rest[rig.role_index("hips"), 2, 3])
    stand_height = hips0 - (REF_HIPS - STAND_HEIGHT) * size
    if abs(size - 1.0) > SAME_SIZE or abs(hips0 - REF_HIPS) > SAME_SIZE:
        r, k = np.sqrt(size), size
        g0 = spec.gait
        g = replace(g0, speed=g0.speed * r, cycle=g0.cycle * r, width=g0.width * k, clearance=g0.clearance * k,
                    height=hips0 - (REF_HIPS - g0.height) * k, bob=g0.bob * k, sway=g0.sway * k)
        spec = replace(spec, gait=g, speed=None if spec.speed is None else spec.speed * r, tau=spec.tau / k)
    return spec, size, stand_height


def _course(spec: ClipSpec, fps: float, size: float) -> _Course:
    """The clip's frame times, speed and stances (``_timeline``) and its path
    (``_path_at``), with the share of full speed at each frame."""
    t, v, stances, T = _timeline(spec, fps, size)
    root, heading = _path_at(t, t, v, spec.tau)
    return _Course(t, v, stances, T, root, heading, np.clip(v / max(spec.v, 1e-9), 0.0, 1.0))


def _place_footprints(course: _Course, spec: ClipSpec, size: float) -> None:
    """Set every stance's footprint (``pos`` heel ground point (2,) m, ``heading`` rad)
    in place: beside the path where the hips are at mid-stance, the gait's width from it
    and its toes out, moved inward when leaning into a turn (the body is inside its feet
    by leg height x tan(lean)); standing feet (a stance open at a clip's end) side by side
    (STAND_WIDTH, STAND_TOE_OUT, times ``size``) where the hips are at the clip's start
    (or end)."""
    g, t, stances = spec.gait, course.t, course.stances
    dur = t[-1]
    standing_at = [None if np.isfinite(st.strike) and np.isfinite(st.liftoff)
                   else (0.0 if not np.isfinite(st.strike) else dur) for st in stances]
    where, facing = _path_at(np.array([st.center if at is None else at for st, at in zip(stances, standing_at)]),
                             t, course.v, spec.tau)
    for st, at, p, h in zip(stances, standing_at, where, facing):
        standing = at is not None
        side = 1.0 if st.foot == 0 else -1.0
        st.heading = h + side * (STAND_TOE_OUT if standing else g.toe_out)
        inward = 0.0 if standing else LEG_HEIGHT * size * np.tan(_lean(spec, spec.v))
        st.pos = p + (side * (STAND_WIDTH * size if standing else g.width) - inward) * _left(h)[0]


@dataclass(frozen=True)
class _FootRest:
    """One foot bone at rest, and the ground points its roll pivots about (armature
    space, m; the rest foot stands flat on z = 0)."""

    rest: np.ndarray  # (4, 4) the foot bone's rest matrix
    heel_g: np.ndarray  # (3,) the ground under the ankle
    ball_g: np.ndarray  # (3,) the ground under the ball joint
    ball_j: np.ndarray  # (3,) the ball joint (the toe bone's head)
    heel_back: np.ndarray  # (3,) the back of the heel on the ground: the heel rocker's pivot

    @classmethod
    def of(cls, rig: Rig, side: str, heel_back_m: float) -> "_FootRest":
        """The foot of ``side`` ("l" or "r"), its heel ``heel_back_m`` m behind the ankle
        (away from the ball)."""
        rest_foot = rig.rest[rig.foot_chain(side)[0]]
        heel_g = rest_foot[:3, 3] * [1, 1, 0]
        ball_j = rig.ball_local(side)[:3] @ rest_foot[:3, :3].T + rest_foot[:3, 3]
        ball_g = ball_j * [1, 1, 0]
        # the heel rocker pivots on the back of the heel, behind the ankle: the ankle rises
        # as the toes do (it is lowest with the foot flat, where the analysis finds its stance)
        heel_back = heel_g + heel_back_m * (heel_g - ball_g) / np.linalg.norm(heel_g - ball_g)
        return cls(rest_foot, heel_g, ball_g, ball_j, heel_back)


def _feet(rig: Rig, course: _Course, g: Gait, size: float) -> tuple[np.ndarray, np.ndarray]:
    """Both feet's tracks (``_foot_track``): armature-space foot matrices (2, F, 4, 4) and
    toe bends (2, F) radians; foot 0 is the left."""
    F = len(course.t)
    foot_m = np.zeros((2, F, 4, 4))
    toe_bend = np.zeros((2, F))
    for i, side in enumerate(SIDES):
        foot = _FootRest.of(rig, side, HEEL_BACK * size)
        foot_m[i], toe_bend[i] = _foot_track(course.t, [st for st in course.stances if st.foot == i], foot, g,
                                             course.cycle)
    return foot_m, toe_bend


def _idle_sway(t) -> np.ndarray:
    """The idle clip's sway signal (F,): one slow sway over the clip, IDLE_SWAY_SIGNAL at
    its peaks (the walk's is +-1)."""
    return IDLE_SWAY_SIGNAL * np.sin(2 * np.pi * t / t[-1])


def _hips_height(course: _Course, sigma, spec: ClipSpec, stand_height: float, size: float) -> np.ndarray:
    """(F,) m the hips' height: the gait's, bobbing with the sway signal ``sigma`` (F,)
    (walking highest at mid-stance, running lowest), eased from ``stand_height`` by the
    share of full speed; an idle clip's dips twice by up to 2 IDLE_DIP (times ``size``)."""
    g, t = spec.gait, course.t
    if spec.kind == "idle":
        return stand_height - IDLE_DIP * size * (1 - np.cos(4 * np.pi * t / t[-1]))
    bob = (-1.0 if g.name == "run" else 1.0) * g.bob * (2 * sigma ** 2 - 1)
    return stand_height + (g.height - stand_height + bob) * course.ramp


def _jump_flight(course: _Course, height, foot_m, size: float) -> np.ndarray:
    """(F,) m the hips' height ``height`` (F,) with the jump's flight a ballistic arc
    (``_ballistic``, a JUMP_DIP crouch either side, times ``size``); the swinging feet of
    ``foot_m`` (2, F, 4, 4) rise with the body (in place)."""
    t = course.t
    flying = _ballistic(t, height, course.stances, dip=JUMP_DIP * size)
    rise = np.maximum(flying - height, 0.0)
    for k in range(2):
        down = np.zeros(len(t), bool)
        for st in course.stances:
            down |= (st.foot == k) & (t >= st.strike) & (t <= st.liftoff)
        foot_m[k, ~down, 2, 3] += rise[~down]
    return flying


def _body_frame(course: _Course, sigma, lift, height, spec: ClipSpec, size: float, fps: float
                ) -> tuple[np.ndarray, np.ndarray]:
    """The hips' armature-space position (F, 3) m and rotation (F, 3, 3): on the path,
    swaying over the standing foot (the sway signal ``sigma`` (F,)) at ``height`` (F,);
    turned to the heading less the pelvis's rotation with the legs (``lift`` (F,)),
    leaning forward with speed and acceleration (ACCEL_LEAN, the speed smoothed over
    ACCEL_SMOOTH s), into turns, and listing with the sway."""
    g, t, v, ramp = spec.gait, course.t, course.v, course.ramp
    sway = (g.sway if spec.kind != "idle" else IDLE_SWAY * size) * sigma * np.maximum(ramp, spec.kind == "idle")
    pos = np.c_[course.root + sway[:, None] * _left(course.heading), height]
    accel_lean = np.gradient(gaussian_filter1d(v, ACCEL_SMOOTH * fps, mode="nearest"), t) * ACCEL_LEAN
    pitch = g.lean * ramp + accel_lean
    roll = _lean(spec, v) - g.pelvis_roll * sigma * ramp
    yaw = course.heading - g.pelvis_yaw * lift * ramp
    return pos, _yaw(yaw) @ Rotation.from_euler("YX", np.c_[roll, pitch]).as_matrix()


def _hips_bases(rig: Rig, pos, R_body, foot_m, loop: bool, fps: float) -> tuple[np.ndarray, np.ndarray]:
    """(pose bases (F, B, 4, 4), the others at rest, with the hips at ``pos`` (F, 3) m
    turned by ``R_body`` (F, 3, 3) and lowered where a leg could not reach its foot
    (``foot_m`` (2, F, 4, 4)); that drop (F,) m (``_reach_drop``))."""
    F = len(pos)
    basis = np.tile(np.eye(4), (F, len(rig.names), 1, 1))
    hips = rig.role_index("hips")
    rest_h = rig.rest[hips]
    arm_h = np.tile(np.eye(4), (F, 1, 1))
    arm_h[:, :3, :3] = R_body @ rest_h[:3, :3]
    arm_h[:, :3, 3] = pos
    drop = _reach_drop(rig, pos, R_body, foot_m, loop, fps)
    arm_h[:, 2, 3] -= drop
    basis[:, hips] = np.linalg.inv(rest_h)[None] @ arm_h
    return basis, drop


def _reach_drop(rig: Rig, pos, R_body, foot_m, loop: bool, fps: float) -> np.ndarray:
    """(F,) m to lower the hips (at ``pos`` (F, 3), turned by ``R_body`` (F, 3, 3)) so
    each ankle of ``foot_m`` (2, F, 4, 4) lies within REACH of its leg's length, coming
    and going smoothly over REACH_WINDOW s; wrapping around for a ``loop`` (its last
    frame is its first)."""
    hips = rig.role_index("hips")
    thigh = [rig.role_index(f"thigh_{x}") for x in SIDES]
    need = np.zeros(len(pos))
    for k in range(2):
        H = pos + np.einsum("fij,j->fi", R_body, rig.rest[thigh[k], :3, 3] - rig.rest[hips, :3, 3])
        need = np.maximum(need, reach_need(H, foot_m[k, :, :3, 3], REACH * sum(leg_lengths(rig, SIDES[k]))))
    win = max(1, int(round(REACH_WINDOW * fps)))
    if loop:
        drop = lower_smoothly(np.maximum(need[:-1], 0.0), win, mode="wrap", edge="wrap")
        return np.maximum(np.r_[drop, drop[:1]], need)
    drop = lower_smoothly(np.maximum(need, 0.0), win, edge="nearest")
    return np.maximum(drop, need)


def _legs(rig: Rig, basis, foot_m, heading) -> None:
    """Solve both legs of pose bases ``basis`` (F, B, 4, 4) in place (``two_bone``, the
    knee forward along ``heading`` (F,)) so the feet take ``foot_m`` (2, F, 4, 4)."""
    feet = [rig.foot_chain(x)[0] for x in SIDES]
    pose = forward_kinematics(rig, basis, bones=feet)
    fwd = np.c_[np.sin(heading), -np.cos(heading), np.zeros(len(heading))]
    for k, side in enumerate(SIDES):
        th, sh, ft = rig.role_index(f"thigh_{side}"), rig.role_index(f"shin_{side}"), feet[k]
        L1, L2 = leg_lengths(rig, side)
        Wt, Ws, Wf = pose[:, th], pose[:, sh], pose[:, ft]
        r1, r2 = two_bone(Wt[:, :3, 3], Ws[:, :3, 3], Wf[:, :3, 3], foot_m[k, :, :3, 3], L1, L2, fwd)
        arm = {th: r1 @ Wt[:, :3, :3], sh: r2 @ r1 @ Ws[:, :3, :3], ft: foot_m[k, :, :3, :3]}
        chain_bases(rig, [th, sh, ft], pose[:, rig.parents[th], :3, :3], arm, basis)


def _toes(rig: Rig, basis, toe_bend) -> None:
    """The toes of pose bases ``basis`` (F, B, 4, 4) bent up by ``toe_bend`` (2, F)
    radians (in place; about the foot's width) as the heel rises."""
    F = toe_bend.shape[1]
    for k, side in enumerate(SIDES):
        toe = rig.foot_chain(side)[1]
        if toe is not None:
            R = rig.rest[toe, :3, :3]
            D = Rotation.from_rotvec(np.c_[-toe_bend[k], np.zeros(F), np.zeros(F)]).as_matrix()
            basis[:, toe, :3, :3] = R.T @ D @ R


def _lean(spec: ClipSpec, v):
    """Lean into the turn (radians, positive to the left) at speed v: the centripetal
    angle, atan(v^2 tau / g), or the gait's share of it."""
    return spec.gait.turn_lean * np.arctan(np.asarray(v) ** 2 * spec.tau / G)


#: The swing's lift u (1 - u)^2 (peaking early, at u = 1/3) times this peaks at 1.
SWING_LIFT_NORM = 6.75
#: Share of the swing over which the toes ease back from toe off to straight.
TOE_EASE = 0.6


def _foot_track(t, stances, foot: _FootRest, g: Gait, T: float):
    """(F, 4, 4) armature-space matrices of one foot bone at frame times ``t`` (F,) s:
    planted and rolling during its ``stances`` (time order), swinging in between; and (F,)
    how far the toes bend up (radians) to stay flat on the ground while the heel is up
    (easing back early in the swing). ``T`` s the cycle (a stance open at a clip's end
    rolls as if it lasted the gait's duty share of it)."""
    out = np.zeros((len(t), 4, 4))
    bend = np.zeros(len(t))
    nominal = g.duty * T
    for st in stances:
        m = (t >= st.strike) & (t <= st.liftoff)
        if m.any():
            out[m] = _rolling(st, t[m], foot, g, nominal)
            bend[m] = np.maximum(_pitch_of(out[m], foot.rest), 0.0)
    for a, b in zip(stances[:-1], stances[1:]):
        m = (t > a.liftoff) & (t < b.strike)
        if m.any():
            out[m], bend[m] = _swing(t[m], a, b, foot, g, nominal)
    return out, bend


def _rolling(st: GaitStance, tq, foot: _FootRest, g: Gait, nominal: float) -> np.ndarray:
    """(n, 4, 4) the foot planted on stance ``st``'s footprint at times ``tq`` (n,) s
    inside it: heel strike with the toes up (the gait's strike pitch), pivoting on the
    back of the heel to flat over its heel-rocker share of the stance; flat; then the
    heel rising (to the toe-off pitch at liftoff), pivoting on the ball over its
    toe-rocker share. A stance open at a clip's end (infinite strike or liftoff) does
    not roll at that end and counts as ``nominal`` s long."""
    a_start = st.strike if np.isfinite(st.strike) else None
    a_end = st.liftoff if np.isfinite(st.liftoff) else None
    dur = (a_end - a_start) if (a_start is not None and a_end is not None) else nominal
    pitch = np.zeros(len(tq))
    pivot = np.zeros((len(tq), 3))
    pivot[:] = foot.heel_back
    toe = np.zeros(len(tq), bool)
    if a_start is not None:
        u = (tq - a_start) / (g.heel_rocker * dur)
        pitch -= np.where(u < 1, g.strike_pitch * (1 - smoothstep(u)), 0.0)
    if a_end is not None:
        u = (tq - (a_end - g.toe_rocker * dur)) / (g.toe_rocker * dur)
        toe = u > 0
        pitch += np.where(toe, g.toeoff_pitch * np.clip(u, 0.0, 1.0) ** 2, 0.0)
        # the foot rolls over the ball: about the ground under its joint, raised so the
        # joint keeps its height (the toes stay flat on the ground)
        pivot[toe] = foot.ball_g
    m = _placed(st, pitch, pivot, foot.rest, foot.heel_g)
    m[toe, 2, 3] += foot.ball_j[2] * (1.0 - np.cos(pitch[toe]))
    return m


def _swing(tq, a: GaitStance, b: GaitStance, foot: _FootRest, g: Gait, nominal: float) -> tuple[np.ndarray, np.ndarray]:
    """The foot between stances ``a`` and ``b`` at times ``tq`` (n,) s: (n, 4, 4) matrices
    moving on a smoothstep from its toe-off pose to its heel-strike pose, lifted by ``b``'s
    clearance (peaking early: the foot leaves briskly, and lands softly), turning
    smoothly, and never with the heel or ball under the ground; and (n,) the toe bend,
    easing back from the toe-off pitch over TOE_EASE of the swing."""
    m0 = _rolling(a, np.array([a.liftoff]), foot, g, nominal)[0]
    m1 = _rolling(b, np.array([b.strike]), foot, g, nominal)[0]
    u = (tq - a.liftoff) / (b.strike - a.liftoff)
    # (a smoothstep, not a minimum-jerk profile: its peak speed is 20 % lower, which
    # spares the thigh a whip through mid swing)
    w = smoothstep(u)
    out = np.zeros((len(tq), 4, 4))
    out[:, :3, 3] = (1 - w)[:, None] * m0[:3, 3] + w[:, None] * m1[:3, 3]
    out[:, 2, 3] += b.clearance * (SWING_LIFT_NORM * u * (1 - u) ** 2)
    rel = Rotation.from_matrix(m0[:3, :3].T @ m1[:3, :3]).as_rotvec()
    out[:, :3, :3] = m0[:3, :3] @ Rotation.from_rotvec(w[:, None] * rel).as_matrix()
    out[:, 3, 3] = 1.0
    out[:, 2, 3] += _under_ground(out, foot)  # the swing's ends are on the ground
    return out, g.toeoff_pitch * (1.0 - smoothstep(u / TOE_EASE))


def _under_ground(m, foot: _FootRest) -> np.ndarray:
    """(n,) m, >= 0: how far the lower of the heel and ball ground points of ``foot``
    lies under z = 0 with the foot bone at ``m`` (n, 4, 4)."""
    lift = np.zeros(len(m))
    for q in (foot.heel_g, foot.ball_g):
        local = np.linalg.inv(foot.rest) @ np.append(q, 1.0)
        z = np.einsum("fij,j->fi", m, local)[:, 2]
        lift = np.maximum(lift, -z)
    return lift


def _pitch_of(m, rest_foot) -> np.ndarray:
    """Heel-up pitch (radians) of foot matrices (F, 4, 4) relative to the rest foot."""
    fwd = np.einsum("fij,j->fi", m[:, :3, :3], rest_foot[:3, :3].T @ [0.0, -1.0, 0.0])
    return np.arctan2(-fwd[:, 2], np.hypot(fwd[:, 0], fwd[:, 1]))


def _placed(st: GaitStance, pitch, pivot, rest_foot, heel_g) -> np.ndarray:
    """(n, 4, 4) the rest foot (``rest_foot`` (4, 4), its ground point under the ankle
    ``heel_g`` (3,)) laid on stance st's footprint (that heel ground point on st.pos,
    turned to st.heading), pitched by ``pitch`` (n,) radians (positive: heel up) about
    ``pivot`` (n, 3) (rest coordinates on the ground)."""
    n = len(pitch)
    Rp = Rotation.from_rotvec(np.c_[pitch, np.zeros(n), np.zeros(n)]).as_matrix()
    Rz = _yaw(st.heading)[0]
    out = np.tile(np.eye(4), (n, 1, 1))
    out[:, :3, :3] = Rz @ Rp @ rest_foot[:3, :3]
    # x -> P + Rp (x - P), then the heel ground point to st.pos
    local = pivot + np.einsum("fij,fj->fi", Rp, rest_foot[:3, 3] - pivot)
    out[:, :3, 3] = np.einsum("ij,fj->fi", Rz, local - heel_g) + np.r_[st.pos, 0.0]
    return out


def _sway_signal(t, stances) -> np.ndarray:
    """+1 at the left foot's mid-stances, -1 at the right's, cosine in between (0 where
    both feet stand)."""
    knots = sorted((st.center, st.foot) for st in stances if np.isfinite(st.strike) and np.isfinite(st.liftoff))
    if len(knots) < 2:
        return np.zeros(len(t))
    tk = np.array([k[0] for k in knots])
    val = np.array([1.0 if k[1] == 0 else -1.0 for k in knots])
    i = np.clip(np.searchsorted(tk, t) - 1, 0, len(tk) - 2)
    u = np.clip((t - tk[i]) / (tk[i + 1] - tk[i]), 0.0, 1.0)
    w = 0.5 - 0.5 * np.cos(np.pi * u)
    out = (1 - w) * val[i] + w * val[i + 1]
    # outside the knots (standing), fade to 0
    out = np.where(t < tk[0], val[0] * smoothstep(1 - (tk[0] - t) / 0.5), out)
    out = np.where(t > tk[-1], val[-1] * smoothstep(1 - (t - tk[-1]) / 0.5), out)
    return out


def _leg_forward(foot_m, root, heading, g, spec) -> np.ndarray:
    """How far the left foot is ahead of the right, along the heading, in half strides
    (about -1 .. 1): drives the pelvis's rotation and the arms."""
    fwd = np.c_[np.sin(heading), -np.cos(heading)]
    ahead = [np.einsum("fi,fi->f", foot_m[k, :, :2, 3] - root, fwd) for k in range(2)]
    half = max(0.5 * spec.v * g.cycle * 0.5, 0.05)
    return np.clip((ahead[0] - ahead[1]) / (2 * half), -1.5, 1.5)


def _ballistic(t, height, stances, dip: float = JUMP_DIP) -> np.ndarray:
    """(F,) the hips' height ``height`` (F,) m at times ``t`` (F,) s with the longest
    flight (no foot down in ``stances``) replaced by a ballistic arc (gravity) that meets
    the height profile at take-off and landing, and a crouch ``dip`` m deep over
    JUMP_CROUCH s before the take-off and after the landing (then Gaussian-smoothed,
    sigma one frame)."""
    down = np.zeros(len(t), bool)
    for st in stances:
        down |= (t >= st.strike) & (t <= st.liftoff)
    air = np.flatnonzero(~down)
    if not len(air):
        return height
    runs = np.split(air, np.flatnonzero(np.diff(air) > 1) + 1)
    r = max(runs, key=len)
    a, b = r[0] - 1, r[-1] + 1
    ta, tb = t[a], t[b]
    za, zb = height[a], height[b]
    vz = (zb - za) / (tb - ta) + 0.5 * G * (tb - ta)
    out = height.copy()
    tt = t[a:b + 1] - ta
    out[a:b + 1] = za + vz * tt - 0.5 * G * tt ** 2
    # ease the stances either side into the arc's take-off and landing speeds: a crouch
    # before the take-off and after the landing
    w = JUMP_CROUCH
    pre = (t > ta - w) & (t <= ta)
    post = (t >= tb) & (t < tb + w)
    out[pre] -= dip * np.sin(np.pi * (t[pre] - (ta - w)) / w) ** 2
    out[post] -= dip * np.sin(np.pi * (t[post] - tb) / w) ** 2
    return gaussian_filter1d(out, 1.0, mode="nearest")


def _upper_body(rig: Rig, basis, lift, sigma, ramp, g: Gait, spec: ClipSpec, t) -> None:
    """Spine counter-rotation, a level head, arm swing against the legs, bent elbows."""
    names = set(rig.names)

    def put(bone, rotvec):
        if bone not in names:
            return
        b = rig.index(bone)
        R = rig.rest[b, :3, :3]
        D = Rotation.from_rotvec(rotvec).as_matrix()
        basis[:, b, :3, :3] = R.T @ D @ R

    F = len(t)
    z = np.zeros(F)
    counter = g.pelvis_yaw * lift * ramp * 0.55
    for bone in ("spine.001", "spine.002", "spine.003"):
        put(bone, np.c_[z, z, counter])
    roll = _lean(spec, ramp * spec.v)
    put("spine.004", np.c_[-0.5 * g.lean * ramp, -0.25 * roll, z])
    put("spine.005", np.c_[-0.3 * g.lean * ramp, -0.25 * roll, z])
    breathe = 0.015 * np.sin(2 * np.pi * t / 3.2) if spec.kind == "idle" else z
    put("spine.002", np.c_[breathe, z, counter])
    for k, side in enumerate(("L", "R")):
        sgn = 1.0 if k == 0 else -1.0
        swing = g.arm_swing * sgn * lift * ramp
        # the arms hang a little out from the body
        put(f"upper_arm.{side}", np.c_[swing + 0.05 * ramp, -sgn * np.radians(6) * np.ones(F), z])
        elbow = np.radians(12) + (g.elbow - np.radians(12) + g.elbow_swing * (-sgn * lift)) * ramp
        put(f"forearm.{side}", np.c_[-elbow, z, z])
