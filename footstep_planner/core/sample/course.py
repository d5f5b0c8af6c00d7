"""A sample clip's path and timing (``gait``'s steps 1 and 2): the frame times, the speed
along the path (ramping up from standing or down to it), the stances at the gait's
cadence and duty factor (standing feet at a start's or stop's end, a jump's flight), the
path itself (a line or an arc of curvature tau), and the footprints laid beside it where
the hips are at mid-stance (``_course``, ``_place_footprints``); the lean into a turn.

Armature space of the mannequin: Z up, metres, heading 0 faces -Y; foot 0 is the left.
Never imports bpy.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..clips.clip import root_frames
from ..footprint import STAND_HALF_WIDTH
from ..solve.easing import smoothstep
from .specs import ClipSpec, GaitStance

G = 9.81
#: Height of the hip joints over the feet when leaning into a turn, m.
LEG_HEIGHT = 0.8


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


# ---------------------------------------------------------------------------- path

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


def _yaw_matrices(h):
    """(N, 3, 3) rotations about +Z by the angles h."""
    h = np.atleast_1d(np.asarray(h, float))
    return root_frames(np.zeros((len(h), 3)), h)[:, :3, :3]


def _left(h):
    """The character's left (armature +X at heading 0) at heading h: (F, 2)."""
    return np.c_[np.cos(h), np.sin(h)]


#: Standing feet (each footprint ``footprint.STAND_HALF_WIDTH`` from the path, at the
#: mannequin's scale): toes this much out (radians).
STAND_TOE_OUT = np.radians(8)


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
    (STAND_HALF_WIDTH, STAND_TOE_OUT, times ``size``) where the hips are at the clip's start
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
        st.pos = p + (side * (STAND_HALF_WIDTH * size if standing else g.width) - inward) * _left(h)[0]


def _lean(spec: ClipSpec, v):
    """Lean into the turn (radians, positive to the left) at speed v: the centripetal
    angle, atan(v^2 tau / g), or the gait's share of it."""
    return spec.gait.turn_lean * np.arctan(np.asarray(v) ** 2 * spec.tau / G)
