"""Motion synthesis: from a footprint path to a body trajectory with blended clips
(thesis 3.3 to 3.7), each stage timed and kept for review.

    smoothing      3.3  binomial kernels on the footprints, snapped to the surface
    refinement     3.5  play the plan's clips (0.3 s transitions), pull the footprints
                        towards what the clips do locally
    body trajectory 3.6 the played body, carried from the played footprints' midpoint
                        spline to the desired footprints' one
    blend groups   3.7  turning weights from the curvature tau of that trajectory, walk/run
                        weights from the speed parameter s; then play, refine and carry the
                        body again

Conventions: world Z up, metres, seconds; headings in radians about +Z relative to the
world forward (the rig's rest forward as the character stands in the scene), positive
turning left; tau positive turning left. Normalized time u counts footsteps.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from . import blend_groups as bg
from .analysis import ClipAnalysis
from .blending import (BlendError, ClipTrack, PlanStep, Playback, Schedule, build_schedule, make_track,
                       playback, step_durations_of)
from .library import Library
from .refinement import Refined, refine
from .settings import Settings
from .smoothing import Smoothed, smooth_footprints
from .steps import bend_chain
from .surface import FootShape, Ground, footprint_support
from .timing import StageTimer
from .trajectory import transfer_body

SnapFn = Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]

#: Footprints before the last two over which the path's end is eased onto the goal.
GOAL_STEPS = 4

#: m: a body that ends further than this from the goal gets one more pass.
GOAL_TOLERANCE = 0.02

#: Hz at which the curvature tau is estimated and low-passed.
TAU_RATE = 10.0

#: Table 4.1's stage columns, in order.
STAGES = ("smoothing", "refinement", "body_trajectory", "blend_groups")


@dataclass
class Pass:
    """One play-refine-carry round."""

    schedule: Schedule
    played: Playback
    refined: Refined
    body_pos: np.ndarray  # (F, 3) desired body trajectory R^D
    body_heading: np.ndarray  # (F,) Q^D


@dataclass
class Synthesis:
    plan: list  # the planned path (navgraph.PathFootprint)
    settings: Settings
    clips: list[str]  # the weight columns
    smoothed: Smoothed
    first: Pass  # the plan's own clips
    tau_plan: np.ndarray  # (F1,) the plan's clips' own tau, blended by the first weights
    tau_raw: np.ndarray  # (F1,) on the first pass's frames
    tau: np.ndarray  # (F1,) smoothed
    final: Pass  # blend groups
    tau_final: np.ndarray  # (F,) tau and s on the final frames
    s_final: np.ndarray
    speed_pins: list[tuple[float, float]]
    seconds: dict = field(default_factory=dict)  # stage -> s
    tracks: dict = field(default_factory=dict, repr=False)  # clip name -> ClipTrack

    # ------------------------------------------------------------------ results
    @property
    def t(self) -> np.ndarray:
        return self.final.schedule.t

    @property
    def body_position(self) -> np.ndarray:
        return self.final.body_pos

    @property
    def body_heading(self) -> np.ndarray:
        return self.final.body_heading

    @property
    def weights(self) -> np.ndarray:
        return self.final.schedule.weights

    @property
    def clip_time(self) -> np.ndarray:
        return self.final.schedule.clip_time

    @property
    def footprints(self) -> tuple[np.ndarray, np.ndarray]:
        r = self.final.refined
        return r.position, r.heading

    def planted(self) -> list[tuple[float, float, float]]:
        """Per footprint: (strike time, stance time, liftoff time) in seconds, from the
        blended contact of its foot around its stance."""
        return planted_ranges(self.final.schedule, self.final.played)

    def to_dict(self, frame0: float = 1.0) -> dict:
        S = self.final.schedule
        fps = S.fps
        fr = lambda t: round(frame0 + float(t) * fps, 2)  # noqa: E731
        pos, head = self.footprints
        r4 = lambda a: np.round(np.asarray(a, float), 4).tolist()  # noqa: E731
        planted = self.planted()
        return {
            "fps": fps, "frame_start": frame0, "frames": S.n,
            "clips": list(self.clips),
            "footprints": [{"foot": "LR"[int(S.feet[i])], "position": r4(pos[i]),
                            "heading": round(float(head[i]), 4),
                            "planned": r4(self.plan[i].position),
                            "smoothed": r4(self.smoothed.position[i]),
                            "played": r4(self.final.played.footprints[i]),
                            "frame": fr(planted[i][1]),
                            "planted": [fr(planted[i][0]), fr(planted[i][2])]}
                           for i in range(len(pos))],
            "curves": {
                "time": r4(S.t), "u": r4(S.u), "tau": r4(self.tau_final), "s": r4(self.s_final),
                "tau_first": {"time": r4(self.first.schedule.t), "plan": r4(self.tau_plan),
                              "raw": r4(self.tau_raw), "smoothed": r4(self.tau)},
                "speed_pins": [[round(u, 3), s] for u, s in self.speed_pins],
            },
            "body": {"position": r4(self.body_position), "heading": r4(self.body_heading)},
            "weights": {c: r4(self.weights[:, i]) for i, c in enumerate(self.clips)},
            "clip_time": {c: r4(self.clip_time[:, i]) for i, c in enumerate(self.clips)},
            "refinement": {"first": r4(self.first.refined.mismatch),
                           "final": r4(self.final.refined.mismatch)},
            "seconds": {k: round(v, 5) for k, v in self.seconds.items()},
        }


# ----------------------------------------------------------------------------- pieces

def stage_row(footprints: int, search_seconds: float, syn: "Synthesis", **later) -> dict:
    """One row of thesis Table 4.1, in ms: footprints, frames, the search, the synthesis
    stages (STAGES) and any later stages given in seconds (``pose_blend=``, ``ik=``,
    ``bake=``). ``synthesis_ms`` sums everything from smoothing to IK (not the search
    nor the bake); ``per_frame_ms`` is that over the frames."""
    frames = int(len(syn.t))
    row = {"footprints": int(footprints), "frames": frames, "search_ms": round(search_seconds * 1e3, 3)}
    seconds = {k: syn.seconds[k] for k in STAGES}
    seconds.update(later)
    for k, v in seconds.items():
        row[f"{k}_ms"] = round(v * 1e3, 3)
    synth = sum(v for k, v in seconds.items() if k != "bake")
    row["synthesis_ms"] = round(synth * 1e3, 3)
    row["per_frame_ms"] = round(synth * 1e3 / max(frames, 1), 4)
    return row


def surface_snap(ground: Ground, obstacles: Ground | None, forward: np.ndarray, foot: FootShape,
                 clearance: float = 0.25, step_height: float = 0.3) -> SnapFn:
    """A snap for the smoothing and refinement stages: the footprint dropped onto the
    traversable surface under it (or pulled to the nearest surface point when there is
    none under it), and whether a foot may stand there (supported, clear of obstacles)."""

    def snap(pos: np.ndarray, heading: np.ndarray):
        pos = np.array(pos, float, copy=True)
        sup = footprint_support(ground, obstacles, pos, heading, forward, foot,
                                step_height=step_height, clearance=clearance)
        off = ~sup.ok & (sup.reason == "off surface")
        if off.any():
            near, _ = ground.nearest(pos[off], max_dist=0.5)
            pos[off] = np.where(np.isfinite(near), near, pos[off])
            again = footprint_support(ground, obstacles, pos[off], heading[off], forward, foot,
                                      step_height=step_height, clearance=clearance)
            sup.ok[off], sup.z[off] = again.ok, again.z
        pos[:, 2] = np.where(sup.ok, sup.z, pos[:, 2])
        return pos, sup.ok

    def height(pos: np.ndarray) -> np.ndarray:
        """The footprints dropped onto the surface under them (where there is one)."""
        pos = np.array(pos, float, copy=True)
        top = pos + [0.0, 0.0, step_height]
        hit = ground.ray_down(top, 2 * step_height)
        pos[:, 2] = np.where(hit.hit, hit.z, pos[:, 2])
        return pos

    snap.height = height
    return snap


def cyclic_clips(library: Library) -> list[str]:
    """The turning groups' clips, walk first, each group sorted by tau."""
    out = []
    for gait in ("walk", "run"):
        g = library.turn_groups.get(gait)
        if g:
            out += [c.clip for c in g.clips if c.clip not in out]
    for name, g in library.turn_groups.items():
        if name not in ("walk", "run"):
            out += [c.clip for c in g.clips if c.clip not in out]
    return out


def label_weights(label: str, library: Library, cyclic: list[str]) -> np.ndarray:
    """The cyclic clip weights (C,) of a plan step's label: a clip name, or
    "<group name>@<tau>" for a blend inside a turning group."""
    w = np.zeros(len(cyclic))
    if "@" in label:
        gname, tau = label.rsplit("@", 1)
        group = next((g for g in library.turn_groups.values() if g.name == gname), None)
        if group is None:
            raise BlendError(f"the plan uses blend group {gname!r}, which the clip library no longer has")
        for c, x in group.weights(float(tau)).items():
            w[cyclic.index(c)] += x
    elif label in cyclic:
        w[cyclic.index(label)] = 1.0
    else:
        raise BlendError(f"the plan uses clip {label!r}, which is not in the clip library's groups")
    return w


def _clip_tau(library: Library, clip: str) -> float:
    for g in library.turn_groups.values():
        for c in g.clips:
            if c.clip == clip:
                return c.tau
    return 0.0


def plan_steps(path, library: Library, cyclic: list[str]) -> list[PlanStep]:
    specials = {s.clip for s in library.specials}
    out = []
    for a, b in zip(path[:-1], path[1:]):
        if b.label in specials:
            out.append(PlanStep(a.foot, b.label, None))
        else:
            out.append(PlanStep(a.foot, None, label_weights(b.label, library, cyclic)))
    return out


def speed_pins(steps: list[PlanStep], tracks: dict[str, ClipTrack]) -> list[tuple[float, float]]:
    """(u, s) where the walk/run parameter is known: walking at the start and the end,
    and each special clip's entry and exit gait at its take-off and landing."""
    val = {"walk": 0.0, "run": 1.0, "stand": 0.0}
    pins = [(0.0, 0.0)]
    for j, s in enumerate(steps):
        if s.special:
            tr = tracks[s.special]
            pins.append((float(j), val.get(tr.entry_gait, 0.0)))
            pins.append((float(j + 1), val.get(tr.exit_gait, 0.0)))
    pins.append((float(len(steps)), 0.0))
    return pins


def planted_ranges(S: Schedule, pb: Playback) -> list[tuple[float, float, float]]:
    """(strike, stance, liftoff) seconds of each footprint: the run of blended contact
    (> 1/2) of its foot that holds its stance time, else the stance time alone."""
    out = []
    for i, T in enumerate(S.footprint_times):
        c = pb.contact[int(S.feet[i])] > 0.5
        k = int(np.clip(np.searchsorted(S.t, T), 0, S.n - 1))
        if not c[k]:
            out.append((float(T), float(T), float(T)))
            continue
        a = k - int(np.argmin(c[k::-1])) + 1 if not c[:k + 1].all() else 0
        b = k + int(np.argmin(c[k:])) - 1 if not c[k:].all() else S.n - 1
        out.append((float(S.t[a]), float(T), float(S.t[b])))
    return out


def _one_pass(schedule, tracks, desired_pos, desired_head, forward, settings: Settings, snap,
              timer: StageTimer, key: str, bends=None) -> Pass:
    """One round: play the schedule, refine the played footprints (each step bent by
    ``bends`` (N-1,) 1/m, as the planner bent it) towards the desired ones (stage
    ``refinement<key>``), carry the played body onto them (``body_trajectory<key>``)."""
    with timer(f"refinement{key}"):
        played = playback(schedule, tracks, start=(desired_pos[0], desired_head[0]), forward=forward)
        fwd = forward if forward is not None else next(iter(tracks.values())).rest_forward
        orig = bend_chain(played.footprints, played.footprint_heading, bends, fwd)
        refined = refine(*orig, desired_pos, desired_head,
                         settings.refinement_iterations, snap, height=getattr(snap, "height", None))
    with timer(f"body_trajectory{key}"):
        body_pos, body_head = transfer_body(played.footprints, played.footprint_heading, refined.position,
                                            refined.heading, schedule.footprint_times, played.root,
                                            played.heading, schedule.t)
    return Pass(schedule, played, refined, body_pos, body_head)


# ----------------------------------------------------------------------------- the pipeline

def ease_end(pos: np.ndarray, heading: np.ndarray, off, snap: SnapFn | None = None,
             steps: int = GOAL_STEPS) -> np.ndarray:
    """The path's last two footprints moved by ``off`` (x, y), the ``steps`` before them by
    less and less; a footprint the surface refuses at its new place goes half or a quarter
    of the way where it may stand, else keeps its old place."""
    pos = np.array(pos, float, copy=True)
    n = len(pos)
    if off is None or n < 3 or not np.any(off):
        return pos
    w = np.zeros(n)
    w[-2:] = 1.0
    k = min(steps, n - 3)
    if k > 0:
        w[n - 2 - k:n - 2] = (np.arange(1, steps + 1) / (steps + 1))[-k:]
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


def synthesize(path, library: Library, analyses: list[ClipAnalysis] | dict[str, ClipTrack],
               settings: Settings | None = None, fps: float = 30.0, forward=None,
               snap: SnapFn | None = None, goal=None) -> Synthesis:
    """Synthesize the motion of a planned path (``navgraph.PathFootprint`` list, feet
    alternating). ``analyses`` are the library's clips analysed (or their tracks);
    ``snap`` keeps footprints on the surface (see ``surface_snap``); ``forward`` is
    the world direction of heading 0 (default the clips' rest forward). With ``goal``
    the path's end is moved so that the body ends on it (the planner stops anywhere
    within its goal radius; see ``ease_end``)."""
    settings = settings or Settings()
    if len(path) < 2:
        raise BlendError("the path has a single footprint: the character is already at its goal")
    timer = StageTimer()
    with timer("total"):
        with timer("tracks"):
            tracks = _tracks_of(library, analyses)
        cyc = cyclic_clips(library)
        steps = plan_steps(path, library, cyc)
        bends = np.array([library.bend_of(f.label) for f in path[1:]])  # steps bent beyond the clips
        with timer("smoothing"):  # 3.3
            smoothed = _smooth(path, settings, snap, goal)
        # 3.5 / 3.6 with the plan's clips
        sch1 = build_schedule(steps, tracks, cyc, fps, settings.transition_time)
        first = _one_pass(sch1, tracks, smoothed.position, smoothed.heading, forward, settings, snap, timer, "_1",
                          bends)
        with timer("blend_groups"):  # 3.7: tau from the body trajectory, s from the special clips
            curves = _tau_curves(library, cyc, sch1, first, settings)
            pins = speed_pins(steps, tracks)
            loco = _LocoWeights(library.turn_groups, cyc, sch1.u, curves.tau, pins, settings.speed_sigma)
            sch2 = _blend_group_schedule(steps, tracks, cyc, fps, settings, loco)
        final = _final_pass(sch2, tracks, first, forward, settings, snap, timer, goal, bends)
        tau_final = np.interp(sch2.u, sch1.u, curves.tau)
        s_final = loco.speed(sch2.u, sch2.n)
    seconds = timer.seconds
    seconds["refinement"] = seconds["refinement_1"] + seconds["refinement_2"]
    seconds["body_trajectory"] = seconds["body_trajectory_1"] + seconds["body_trajectory_2"]
    return Synthesis(plan=list(path), settings=settings, clips=sch2.clips, smoothed=smoothed,
                     first=first, tau_plan=curves.plan, tau_raw=curves.raw, tau=curves.tau, final=final,
                     tau_final=tau_final, s_final=s_final, speed_pins=list(pins), seconds=seconds, tracks=tracks)


def _tracks_of(library: Library, analyses) -> dict[str, ClipTrack]:
    """Clip name -> ClipTrack of every clip of the library (``analyses`` may already be
    the tracks)."""
    if isinstance(analyses, dict):
        return analyses
    by = {a.name: a for a in analyses}
    missing = [c for c in library.clips() if c not in by]
    if missing:
        raise BlendError(f"clips of the library are missing: {', '.join(missing)}")
    return {c: make_track(by[c]) for c in library.clips()}


def _smooth(path, settings: Settings, snap, goal) -> Smoothed:
    """3.3: the planned footprints smoothed; with a goal, the path's end first eased so
    that the body ends between the last two feet on it."""
    pos0 = np.array([f.position for f in path], float)
    head0 = np.unwrap(np.array([f.heading for f in path], float))
    if goal is not None:
        pos0 = ease_end(pos0, head0, np.asarray(goal, float)[:2] - 0.5 * (pos0[-1, :2] + pos0[-2, :2]), snap)
    return smooth_footprints(pos0, head0, settings.smoothing_iterations, snap,
                             preserve_arcs=settings.smoothing_keep_arcs)


@dataclass
class _TauCurves:
    plan: np.ndarray  # (F1,) the plan's clips' own tau, blended by the first weights
    raw: np.ndarray  # (F1,) the first pass's body trajectory's tau
    tau: np.ndarray  # (F1,) that, low-passed


def _tau_curves(library: Library, cyc: list[str], sch1: Schedule, first: Pass, settings: Settings) -> _TauCurves:
    """3.7: the curvature tau (1/m) of the first pass's body trajectory, estimated and
    low-passed at TAU_RATE Hz (the filter keeps nothing faster than a step), read at
    every frame of the first schedule; and the plan's own tau for comparison."""
    cyc_tau = np.array([_clip_tau(library, c) for c in cyc])
    wc = sch1.weights[:, :len(cyc)]
    tau_plan = (wc @ cyc_tau) / np.maximum(wc.sum(axis=1), 1e-9)
    tc = np.linspace(0.0, sch1.t[-1], max(8, int(np.ceil(sch1.t[-1] * TAU_RATE)) + 1))
    body_c = np.stack([np.interp(tc, sch1.t, first.body_pos[:, k]) for k in range(3)], axis=1)
    tau_c = bg.curvature(body_c, tc, settings.tau_dt)
    tau_raw = np.interp(sch1.t, tc, tau_c)
    tau = np.interp(sch1.t, tc, bg.smooth_signal(tc, tau_c, settings.tau_smoothing / (2 * np.pi)))
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
                          loco: _LocoWeights) -> Schedule:
    """The schedule under the blend groups' weights, each step lasting what its clips'
    weights (evaluated mid-step) make it last."""
    wmid = loco(np.arange(len(steps)) + 0.5)
    feet = np.array([st.foot for st in steps])
    dur = (wmid * step_durations_of([tracks[c] for c in cyc])[feet]).sum(axis=1)
    return build_schedule(steps, tracks, cyc, fps, settings.transition_time, loco_weights=loco,
                          step_durations=dur)


def _final_pass(sch2: Schedule, tracks, first: Pass, forward, settings: Settings, snap, timer: StageTimer,
                goal, bends=None) -> Pass:
    """The blend groups' pass. With a goal, the path's end is moved by where the first
    pass's body ended, and once more if the blend groups still miss it by more than
    GOAL_TOLERANCE."""
    desired, heading = first.refined.position, first.refined.heading
    if goal is not None:
        desired = ease_end(desired, heading, np.asarray(goal, float)[:2] - first.body_pos[-1, :2], snap)
    final = _one_pass(sch2, tracks, desired, heading, forward, settings, snap, timer, "_2", bends)
    if goal is not None:
        miss = np.asarray(goal, float)[:2] - final.body_pos[-1, :2]
        if np.linalg.norm(miss) > GOAL_TOLERANCE:
            desired = ease_end(desired, heading, miss, snap)
            final = _one_pass(sch2, tracks, desired, heading, forward, settings, snap, timer, "_2", bends)
    return final
