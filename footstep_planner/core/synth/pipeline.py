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

from dataclasses import dataclass, field, replace
from typing import Callable

import numpy as np

from . import blend_groups as bg
from ..footprint import PIVOT, STAND_LABEL, STAND_WIDTH, beside_position
from ..clips.analysis import ClipAnalysis
from .blending import (MIN_STEP, BlendError, ClipTrack, PlanStep, Playback, Schedule, Standing, build_schedule,
                       make_track, playback, rest_times, standing_track, step_durations_of)
from ..clips.library import Library
from .refinement import Refined, refine
from ..base.settings import Settings
from .smoothing import Smoothed, smooth_footprints
from ..clips.steps import bend_chain
from ..plan.surface import EDGE_STEP, FootShape, Ground, footprint_support, ground_heights, largest_step_along
from ..base.timing import StageTimer
from .trajectory import transfer_body

SnapFn = Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]

#: Footprints before the last two over which the path's end is eased onto the goal.
GOAL_STEPS = 4

#: m: a body that ends further than this from the goal gets one more pass.
GOAL_TOLERANCE = 0.02

#: Hz at which the curvature tau is estimated and low-passed.
TAU_RATE = 10.0

#: The first foot to step leaves its standing footprint when the standing clip's weight
#: falls under this (the walk has begun to lift it).
STAND_RELEASE = 0.8

#: s: the most the character stands before its first step.
STAND_LEAD = 0.5

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
    standing: Standing | None = None  # starting and stopping standing (the last column's clip)
    turns: list = field(default_factory=list)  # where it turns in place (``turn_in_place.synthesize``)
    flat: np.ndarray | None = field(default=None, repr=False)  # (F,) the feet kept level at least this much

    def posed_schedule(self) -> Schedule:
        """The final schedule as the pose is blended from it: through a turn in place
        (``flat``), the standing clip's weight (the last column) raised to TURN_STAND where
        it is less and the others scaled down to make room, so the legs step nearer under
        the body, as in a pivot step (the feet's contacts, and so their planted times,
        stay the walk's)."""
        S = self.final.schedule
        if self.flat is None or self.standing is None:
            return S
        w = np.array(S.weights, float, copy=True)
        lam = np.maximum(w[:, -1], TURN_STAND * self.flat)
        rest = w[:, :-1].sum(axis=1)
        w[:, :-1] *= np.where(rest > 1e-12, (1.0 - lam) / np.maximum(rest, 1e-12), 0.0)[:, None]
        w[:, -1] = lam
        return replace(S, weights=w)

    def stand_weight(self) -> np.ndarray:
        """(F,) how far the feet are laid level at each frame: the standing clip's weight
        (0 everywhere without standing), or ``flat`` where that is more (a turn in place
        pivots on level feet)."""
        S = self.final.schedule
        w = S.weights[:, -1].copy() if self.standing is not None else np.zeros(S.n)
        return w if self.flat is None else np.maximum(w, self.flat)

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
        out = planted_ranges(self.final.schedule, self.final.played)
        return out if self.standing is None else _standing_planted(out, self.final.schedule, self.standing)

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
                 clearance: float | None = None, step_height: float | None = None) -> SnapFn:
    """A snap for the smoothing and refinement stages: the footprint dropped onto the
    traversable surface under it (or pulled to the nearest surface point when there is
    none under it), and whether a foot may stand there (supported, clear of obstacles).
    Lengths not given are a human's (0.25 and 0.3 m) times the foot's ``scale``; so are
    this function's own (how far a footprint is pulled, a step's edge)."""
    k = foot.scale
    clearance = 0.25 * k if clearance is None else clearance
    step_height = 0.3 * k if step_height is None else step_height

    def snap(pos: np.ndarray, heading: np.ndarray):
        pos = np.array(pos, float, copy=True)
        sup = footprint_support(ground, obstacles, pos, heading, forward, foot,
                                step_height=step_height, clearance=clearance)
        off = ~sup.ok & (sup.reason == "off surface")
        if off.any():
            near, _ = ground.nearest(pos[off], max_dist=0.5 * k)
            pos[off] = np.where(np.isfinite(near), near, pos[off])
            again = footprint_support(ground, obstacles, pos[off], heading[off], forward, foot,
                                      step_height=step_height, clearance=clearance)
            sup.ok[off], sup.z[off] = again.ok, again.z
        pos[:, 2] = np.where(sup.ok, sup.z, pos[:, 2])
        return pos, sup.ok

    def height(pos: np.ndarray) -> np.ndarray:
        """The footprints dropped onto the surface under them (where there is one)."""
        pos = np.array(pos, float, copy=True)
        z = ground_heights(ground, pos + [0.0, 0.0, step_height], 2 * step_height)
        pos[:, 2] = np.where(np.isfinite(z), z, pos[:, 2])
        return pos

    def crosses_edge(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """(N,) whether the ground from each footprint ``a`` (N, 3) to ``b`` (N, 3) has an
        edge (``surface.largest_step_along``: a step of more than EDGE_STEP, or no surface): a
        footprint moved across one leaves the tread, kerb or floor it was planned on
        (smoothing and refinement keep each footprint on its side)."""
        a, b = np.asarray(a, float), np.asarray(b, float)
        if not len(a):
            return np.zeros(0, bool)

        def under(p):
            return ground_heights(ground, p, 2 * step_height + 0.2 * k)

        return largest_step_along(under, a, b, np.maximum(a[:, 2], b[:, 2]) + step_height, k) > EDGE_STEP * k

    snap.height = height
    snap.crosses_edge = crosses_edge
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


def _clip_gait(library: Library, clip: str) -> str:
    """The gait ("walk" or "run") of the turning group that holds ``clip`` (a clip name or
    a "<group>@<tau>" label); "walk" for any other."""
    group = clip.rsplit("@", 1)[0] if "@" in clip else None
    for gait, g in library.turn_groups.items():
        if g.name == group or any(c.clip == clip for c in g.clips):
            return g.gait if g.gait in ("walk", "run") else "walk"
    return "walk"


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


def speed_pins(steps: list[PlanStep], tracks: dict[str, ClipTrack], gaits=None) -> list[tuple[float, float]]:
    """(u, s) where the walk/run parameter is known: walking at the start and the end,
    each special clip's entry and exit gait at its take-off and landing, and running in
    the middle of each step the plan runs (``gaits`` (len(steps),), the gait of the step
    to each footprint: a run the planner chose, not only a jump's run-up)."""
    val = {"walk": 0.0, "run": 1.0, "stand": 0.0}
    pins = [(0.0, 0.0)]
    for j, s in enumerate(steps):
        if s.special:
            tr = tracks[s.special]
            pins.append((float(j), val.get(tr.entry_gait, 0.0)))
            pins.append((float(j + 1), val.get(tr.exit_gait, 0.0)))
        elif gaits is not None and gaits[j] == "run" and 0 < j < len(steps) - 1:
            pins.append((j + 0.5, 1.0))
    pins.append((float(len(steps)), 0.0))
    return sorted(pins, key=lambda p: p[0])


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


def _standing_planted(planted: list, S: Schedule, stand: Standing) -> list:
    """The planted ranges of a standing schedule: both feet stand from the first frame and
    to the last; the first foot to step leaves its standing footprint as the standing
    clip hands over (when its weight falls under STAND_RELEASE: the walk, held at
    ``u_start``, has that foot in the air). A start (stop) clip lifts (puts down) the
    first (last) foot as its contact says (``planted_ranges``)."""
    t, lam = S.t, S.weights[:, -1]
    moving = np.flatnonzero(lam < 1.0 - 1e-9)
    leave = np.flatnonzero(lam < STAND_RELEASE) if stand.start is None else moving[:1]
    go = float(t[max(leave[0] - 1, 0) if stand.start else leave[0]]) if len(leave) else float(t[0])
    out = list(planted)
    out[:2] = [(float(t[0]), m, b) for _, m, b in out[:2]]
    out[-2:] = [(a, m, float(t[-1])) for a, m, _ in out[-2:]]
    stop = float(t[min(moving[-1] + 1, S.n - 1)]) if len(moving) else float(t[-1])
    if stand.start is None:
        a, m, b = out[0]
        out[0] = (a, min(m, go), min(b, go))
    else:  # (their stance where both stand in the standing clip alone, before it hands over)
        out[:2] = [(a, min(m, go), b) for a, m, b in out[:2]]
    if stand.stop is None:
        a, m, b = out[-1]
        out[-1] = (max(a, stop), max(m, stop), b)
    else:
        out[-2:] = [(a, max(m, stop), b) for a, m, b in out[-2:]]
    return out


def _one_pass(schedule, tracks, desired_pos, desired_head, forward, settings: Settings, snap,
              timer: StageTimer, key: str, bends=None, stand: Standing | None = None, pinned: bool = False) -> Pass:
    """One round: play the schedule, refine the played footprints (each step bent by
    ``bends`` (N-1,) 1/m, as the planner bent it) towards the desired ones (stage
    ``refinement<key>``), carry the played body onto them (``body_trajectory<key>``).
    With ``stand`` the standing feet at either end stay where they are desired and the
    body stands over them (``stand_body``) as the standing clip takes over. ``pinned``:
    every footprint stays where it is desired (a turn in place's pivot steps)."""
    fwd = forward if forward is not None else next(iter(tracks.values())).rest_forward
    with timer(f"refinement{key}"):
        played = playback(schedule, tracks, start=(desired_pos[0], desired_head[0]), forward=forward)
        orig = bend_chain(played.footprints, played.footprint_heading, bends, fwd)
        fixed = None
        if stand is not None or pinned:
            fixed = np.full(len(desired_pos), pinned)
            fixed[[0, 1, -2, -1]] = True
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


#: A turn in place's pose keeps the standing clip's weight at least this (``Synthesis.
#: posed_schedule``): the walk's stride and its feet's lift shrink.
TURN_STAND = 0.4

#: How far a turn in place's feet are laid level (``Synthesis.flat``): the walk's heel
#: strike and toe-off, played on the spot, would pitch the foot steeply while the leg
#: twists over it.
TURN_FLAT = 1.0

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
               snap: SnapFn | None = None, goal=None, standing: bool = False, start_other=None,
               goal_heading: float | None = None, pace=None, lead: float | None = None,
               hold: float | None = None) -> Synthesis:
    """Synthesize the motion of a planned path (``navgraph.PathFootprint`` list, feet
    alternating). ``analyses`` are the library's clips analysed (or their tracks);
    ``snap`` keeps footprints on the surface (see ``surface_snap``); ``forward`` is
    the world direction of heading 0 (default the clips' rest forward). With ``goal``
    the path's end is moved so that the body ends on it (the planner stops anywhere
    within its goal radius; see ``ease_end``). With ``standing`` the character starts
    from standing on the path's first footprint and ``start_other`` (the other standing
    foot, default beside it) and stops to standing, the last two feet side by side facing
    ``goal_heading`` when given (``standing_path``, ``blending.Standing``); ``lead`` and
    ``hold`` (s) then set how long it stands before its first step and after its last
    (default: ``Settings.stand_hold``, the lead at most STAND_LEAD).

    ``pace`` (a number, or one per step of ``path``) plays the walking steps that much
    faster (the clips' time warped: a step lasts its clips' duration over its pace; the
    footprints stay where they are)."""
    settings = settings or Settings()
    if len(path) < 2:
        raise BlendError("the path has a single footprint: the character is already at its goal")
    timer = StageTimer()
    with timer("total"):
        with timer("tracks"):
            tracks = _tracks_of(library, analyses)
        cyc = cyclic_clips(library)
        stand = None
        pivot = standing and len(path) > 1 and all(f.label == PIVOT for f in path[1:])
        shown = None
        if pivot and cyc:  # a turn in place: the straight walk's steps on the pivot footprints, all kept
            straight = _straight(library, cyc)
            other = start_other if start_other is not None and start_other.foot != path[0].foot else \
                replace(path[0], foot=1 - path[0].foot)
            shown = [replace(other, label=STAND_LABEL, time=0.0)] + list(path)
            path = [shown[0]] + [replace(f, label=straight, gait="walk", jump=False) for f in path]
            goal = goal_heading = None
        if standing and cyc:
            fwd = forward if forward is not None else next(iter(tracks.values())).rest_forward
            stand = _standing(library, tracks, cyc, settings, lead, hold)
            n_plan = len(path)
            given = len(path) > 2 and path[0].label == STAND_LABEL  # (a synthesis's own path: laid out already)
            path = standing_path(path, library, cyc, fwd, start_other, goal_heading, tracks[stand.clip],
                                 settings.body_scale)
            if pace is not None and np.ndim(pace):  # the standing steps at either end: their neighbours'
                pace = np.r_[pace[0], np.asarray(pace, float)[:n_plan - 1], pace[-1]]
        steps = plan_steps(path, library, cyc)
        if stand is not None and shown is None:  # the library's start and stop clips, where they fit
            path, steps, stand = end_clip_steps(path, steps, library, tracks, stand, fwd, layout=not given, snap=snap,
                                                level=settings.length(END_LEVEL))
        rate = _climb_pace(_step_pace(pace, len(steps)), path, settings.climb_time)
        bends = np.array([library.bend_of(f.label) for f in path[1:]])  # steps bent beyond the clips
        with timer("smoothing"):  # 3.3
            smoothed = _smooth(path, settings, snap, goal, fixed=len(path) if shown else _end_fixed(steps, stand))
        # 3.5 / 3.6 with the plan's clips
        sch1 = build_schedule(steps, tracks, cyc, fps, settings.transition_time, standing=stand,
                              pace=rate)
        first = _one_pass(sch1, tracks, smoothed.position, smoothed.heading, forward, settings, snap, timer, "_1",
                          bends, stand, pinned=shown is not None)
        with timer("blend_groups"):  # 3.7: tau from the body trajectory, s from the special clips
            curves = _tau_curves(library, cyc, sch1, first, settings)
            pins = speed_pins(steps, tracks, [f.gait for f in path[1:]])
            loco = _LocoWeights(library.turn_groups, cyc, sch1.u, curves.tau, pins, settings.speed_sigma)
            if stand is not None and (stand.start or stand.stop):
                steps = end_stretch(steps, first, stand)
            sch2 = _blend_group_schedule(steps, tracks, cyc, fps, settings, loco, stand, rate)
        final = _final_pass(sch2, tracks, first, forward, settings, snap, timer, goal, bends, stand,
                            pinned=shown is not None)
        tau_final = np.interp(sch2.u, sch1.u, curves.tau)
        s_final = loco.speed(sch2.u, sch2.n)
    seconds = timer.seconds
    seconds["refinement"] = seconds["refinement_1"] + seconds["refinement_2"]
    seconds["body_trajectory"] = seconds["body_trajectory_1"] + seconds["body_trajectory_2"]
    return Synthesis(plan=list(shown or path), settings=settings, clips=sch2.clips, smoothed=smoothed,
                     first=first, tau_plan=curves.plan, tau_raw=curves.raw, tau=curves.tau, final=final,
                     tau_final=tau_final, s_final=s_final, speed_pins=list(pins), seconds=seconds, tracks=tracks,
                     standing=stand, flat=None if shown is None else np.full(sch2.n, TURN_FLAT))


def standing_path(path, library: Library, cyc: list[str], forward, other=None, goal_heading=None,
                  stand: ClipTrack | None = None, scale: float = 1.0) -> list:
    """The path with both standing feet at its ends: ``other`` (the standing foot the path
    does not hold; default beside its first footprint) before it, and after its last
    footprint the other foot beside it, where the standing clip ``stand`` puts it (a
    straight walk's step; without one STAND_WIDTH, a human's, times the body's ``scale``); with ``goal_heading`` the last footprints turn to it, the
    last two all the way, the GOAL_STEPS before them less and less. A path that already
    begins with a standing foot (STAND_LABEL) is returned as it is."""
    if len(path) > 2 and path[0].label == STAND_LABEL:  # already standing at both ends
        return list(path)
    first, loco = path[0], [f.label for f in path[1:] if f.label not in {s.clip for s in library.specials}]
    straight = _straight(library, cyc)
    label = loco[0] if loco else straight
    if other is None or other.foot == first.foot:
        other = replace(first, foot=1 - first.foot, position=beside_position(first, 1 - first.foot, forward,
                                                                                   2 * STAND_WIDTH * scale))
    other = replace(other, label=STAND_LABEL, time=0.0)
    path = [other, replace(first, label=label, gait=_clip_gait(library, label))] + list(path[1:])
    if goal_heading is not None:
        n = len(path)
        dh = float(np.angle(np.exp(1j * (goal_heading - path[-1].heading))))
        w = np.clip((np.arange(n) - (n - 2 - GOAL_STEPS)) / (GOAL_STEPS + 1.0), 0.0, 1.0)
        w[:2] = 0.0
        path = [replace(f, heading=f.heading + x * dh) if x > 0 else f for f, x in zip(path, w)]
    last = path[-1]
    end = replace(last, foot=1 - last.foot,
                  position=beside_position(last, 1 - last.foot, forward, 2 * STAND_WIDTH * scale, stand),
                  label=straight, gait=_clip_gait(library, straight), jump=False)
    return path + [end]


#: rad: the most the path may turn over a start or stop clip's steps (the clips walk
#: straight on; a path that turns more there starts or stops synthesized).
END_TURN = np.radians(30.0)

#: m: the most a start or stop clip's footprints may differ in height (the clips walk on
#: the level; on stairs or a ramp the start or stop is synthesized).
END_LEVEL = 0.03

#: A start clip plays its steps until it walks at this share of its top speed (it then
#: ramps out into the cycles over its next step); a stop clip from its last step at it.
END_SPEED = 0.9


def end_windows(track: ClipTrack) -> tuple[int, list[tuple[float, float]]] | None:
    """(the foot it leads with, its steps: clip times (from, to)) of a start clip (a stop
    clip: ``track.kind``) played over a path's first (last) steps. A start clip's steps
    run from its standing feet (the first to lift first: the foot it leads with) to the
    step at which it walks at END_SPEED of its top speed (the last in the list: the step
    it ramps out over); a stop clip's from the step before the first one slower than that
    (the first in the list: the step it ramps in over) to its standing feet (the last to
    land last: the foot it leads with). The standing feet's keys lie in their stances,
    in their order (the stance times of feet down from a clip's start or to its end are
    merely where they are lowest). None where the clip has no such feet, its steps do not
    alternate feet or it has too few."""
    st = list(track.stances)
    down = track.contact > 0.5  # (2, n)
    if track.kind not in ("start", "stop") or len(st) < 4 or not down[:, 0 if track.kind == "start" else -1].all():
        return None
    rate, n = track.rate, down.shape[1]
    if track.kind == "start":
        lift = [int(np.argmin(d)) if not d.all() else n for d in down]  # each foot's first liftoff (sample)
        lead = int(np.argmin(lift))
        firsts = [next(i for i, x in enumerate(st) if x[0] == f) for f in (0, 1)]
        rest = [x for i, x in enumerate(st) if i not in firsts]
        if not rest or rest[0][0] != lead:
            return None
        k0 = min(st[firsts[lead]][1], (lift[lead] - 1) / rate)
        hi = min(rest[0][1], (lift[1 - lead] - 1) / rate)
        k1 = st[firsts[1 - lead]][1]
        keys = [k0, k1 if k0 < k1 < hi else 0.5 * (k0 + hi)] + [x[1] for x in rest]
        feet = [lead, 1 - lead] + [x[0] for x in rest]
    else:
        land = [n - int(np.argmin(d[::-1])) if not d.all() else 0 for d in down]  # each foot's last strike
        lead = int(np.argmax(land))
        lasts = [max(i for i, x in enumerate(st) if x[0] == f) for f in (0, 1)]
        rest = [x for i, x in enumerate(st) if i not in lasts]
        if not rest or rest[-1][0] != lead:
            return None
        k1 = max(st[lasts[lead]][1], land[lead] / rate)
        lo = max(rest[-1][1], land[1 - lead] / rate)
        k0 = st[lasts[1 - lead]][1]
        keys = [x[1] for x in rest] + [k0 if lo < k0 < k1 else 0.5 * (lo + k1), k1]
        feet = [x[0] for x in rest] + [1 - lead, lead]
    if any(a == b for a, b in zip(feet[:-1], feet[1:])) or np.any(np.diff(keys) <= MIN_STEP):
        return None
    win = list(zip(keys[:-1], keys[1:]))
    span = [(int(round(a * rate)), int(round(b * rate))) for a, b in win]
    speed = np.array([np.linalg.norm(track.vel[i:max(k, i + 1)], axis=1).mean() for i, k in span])
    fast = speed >= END_SPEED * speed.max()
    if track.kind == "start":
        k = next((i for i in range(2, len(win)) if fast[i]), None)
        return None if k is None else (lead, win[:k + 1])
    k = next((i for i in range(len(win) - 2, -1, -1) if fast[i]), None)
    return None if k is None else (lead, win[k:])


def end_clip_steps(path, steps: list[PlanStep], library: Library, tracks: dict, stand: Standing, forward,
                   layout: bool = True, snap: SnapFn | None = None, level: float = END_LEVEL
                   ) -> tuple[list, list[PlanStep], Standing]:
    """The path, steps and standing of a standing path (``standing_path``) with the
    library's start clip on its first steps and its stop clip on its last
    (``end_windows``, ``Standing``). A start (stop) clip is played where its first (last)
    foot to move (to arrive) is the path's and the path goes its steps and the one it
    ramps over on the level (within ``level`` m: END_LEVEL, a human's) in the clip's own gait (a walk's start or stop on
    walking steps, a run's on running ones), without a special clip, a jump or a turn of
    more than END_TURN, and where ``snap`` lets the footprints laid out stand; a path too short
    for both keeps the start. Elsewhere the start (stop) is synthesized from the
    walk. With ``layout`` the footprints at either end are laid out as the clip steps
    (``_end_layout``; ``forward`` the world's heading 0); a synthesis's own path (a plan
    saved and baked again) has them so already."""
    n = len(steps)
    heads = np.unwrap([f.heading for f in path])
    heads = np.r_[heads[0], 0.5 * (heads[1:] + heads[:-1])]  # (each and the one before: the feet's turn out cancels)
    specials = {sp.clip for sp in library.specials}

    def fits(lo: int, hi: int, gait: str) -> bool:  # steps lo .. hi - 1 (footprints lo .. hi) go straight on
        on = [i < len(path) and path[i].gait == gait and not path[i].jump for i in range(lo + 1, hi + 1)]
        ok = 0 <= lo and hi <= n and all(on) and all(path[i].label not in specials for i in range(lo + 1, hi + 1))
        z = [float(path[i].position[2]) for i in range(max(lo, 0), min(hi, n) + 1)]
        return ok and float(np.ptp(heads[lo + 1:hi + 1])) <= END_TURN and float(np.ptp(z)) <= level

    def laid(new_path, lo: int, hi: int) -> bool:  # the footprints moved there may stand where they are
        if snap is None:
            return True
        pos = np.array([f.position for f in new_path[lo:hi]], float)
        _, ok = snap(pos, np.array([f.heading for f in new_path[lo:hi]], float))
        return bool(np.all(ok))

    out, used = list(steps), 0
    start = stop = None
    for kind in ("start", "stop"):
        for sp in library.specials:
            tr = tracks.get(sp.clip) if sp.kind == kind and sp.clip in tracks else None
            ends = end_windows(tr) if tr is not None and tr.kind == kind else None
            if ends is None:
                continue
            foot, win = ends
            k = len(win)
            if kind == "start":
                if foot != path[0].foot or not fits(0, k, tr.exit_gait):
                    continue
                moved = _end_layout(path, tr, win, forward) if layout else path
                if not laid(moved, 0, min(k + END_EASE[0] + 1, len(path))):
                    continue
                out[:k - 1] = [replace(s, special=sp.clip, weights=None, window=w) for s, w in zip(steps, win[:-1])]
                used, start, path = k, sp.clip, moved
            else:
                if foot != path[-1].foot or not fits(n - k, n, tr.entry_gait) or used + k > n:
                    continue
                moved = _end_layout(path, tr, win, forward) if layout else path
                if not laid(moved, max(len(path) - k - 2 - END_EASE[1], 0), len(path)):
                    continue
                out[n - k + 1:] = [replace(s, special=sp.clip, weights=None, window=w)
                                   for s, w in zip(steps[n - k + 1:], win[1:])]
                stop, path = sp.clip, moved
            break
    return path, out, replace(stand, start=start, stop=stop)


def clip_feet(track: ClipTrack, times) -> tuple[np.ndarray, np.ndarray]:
    """(the feet's heel/toe midpoints (2, len(times), 3) m, the root's facing (len(times),)
    rad from the x axis) of a clip played alone from its start, its root at the origin
    facing its rest forward there."""
    dt = 1.0 / track.rate
    psi = np.concatenate([[0.0], np.cumsum(0.5 * (track.yaw_rate[1:] + track.yaw_rate[:-1]) * dt)])
    hm = 0.5 * (psi[1:] + psi[:-1])
    v = 0.5 * (track.vel[1:] + track.vel[:-1])
    step = np.stack([np.cos(hm) * v[:, 0] - np.sin(hm) * v[:, 1], np.sin(hm) * v[:, 0] + np.cos(hm) * v[:, 1]], 1)
    root = np.vstack([np.zeros(2), np.cumsum(step * dt, axis=0)])
    t = np.asarray(times, float)
    x = np.clip(t * track.rate, 0, track.n - 1)
    h = np.interp(x, np.arange(track.n), psi)
    r = np.stack([np.interp(x, np.arange(track.n), root[:, k]) for k in range(2)], 1)
    smp = track.sample(t)
    mid = 0.5 * (smp["heel"] + smp["toe"])
    out = mid.copy()
    out[..., 0] = np.cos(h) * mid[..., 0] - np.sin(h) * mid[..., 1] + r[:, 0]
    out[..., 1] = np.sin(h) * mid[..., 0] + np.cos(h) * mid[..., 1] + r[:, 1]
    return out, h + np.arctan2(track.rest_forward[1], track.rest_forward[0])


#: Footprints after a start clip's (before a stop clip's) over which the move onto its
#: steps is eased: a start clip's first steps are much shorter than the walk's.
END_EASE = (8, 4)


def _end_layout(path, track: ClipTrack, win, forward) -> list:
    """The path's first (a start clip ``track``) or last footprints (a stop clip) laid out
    as the clip places its feet on its steps ``win`` (``end_windows``), about the path's
    standing pair at that end (their middle: the clip's feet standing there), the
    footprint it ramps over moved half way; the END_EASE footprints beyond
    moved less and less. The first standing pair stays where it stands; the last foot
    stands beside the one before as the clip puts it. The clip's footprints are turned
    about the pair the way the planned ones go. A clip's steps speeding up or
    slowing down are shorter than the walk's the planner laid: played on the walk's, the
    legs would reach for them."""
    k, n, start = len(win), len(path), track.kind == "start"
    times = [win[0][0]] + [b for _, b in win]
    feet, _ = clip_feet(track, times)
    idx = list(range(0, k + 1)) if start else list(range(n - k - 1, n))
    clip = np.array([feet[path[i].foot, j, :2] for j, i in enumerate(idx)])  # (k + 1, 2)
    pair, _ = clip_feet(track, [rest_times(track)[0 if start else 1]])
    c0 = 0.5 * (pair[0, 0, :2] + pair[1, 0, :2])
    a, b = (path[0], path[1]) if start else (path[-2], path[-1])
    c1 = 0.5 * (np.asarray(a.position, float)[:2] + np.asarray(b.position, float)[:2])
    # turned the way the path goes there (the least-squares turn of the clip's footprints
    # about the standing pair onto the planned ones: a pair turned to the goal's heading
    # does not turn the way)
    u = clip - c0
    v = np.array([np.asarray(path[i].position, float)[:2] for i in idx]) - c1
    ang = float(np.arctan2((u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]).sum(), (u * v).sum()))
    rot = np.array([[np.cos(ang), -np.sin(ang)], [np.sin(ang), np.cos(ang)]])
    want = u @ rot.T + c1
    if not start:  # the last foot beside the one before as the clip has it, about the pair's middle
        last = want[-1] - want[-2]
        want[-2:] = c1 + np.array([-0.5, 0.5])[:, None] * last
    delta = {i: want[j] - np.asarray(path[i].position, float)[:2] for j, i in enumerate(idx)}
    if start:
        delta[0] = delta[1] = np.zeros(2)  # (the character's own feet)
    far, sign = (idx[-1], 1) if start else (idx[0], -1)
    delta[far] = 0.5 * delta[far]  # (where it ramps over: half the clip's, half the walk's)
    ease = END_EASE[0 if start else 1]
    for m in range(1, ease + 1):
        i = far + sign * m
        if not 0 <= i < n:
            break
        j = i - sign * 2
        while j not in delta:
            j -= sign * 2
        delta[i] = delta[j] * (ease + 1 - m) / (ease + 1.0)
    out = list(path)
    for i, d in delta.items():
        p = np.asarray(path[i].position, float).copy()
        p[:2] += d
        out[i] = replace(path[i], position=p)
    return out


#: The most a start or stop clip's step is stretched or shortened in time to walk the
#: planned footprints at the clip's own speed (``end_stretch``).
END_STRETCH = (0.8, 1.25)


def end_stretch(steps: list[PlanStep], first: Pass, stand: Standing) -> list[PlanStep]:
    """The steps with each of the start and stop clips' (``Standing``) lasting as much
    longer than its clip time as the refined footprints of the ``first`` pass lie further
    apart than the clip played them (the midpoints between consecutive footprints: where
    the body passes), within END_STRETCH: the body keeps the clip's speed on footprints
    the planner spaced otherwise, time warped onto them."""
    mids = lambda p: 0.5 * (p[1:, :2] + p[:-1, :2])  # noqa: E731
    want = np.linalg.norm(np.diff(mids(first.refined.position), axis=0), axis=1)
    have = np.linalg.norm(np.diff(mids(first.played.footprints), axis=0), axis=1)
    ratio = np.clip(want / np.maximum(have, 1e-6), *END_STRETCH)  # (steps 1 .. N-2)
    out = list(steps)
    for j, s in enumerate(steps):
        if s.special is not None and s.special in (stand.start, stand.stop) and 1 <= j <= len(ratio):
            out[j] = replace(s, stretch=float(ratio[j - 1]))
    return out


def _straight(library: Library, cyc: list[str]) -> str:
    """The straightest clip of the walk's turning group (of any cyclic clip without one)."""
    walk = library.turn_groups.get("walk")
    return min(cyc, key=lambda c: (walk is not None and c not in [g.clip for g in walk.clips],
                                   abs(_clip_tau(library, c))))


def _climb_pace(rate: np.ndarray | None, path, climb_time: float) -> np.ndarray | None:
    """(len(path) - 1,) ``rate`` (None: 1) over 1 + ``climb_time`` times the height each
    step's swinging foot climbs or descends (from the footprint before the step's own to
    the one it lands on; the first step's from its own), or ``rate`` itself on level
    ground."""
    z = np.array([f.position[2] for f in path], float)
    rise = np.abs(z[1:] - np.r_[z[0], z[:-2]])
    slow = 1.0 + climb_time * rise
    if not (slow > 1.0 + 1e-9).any():
        return rate
    return (1.0 if rate is None else rate) / slow


def _step_pace(pace, n: int) -> np.ndarray | None:
    """(n,) the pace of each step (None: every step at its clips' own)."""
    if pace is None:
        return None
    rate = np.broadcast_to(np.asarray(pace, float), (n,)).copy() if np.ndim(pace) == 0 else np.asarray(pace, float)
    if rate.shape != (n,) or not np.isfinite(rate).all() or (rate <= 0).any():
        raise BlendError(f"the pace must be one positive number per step ({n}), not {np.shape(pace)}")
    return None if np.allclose(rate, 1.0) else rate


def _standing(library: Library, tracks: dict, cyc: list[str], settings: Settings, lead: float | None = None,
              hold: float | None = None) -> Standing:
    """The standing of a path's ends: the library's idle clip, held at its start, or one
    made from the straightest walk (``standing_track``) added to ``tracks``; the walk is
    held, at either end, where the stepping foot swings past the standing one
    (``mid_swing``)."""
    walk = _straight(library, cyc)
    idle = next((sp.clip for sp in library.specials if sp.kind == "idle" and sp.clip in tracks), None)
    if idle is None:
        idle = f"{walk}~stand"
        tracks[idle] = standing_track(tracks[walk], idle)
    own = float(settings.stand_hold)
    hold = own if hold is None else max(float(hold), 0.0)
    lead = min(own, STAND_LEAD) if lead is None else max(float(lead), 0.0)
    u = mid_swing(tracks[walk])
    return Standing(clip=idle, lead=lead, hold=hold, u_start=u, u_back=2.0 - u)


def standing_body(library: Library, analyses) -> np.ndarray:
    """(2,) where the body (the root) of the library's standing pose (``_standing``: its
    idle clip, or one made from its walk) stands from the middle of its feet: (ahead,
    left) m in the feet's frame. Zeros without a cyclic clip."""
    cyc = cyclic_clips(library)
    if not cyc:
        return np.zeros(2)
    tracks = _LazyTracks(analyses)  # (only the walk's and the idle's are made)
    st = _standing(library, tracks, cyc, Settings())
    tr = tracks[st.clip]
    smp = tr.sample(np.array([st.clip_time]))
    local = 0.25 * (smp["heel"][0, 0] + smp["toe"][0, 0] + smp["heel"][1, 0] + smp["toe"][1, 0])  # root frame
    f = np.asarray(tr.rest_forward, float)[:2]
    f = f / np.linalg.norm(f)
    return -np.array([local[:2] @ f, local[:2] @ [-f[1], f[0]]])


class _LazyTracks(dict):
    """Clip name -> ClipTrack, each made (``make_track``) when first asked for."""

    def __init__(self, analyses):
        super().__init__()
        self.by = {a.name: a for a in analyses} if not isinstance(analyses, dict) else {}
        if isinstance(analyses, dict):
            self.update(analyses)

    def __missing__(self, name: str) -> ClipTrack:
        self[name] = make_track(self.by[name])
        return self[name]

    def __contains__(self, name) -> bool:
        return dict.__contains__(self, name) or name in self.by


def mid_swing(track: ClipTrack) -> float:
    """Footsteps from a foot's stance to the middle of its next swing in a cyclic clip
    (1 when the swing is centred on the other foot's stance), kept within 0.6 to 1.4."""
    phase = np.linspace(0.0, 1.0, 201)
    ct, _ = track.clip_time_of_phase(phase)
    swing = phase[track.sample(ct)["contact"][0] < 0.5]
    return float(np.clip(2.0 * swing.mean(), 0.6, 1.4)) if len(swing) else 1.0


def _tracks_of(library: Library, analyses) -> dict[str, ClipTrack]:
    """Clip name -> ClipTrack of every clip of the library (``analyses`` may already be
    the tracks)."""
    if isinstance(analyses, dict):
        return dict(analyses)
    by = {a.name: a for a in analyses}
    missing = [c for c in library.clips() if c not in by]
    if missing:
        raise BlendError(f"clips of the library are missing: {', '.join(missing)}")
    return {c: make_track(by[c]) for c in library.clips()}


def _end_fixed(steps: list[PlanStep], stand: Standing | None) -> tuple[int, int]:
    """(first, last) footprints the smoothing keeps: one at either end walking, both
    standing feet standing, and with a start (stop) clip all the footprints of its steps
    too (the clip's own steps: shorter while it speeds up or slows down)."""
    if stand is None:
        return 1, 1
    lead = next((j for j, s in enumerate(steps) if s.special != stand.start), len(steps)) if stand.start else 0
    tail = next((j for j, s in enumerate(steps[::-1]) if s.special != stand.stop), len(steps)) if stand.stop else 0
    return max(2, lead + 1), max(2, tail + 2)


def _smooth(path, settings: Settings, snap, goal, fixed=1) -> Smoothed:
    """3.3: the planned footprints smoothed, the first and last ``fixed`` kept (a number,
    or (first, last)); with a goal, the path's end first eased so that the body ends
    between the last two feet on it."""
    pos0 = np.array([f.position for f in path], float)
    head0 = np.unwrap(np.array([f.heading for f in path], float))
    if goal is not None:
        pos0 = ease_end(pos0, head0, np.asarray(goal, float)[:2] - 0.5 * (pos0[-1, :2] + pos0[-2, :2]), snap)
    keep = np.zeros(len(pos0), bool)
    first, last = (fixed, fixed) if np.ndim(fixed) == 0 else fixed
    keep[:first] = keep[len(keep) - last:] = True
    return smooth_footprints(pos0, head0, settings.smoothing_iterations, snap, fixed=keep,
                             preserve_arcs=settings.smoothing_keep_arcs)


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


def _final_pass(sch2: Schedule, tracks, first: Pass, forward, settings: Settings, snap, timer: StageTimer,
                goal, bends=None, stand: Standing | None = None, pinned: bool = False) -> Pass:
    """The blend groups' pass. With a goal, the path's end is moved by where the first
    pass's body ended, and once more if the blend groups still miss it by more than
    GOAL_TOLERANCE."""
    desired, heading = first.refined.position, first.refined.heading
    if goal is not None:
        desired = ease_end(desired, heading, np.asarray(goal, float)[:2] - first.body_pos[-1, :2], snap)
    final = _one_pass(sch2, tracks, desired, heading, forward, settings, snap, timer, "_2", bends, stand, pinned)
    if goal is not None:
        miss = np.asarray(goal, float)[:2] - final.body_pos[-1, :2]
        if np.linalg.norm(miss) > settings.length(GOAL_TOLERANCE):
            desired = ease_end(desired, heading, miss, snap)
            final = _one_pass(sch2, tracks, desired, heading, forward, settings, snap, timer, "_2", bends, stand)
    return final
