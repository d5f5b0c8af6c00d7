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

from .clip import root_frames
from .errors import FootstepError
from .ik import chain_bases, leg_lengths, lower_smoothly, reach_need, smoothstep, two_bone
from .rig import Rig, forward_kinematics


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
class Stance:
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
    stances: list[Stance]
    hips_drop: np.ndarray  # (F,) m lowered to keep the legs in reach


# ---------------------------------------------------------------------------- timing

def _timeline(spec: ClipSpec, fps: float, size: float = 1.0):
    """Duration, speed profile v(t) on the frame times, and the stances (unplaced)."""
    g = spec.gait
    T = round(g.cycle * fps) / fps  # a whole number of frames, so a cycle clip loops
    D = g.duty * T
    if spec.kind == "idle":
        dur = 2.4
        t = np.arange(round(dur * fps) + 1) / fps
        st = [Stance(k, -np.inf, np.inf, 0.0) for k in range(2)]
        return t, np.zeros(len(t)), st, T
    if spec.kind == "cycle":
        dur = spec.cycles * T
    elif spec.kind in ("start", "stop"):
        dur = 0.5 + 1.4 + 2 * T + 0.5
    else:  # jump
        dur = 3 * T + 0.6
    t = np.arange(round(dur * fps) + 1) / fps
    dur = t[-1]
    # steady stances: left centred at T/4 + jT, right at 3T/4 + jT
    centers = [(k ^ spec.lead, 0.25 * T + 0.5 * k * T + j * T) for j in range(-3, int(dur / T) + 4)
               for k in (0, 1)]
    centers.sort(key=lambda kc: kc[1])
    v = np.full(len(t), spec.v)
    # the hips pass over the ankle early in the stance: the foot lands a little ahead of
    # them, and leaves far behind, on its toes
    P = g.passing * D
    stances = [Stance(k, c - P, c - P + D, c, clearance=g.clearance) for k, c in centers]
    if spec.kind == "start":
        go = 0.5  # standing until then, then 1.4 s to full speed
        v = spec.v * smoothstep((t - go) / 1.4)
        stances = _stand_ends(stances, go + 0.45 * T, start=True)
    elif spec.kind == "stop":
        halt = dur - 0.5  # full speed until 1.4 s before, standing after
        v = spec.v * (1.0 - smoothstep((t - (halt - 1.4)) / 1.4))
        stances = _stand_ends(stances, halt - 0.55 * T, start=False)
    elif spec.kind == "jump":
        # take off from the left foot at about 1.3 cycles, fly, land on the right
        j0 = next(i for i, s in enumerate(stances) if s.foot == 0 and s.center > 1.2 * T)
        # the flight: at 3.2 m/s, 0.3 s in the air carry the take-off toe 1.7 m from the
        # landing heel (the toe leaves 0.4 m behind the hips, the heel lands 0.3 m ahead)
        shift = spec.jump_flight - (T / 2 - D)  # (the steady flight is T/2 - D)
        for s in stances[j0 + 1:]:
            s.strike, s.liftoff, s.center = s.strike + shift, s.liftoff + shift, s.center + shift
        stances[j0 + 1].clearance = stances[j0 + 2].clearance = 0.3 * size
    # every stance that touches the clip, and the one before and after it for each foot
    # (the swings at the clip's ends run between them)
    stances = [s for s in stances if s.liftoff > -T and s.strike < dur + T]
    return t, v, stances, T


def _stand_ends(stances, when, start):
    """Standing feet at the start (or the end): the last (first) stance of each foot
    centred before (after) ``when`` lasts from the clip's start (to its end); the stances
    beyond are dropped."""
    out = []
    if start:
        keep = {}
        for i, s in enumerate(stances):
            if s.center <= when:
                keep[s.foot] = i
        first = min(keep.values())
        for i, s in enumerate(stances):
            if i in keep.values():
                s.strike = -np.inf
                out.append(s)
            elif i > first and s.center > when:
                out.append(s)
        return out
    ends = {}
    for i, s in enumerate(stances):
        if s.center >= when and s.foot not in ends:
            ends[s.foot] = i
    for i, s in enumerate(stances):
        if i in ends.values():
            s.liftoff = np.inf
            out.append(s)
        elif i < max(ends.values()) and s.center < when:
            out.append(s)
    return out


# ---------------------------------------------------------------------------- generation

def _path_at(tq, t, v, tau):
    """Position (..., 2) and heading (...) at times ``tq`` along an arc of curvature tau
    travelled at speed v(t) (held beyond the clip's ends), starting at the origin with
    heading 0 (facing -Y) at t = 0."""
    dt = t[1] - t[0]
    pad = int(np.ceil(3.0 / dt))
    te = np.r_[t[0] - dt * np.arange(pad, 0, -1), t, t[-1] + dt * np.arange(1, pad + 1)]
    ve = np.r_[np.full(pad, v[0]), v, np.full(pad, v[-1])]
    s = np.r_[0.0, np.cumsum(0.5 * (ve[1:] + ve[:-1]) * dt)]
    s -= s[pad]
    sq = np.interp(tq, te, s)
    heading = tau * sq
    if abs(tau) < 1e-9:
        pos = np.stack([np.zeros_like(sq), -sq], axis=-1)
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


def generate(rig: Rig, spec: ClipSpec, fps: float = 30.0) -> GaitClip:
    """Generate one clip for ``rig`` at ``fps``: the mannequin, or a rig with the human
    metarig's hips and leg bones (``require_metarig``; spine and arm bones are posed
    where they have the metarig's names too). A rig of other proportions gets the gait scaled to its legs: lengths by the
    ratio of leg lengths s, speeds and times by sqrt(s) (equal Froude numbers), heights
    measured down from its hips' rest height."""
    require_metarig(rig)
    size = sum(leg_lengths(rig, "l")) / REF_LEG
    hips0 = float(rig.rest[rig.role_index("hips"), 2, 3])
    stand_height = hips0 - (REF_HIPS - STAND_HEIGHT) * size
    if abs(size - 1.0) > 1e-4 or abs(hips0 - REF_HIPS) > 1e-4:
        r, k = np.sqrt(size), size
        g0 = spec.gait
        g = replace(g0, speed=g0.speed * r, cycle=g0.cycle * r, width=g0.width * k, clearance=g0.clearance * k,
                    height=hips0 - (REF_HIPS - g0.height) * k, bob=g0.bob * k, sway=g0.sway * k)
        spec = replace(spec, gait=g, speed=None if spec.speed is None else spec.speed * r, tau=spec.tau / k)
    g = spec.gait
    t, v, stances, T = _timeline(spec, fps, size)
    F = len(t)
    dur = t[-1]
    root, heading = _path_at(t, t, v, spec.tau)
    ramp = np.clip(v / max(spec.v, 1e-9), 0.0, 1.0)

    # footprints: beside the path where the hips are at mid-stance; standing feet side by
    # side where the hips are at the clip's start (or end)
    standing_at = [None if np.isfinite(s.strike) and np.isfinite(s.liftoff)
                   else (0.0 if not np.isfinite(s.strike) else dur) for s in stances]
    where, facing = _path_at(np.array([s.center if at is None else at for s, at in zip(stances, standing_at)]),
                             t, v, spec.tau)
    for s, at, p, h in zip(stances, standing_at, where, facing):
        standing = at is not None
        side = 1.0 if s.foot == 0 else -1.0
        s.heading = h + side * (np.radians(8) if standing else g.toe_out)
        # leaning into a turn, the body is inside its feet by leg height x tan(lean)
        inward = 0.0 if standing else LEG_HEIGHT * size * np.tan(_lean(spec, spec.v))
        s.pos = p + (side * (0.1 * size if standing else g.width) - inward) * _left(h)[0]

    # feet
    feet = [rig.foot_chain(x)[0] for x in SIDES]
    foot_m = np.zeros((2, F, 4, 4))
    toe_bend = np.zeros((2, F))
    for i, side in enumerate(SIDES):
        rest_foot = rig.rest[feet[i]]
        heel_g = rest_foot[:3, 3] * [1, 1, 0]  # the ground under the ankle
        ball_j = rig.ball_local(side)[:3] @ rest_foot[:3, :3].T + rest_foot[:3, 3]  # the ball joint
        ball_g = ball_j * [1, 1, 0]  # the ground under it
        foot_m[i], toe_bend[i] = _foot_track(t, [s for s in stances if s.foot == i], rest_foot,
                                             heel_g, ball_g, ball_j, g, T, HEEL_BACK * size)

    # body: height, sway, rotation
    sigma = _sway_signal(t, stances)
    lift = _leg_forward(foot_m, root, heading, g, spec)
    if spec.kind == "idle":
        sigma = 0.6 * np.sin(2 * np.pi * t / dur)
    run = g.name == "run"
    bob = (-1.0 if run else 1.0) * g.bob * (2 * sigma ** 2 - 1)
    height = stand_height + (g.height - stand_height + bob) * ramp
    if spec.kind == "idle":
        height = stand_height - 0.004 * size * (1 - np.cos(4 * np.pi * t / dur))
    if spec.kind == "jump":
        flying = _ballistic(t, height, stances, dip=0.06 * size)
        # the swinging feet rise with the body
        rise = np.maximum(flying - height, 0.0)
        for k in range(2):
            down = np.zeros(F, bool)
            for s in stances:
                down |= (s.foot == k) & (t >= s.strike) & (t <= s.liftoff)
            foot_m[k, ~down, 2, 3] += rise[~down]
        height = flying
    sway = (g.sway if spec.kind != "idle" else 0.03 * size) * sigma * np.maximum(ramp, spec.kind == "idle")
    pos = np.c_[root + sway[:, None] * _left(heading), height]
    # lean: forward with speed, into turns (centripetal), pelvic list and rotation
    accel_lean = np.gradient(gaussian_filter1d(v, 0.15 * fps, mode="nearest"), t) * 0.03
    pitch = g.lean * ramp + accel_lean
    roll = _lean(spec, v) - g.pelvis_roll * sigma * ramp
    yaw = heading - g.pelvis_yaw * lift * ramp
    R_body = _yaw(yaw) @ Rotation.from_euler("YX", np.c_[roll, pitch]).as_matrix()

    basis = np.tile(np.eye(4), (F, len(rig.names), 1, 1))
    hips = rig.role_index("hips")
    rest_h = rig.rest[hips]
    arm_h = np.tile(np.eye(4), (F, 1, 1))
    arm_h[:, :3, :3] = R_body @ rest_h[:3, :3]
    arm_h[:, :3, 3] = pos
    # reach: lower the hips where an ankle is out of the leg's reach
    thigh = [rig.role_index(f"thigh_{x}") for x in SIDES]
    need = np.zeros(F)
    for k in range(2):
        H = pos + np.einsum("fij,j->fi", R_body, rig.rest[thigh[k], :3, 3] - rest_h[:3, 3])
        need = np.maximum(need, reach_need(H, foot_m[k, :, :3, 3], REACH * sum(leg_lengths(rig, SIDES[k]))))
    win = max(1, int(round(0.12 * fps)))
    if spec.kind == "cycle":  # a loop: its last frame is its first
        drop = lower_smoothly(np.maximum(need[:-1], 0.0), win, mode="wrap", edge="wrap")
        drop = np.maximum(np.r_[drop, drop[:1]], need)
    else:
        drop = lower_smoothly(np.maximum(need, 0.0), win, edge="nearest")
        drop = np.maximum(drop, need)
    arm_h[:, 2, 3] -= drop
    basis[:, hips] = np.linalg.inv(rest_h)[None] @ arm_h

    _upper_body(rig, basis, lift, sigma, ramp, g, spec, t)

    # legs
    pose = forward_kinematics(rig, basis, bones=feet)
    fwd = np.c_[np.sin(heading), -np.cos(heading), np.zeros(F)]
    for k, side in enumerate(SIDES):
        th, sh, ft = thigh[k], rig.role_index(f"shin_{side}"), feet[k]
        L1, L2 = leg_lengths(rig, side)
        Wt, Ws, Wf = pose[:, th], pose[:, sh], pose[:, ft]
        r1, r2 = two_bone(Wt[:, :3, 3], Ws[:, :3, 3], Wf[:, :3, 3], foot_m[k, :, :3, 3], L1, L2, fwd)
        arm = {th: r1 @ Wt[:, :3, :3], sh: r2 @ r1 @ Ws[:, :3, :3], ft: foot_m[k, :, :3, :3]}
        chain_bases(rig, [th, sh, ft], pose[:, rig.parents[th], :3, :3], arm, basis)
        toe = rig.foot_chain(side)[1]
        if toe is not None:  # the toes bend up as the heel rises (about the foot's width)
            R = rig.rest[toe, :3, :3]
            D = Rotation.from_rotvec(np.c_[-toe_bend[k], np.zeros(F), np.zeros(F)]).as_matrix()
            basis[:, toe, :3, :3] = R.T @ D @ R
    return GaitClip(spec, float(fps), basis, stances, drop)


def _lean(spec: ClipSpec, v):
    """Lean into the turn (radians, positive to the left) at speed v: the centripetal
    angle, atan(v^2 tau / g), or the gait's share of it."""
    return spec.gait.turn_lean * np.arctan(np.asarray(v) ** 2 * spec.tau / G)


def _foot_track(t, stances, rest_foot, heel_g, ball_g, ball_j, g: Gait, T: float, heel_back_m: float = HEEL_BACK):
    """(F, 4, 4) armature-space matrices of one foot bone: planted and rolling during its
    stances, swinging in between; and (F,) how far the toes bend up (radians) to stay flat
    on the ground while the heel is up (easing back early in the swing)."""
    F = len(t)
    out = np.zeros((F, 4, 4))
    bend = np.zeros(F)
    nominal = g.duty * T
    # the heel rocker pivots on the back of the heel, behind the ankle: the ankle rises as
    # the toes do (it is lowest with the foot flat, where the analysis finds its stance)
    heel_back = heel_g + heel_back_m * (heel_g - ball_g) / np.linalg.norm(heel_g - ball_g)

    def planted(s, tq):
        """Foot matrices at times tq inside stance s."""
        a_start = s.strike if np.isfinite(s.strike) else None
        a_end = s.liftoff if np.isfinite(s.liftoff) else None
        dur = (a_end - a_start) if (a_start is not None and a_end is not None) else nominal
        pitch = np.zeros(len(tq))
        pivot = np.zeros((len(tq), 3))
        pivot[:] = heel_back
        if a_start is not None:
            u = (tq - a_start) / (g.heel_rocker * dur)
            pitch -= np.where(u < 1, g.strike_pitch * (1 - smoothstep(u)), 0.0)
        if a_end is not None:
            u = (tq - (a_end - g.toe_rocker * dur)) / (g.toe_rocker * dur)
            toe = u > 0
            pitch += np.where(toe, g.toeoff_pitch * np.clip(u, 0.0, 1.0) ** 2, 0.0)
            # the foot rolls over the ball: about the ground under its joint, raised so
            # the joint keeps its height (the toes stay flat on the ground)
            pivot[toe] = ball_g
            m = _placed(s, pitch, pivot, rest_foot, heel_g)
            m[toe, 2, 3] += ball_j[2] * (1.0 - np.cos(pitch[toe]))
            return m
        return _placed(s, pitch, pivot, rest_foot, heel_g)

    for s in stances:
        m = (t >= s.strike) & (t <= s.liftoff)
        if m.any():
            out[m] = planted(s, t[m])
            bend[m] = np.maximum(_pitch_of(out[m], rest_foot), 0.0)
    for a, b in zip(stances[:-1], stances[1:]):
        m = (t > a.liftoff) & (t < b.strike)
        if not m.any():
            continue
        m0 = planted(a, np.array([a.liftoff]))[0]
        m1 = planted(b, np.array([b.strike]))[0]
        u = (t[m] - a.liftoff) / (b.strike - a.liftoff)
        # (a smoothstep, not a minimum-jerk profile: its peak speed is 20 % lower, which
        # spares the thigh a whip through mid swing)
        w = smoothstep(u)
        p = (1 - w)[:, None] * m0[:3, 3] + w[:, None] * m1[:3, 3]
        # the lift peaks early (the foot leaves briskly, and lands softly)
        p[:, 2] += b.clearance * (6.75 * u * (1 - u) ** 2)
        rel = Rotation.from_matrix(m0[:3, :3].T @ m1[:3, :3]).as_rotvec()
        R = m0[:3, :3] @ Rotation.from_rotvec(w[:, None] * rel).as_matrix()
        out[m, :3, :3] = R
        out[m, :3, 3] = p
        out[m, 3, 3] = 1.0
        # heel and ball never pass under the ground (the swing's ends are on it)
        lift = np.zeros(m.sum())
        for q in (heel_g, ball_g):
            local = np.linalg.inv(rest_foot) @ np.append(q, 1.0)
            z = np.einsum("fij,j->fi", out[m], local)[:, 2]
            lift = np.maximum(lift, -z)
        out[m, 2, 3] += lift
        bend[m] = g.toeoff_pitch * (1.0 - smoothstep(u / 0.6))
    return out, bend


def _pitch_of(m, rest_foot) -> np.ndarray:
    """Heel-up pitch (radians) of foot matrices (F, 4, 4) relative to the rest foot."""
    fwd = np.einsum("fij,j->fi", m[:, :3, :3], rest_foot[:3, :3].T @ [0.0, -1.0, 0.0])
    return np.arctan2(-fwd[:, 2], np.hypot(fwd[:, 0], fwd[:, 1]))


def _placed(s: Stance, pitch, pivot, rest_foot, heel_g) -> np.ndarray:
    """The rest foot laid on stance s's footprint (its heel ground point on s.pos, turned
    to s.heading), pitched by ``pitch`` (positive: heel up) about ``pivot`` (rest
    coordinates on the ground)."""
    n = len(pitch)
    Rp = Rotation.from_rotvec(np.c_[pitch, np.zeros(n), np.zeros(n)]).as_matrix()
    Rz = _yaw(s.heading)[0]
    out = np.tile(np.eye(4), (n, 1, 1))
    out[:, :3, :3] = Rz @ Rp @ rest_foot[:3, :3]
    # x -> P + Rp (x - P), then the heel ground point to s.pos
    local = pivot + np.einsum("fij,fj->fi", Rp, rest_foot[:3, 3] - pivot)
    out[:, :3, 3] = np.einsum("ij,fj->fi", Rz, local - heel_g) + np.r_[s.pos, 0.0]
    return out


def _sway_signal(t, stances) -> np.ndarray:
    """+1 at the left foot's mid-stances, -1 at the right's, cosine in between (0 where
    both feet stand)."""
    knots = sorted((s.center, s.foot) for s in stances if np.isfinite(s.strike) and np.isfinite(s.liftoff))
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


def _ballistic(t, height, stances, dip: float = 0.06) -> np.ndarray:
    """Replace the hips' height in the longest flight by a ballistic arc (gravity) that
    meets the height profile at take-off and landing with its slope."""
    down = np.zeros(len(t), bool)
    for s in stances:
        down |= (t >= s.strike) & (t <= s.liftoff)
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
    w = 0.25
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
