"""The passes of the synthesis (thesis 3.3, 3.5 to 3.7): the smoothing (``_smooth``), one
play-refine-carry round (``Pass``, ``_one_pass``, with what both rounds share in a
``PassContext``: the clips played, the footprints refined, the body carried onto them;
the standing body, a turn in place's body), the path's end eased onto the goal
(``ease_end``), the blend groups' curvature tau (``_tau_curves``), walk/run speed pins
(``speed_pins``) and weights (``_LocoWeights``), and the blend groups' pass
(``_final_pass``).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Callable

import numpy as np

from . import blend_groups as bg
from ..base.settings import Settings
from ..base.timing import StageTimer
from ..clips.library import Library
from ..clips.steps import bend_chain
from .blending import Playback, playback
from .labels import _clip_tau
from .refinement import Refined, refine
from .schedule import PlanStep, Schedule, build_schedule, step_durations_of
from .smoothing import Smoothed, smooth_footprints
from .standing import Standing
from .tracks import ClipTrack
from .trajectory import transfer_body


SnapFn = Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]


#: Footprints before the last two over which the path's end is eased onto the goal.
GOAL_STEPS = 4


#: m: a body that ends further than this from the goal gets one more pass.
GOAL_TOLERANCE = 0.02


#: Hz at which the curvature tau is estimated and low-passed.
TAU_RATE = 10.0


@dataclass
class Pass:
    """One play-refine-carry round."""

    schedule: Schedule
    played: Playback
    refined: Refined
    body_pos: np.ndarray  # (F, 3) desired body trajectory R^D
    body_heading: np.ndarray  # (F,) Q^D


def speed_pins(steps: list[PlanStep], tracks: dict[str, ClipTrack], gaits=None,
               corners=None, blends=None) -> list[tuple[float, float]]:
    """(u, s) where the walk/run parameter is known: walking at the start and the end,
    each special clip's entry and exit gait at its take-off and landing, running in
    the middle of each step the plan runs (``gaits`` (len(steps),), the gait of the step
    to each footprint: a run the planner chose, not only a jump's run-up), and walking in
    the middle of each corner (``corners`` (len(steps),) bool, ``Library.corners``: a
    walk's turn tighter than any run turns, where the run slows into the walk; without
    that pin a few walking steps between runs play as a run), and at its blend in the
    middle of each step a jog laid (``blends`` (len(steps),) s or None,
    ``PathFootprint.speed``: ``perform.stride``; a jog's pin is kept through its corners,
    which its laying turns no tighter than the plan did: a corner's walking pin on every
    other step of a jog would blend the run in and out at each step)."""
    val = {"walk": 0.0, "run": 1.0, "stand": 0.0}
    pins = [(0.0, 0.0)]
    for j, s in enumerate(steps):
        if s.special:
            tr = tracks[s.special]
            pins.append((float(j), val.get(tr.entry_gait, 0.0)))
            pins.append((float(j + 1), val.get(tr.exit_gait, 0.0)))
        elif gaits is not None and gaits[j] == "run" and 0 < j < len(steps) - 1:
            pins.append((j + 0.5, 1.0))
        elif blends is not None and blends[j] is not None and 0 < j < len(steps) - 1:
            pins.append((j + 0.5, float(blends[j])))
        elif corners is not None and corners[j]:
            pins.append((j + 0.5, 0.0))
    pins.append((float(len(steps)), 0.0))
    return sorted(pins, key=lambda p: p[0])


def _smooth(path, settings: Settings, snap, goal, fixed=1) -> Smoothed:
    """3.3: the planned footprints smoothed, the first and last ``fixed`` kept (a number,
    or (first, last)), and every footprint the planner set on a stair's tread
    (``PathFootprint.tread``); with a goal, the path's end first eased so that the body
    ends between the last two feet on it."""
    pos0 = np.array([f.position for f in path], float)
    head0 = np.unwrap(np.array([f.heading for f in path], float))
    if goal is not None:
        pos0 = ease_end(pos0, head0, np.asarray(goal, float)[:2] - 0.5 * (pos0[-1, :2] + pos0[-2, :2]), snap,
                        kept=np.array([f.tread for f in path], bool))
    keep = np.zeros(len(pos0), bool)
    first, last = (fixed, fixed) if np.ndim(fixed) == 0 else fixed
    keep[:first] = keep[len(keep) - last:] = True
    keep |= np.array([f.tread for f in path], bool)
    return smooth_footprints(pos0, head0, settings.smoothing_iterations, snap, fixed=keep,
                             preserve_arcs=settings.smoothing_keep_arcs)


def ease_end(pos: np.ndarray, heading: np.ndarray, off, snap: SnapFn | None = None,
             steps: int = GOAL_STEPS, kept: np.ndarray | None = None) -> np.ndarray:
    """The path's last two footprints moved by ``off`` (x, y), the ``steps`` before them by
    less and less, but for the ``kept`` (N,) bool ones (on a stair's tread); a footprint
    the surface refuses at its new place goes half or a quarter of the way where it may
    stand, else keeps its old place."""
    pos = np.array(pos, float, copy=True)
    n = len(pos)
    if off is None or n < 3 or not np.any(off):
        return pos
    w = np.zeros(n)
    w[-2:] = 1.0
    k = min(steps, n - 3)
    if k > 0:
        w[n - 2 - k:n - 2] = (np.arange(1, steps + 1) / (steps + 1))[-k:]
    if kept is not None:
        w[np.asarray(kept, bool)] = 0.0
    moved = pos.copy()
    moved[:, :2] += w[:, None] * np.asarray(off, float)[:2]
    sel = np.flatnonzero(w > 0)
    if snap is None or not len(sel):
        return moved
    heading = np.asarray(heading, float)[sel]
    sp, ok = snap(moved[sel], heading)
    moved[sel] = np.where(ok[:, None], sp, pos[sel])
    for share in (0.5, 0.25):  # a refused footprint goes part of the way, where it may stand
        todo = sel[~ok]
        if not len(todo):
            break
        part = pos[todo].copy()
        part[:, :2] += share * w[todo, None] * np.asarray(off, float)[:2]
        sp2, ok2 = snap(part, heading[~ok])
        moved[todo] = np.where(ok2[:, None], sp2, pos[todo])
        ok[~ok] = ok2
    return moved


@dataclass(frozen=True)
class PassContext:
    """What both play-refine-carry rounds of a synthesis share (``_one_pass``, ``_final_pass``).

    ``tracks``: clip name -> ``ClipTrack``. ``forward``: (3,) the world direction of
    heading 0, None for the clips' rest forward. ``settings``: the synthesis's
    ``Settings``. ``snap``: keeps footprints on the surface (``SnapFn``), or None.
    ``timer``: the ``StageTimer`` the stages are timed on (s). ``bends``: (N-1,) 1/m, how
    the planner bent each step, or None. ``stand``: the ``Standing`` at either end, or
    None. ``pinned``: every footprint stays where it is desired (a turn in place's pivot
    steps). ``kept``: (N,) bool, the footprints that stay where they are desired whatever
    (the planner set them square and whole on a stair's tread, ``PathFootprint.tread``),
    or None."""

    tracks: dict
    forward: np.ndarray | None
    settings: Settings
    snap: SnapFn | None
    timer: StageTimer
    bends: np.ndarray | None = None
    stand: Standing | None = None
    pinned: bool = False
    kept: np.ndarray | None = None


def _one_pass(ctx: PassContext, schedule: Schedule, desired_pos, desired_head, key: str) -> Pass:
    """One round: play the schedule, refine the played footprints (each step bent by
    ``ctx.bends`` (N-1,) 1/m, as the planner bent it) towards the desired ones (stage
    ``refinement<key>``), carry the played body onto them (``body_trajectory<key>``).
    With ``ctx.stand`` the standing feet at either end stay where they are desired and the
    body stands over them (``stand_body``) as the standing clip takes over. ``ctx.pinned``:
    every footprint stays where it is desired (a turn in place's pivot steps)."""
    tracks, forward, settings, snap, timer = ctx.tracks, ctx.forward, ctx.settings, ctx.snap, ctx.timer
    bends, stand, pinned = ctx.bends, ctx.stand, ctx.pinned
    fwd = forward if forward is not None else next(iter(tracks.values())).rest_forward
    with timer(f"refinement{key}"):
        played = playback(schedule, tracks, start=(desired_pos[0], desired_head[0]), forward=forward)
        orig = bend_chain(played.footprints, played.footprint_heading, bends, fwd)
        fixed = None
        if stand is not None or pinned:
            fixed = np.full(len(desired_pos), pinned)
            fixed[[0, 1, -2, -1]] = True
        if ctx.kept is not None and ctx.kept.any():
            if fixed is None:  # (refine's own default: the first and the last)
                fixed = np.zeros(len(desired_pos), bool)
                fixed[[0, -1]] = True
            fixed = fixed | ctx.kept
        refined = refine(*orig, desired_pos, desired_head, settings.refinement_iterations, snap, fixed=fixed,
                         height=getattr(snap, "height", None))
    with timer(f"body_trajectory{key}"):
        body_pos, body_head = transfer_body(played.footprints, played.footprint_heading, refined.position,
                                            refined.heading, schedule.walk_times, played.root,
                                            played.heading, schedule.walk_t)
        if pinned:  # (turning on the spot: the body turns steadily, not step by step)
            body_head = _steady(body_head, schedule.fps)
        if stand is not None:
            body_pos, body_head = stand_body(schedule, tracks[stand.clip], refined, body_pos, body_head, fwd)
        if pinned:
            body_pos = _on_the_spot(body_pos, schedule.t)
    return Pass(schedule, played, refined, body_pos, body_head)


def _on_the_spot(body_pos: np.ndarray, t: np.ndarray) -> np.ndarray:
    """A turn in place's body (F, 3) kept over the spot it stands on, first to last (eased
    from one to the other), at the heights it has: the walk's body, carried onto pivot
    steps, would sway back and forth with its steps' lead and lag."""
    out = np.array(body_pos, float, copy=True)
    u = (t - t[0]) / max(t[-1] - t[0], 1e-9)
    u = u * u * (3.0 - 2.0 * u)
    out[:, :2] = (1.0 - u)[:, None] * body_pos[0, :2] + u[:, None] * body_pos[-1, :2]
    return out


#: s: the Gaussian width over which a turn in place's body heading is smoothed
TURN_SMOOTHING = 0.3


def _steady(heading: np.ndarray, fps: float) -> np.ndarray:
    """A body heading (F,) low-passed over TURN_SMOOTHING s, its ends kept."""
    from scipy.ndimage import gaussian_filter1d

    return gaussian_filter1d(np.asarray(heading, float), TURN_SMOOTHING * fps, mode="nearest")


def stand_body(S: Schedule, track: ClipTrack, refined: Refined, body_pos: np.ndarray, body_head: np.ndarray,
               forward) -> tuple[np.ndarray, np.ndarray]:
    """The body (F, 3), (F,) moved, as far as the standing clip (``track``, the last column
    of ``S``) has weight, to where that clip's feet stand on the standing footprints: the
    first two at the start, the last two at the end, facing their mean heading."""
    lam = S.weights[:, -1]
    smp = track.sample(S.clip_time[[0, -1], -1])
    mid = 0.5 * (smp["heel"] + smp["toe"])  # (2 feet, 2 ends, 3) root frame
    spin = float(np.arctan2(forward[1], forward[0]) - np.arctan2(track.rest_forward[1], track.rest_forward[0]))
    pos, head = refined.position, refined.heading
    out_p, out_h = np.array(body_pos, float, copy=True), np.array(body_head, float, copy=True)
    end = S.t >= 0.5 * (S.t[0] + S.t[-1])
    for k, (a, b) in enumerate(((0, 1), (-2, -1))):
        h = head[a] + 0.5 * float(np.angle(np.exp(1j * (head[b] - head[a]))))
        c = np.angle(np.exp(1j * (h + spin)))
        local = 0.5 * (mid[0, k] + mid[1, k])
        root = 0.5 * (pos[a] + pos[b])[:2] - [np.cos(c) * local[0] - np.sin(c) * local[1],
                                               np.sin(c) * local[0] + np.cos(c) * local[1]]
        sel = end if k else ~end
        w = lam[sel]
        out_p[sel, :2] += w[:, None] * (root - out_p[sel, :2])
        out_h[sel] += w * np.angle(np.exp(1j * (h - out_h[sel])))
    return out_p, out_h


@dataclass
class _TauCurves:
    plan: np.ndarray  # (F1,) the plan's clips' own tau, blended by the first weights
    raw: np.ndarray  # (F1,) the first pass's body trajectory's tau
    tau: np.ndarray  # (F1,) that, low-passed


#: Share of its median speed under which the body's curvature is not read (``_tau_curves``).
TAU_MIN_SPEED = 0.5


def _tau_curves(library: Library, cyc: list[str], sch1: Schedule, first: Pass, settings: Settings) -> _TauCurves:
    """3.7: the curvature tau (1/m) of the first pass's body trajectory, estimated and
    low-passed at TAU_RATE Hz (the filter keeps nothing faster than a step), read at
    every frame of the first schedule; and the plan's own tau for comparison."""
    cyc_tau = np.array([_clip_tau(library, c) for c in cyc])
    wc = sch1.weights[:, :len(cyc)]
    tau_plan = (wc @ cyc_tau) / np.maximum(wc.sum(axis=1), 1e-9)
    wt = sch1.walk_t  # on the walk's own time: a standing body has no curvature
    tc = np.linspace(wt[0], wt[-1], max(8, int(np.ceil((wt[-1] - wt[0]) * TAU_RATE)) + 1))
    body_c = np.stack([np.interp(tc, wt, first.body_pos[:, k]) for k in range(3)], axis=1)
    tau_c = bg.curvature(body_c, tc, settings.tau_dt)
    # where the body barely goes on (standing, a start clip's weight shift onto the first
    # foot) a sideways move reads as a tight turn: those samples take their neighbours'
    speed = np.linalg.norm(np.gradient(body_c[:, :2], tc, axis=0), axis=1)
    fast = speed >= TAU_MIN_SPEED * max(float(np.median(speed)), 1e-9)
    if fast.any() and not fast.all():
        tau_c = np.interp(tc, tc[fast], tau_c[fast])
    tau_raw = np.interp(wt, tc, tau_c)
    tau = np.interp(wt, tc, bg.smooth_signal(tc, tau_c, settings.tau_smoothing / (2 * np.pi)))
    return _TauCurves(tau_plan, tau_raw, tau)


class _LocoWeights:
    """The cyclic clips' weights (N, C) at normalized times u (footsteps): each gait's
    turning group blended by tau, walk and run by the speed parameter s."""

    def __init__(self, groups: dict, cyc: list[str], u_tau: np.ndarray, tau: np.ndarray, pins, sigma: float):
        self.walk, self.run = groups.get("walk"), groups.get("run")
        self.cyc, self.u_tau, self.tau, self.sigma = cyc, u_tau, tau, sigma
        self.pin_u, self.pin_s = zip(*pins)

    def __call__(self, u: np.ndarray) -> np.ndarray:
        tau_u = np.interp(u, self.u_tau, self.tau)
        parts = []
        for g in (self.walk, self.run):
            if g is None or not g.clips:
                continue
            w = bg.group_weights(np.array([c.tau for c in g.clips]), tau_u)
            full = np.zeros((len(u), len(self.cyc)))
            for k, c in enumerate(g.clips):
                full[:, self.cyc.index(c.clip)] += w[:, k]
            parts.append(full)
        if len(parts) == 2:
            sp = bg.speed_parameter(u, self.pin_u, self.pin_s, self.sigma)
            return (1.0 - sp)[:, None] * parts[0] + sp[:, None] * parts[1]
        return parts[0]

    def speed(self, u: np.ndarray, n: int) -> np.ndarray:
        """(n,) the walk/run parameter s at ``u`` (constant 0 or 1 with one gait only)."""
        walk, run = self.walk, self.run
        if walk and run and walk.clips and run.clips:
            return bg.speed_parameter(u, self.pin_u, self.pin_s, self.sigma)
        return np.full(n, 1.0 if run and not walk else 0.0)


def _blend_group_schedule(steps: list[PlanStep], tracks, cyc: list[str], fps: float, settings: Settings,
                          loco: _LocoWeights, standing: Standing | None = None, rate=None) -> Schedule:
    """The schedule under the blend groups' weights, each step lasting what its clips'
    weights (evaluated mid-step) make it last, over its pace ``rate`` (len(steps),)."""
    wmid = loco(np.arange(len(steps)) + 0.5)
    feet = np.array([st.foot for st in steps])
    dur = (wmid * step_durations_of([tracks[c] for c in cyc])[feet]).sum(axis=1)
    return build_schedule(steps, tracks, cyc, fps, settings.transition_time, loco_weights=loco,
                          step_durations=dur, standing=standing, pace=rate)


def _final_pass(ctx: PassContext, sch2: Schedule, first: Pass, goal) -> Pass:
    """The blend groups' pass. With a goal, the path's end is moved by where the first
    pass's body ended, and once more (not pinned) if the blend groups still miss it by
    more than GOAL_TOLERANCE."""
    desired, heading = first.refined.position, first.refined.heading
    if goal is not None:
        desired = ease_end(desired, heading, np.asarray(goal, float)[:2] - first.body_pos[-1, :2], ctx.snap,
                           kept=ctx.kept)
    final = _one_pass(ctx, sch2, desired, heading, "_2")
    if goal is not None:
        miss = np.asarray(goal, float)[:2] - final.body_pos[-1, :2]
        if np.linalg.norm(miss) > ctx.settings.length(GOAL_TOLERANCE):
            desired = ease_end(desired, heading, miss, ctx.snap, kept=ctx.kept)
            final = _one_pass(replace(ctx, pinned=False), sch2, desired, heading, "_2")
    return final
