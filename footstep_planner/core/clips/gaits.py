"""What a clip's stances (``stances``) say of it, for its analysis (``analysis``): its
flights and jumps (a loop's counted period by period), whether it is at rest at its start
and its end, its kind ("cycle", "start", "stop", "jump", "idle", or "other": not
locomotion) and its gaits ("walk", "run" or "stand"; on entry and exit too).

Pure numpy: never imports bpy.
"""

from __future__ import annotations

import numpy as np

from .clip import ClipMotion
from .stances import Stance, _Dense, _runs
from ..base.settings import Settings


def _flights_and_jumps(stances: list[Stance], d: _Dense, s: Settings
                       ) -> tuple[list[tuple[float, float]], list[tuple[float, float]]]:
    """(flights, jumps) as (start, end) s. A flight: inside the clip, neither foot bears
    weight, for 0.02 s or more. A jump: a flight of ``s.jump_min_flight`` or more that
    lasts twice the median flight (or any such flight when there are at most two)."""
    flights = _gaps([(st.strike, st.liftoff) for st in stances], 0.0, (d.n - 1) * d.dt)
    flights = [f for f in flights if f[1] - f[0] >= 0.02]
    durations = np.array([b - a for a, b in flights])
    typical = float(np.median(durations)) if len(durations) else 0.0
    jumps = [f for f in flights
             if f[1] - f[0] >= s.jump_min_flight and (f[1] - f[0] >= 2.0 * typical or len(flights) <= 2)]
    return flights, jumps


def _loop_jumps(flights: list[tuple[float, float]], period: float, s: Settings) -> list[tuple[float, float]]:
    """The jumps of a loop tiled period after period (``period`` s), its ``flights`` (start,
    end) s: a flight of ``s.jump_min_flight`` or more that lasts twice the median of the
    other flights of its period (any such flight when it is its period's only one: a run's
    cycle has two alike, a running jump's cycle a jump and a run's flights), the second
    period's read, the others' by their repeats."""
    own = [f for f in flights if period <= f[0] < 2 * period]
    jump_starts = []
    for f in own:
        others = [g[1] - g[0] for g in own if g is not f]
        if f[1] - f[0] >= s.jump_min_flight and (not others or f[1] - f[0] >= 2.0 * float(np.median(others))):
            jump_starts.append(f[0] - period)
    tol = 0.25 * min((b - a for a, b in flights), default=0.0) + 1e-6
    return [f for f in flights if any(abs(np.mod(f[0] - t + 0.5 * period, period) - 0.5 * period) <= tol
                                      for t in jump_starts)]


def _rest_at_ends(d: _Dense, contact: np.ndarray, s: Settings) -> tuple[bool, bool, np.ndarray]:
    """(starts_at_rest, ends_at_rest, moving): at rest is the body slower than
    ``s.rest_speed`` with both feet down, for ``s.rest_time`` at the clip's start or end;
    ``moving`` (n,) bool is every sample but the runs of rest touching either end."""
    rest_n = max(1, int(round(s.rest_time / d.dt)))
    both = contact[0] & contact[1]
    at_rest = (d.body_speed_s < s.rest_speed) & both
    starts_at_rest = bool(d.n > rest_n and at_rest[:rest_n].all())
    ends_at_rest = bool(d.n > rest_n and at_rest[-rest_n:].all())
    moving = ~(at_rest & _edge_runs(at_rest))
    return starts_at_rest, ends_at_rest, moving


def _jump_mask(d: _Dense, jumps: list[tuple[float, float]]) -> np.ndarray:
    """(n,) bool: the dense samples inside a jump's flight (ends rounded, included)."""
    in_jump = np.zeros(d.n, bool)
    for a, b in jumps:
        in_jump[int(round(a / d.dt)):int(round(b / d.dt)) + 1] = True
    return in_jump


def _kind(d: _Dense, jumps: list, starts_at_rest: bool, ends_at_rest: bool, s: Settings) -> str:
    """"jump" with a jump; "idle" at rest at both ends travelling under 0.5 m (a human's),
    else "start" / "stop" at rest at the start / end; "cycle" otherwise."""
    if jumps:
        return "jump"
    if starts_at_rest and ends_at_rest:
        pos = d.motion.root_pos
        travel = float(np.linalg.norm(pos[-1, :2] - pos[0, :2]))
        return "idle" if travel < s.length(0.5) else "start"
    if starts_at_rest:
        return "start"
    if ends_at_rest:
        return "stop"
    return "cycle"


#: m/s (a human's): locomotion whose steps have flights is still a walk while its body
#: goes slower than this (its 90th percentile): a game character's walk whose feet hover
#: a little over the ground between its steps; the slowest runs and jogs go faster.
WALK_TOP_SPEED = 2.0

#: The body stands at a clip's end while its hips are at least this share of their
#: standing height (the rig's, as it stands at rest; or the highest they are in the clip
#: with a foot on the ground, if lower) there, over END_POSTURE s.
STANDING_HIPS = 0.7
END_POSTURE = 0.2


def _locomotion_kind(kind: str, gait: str, m: ClipMotion, down: np.ndarray) -> str:
    """``kind``, or "other" for a clip (``m`` at the analysis rate, a foot ``down`` (n,)
    bool) that is not locomotion: its body does not stand at its start or its end (its
    hips below STANDING_HIPS of their standing height there: lying down, sitting, getting
    up), or a start or stop that neither walks nor runs (a lunge, a stagger that ends at
    rest). Such clips are never put in the library."""
    h = m.hips_in_root[:, 2, 3]
    top = float(h[down].max()) if down.any() else float(np.median(h))
    if m.stand_height is not None and m.stand_height > 0:
        top = min(top, m.stand_height)
    n = max(1, int(round(END_POSTURE * m.fps)))
    if top > 0 and min(float(np.mean(h[:n])), float(np.mean(h[-n:]))) < STANDING_HIPS * top:
        return "other"
    if kind in ("start", "stop") and gait not in ("walk", "run"):
        return "other"
    return kind


def _gait_of(d: _Dense, mask: np.ndarray, stances: list[Stance], flights: list,
             jumps: list, s: Settings) -> str | None:
    """The gait of the dense samples in ``mask`` (n,) bool: None under 0.15 s; "stand"
    when the body is slow or no foot lifts or lands in it; "walk" when a foot is always down, "run" when the steps have
    flight phases: decided by the share of the steps inside ``mask`` followed by a
    flight that is not a jump."""
    dt, n = d.dt, d.n
    if mask.sum() * dt < 0.15:
        return None
    if np.mean(d.body_speed_s[mask]) < 2 * s.rest_speed:
        return "stand"
    inside = lambda t_: mask[min(int(round(t_ / dt)), n - 1)]  # noqa: E731
    if not any(inside(t_) for st in stances for t_, cut in ((st.strike, st.open_start), (st.liftoff, st.open_end))
               if not cut):
        return "stand"  # no foot lifts or lands: the feet stay down (a jump on the spot's run-up)
    steps = sum(1 for st in stances if inside(st.stance))
    air = sum(1 for a, b in flights if inside(0.5 * (a + b)) and (a, b) not in jumps)
    runs = air > 0 if steps < 2 else air >= s.run_flight_share * (steps - 1)
    if runs and float(np.percentile(d.body_speed_s[mask], 90)) < s.length(WALK_TOP_SPEED):
        return "walk"  # (a game's walk whose feet hover between its steps: at a walk's speed, a walk)
    return "run" if runs else "walk"


def _gaits(d: _Dense, loco: np.ndarray, stances: list[Stance], flights: list, jumps: list,
           mine: list, starts_at_rest: bool, ends_at_rest: bool, s: Settings) -> tuple[str, str, str]:
    """(gait, entry_gait, exit_gait). The gait is that of the locomotion ``loco`` (n,)
    bool ("stand" when too short to tell); the clip is entered and left in it, or in the
    gaits before the first and after the last of the jumps ``mine`` (of all ``jumps``: the
    locomotion from the jump before them, to the jump after them), or "stand" from and to
    rest."""
    gait = _gait_of(d, loco, stances, flights, jumps, s) or "stand"
    if not mine:
        return (gait, "stand" if starts_at_rest else gait,
                "stand" if ends_at_rest else gait)
    ja, jb = int(round(mine[0][0] / d.dt)), int(round(mine[-1][1] / d.dt))
    before = [b for a, b in jumps if b <= mine[0][0]]
    after = [a for a, b in jumps if a >= mine[-1][1]]
    pre = loco.copy()
    pre[ja:] = False
    if before:
        pre[:int(round(max(before) / d.dt)) + 1] = False
    post = loco.copy()
    post[:jb + 1] = False
    if after:
        post[int(round(min(after) / d.dt)):] = False
    entry_gait = "stand" if starts_at_rest else (_gait_of(d, pre, stances, flights, jumps, s) or gait)
    exit_gait = "stand" if ends_at_rest else (_gait_of(d, post, stances, flights, jumps, s) or gait)
    return gait, entry_gait, exit_gait


def _gaps(intervals, lo, hi):
    """Interior gaps (a, b) of the union of closed intervals within [lo, hi]."""
    out, end = [], None
    for a, b in sorted(intervals):
        if end is not None and a > end:
            out.append((end, a))
        end = b if end is None else max(end, b)
    return [(a, b) for a, b in out if a > lo and b < hi]


def _edge_runs(mask: np.ndarray) -> np.ndarray:
    """Only the runs of ``mask`` touching either end of the clip."""
    out = np.zeros_like(mask)
    for a, b in _runs(mask):
        if a == 0 or b == len(mask):
            out[a:b] = True
    return out
