"""The report of a plan and of a bake, built from the core's results and plain arrays.

Every caller (the command line's plan and bake, the panel's operators, the demo, the
benchmarks) builds its report here, so the figures mean the same everywhere. The
Blender layer's only part is to read what Blender evaluates into the arrays that
``measure_bake`` takes (``PlayedPose``, ``FootPoints``).

Conventions: Blender world, Z up, metres; frames are scene frames, ``frame_start`` the
first baked frame; times in seconds from the path's start; headings in radians.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from .metrics import introduced_pops, quality, rotation_steps
from ..plan.navgraph import PlanResult
from ..synth.pipeline import Synthesis, stage_row
from ..plan.surface import Ground


def _r4(v) -> list:
    return [round(float(x), 4) for x in v]


def frame_index(t: float, fps: float, frames: int) -> int:
    """The frame index (0..frames-1) nearest the time ``t`` (s) at ``fps``."""
    return int(np.clip(round(t * fps), 0, frames - 1))


def planted_stances(feet: np.ndarray, planted: Sequence[tuple[float, float, float]], positions: np.ndarray,
                    headings: np.ndarray, fps: float, frames: int) -> list[dict]:
    """The stances ``metrics`` measures, one per footprint: ``foot``, ``start``,
    ``stance``, ``end`` (frame indices of strike, stance and liftoff), and the footprint's
    ``position`` (3,) and ``heading``. ``planted`` holds (strike, stance, liftoff)
    seconds per footprint (``Synthesis.planted``)."""
    idx = lambda t: frame_index(t, fps, frames)  # noqa: E731
    return [{"foot": int(feet[i]), "start": idx(a), "end": idx(b), "stance": idx(m),
             "position": positions[i], "heading": float(headings[i])}
            for i, (a, m, b) in enumerate(planted)]


def source_steps(tracks: dict, clips: Sequence[str], weights: np.ndarray, fps: float) -> np.ndarray:
    """(B,) the largest rotation step (rad) each bone takes between two frames at ``fps``
    in any clip that plays (a weight above 0 in ``weights`` (F, C), columns ``clips``)."""
    out = None
    for c, name in enumerate(clips):
        if not (weights[:, c] > 0).any():
            continue
        tr = tracks[name]
        step = rotation_steps(tr.quat).max(axis=0) * tr.pose_rate / fps  # per sample -> per frame
        out = step if out is None else np.maximum(out, step)
    return out


def ground_under(ground: Ground, points: np.ndarray) -> np.ndarray:
    """(...,) the surface height under ``points`` (..., 3) within half a metre above and
    a metre below them; NaN where there is none (a gap)."""
    p = np.asarray(points, float)
    hit = ground.ray_down(p.reshape(-1, 3) + [0.0, 0.0, 0.5], 1.5)
    return np.where(hit.hit, hit.z, np.nan).reshape(p.shape[:-1])


@dataclass(frozen=True, eq=False)
class PlayedPose:
    """A baked motion as Blender plays it, F frames of a rig of B bones, for
    ``measure_bake``:

    - ``world`` (F, B, 4, 4): each bone's matrix in the world (metres);
    - ``bone_rot`` (F, B, 4): each bone's rotation relative to its rest pose (scipy x, y, z, w);
    - ``body_pos`` (F, 3): the body's position in the world (metres);
    - ``body_yaw`` (F,): the body's heading in the planner's heading frame (radians, unwrapped);
    - ``bone_names`` (B,): the bones' names, for the figures that name one;
    - ``tips`` (2, F, 3) or None: the left and right toe tips in the world (metres), when
      the lowest of heel, ball and tip is to be measured too."""

    world: np.ndarray
    bone_rot: np.ndarray
    body_pos: np.ndarray
    body_yaw: np.ndarray
    bone_names: Sequence[str]
    tips: np.ndarray | None = None


@dataclass(frozen=True, eq=False)
class FootPoints:
    """The points ``measure_bake`` measures on each foot (left, then right):

    - ``bones`` (2,): the foot bones' indices in the rig;
    - ``heel_local`` (2, 4): the heel points, homogeneous, each in its foot bone's own
      space (metres);
    - ``toe_local`` (2, 4): the toe (ball) points, likewise."""

    bones: Sequence[int]
    heel_local: np.ndarray
    toe_local: np.ndarray


def measure_bake(pose: PlayedPose, feet: FootPoints, ground: Ground, stances: list[dict], goal, goal_heading,
                 allowance: np.ndarray | None) -> dict:
    """The quality of a baked motion as it plays (see ``metrics``): the ``pose`` played, its
    heel and toe points ``feet`` over the ``ground``, its ``stances`` (``planted_stances``),
    the ``goal`` (3,) and ``goal_heading`` (rad, the planner's, or None) it is to reach;
    ``allowance`` (B,) each bone's largest step in its clips (``source_steps``), for the pops
    the planner made. Bones are named."""
    world, bone_rot = pose.world, pose.bone_rot
    heel = np.stack([(world[:, f] @ feet.heel_local[k])[:, :3] for k, f in enumerate(feet.bones)])
    toe = np.stack([(world[:, f] @ feet.toe_local[k])[:, :3] for k, f in enumerate(feet.bones)])
    ground_z = np.stack([ground_under(ground, heel), ground_under(ground, toe)], axis=-1)
    qual = quality(heel, toe, ground_z, stances, world[..., :3, 3], bone_rot, pose.body_pos, pose.body_yaw,
                   np.asarray(goal, float), goal_heading)
    qual["pops"]["introduced"] = introduced_pops(bone_rot, allowance)
    if pose.tips is not None:  # (the toe tips (2, F, 3) too: the lowest of heel, ball and tip)
        depth = ground_under(ground, pose.tips) - np.asarray(pose.tips, float)[..., 2]
        tip = max(float(np.nanmax(depth)) if np.isfinite(depth).any() else 0.0, 0.0) * 1000.0
        pen = qual["penetration"]
        pen["tip_max_mm"] = round(tip, 3)
        pen["lowest_mm"] = round(max(pen["max_mm"], tip), 3)
    names = pose.bone_names
    for key in ("rotation_bone", "offset_bone"):
        if qual["pops"].get(key) is not None:
            qual["pops"][key] = names[qual["pops"][key]]
    if qual["pops"]["introduced"]["bone"] is not None:
        qual["pops"]["introduced"]["bone"] = names[qual["pops"]["introduced"]["bone"]]
    return qual


#: A bake as played is wrong (an error, not a result) when its body ends this much
#: further from the goal than the plan's own goal radius, or a planted foot slides more
#: than this (a human's metres; times the body's size).
PLAYED_GOAL_SLACK = 0.25
PLAYED_SKATE_MAX = 0.1


def tolerances(goal_radius: float, scale: float = 1.0) -> dict:
    """The limits ``played_faults`` holds a bake to, for a plan of ``goal_radius`` (m) and
    a body ``scale`` times a human's: goal distance (m) and foot skate (mm)."""
    return {"goal_m": round(float(goal_radius + PLAYED_GOAL_SLACK * scale), 4),
            "foot_skate_mm": round(float(PLAYED_SKATE_MAX * scale * 1000.0), 3)}


def played_faults(quality: dict, limits: dict) -> list[str]:
    """What of a bake's measured quality (``measure_bake``) is beyond ``limits``
    (``tolerances``): each a phrase naming the figure and its limit."""
    out = []
    dist = (quality.get("goal") or {}).get("distance_m")
    if dist is not None and np.isfinite(dist) and dist > limits["goal_m"]:
        out.append(f"as played it ends {dist:.2f} m from the goal (the limit is {limits['goal_m']:.2f} m)")
    skate = (quality.get("foot_skate") or {}).get("max_mm")
    if skate is not None and np.isfinite(skate) and skate > limits["foot_skate_mm"]:
        out.append(f"a planted foot slides {skate:.0f} mm as played (the limit is {limits['foot_skate_mm']:.0f} mm)")
    return out


def feet_points(bones: Sequence[str], heel_local: np.ndarray, toe_local: np.ndarray) -> dict:
    """What ``measure_bake`` measures on each foot, for anyone to measure it again: the left
    and right foot bones' names and the heel and toe points (homogeneous, in each foot
    bone's own space, metres)."""
    return {"bones": list(bones), "heel_local": np.round(np.asarray(heel_local, float), 6).tolist(),
            "toe_local": np.round(np.asarray(toe_local, float), 6).tolist()}


def plan_report(result: PlanResult, syn: Synthesis, character: str, goal, frame_start: float,
                synthesis: bool = True, **later_stages) -> dict:
    """A plan's report: the search's footprints and figures, the character, the goal, the
    stage times (Table 4.1 layout; ``later_stages`` in seconds, e.g. ``ik=``) and, with
    ``synthesis``, the per-frame synthesis from ``frame_start``."""
    doc = result.to_dict()
    doc["character"] = character
    doc["goal"] = _r4(goal)
    doc["stages"] = stage_row(len(result.footprints), result.seconds, syn, **later_stages)
    doc["turns_in_place"] = turn_rows(syn, frame_start)
    if synthesis:
        doc["synthesis"] = syn.to_dict(frame0=float(frame_start))
    return doc


def turn_rows(syn: Synthesis, frame_start: float) -> list[dict]:
    """Where the motion turns in place (``turn_in_place``): at the "start", at a "waypoint"
    it stops at or at the "end"; the degrees the body turns (positive left), its pivot
    steps, its first and last scene frame (the first frame being ``frame_start``) and its
    seconds."""
    return [dict(t, frames=[frame_start + f for f in t["frames"]]) for t in getattr(syn, "turns", [])]


@dataclass(frozen=True)
class BakeIdentity:
    """What a bake is, by name: ``character`` the character's (object's) name, ``name`` the
    bake's name, ``action`` and ``track`` the names of the Action and the NLA track it was
    baked into."""

    character: str
    name: str
    action: str
    track: str


@dataclass(frozen=True, eq=False)
class BakeTiming:
    """When a bake plays: ``frame_start`` its first scene frame (an integer frame),
    ``frames`` how many frames it has, ``fps`` the scene's frames per second, and
    ``planted`` (strike, stance, liftoff) seconds from the path's start per footprint when
    the bake's timing is not the synthesis's (as after a re-bake's splice), else None (the
    synthesis's own, ``Synthesis.planted``)."""

    frame_start: int
    frames: int
    fps: float
    planted: Sequence[tuple[float, float, float]] | None = None


def bake_report(result: PlanResult, syn: Synthesis, baked: BakeIdentity, timing: BakeTiming, *, goal, forward,
                stages: dict, quality: dict) -> dict:
    """A bake's report: the plan's (``plan_report``) with the bake's name, frames, action
    and track (``baked``, ``timing``), its stage times and quality, and per footprint the
    frames its foot is planted (scene frames, at ``timing``'s) and its final place."""
    frame_start, frames = timing.frame_start, timing.frames
    doc = plan_report(result, syn, baked.character, goal, frame_start, synthesis=False)
    pos, head = syn.footprints
    planted = syn.planted() if timing.planted is None else timing.planted
    fr = lambda t: frame_start + frame_index(t, timing.fps, frames)  # noqa: E731
    doc.update({"name": baked.name, "forward": [round(float(v), 6) for v in forward],
                "frame_start": frame_start, "frame_end": frame_start + frames - 1,
                "action": baked.action, "track": baked.track, "stages": stages, "quality": quality,
                "footprints": [{**f, "planted_frames": [fr(a), fr(b)], "frame": fr(m),
                                "position": _r4(pos[i]), "heading": round(float(head[i]), 4)}
                               for i, (f, (a, m, b)) in enumerate(zip(doc["footprints"], planted))]})
    doc["synthesis"] = syn.to_dict(frame0=float(frame_start))
    return doc
