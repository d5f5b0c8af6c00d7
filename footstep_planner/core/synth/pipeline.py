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

import numpy as np

from ..base.settings import Settings
from ..base.timing import StageTimer
from ..clips.analysis import ClipAnalysis
from ..clips.library import Library
from ..footprint import Leg
from ..plan.surface import (EDGE_STEP, FootShape, Ground, SupportLimits, footprint_support, ground_heights,
                            largest_step_along)
from .blending import Playback
from .ends import _end_fixed, _standing, _standing_planted, end_stretch, standing_ends, turn_in_place_path
from .labels import _LazyTracks, _climb_pace, _step_pace, clip_tracks, cyclic_clips, plan_steps
from .passes import (Pass, PassContext, SnapFn, _blend_group_schedule, _final_pass, _LocoWeights, _one_pass,
                     _smooth, _tau_curves, _TauCurves, speed_pins)
from .schedule import PlanStep, Schedule, build_schedule
from .smoothing import Smoothed
from .standing import Standing
from .tracks import BlendError, ClipTrack


#: Table 4.1's stage columns, in order.
STAGES = ("smoothing", "refinement", "body_trajectory", "blend_groups")


#: A turn in place's pose keeps the standing clip's weight at least this (``Synthesis.
#: posed_schedule``): the walk's stride and its feet's lift shrink.
TURN_STAND = 0.4


#: How far a turn in place's feet are laid level (``Synthesis.flat``): the walk's heel
#: strike and toe-off, played on the spot, would pitch the foot steeply while the leg
#: twists over it.
TURN_FLAT = 1.0


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
    limits = SupportLimits(step_height=step_height, clearance=clearance)

    def snap(pos: np.ndarray, heading: np.ndarray):
        pos = np.array(pos, float, copy=True)
        sup = footprint_support(ground, obstacles, pos, heading, forward, foot, limits)
        off = ~sup.ok & (sup.reason == "off surface")
        if off.any():
            near, _ = ground.nearest(pos[off], max_dist=0.5 * k)
            pos[off] = np.where(np.isfinite(near), near, pos[off])
            again = footprint_support(ground, obstacles, pos[off], heading[off], forward, foot, limits)
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


def synthesize(path, library: Library, analyses: list[ClipAnalysis] | dict[str, ClipTrack], leg: Leg = Leg(),
               settings: Settings | None = None, fps: float = 30.0, forward=None,
               snap: SnapFn | None = None) -> Synthesis:
    """Synthesize the motion of a planned path (``navgraph.PathFootprint`` list, feet
    alternating). ``analyses`` are the library's clips analysed (or their tracks);
    ``snap`` keeps footprints on the surface (see ``surface_snap``); ``forward`` is
    the world direction of heading 0 (default the clips' rest forward). ``leg`` says
    what its ends are (``footprint.Leg``). With ``leg.goal`` the path's end is moved so
    that the body ends on it (the planner stops anywhere within its goal radius; see
    ``ease_end``). With ``leg.standing`` the character starts from standing on the path's
    first footprint and ``leg.start_other`` (the other standing foot, default beside it)
    and stops to standing, the last two feet side by side facing ``leg.goal_heading`` when
    given (``standing_path``, ``standing.Standing``); ``leg.lead`` and ``leg.hold`` (s)
    then set how long it stands before its first step and after its last (default:
    ``Settings.stand_hold``, the lead at most STAND_LEAD).

    ``leg.pace`` (a number, or one per step of ``path``) plays the walking steps that much
    faster (the clips' time warped: a step lasts its clips' duration over its pace; the
    footprints stay where they are)."""
    settings = settings or Settings()
    goal, standing, pace = leg.goal, leg.standing, leg.pace
    if len(path) < 2:
        raise BlendError("the path has a single footprint: the character is already at its goal")
    timer = StageTimer()
    with timer("total"):
        with timer("tracks"):
            tracks = clip_tracks(library, analyses)
        cyc = cyclic_clips(library)
        shown, path = turn_in_place_path(path, library, cyc, leg.start_other) if standing and cyc else (None, path)
        if shown is not None:  # (every footprint kept: no goal to ease the path's end onto)
            goal, leg = None, replace(leg, goal=None, goal_heading=None)
        if standing and cyc:  # the standing feet at either end, the start and stop clips where they fit
            path, steps, stand, pace = standing_ends(path, library, tracks, cyc, settings, forward, snap, leg,
                                                     end_clips=shown is None)
        else:
            steps, stand = plan_steps(path, library, cyc), None
        rate = _climb_pace(_step_pace(pace, len(steps)), path, settings.climb_time)
        bends = np.array([library.bend_of(f.label) for f in path[1:]])  # steps bent beyond the clips
        with timer("smoothing"):  # 3.3
            smoothed = _smooth(path, settings, snap, goal, fixed=len(path) if shown else _end_fixed(steps, stand))
        # 3.5 / 3.6 with the plan's clips
        sch1 = build_schedule(steps, tracks, cyc, fps, settings.transition_time, standing=stand, pace=rate)
        ctx = PassContext(tracks, forward, settings, snap, timer, bends, stand, pinned=shown is not None,
                          kept=np.array([f.tread for f in path], bool))
        first = _one_pass(ctx, sch1, smoothed.position, smoothed.heading, "_1")
        with timer("blend_groups"):  # 3.7: tau from the body trajectory, s from the special clips
            curves, pins, loco, sch2 = _blend_groups(path, steps, library, ctx, cyc, sch1, first, rate)
        final = _final_pass(ctx, sch2, first, goal)
        tau_final = np.interp(sch2.u, sch1.u, curves.tau)
        s_final = loco.speed(sch2.u, sch2.n)
    seconds = timer.seconds
    seconds["refinement"] = seconds["refinement_1"] + seconds["refinement_2"]
    seconds["body_trajectory"] = seconds["body_trajectory_1"] + seconds["body_trajectory_2"]
    return Synthesis(plan=list(shown or path), settings=settings, clips=sch2.clips, smoothed=smoothed,
                     first=first, tau_plan=curves.plan, tau_raw=curves.raw, tau=curves.tau, final=final,
                     tau_final=tau_final, s_final=s_final, speed_pins=list(pins), seconds=seconds, tracks=tracks,
                     standing=stand, flat=None if shown is None else np.full(sch2.n, TURN_FLAT))


def _blend_groups(path, steps: list[PlanStep], library: Library, ctx: PassContext, cyc: list[str], sch1: Schedule,
                  first: Pass, rate) -> tuple[_TauCurves, list[tuple[float, float]], _LocoWeights, Schedule]:
    """3.7: (the tau curves, the speed pins, the blend groups' weights, their schedule) of
    the ``first`` pass: tau from its body trajectory, s pinned by the special clips and the
    plan's gaits; the start and stop clips' steps stretched onto the footprints
    (``end_stretch``). ``ctx`` gives the tracks, the settings and the standing; ``rate``
    is the steps' pace; the schedule's frame rate is ``sch1``'s."""
    tracks, settings, stand = ctx.tracks, ctx.settings, ctx.stand
    curves = _tau_curves(library, cyc, sch1, first, settings)
    gaits = [f.gait for f in path[1:]]
    pins = speed_pins(steps, tracks, gaits, library.corners([f.label for f in path[1:]], gaits,
                                                            settings.bend_curvature),
                      [f.speed for f in path[1:]])
    loco = _LocoWeights(library.turn_groups, cyc, sch1.u, curves.tau, pins, settings.speed_sigma)
    if stand is not None and (stand.start or stand.stop):
        steps = end_stretch(steps, first, stand)
    sch2 = _blend_group_schedule(steps, tracks, cyc, sch1.fps, settings, loco, stand, rate)
    return curves, pins, loco, sch2
