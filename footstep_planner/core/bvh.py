"""Reading a BVH file's skeleton and checking the file is well formed.

Blender's own importer reads the motion; this module only checks the file (so a bad file
gives one clear message naming the file and line, before anything in the scene changes)
and reads what the import needs to know: joint names and offsets, channels, frame count,
frame rate, and the length unit.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

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
    if not os.path.isfile(path):
        raise BvhError(f"{path}: no such file")
    try:
        with open(path, "r", encoding="utf-8", errors="replace") as fh:
            lines = fh.read().splitlines()
    except OSError as ex:
        raise BvhError(f"{path}: cannot read ({ex.strerror})") from None

    def fail(i, msg):
        raise BvhError(f"{path}, line {i + 1}: {msg}")

    i = 0
    while i < len(lines) and not lines[i].strip():
        i += 1
    if i >= len(lines) or lines[i].strip().upper() != "HIERARCHY":
        raise BvhError(f"{path}: not a BVH file (it does not start with HIERARCHY)")
    names, parents, offsets, channels, ends = [], [], [], [], []
    stack: list[int] = []
    pending: int | None = None  # joint whose "{" is expected
    i += 1
    while i < len(lines):
        tok = lines[i].split()
        i += 1
        if not tok:
            continue
        key = tok[0].upper()
        if key in ("ROOT", "JOINT"):
            if (key == "ROOT") != (not stack):
                fail(i - 1, f"{key} in the wrong place")
            if len(tok) < 2:
                fail(i - 1, f"{key} without a name")
            names.append(" ".join(tok[1:]))
            parents.append(stack[-1] if stack else -1)
            offsets.append(np.zeros(3))
            channels.append(())
            ends.append(np.zeros(3))
            pending = len(names) - 1
        elif key == "END":
            pending = -2
        elif key == "{":
            if pending is None:
                fail(i - 1, "unexpected '{'")
            stack.append(pending)
            pending = None
        elif key == "}":
            if not stack:
                fail(i - 1, "unbalanced '}'")
            stack.pop()
        elif key == "OFFSET":
            try:
                vec = np.array([float(v) for v in tok[1:4]])
            except ValueError:
                fail(i - 1, "OFFSET needs three numbers")
            if len(vec) != 3 or not np.all(np.isfinite(vec)):
                fail(i - 1, "OFFSET needs three numbers")
            if stack and stack[-1] == -2:
                ends[[s for s in stack if s >= 0][-1]] = vec
            elif stack:
                offsets[stack[-1]] = vec
            else:
                fail(i - 1, "OFFSET outside a joint")
        elif key == "CHANNELS":
            if not stack or stack[-1] < 0:
                fail(i - 1, "CHANNELS outside a joint")
            try:
                n = int(tok[1])
            except (IndexError, ValueError):
                fail(i - 1, "CHANNELS needs a count")
            if len(tok) != n + 2:
                fail(i - 1, f"CHANNELS says {n} channels but lists {len(tok) - 2}")
            channels[stack[-1]] = tuple(t.upper() for t in tok[2:])
        elif key == "MOTION":
            break
        else:
            fail(i - 1, f"unexpected {tok[0]!r} in the hierarchy")
    else:
        raise BvhError(f"{path}: no MOTION section")
    if stack:
        raise BvhError(f"{path}: the hierarchy is not closed (missing '}}')")
    if not names:
        raise BvhError(f"{path}: the hierarchy has no joints")

    def header(prefix):
        nonlocal i
        while i < len(lines) and not lines[i].strip():
            i += 1
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
    width = sum(len(c) for c in channels)
    data = [ln for ln in lines[i:] if ln.strip()]
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
    return BvhSkeleton(path, tuple(names), tuple(parents), np.array(offsets), tuple(channels),
                       np.array(ends), frames, frame_time)
