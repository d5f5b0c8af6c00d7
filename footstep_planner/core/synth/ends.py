"""The standing ends of a path and the start and stop clips: the path a turn in place
walks (``turn_in_place_path``); a path walked from standing to standing, set up in
``standing_ends``: the standing (``_standing``) and both standing feet at either end
(``standing_path``), the library's start and stop clips on its first and last steps
(``end_windows``, ``end_clip_steps``, the footprints laid out as the clips step:
``_end_layout``) and their steps stretched onto the footprints (``end_stretch``); the
footprints the smoothing keeps there (``_end_fixed``) and the standing feet's planted
ranges (``_standing_planted``).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..base.settings import Settings
from ..clips.library import Library
from ..footprint import PIVOT, STAND_LABEL, STAND_HALF_WIDTH, Leg, beside_position
from .labels import _clip_gait, _straight, plan_steps
from .passes import GOAL_STEPS, Pass, SnapFn
from .schedule import PlanStep, Schedule
from .standing import Standing, rest_times, standing_track
from .tracks import MIN_DURATION, ClipTrack


#: The first foot to step leaves its standing footprint when the standing clip's weight
#: falls under this (the walk has begun to lift it).
STAND_RELEASE = 0.8


#: s: the most the character stands before its first step.
STAND_LEAD = 0.5


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


def mid_swing(track: ClipTrack) -> float:
    """Footsteps from a foot's stance to the middle of its next swing in a cyclic clip
    (1 when the swing is centred on the other foot's stance), kept within 0.6 to 1.4."""
    phase = np.linspace(0.0, 1.0, 201)
    ct, _ = track.clip_time_of_phase(phase)
    swing = phase[track.sample(ct)["contact"][0] < 0.5]
    return float(np.clip(2.0 * swing.mean(), 0.6, 1.4)) if len(swing) else 1.0


def standing_path(path, library: Library, cyc: list[str], forward, other=None, goal_heading=None,
                  stand: ClipTrack | None = None, scale: float = 1.0) -> list:
    """The path with both standing feet at its ends: ``other`` (the standing foot the path
    does not hold; default beside its first footprint) before it, and after its last
    footprint the other foot beside it, where the standing clip ``stand`` puts it (a
    straight walk's step; without one STAND_HALF_WIDTH, a human's, times the body's ``scale``); with ``goal_heading`` the last footprints turn to it, the
    last two all the way, the GOAL_STEPS before them less and less. A path that already
    begins with a standing foot (STAND_LABEL) is returned as it is."""
    if len(path) > 2 and path[0].label == STAND_LABEL:  # already standing at both ends
        return list(path)
    first, loco = path[0], [f.label for f in path[1:] if f.label not in {s.clip for s in library.specials}]
    straight = _straight(library, cyc)
    label = loco[0] if loco else straight
    if other is None or other.foot == first.foot:
        other = replace(first, foot=1 - first.foot, position=beside_position(first, 1 - first.foot, forward,
                                                                                   2 * STAND_HALF_WIDTH * scale))
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
                  position=beside_position(last, 1 - last.foot, forward, 2 * STAND_HALF_WIDTH * scale, stand),
                  label=straight, gait=_clip_gait(library, straight), jump=False)
    return path + [end]


def turn_in_place_path(path, library: Library, cyc: list[str], start_other=None) -> tuple[list | None, list]:
    """(the footprints shown, the path walked) of a turn in place (every footprint after
    the first a pivot's, PIVOT): the other standing foot (``start_other``, default where
    the first stands) before the path, and the straight walk's steps on the pivot
    footprints, all kept; (None, the path) for any other path."""
    if not (len(path) > 1 and all(f.label == PIVOT for f in path[1:])):
        return None, path
    straight = _straight(library, cyc)
    other = start_other if start_other is not None and start_other.foot != path[0].foot else \
        replace(path[0], foot=1 - path[0].foot)
    shown = [replace(other, label=STAND_LABEL, time=0.0)] + list(path)
    return shown, [shown[0]] + [replace(f, label=straight, gait="walk", jump=False) for f in path]


def standing_ends(path, library: Library, tracks: dict, cyc: list[str], settings: Settings, forward, snap,
                  leg: Leg, end_clips: bool = True) -> tuple[list, list[PlanStep], Standing, object]:
    """(path, steps, standing, pace) of a path walked from standing to standing, its ends
    as ``leg`` says (``footprint.Leg``): the standing (``_standing``: ``leg.lead`` and
    ``leg.hold`` s), both standing feet at either end (``standing_path``:
    ``leg.start_other``, ``leg.goal_heading``), ``leg.pace`` with the pace of the standing
    steps their neighbours'; the plan's steps (``plan_steps``) and, with ``end_clips``, the
    library's start and stop clips on them where they fit (``end_clip_steps``)."""
    start_other, goal_heading, pace = leg.start_other, leg.goal_heading, leg.pace
    fwd = forward if forward is not None else next(iter(tracks.values())).rest_forward
    stand = _standing(library, tracks, cyc, settings, leg.lead, leg.hold)
    n_plan = len(path)
    given = len(path) > 2 and path[0].label == STAND_LABEL  # (a synthesis's own path: laid out already)
    path = standing_path(path, library, cyc, fwd, start_other, goal_heading, tracks[stand.clip],
                         settings.body_scale)
    if pace is not None and np.ndim(pace):  # the standing steps at either end: their neighbours'
        pace = np.r_[pace[0], np.asarray(pace, float)[:n_plan - 1], pace[-1]]
    steps = plan_steps(path, library, cyc)
    if end_clips:  # the library's start and stop clips, where they fit
        path, steps, stand = end_clip_steps(path, steps, library, tracks, stand, fwd, layout=not given, snap=snap,
                                            level=settings.length(END_LEVEL))
    return path, steps, stand, pace


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
    if any(a == b for a, b in zip(feet[:-1], feet[1:])) or np.any(np.diff(keys) <= MIN_DURATION):
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
                if not _laid(snap, moved, 0, min(k + END_EASE[0] + 1, len(path))):
                    continue
                out[:k - 1] = [replace(s, special=sp.clip, weights=None, window=w) for s, w in zip(steps, win[:-1])]
                used, start, path = k, sp.clip, moved
            else:
                if foot != path[-1].foot or not fits(n - k, n, tr.entry_gait) or used + k > n:
                    continue
                moved = _end_layout(path, tr, win, forward) if layout else path
                if not _laid(snap, moved, max(len(path) - k - 2 - END_EASE[1], 0), len(path)):
                    continue
                out[n - k + 1:] = [replace(s, special=sp.clip, weights=None, window=w)
                                   for s, w in zip(steps[n - k + 1:], win[1:])]
                stop, path = sp.clip, moved
            break
    return path, out, replace(stand, start=start, stop=stop)


def _laid(snap: SnapFn | None, new_path, lo: int, hi: int) -> bool:
    """Whether the footprints ``new_path[lo:hi]`` moved there may stand where they are
    (``snap`` says so; True without one)."""
    if snap is None:
        return True
    pos = np.array([f.position for f in new_path[lo:hi]], float)
    _, ok = snap(pos, np.array([f.heading for f in new_path[lo:hi]], float))
    return bool(np.all(ok))


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


def _end_fixed(steps: list[PlanStep], stand: Standing | None) -> tuple[int, int]:
    """(first, last) footprints the smoothing keeps: one at either end walking, both
    standing feet standing, and with a start (stop) clip all the footprints of its steps
    too (the clip's own steps: shorter while it speeds up or slows down)."""
    if stand is None:
        return 1, 1
    lead = next((j for j, s in enumerate(steps) if s.special != stand.start), len(steps)) if stand.start else 0
    tail = next((j for j, s in enumerate(steps[::-1]) if s.special != stand.stop), len(steps)) if stand.stop else 0
    return max(2, lead + 1), max(2, tail + 2)


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
