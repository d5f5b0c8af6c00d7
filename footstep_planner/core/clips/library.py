"""A character's clip library: clips grouped into blend groups (thesis 3.7).

Proposed from the clip analysis, editable by the user, stored as JSON on the armature.

- A *turning group* per gait (walk, run) holds the cyclic clips of that gait, each with
  its curvature tau (1/m, positive turning left); the planner blends the two clips that
  bracket the path's tau. Beyond the group's range a plan step may still turn: the
  steps of its outermost clip are bent into arcs (core.steps, ``bend_curvature``); their
  labels "group@tau" lie outside the range (``Library.bend_of``).
- The *speed group* blends the walk group (s = 0) with the run group (s = 1).
- *Special clips* (jumps, starts, stops, idles) are played whole, never blended with
  the groups; each carries the gait it is entered and left in ("stand", "walk", "run").
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np

from .analysis import ClipAnalysis
from ..base.errors import FootstepError

GAITS = ("walk", "run")
SPECIAL_KINDS = ("jump", "start", "stop", "idle")


class LibraryError(FootstepError):
    """A library that does not fit its clips; the message names the clip or group."""


@dataclass
class GroupClip:
    clip: str
    tau: float  # 1/m
    speed: float  # m/s


@dataclass
class TurnGroup:
    name: str
    gait: str
    clips: list[GroupClip] = field(default_factory=list)  # sorted by tau

    def tau_range(self) -> tuple[float, float]:
        taus = [c.tau for c in self.clips]
        return (min(taus), max(taus)) if taus else (0.0, 0.0)

    def weights(self, tau: float) -> dict[str, float]:
        """Thesis 3.7.1: linear interpolation between the two clips bracketing ``tau``;
        outside the range the nearest clip takes it all. Weights sum to 1."""
        cs = self.clips
        if not cs:
            return {}
        if tau <= cs[0].tau:
            return {cs[0].clip: 1.0}
        if tau >= cs[-1].tau:
            return {cs[-1].clip: 1.0}
        for a, b in zip(cs[:-1], cs[1:]):
            if a.tau <= tau <= b.tau:
                if b.tau - a.tau < 1e-12:
                    return {a.clip: 1.0}
                w = (tau - a.tau) / (b.tau - a.tau)
                out = {a.clip: 1.0 - w}
                out[b.clip] = out.get(b.clip, 0.0) + w
                return out
        raise AssertionError("unreachable")

    def bend(self, tau: float) -> float:
        """How far (1/m, signed) ``tau`` lies beyond the clips' own turning range: the
        curvature a step of ``tau`` is bent by beyond the clip that plays it (0 inside
        the range)."""
        lo, hi = self.tau_range()
        return float(tau - min(max(tau, lo), hi)) if self.clips else 0.0


@dataclass
class SpecialClip:
    clip: str
    kind: str  # one of SPECIAL_KINDS
    entry_gait: str
    exit_gait: str


@dataclass
class Library:
    turn_groups: dict[str, TurnGroup] = field(default_factory=dict)  # keyed by gait
    specials: list[SpecialClip] = field(default_factory=list)
    excluded: list[str] = field(default_factory=list)  # clips left out, by the user
    edited: bool = False  # True once a user changed it; a proposal is never stored over it

    @property
    def speed_group(self) -> tuple[str, str] | None:
        """(walk group, run group) when both exist: the walk/run blend parameter s."""
        if all(g in self.turn_groups and self.turn_groups[g].clips for g in GAITS):
            return ("walk", "run")
        return None

    def clips(self) -> list[str]:
        names = [c.clip for g in self.turn_groups.values() for c in g.clips]
        return names + [sp.clip for sp in self.specials]

    def label_tau(self, label: str) -> float | None:
        """The curvature tau (1/m) a plan step's label turns: a "<group name>@<tau>"'s tau,
        a turning group clip's own; None for any other label (a special clip, a start)."""
        if "@" in label:
            try:
                return float(label.rsplit("@", 1)[1])
            except ValueError:
                return None
        for g in self.turn_groups.values():
            for c in g.clips:
                if c.clip == label:
                    return c.tau
        return None

    def run_reach(self, bend_curvature: float) -> tuple[float, float] | None:
        """(least, most) tau (1/m) the library's running steps turn: the run group's clips'
        range, out to +-``bend_curvature`` on a side where its steps are bent that far
        (no clip of the library turns that tightly there: ``steps.bend_curvatures``).
        None without both a walk and a run group (no walk to slow a run's turn into)."""
        if self.speed_group is None:
            return None
        lo, hi = self.turn_groups["run"].tau_range()
        every = [c.tau for g in self.turn_groups.values() for c in g.clips]
        if bend_curvature > 0 and max(every) < bend_curvature - 1e-3:
            hi = max(hi, bend_curvature)
        if bend_curvature > 0 and min(every) > -bend_curvature + 1e-3:
            lo = min(lo, -bend_curvature)
        return lo, hi

    def corners(self, labels, gaits, bend_curvature: float) -> np.ndarray:
        """(N,) bool: which plan steps (their ``labels`` and ``gaits`` (N,)) are a walk's
        turn tighter than any running step of the library turns (``run_reach``, beyond it
        by more than a label's precision): where a run slows into a walk to turn, and the
        blend follows (``synth.passes.speed_pins``; the search's ``CORNER_STEPS``)."""
        out = np.zeros(len(labels), bool)
        reach = self.run_reach(bend_curvature)
        if reach is None:
            return out
        lo, hi = reach
        for i, (label, gait) in enumerate(zip(labels, gaits)):
            tau = self.label_tau(str(label)) if gait == "walk" else None
            out[i] = tau is not None and (tau > hi + 1e-3 or tau < lo - 1e-3)
        return out

    def bend_of(self, label: str) -> float:
        """The bend (1/m, ``TurnGroup.bend``) of a plan step's label: non-zero only for a
        "<group name>@<tau>" beyond that group's clips, a step the planner bent."""
        if "@" not in label:
            return 0.0
        gname, tau = label.rsplit("@", 1)
        group = next((g for g in self.turn_groups.values() if g.name == gname), None)
        try:
            bend = group.bend(float(tau)) if group is not None else 0.0
        except ValueError:
            return 0.0
        return bend if abs(bend) >= 1e-3 else 0.0  # within the label's precision: inside

    def to_dict(self) -> dict:
        return {
            "turn_groups": {k: asdict(g) for k, g in self.turn_groups.items()},
            "speed_group": self.speed_group,
            "specials": [asdict(sp) for sp in self.specials],
            "excluded": list(self.excluded),
            "edited": self.edited,
        }

    def check(self, available: set[str]) -> None:
        """Raise LibraryError naming any clip the library uses that no longer exists."""
        gone = [c for c in self.clips() if c not in available]
        if gone:
            raise LibraryError(f"the clip library names clips that no longer exist: {', '.join(gone)}")


def propose_library(analyses: list[ClipAnalysis], excluded=()) -> Library:
    """The library the analysis suggests: cyclic clips into a turning group per gait,
    jumps, starts, stops and idles as special clips (the stillest idle first: the one the
    character stands in, not a clapping or a looking-round); clips that are not
    locomotion (kind "other": lying, sitting, a lunge) are left out."""
    groups: dict[str, TurnGroup] = {}
    specials: list[SpecialClip] = []
    for a in analyses:
        if a.name in excluded:
            continue
        if a.kind == "cycle" and a.gait in GAITS:
            g = groups.setdefault(a.gait, TurnGroup(f"{a.gait}_turn", a.gait))
            g.clips.append(GroupClip(a.name, float(a.tau), float(a.speed)))
        elif a.kind in SPECIAL_KINDS:
            specials.append(SpecialClip(a.name, a.kind, a.entry_gait, a.exit_gait))
    for g in groups.values():
        g.clips.sort(key=lambda c: c.tau)
    stir = {a.name: _stir(a) for a in analyses if a.kind == "idle"}
    specials.sort(key=lambda sp: (SPECIAL_KINDS.index(sp.kind), stir.get(sp.clip, 0.0), sp.clip))
    return Library(groups, specials, list(excluded))


def _stir(a: ClipAnalysis) -> float:
    """rad/s: how much a clip's bones turn, the mean over its bones and samples of each
    one's rotation from one sample to the next (0 without a motion)."""
    m = a.motion
    if m is None or m.n < 2:
        return 0.0
    r = np.asarray(m.local_rot, float)
    trace = np.einsum("fbij,fbij->fb", r[1:], r[:-1])
    return float(np.arccos(np.clip((trace - 1.0) / 2.0, -1.0, 1.0)).mean() * m.fps)
