"""A plan read against the clip library: the cyclic clips (``cyclic_clips``), a plan
label's weights, gait and curvature, the plan's steps (``plan_steps``), each step's pace
(``_step_pace``, ``_climb_pace``) and the clips' tracks (``clip_tracks``, ``_LazyTracks``).
"""

from __future__ import annotations

import numpy as np

from ..clips.library import Library
from .schedule import PlanStep
from .tracks import BlendError, ClipTrack, make_track


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
    tau = library.label_tau(clip)
    return 0.0 if tau is None else tau


def plan_steps(path, library: Library, cyclic: list[str]) -> list[PlanStep]:
    specials = {s.clip for s in library.specials}
    out = []
    for a, b in zip(path[:-1], path[1:]):
        if b.label in specials:
            out.append(PlanStep(a.foot, b.label, None))
        else:
            out.append(PlanStep(a.foot, None, label_weights(b.label, library, cyclic)))
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


def clip_tracks(library: Library, analyses) -> dict[str, ClipTrack]:
    """Clip name -> ClipTrack of every clip of the library (``analyses`` may already be
    the tracks: a copy of that dict). ``synthesize`` takes the result in place of the
    analyses, so a run of many legs makes them once."""
    if isinstance(analyses, dict):
        return dict(analyses)
    by = {a.name: a for a in analyses}
    missing = [c for c in library.clips() if c not in by]
    if missing:
        raise BlendError(f"clips of the library are missing: {', '.join(missing)}")
    return {c: make_track(by[c]) for c in library.clips()}


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
