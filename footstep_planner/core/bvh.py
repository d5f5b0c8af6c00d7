"""Reading a BVH file's skeleton and checking the file is well formed.

Blender's own importer reads the motion; this module only checks the file (so a bad file
gives one clear message naming the file and line, before anything in the scene changes)
and reads what the import needs to know: joint names and offsets, channels, frame count,
frame rate, and the length unit.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field

import numpy as np
from .errors import FootstepError


class BvhError(FootstepError):
    """A BVH file that cannot be read; the message names the file (and line)."""


@dataclass(frozen=True)
class BvhSkeleton:
    path: str
    names: tuple[str, ...]
    parents: tuple[int, ...]
    offsets: np.ndarray  # (J, 3) in file units, file axes (Y up)
    channels: tuple[tuple[str, ...], ...]
    end_sites: np.ndarray  # (J, 3) end-site offset of each joint (zeros if none)
    frames: int
    frame_time: float

    @property
    def fps(self) -> float:
        """Frames per second; a rate within 0.01 of a whole number (120.0005 written as
        a frame time of 0.0083333) is taken as that number."""
        fps = 1.0 / self.frame_time
        return float(round(fps)) if abs(fps - round(fps)) < 0.01 else fps

    def heads(self) -> np.ndarray:
        """Rest head positions in file units, file axes."""
        heads = np.zeros_like(self.offsets)
        for j, p in enumerate(self.parents):
            heads[j] = self.offsets[j] + (heads[p] if p >= 0 else 0.0)
        return heads

    def heads_z_up(self) -> np.ndarray:
        """Rest heads in Blender's axes (Y-up file, -Z forward -> Z up): (x, -z, y)."""
        h = self.heads()
        return np.stack([h[:, 0], -h[:, 2], h[:, 1]], axis=1)

    def tails_z_up(self) -> np.ndarray:
        """Rest tails in Blender's axes: the mean head of a joint's children, or for a
        joint without children its head plus its end-site offset."""
        heads = self.heads()
        tails = heads.copy()
        for j in range(len(self.names)):
            kids = [c for c, p in enumerate(self.parents) if p == j]
            if kids:
                tails[j] = np.mean(heads[kids], axis=0)
            else:
                tails[j] = heads[j] + self.end_sites[j]
        return np.stack([tails[:, 0], -tails[:, 2], tails[:, 1]], axis=1)

    def unit_scale(self) -> float:
        """Metres per file unit, guessed from the skeleton's height (the vertical extent of
        the rest pose): metres, centimetres or inches for a human-sized character."""
        h = self.heads()
        span = float(np.ptp(h[:, 1])) if len(h) else 0.0
        if span <= 0:
            raise BvhError(f"{self.path}: the skeleton has no height; cannot guess its unit")
        for scale in (1.0, 0.01, 0.0254, 0.001):
            if 0.4 <= span * scale <= 3.0:
                return scale
        raise BvhError(f"{self.path}: skeleton height {span:g} units fits neither metres, "
                       "centimetres, inches nor millimetres; give the scale by hand")


def read_skeleton(path: str) -> BvhSkeleton:
    """Parse and check a BVH file. Raises BvhError naming the file and line at fault."""
    lines = _read_lines(path)
    i = _hierarchy_start(lines, path)
    joints, i = _parse_hierarchy(lines, i, path)
    frames, frame_time, i = _motion_header(lines, i, path)
    _check_motion(lines[i:], frames, sum(len(c) for c in joints.channels), path)
    return BvhSkeleton(path, tuple(joints.names), tuple(joints.parents), np.array(joints.offsets),
                       tuple(joints.channels), np.array(joints.ends), frames, frame_time)


@dataclass
class _Joints:
    """The hierarchy as parsed so far, one entry per joint in file order."""

    names: list[str] = field(default_factory=list)
    parents: list[int] = field(default_factory=list)  # index of the parent joint, -1 for the root
    offsets: list[np.ndarray] = field(default_factory=list)  # (3,) file units, file axes
    channels: list[tuple[str, ...]] = field(default_factory=list)  # upper case
    ends: list[np.ndarray] = field(default_factory=list)  # (3,) end-site offset, zeros if none


# Markers on the stack of open blocks besides joint indices (>= 0).
_END_SITE = -2  # an "End Site" block


def _read_lines(path: str) -> list[str]:
    """The file's lines (undecodable bytes replaced); BvhError when it cannot be read."""
    if not os.path.isfile(path):
        raise BvhError(f"{path}: no such file")
    try:
        with open(path, "r", encoding="utf-8", errors="replace") as fh:
            return fh.read().splitlines()
    except OSError as ex:
        raise BvhError(f"{path}: cannot read ({ex.strerror})") from None


def _skip_blank(lines: list[str], i: int) -> int:
    """Index of the first non-blank line at or after ``i`` (len(lines) if none)."""
    while i < len(lines) and not lines[i].strip():
        i += 1
    return i


def _hierarchy_start(lines: list[str], path: str) -> int:
    """Index of the line after the leading HIERARCHY keyword; BvhError without it."""
    i = _skip_blank(lines, 0)
    if i >= len(lines) or lines[i].strip().upper() != "HIERARCHY":
        raise BvhError(f"{path}: not a BVH file (it does not start with HIERARCHY)")
    return i + 1


def _parse_hierarchy(lines: list[str], i: int, path: str) -> tuple[_Joints, int]:
    """The joints from line ``i`` up to MOTION, and the index of the line after MOTION.
    BvhError naming the 1-based line of the first fault."""
    joints = _Joints()
    stack: list[int] = []  # open blocks: joint indices, or _END_SITE
    pending: int | None = None  # the joint (or _END_SITE) whose "{" is expected
    while i < len(lines):
        tok = lines[i].split()
        i += 1
        if not tok:
            continue
        if tok[0].upper() == "MOTION":
            break
        try:
            pending = _hierarchy_line(tok, joints, stack, pending)
        except _LineError as ex:
            raise BvhError(f"{path}, line {i}: {ex}") from None
    else:
        raise BvhError(f"{path}: no MOTION section")
    if stack:
        raise BvhError(f"{path}: the hierarchy is not closed (missing '}}')")
    if not joints.names:
        raise BvhError(f"{path}: the hierarchy has no joints")
    return joints, i


class _LineError(Exception):
    """A fault in one line of the hierarchy (the caller adds file and line)."""


def _hierarchy_line(tok: list[str], joints: _Joints, stack: list[int], pending: int | None
                    ) -> int | None:
    """Apply one hierarchy line, split into tokens ``tok``, to ``joints`` and the block
    ``stack`` (both changed in place); returns the new ``pending``. _LineError on a
    fault."""
    key = tok[0].upper()
    if key in ("ROOT", "JOINT"):
        return _new_joint(key, tok, joints, stack)
    if key == "END":
        return _END_SITE
    if key == "{":
        if pending is None:
            raise _LineError("unexpected '{'")
        stack.append(pending)
        return None
    if key == "}":
        if not stack:
            raise _LineError("unbalanced '}'")
        stack.pop()
    elif key == "OFFSET":
        _set_offset(tok, joints, stack)
    elif key == "CHANNELS":
        _set_channels(tok, joints, stack)
    else:
        raise _LineError(f"unexpected {tok[0]!r} in the hierarchy")
    return pending


def _new_joint(key: str, tok: list[str], joints: _Joints, stack: list[int]) -> int:
    """Add the joint a ROOT or JOINT line names, child of the innermost open joint;
    returns its index (its "{" is now expected)."""
    if (key == "ROOT") != (not stack):
        raise _LineError(f"{key} in the wrong place")
    if len(tok) < 2:
        raise _LineError(f"{key} without a name")
    joints.names.append(" ".join(tok[1:]))
    joints.parents.append(stack[-1] if stack else -1)
    joints.offsets.append(np.zeros(3))
    joints.channels.append(())
    joints.ends.append(np.zeros(3))
    return len(joints.names) - 1


def _set_offset(tok: list[str], joints: _Joints, stack: list[int]) -> None:
    """An OFFSET line: three finite numbers, the offset of the innermost open joint, or
    inside an End Site block the end site of the innermost joint."""
    try:
        vec = np.array([float(v) for v in tok[1:4]])
    except ValueError:
        raise _LineError("OFFSET needs three numbers") from None
    if len(vec) != 3 or not np.all(np.isfinite(vec)):
        raise _LineError("OFFSET needs three numbers")
    if stack and stack[-1] == _END_SITE:
        joints.ends[[j for j in stack if j >= 0][-1]] = vec
    elif stack:
        joints.offsets[stack[-1]] = vec
    else:
        raise _LineError("OFFSET outside a joint")


def _set_channels(tok: list[str], joints: _Joints, stack: list[int]) -> None:
    """A CHANNELS line: a count and that many channel names, of the innermost joint."""
    if not stack or stack[-1] < 0:
        raise _LineError("CHANNELS outside a joint")
    try:
        n = int(tok[1])
    except (IndexError, ValueError):
        raise _LineError("CHANNELS needs a count") from None
    if len(tok) != n + 2:
        raise _LineError(f"CHANNELS says {n} channels but lists {len(tok) - 2}")
    joints.channels[stack[-1]] = tuple(t.upper() for t in tok[2:])


def _motion_header(lines: list[str], i: int, path: str) -> tuple[int, float, int]:
    """(frames, frame time s, index of the line after the header) from the "Frames:"
    and "Frame Time:" lines at ``i``; BvhError when they are missing, malformed or say
    there is nothing to import."""

    def header(prefix):
        nonlocal i
        i = _skip_blank(lines, i)
        if i >= len(lines) or not lines[i].strip().lower().startswith(prefix.lower()):
            raise BvhError(f"{path}, line {i + 1}: expected '{prefix}'")
        value = lines[i].split(":", 1)[1].strip()
        i += 1
        return value

    try:
        frames = int(header("Frames:"))
        frame_time = float(header("Frame Time:"))
    except ValueError:
        raise BvhError(f"{path}, line {i}: bad frame count or frame time") from None
    if frames < 1 or not (0 < frame_time < 10):
        raise BvhError(f"{path}: {frames} frames at frame time {frame_time}: nothing to import")
    return frames, frame_time, i


def _check_motion(lines: list[str], frames: int, width: int, path: str) -> None:
    """BvhError unless the non-blank ``lines`` hold ``frames`` rows of ``width`` numbers
    (rows beyond ``frames`` are ignored)."""
    data = [ln for ln in lines if ln.strip()]
    if len(data) < frames:
        raise BvhError(f"{path}: the header says {frames} frames but the file has {len(data)}")
    for k, ln in enumerate(data[:frames]):
        parts = ln.split()
        if len(parts) != width:
            raise BvhError(f"{path}, frame {k + 1}: {len(parts)} values, expected {width}")
    try:
        np.array(" ".join(data[:frames]).split(), dtype=np.float64)
    except ValueError:
        raise BvhError(f"{path}: the motion data has a value that is not a number") from None
