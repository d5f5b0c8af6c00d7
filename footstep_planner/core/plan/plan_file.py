"""A plan as data (PLAN.json): the footprints of a planned path, for a pipeline (or an
animator, by hand) to edit and bake (``plan --out-plan``, ``bake --plan``).

    {"format": "footstep-plan", "version": 1,
     "character": "Hero", "forward": [0, -1, 0],
     "goal": [x, y, z], "goal_heading": 1.57 or null,
     "footprints": [{"foot": "L", "position": [x, y, z], "heading": 0.0, "time": 0.0,
                     "clip": "walk", "gait": "walk", "jump": false, "tread": false,
                     "locked": false, "planned": [x, y, z, heading]}, ...]}

Positions are world metres; a heading is a yaw (rad, positive turning left) from
``forward``, the world direction of heading 0 (the character's rest forward as it stood
in the scene when planned). Numbers are written in full, so a plan read back is the plan
written. ``planned`` is the pose the planner gave the footprint: a footprint whose
position or heading an edit changed from it counts as moved (and so locked: whoever
moved it wants it there); without ``planned`` a footprint counts as unmoved. ``tread``:
the planner set the footprint square and whole on a stair's tread, and the synthesis keeps
it where it is (absent: false). ``blend`` (only where a jog laid the step to it): the
walk/run blend it is played at, 0 the walk to 1 the run (``core.perform.stride``).
Pure Python and numpy.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass

import numpy as np

from ..base.errors import FootstepError
from ..footprint import PathFootprint

FORMAT = "footstep-plan"
VERSION = 1
GAITS = ("walk", "run", "stand")
#: m and rad a footprint may differ from its planned pose and still count as unmoved
TOUCH = 1e-4


class PlanFileError(FootstepError):
    """A PLAN.json that can't be used: names the file, the footprint and the field."""


@dataclass
class PlanFile:
    """A plan read from (or to write to) a PLAN.json."""

    character: str
    forward: np.ndarray  # (3,) world direction of heading 0
    footprints: list[PathFootprint]
    locked: np.ndarray  # (N,) bool
    goal: np.ndarray | None = None  # (3,)
    goal_heading: float | None = None  # rad, from ``forward``
    moved: np.ndarray | None = None  # (N,) bool: changed from the planned pose by an edit

    def __post_init__(self):
        if self.moved is None:
            self.moved = np.zeros(len(self.footprints), bool)

    def to_dict(self) -> dict:
        fl = lambda v: [float(x) for x in v]  # noqa: E731
        return {"format": FORMAT, "version": VERSION, "character": self.character, "forward": fl(self.forward),
                "goal": None if self.goal is None else fl(self.goal),
                "goal_heading": None if self.goal_heading is None else float(self.goal_heading),
                "footprints": [{"foot": "LR"[f.foot], "position": fl(f.position), "heading": float(f.heading),
                                "time": float(f.time), "clip": f.label, "gait": f.gait, "jump": bool(f.jump),
                                "tread": bool(f.tread), "locked": bool(lk), "planned": [*fl(f.position), float(f.heading)],
                                **({} if f.speed is None else {"blend": float(f.speed)})}
                               for f, lk in zip(self.footprints, self.locked)]}


def _vector(value, n: int) -> np.ndarray | None:
    ok = isinstance(value, list) and len(value) == n and all(
        isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in value)
    return np.array(value, float) if ok else None


def _number(value) -> float | None:
    ok = isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
    return float(value) if ok else None


def _moved(d: dict, pos: np.ndarray, heading: float, bad) -> bool:
    """Whether a footprint differs from its ``planned`` pose (False without one)."""
    if d.get("planned") is None:
        return False
    planned = _vector(d.get("planned"), 4)
    if planned is None:
        raise bad("planned", "four finite numbers (x, y, z, heading) or missing")
    turn = abs((heading - planned[3] + math.pi) % (2 * math.pi) - math.pi)
    return bool(np.abs(pos - planned[:3]).max() > TOUCH or turn > TOUCH)


def _footprint(i: int, d, where: str) -> tuple[PathFootprint, bool, bool]:
    """Footprint ``i`` of the file, checked field by field."""
    def bad(field: str, want: str):
        got = json.dumps(d.get(field) if isinstance(d, dict) else d)[:40]
        return PlanFileError(f"{where}: footprint {i}: {field!r} must be {want}; got {got}")

    if not isinstance(d, dict):
        raise bad("footprint", "an object")
    if d.get("foot") not in ("L", "R"):
        raise bad("foot", '"L" or "R"')
    pos = _vector(d.get("position"), 3)
    if pos is None:
        raise bad("position", "three finite numbers (m)")
    heading = _number(d.get("heading"))
    if heading is None:
        raise bad("heading", "a finite number (rad)")
    time = _number(d.get("time", 0.0))
    if time is None:
        raise bad("time", "a finite number (s)")
    for field in ("clip", "gait"):
        if not isinstance(d.get(field, ""), str):
            raise bad(field, "text")
    for field in ("jump", "tread", "locked"):
        if not isinstance(d.get(field, False), bool):
            raise bad(field, "true or false")
    blend = d.get("blend")
    if blend is not None and (_number(blend) is None or not 0.0 <= blend <= 1.0):
        raise bad("blend", "a number from 0 (the walk) to 1 (the run)")
    fp = PathFootprint("LR".index(d["foot"]), pos, heading, time, d.get("clip") or "",
                       d.get("gait") or "walk", bool(d.get("jump", False)), bool(d.get("tread", False)),
                       None if blend is None else float(blend))
    return fp, bool(d.get("locked", False)), _moved(d, pos, heading, bad)


def _check_feet(footprints: list[PathFootprint], where: str) -> None:
    for i in range(1, len(footprints)):
        if footprints[i].foot == footprints[i - 1].foot:
            raise PlanFileError(f"{where}: footprints {i - 1} and {i} are both {'LR'[footprints[i].foot]}: "
                                "the feet must alternate")


def plan_from_dict(doc, where: str = "the plan") -> PlanFile:
    """A PlanFile from a PLAN.json's document, every field checked (a PlanFileError names
    the file, the footprint and the field)."""
    if not isinstance(doc, dict) or doc.get("format") != FORMAT:
        raise PlanFileError(f"{where} is not a footstep plan (no \"format\": \"{FORMAT}\"): make one "
                            "with: footstep plan ... --out-plan PLAN.json")
    if doc.get("version") != VERSION:
        raise PlanFileError(f"{where}: plan version {doc.get('version')!r} is not {VERSION}")
    if not isinstance(doc.get("character"), str) or not doc["character"]:
        raise PlanFileError(f"{where}: 'character' must be an armature's name")
    forward = _vector(doc.get("forward"), 3)
    if forward is None or np.linalg.norm(forward[:2]) < 1e-6:
        raise PlanFileError(f"{where}: 'forward' must be three finite numbers, not vertical")
    raw = doc.get("footprints")
    if not isinstance(raw, list) or len(raw) < 2:
        raise PlanFileError(f"{where}: 'footprints' must be a list of at least two footprints")
    pairs = [_footprint(i, d, where) for i, d in enumerate(raw)]
    footprints = [p[0] for p in pairs]
    _check_feet(footprints, where)
    goal = None if doc.get("goal") is None else _vector(doc.get("goal"), 3)
    if doc.get("goal") is not None and goal is None:
        raise PlanFileError(f"{where}: 'goal' must be three finite numbers or null")
    heading = None if doc.get("goal_heading") is None else _number(doc.get("goal_heading"))
    if doc.get("goal_heading") is not None and heading is None:
        raise PlanFileError(f"{where}: 'goal_heading' must be a finite number (rad) or null")
    moved = np.array([p[2] for p in pairs], bool)
    return PlanFile(doc["character"], forward / np.linalg.norm(forward), footprints,
                    np.array([p[1] for p in pairs], bool) | moved, goal, heading, moved)


def read_plan(text: str, where: str) -> PlanFile:
    try:
        doc = json.loads(text)
    except ValueError as ex:
        raise PlanFileError(f"{where} is not JSON ({ex})") from None
    return plan_from_dict(doc, where)


__all__ = ["FORMAT", "TOUCH", "PlanFile", "PlanFileError", "VERSION", "plan_from_dict", "read_plan"]
