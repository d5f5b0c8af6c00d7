"""Reading a BVH file: its skeleton and its motion, checked as they are read.

A bad file gives one clear message naming the file and line (and for the motion, the
frame and channel) before anything in the scene changes: a malformed hierarchy, a joint
that would be a bone of no length, an absurd frame time, a motion value that is not a
finite number. The motion is read a block of lines at a time into float32 (a 100,000
frame clip of 31 joints is 38 MB), never held whole as text or Python floats.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field

import numpy as np
from ..base.errors import FootstepError


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


#: Frame times a BVH file may give, seconds: 1000 down to 1 frame per second.
FRAME_TIME_RANGE = (0.001, 1.0)
#: Motion lines parsed at a time: the file is never held whole, as text or as floats.
_BLOCK = 4096
#: The largest magnitude a motion value may have (it is stored as a 32-bit float).
_FLOAT32_MAX = float(np.finfo(np.float32).max)


def read_skeleton(path: str) -> BvhSkeleton:
    """Parse and check a BVH file (its motion too, which is not kept). Raises BvhError
    naming the file and line at fault."""
    return _read(path, keep=False)[0]


def read_bvh(path: str) -> tuple[BvhSkeleton, np.ndarray]:
    """Parse and check a BVH file: its skeleton and its motion, (frames, channels) float32
    in file units and degrees, channels in file order (``skeleton.channels`` flattened).
    Rows beyond the header's frame count are ignored. BvhError naming file and line."""
    return _read(path, keep=True)


def _read(path: str, keep: bool) -> tuple[BvhSkeleton, np.ndarray | None]:
    """The skeleton and (``keep``) the motion, reading the file once, line by line."""
    with _open(path) as fh:
        lines = _Lines(fh)
        _hierarchy_start(lines, path)
        joints = _parse_hierarchy(lines, path)
        _check_bone_lengths(joints, path)
        frames, frame_time = _motion_header(lines, path)
        sk = BvhSkeleton(path, tuple(joints.names), tuple(joints.parents), np.array(joints.offsets),
                         tuple(joints.channels), np.array(joints.ends), frames, frame_time)
        motion = _read_motion(lines, sk, path, keep)
    return sk, motion


@dataclass
class _Joints:
    """The hierarchy as parsed so far, one entry per joint in file order."""

    names: list[str] = field(default_factory=list)
    parents: list[int] = field(default_factory=list)  # index of the parent joint, -1 for the root
    offsets: list[np.ndarray] = field(default_factory=list)  # (3,) file units, file axes
    channels: list[tuple[str, ...]] = field(default_factory=list)  # upper case
    ends: list[np.ndarray] = field(default_factory=list)  # (3,) end-site offset, zeros if none
    lines: list[int] = field(default_factory=list)  # 1-based line of the ROOT or JOINT keyword


# Markers on the stack of open blocks besides joint indices (>= 0).
_END_SITE = -2  # an "End Site" block


def _open(path: str):
    """The file opened as text (a UTF-8 byte-order mark dropped, undecodable bytes
    replaced); BvhError naming it when it is not a readable file."""
    if os.path.isdir(path):
        raise BvhError(f"{path}: is a folder, not a BVH file")
    if not os.path.exists(path):
        raise BvhError(f"{path}: no such file")
    if not os.path.isfile(path):
        raise BvhError(f"{path}: not a regular file")
    try:
        return open(path, "r", encoding="utf-8-sig", errors="replace")
    except OSError as ex:
        raise BvhError(f"{path}: cannot read ({ex.strerror})") from None


class _Lines:
    """The lines of an open file, read one at a time; ``number`` is the 1-based number
    of the line read last."""

    def __init__(self, fh):
        self._it = enumerate(fh, 1)
        self.number = 0

    def __iter__(self):
        return self

    def __next__(self) -> str:
        self.number, text = next(self._it)
        return text

    def next_filled(self) -> str | None:
        """The next line that is not blank (None at the end of the file)."""
        for text in self:
            if text.strip():
                return text
        return None


def _hierarchy_start(lines: _Lines, path: str) -> None:
    """Read the leading HIERARCHY keyword; BvhError without it."""
    text = lines.next_filled()
    if text is None or text.strip().upper() != "HIERARCHY":
        raise BvhError(f"{path}: not a BVH file (it does not start with HIERARCHY)")


def _parse_hierarchy(lines: _Lines, path: str) -> _Joints:
    """The joints up to MOTION (read too). BvhError naming the 1-based line of the
    first fault."""
    joints = _Joints()
    stack: list[int] = []  # open blocks: joint indices, or _END_SITE
    pending: int | None = None  # the joint (or _END_SITE) whose "{" is expected
    for text in lines:
        tok = text.split()
        if not tok:
            continue
        if tok[0].upper() == "MOTION":
            break
        try:
            pending = _hierarchy_line(tok, joints, stack, pending)
        except _LineError as ex:
            raise BvhError(f"{path}, line {lines.number}: {ex}") from None
        if len(joints.lines) < len(joints.names):
            joints.lines.append(lines.number)
    else:
        raise BvhError(f"{path}: no MOTION section")
    if stack:
        raise BvhError(f"{path}: the hierarchy is not closed (missing '}}')")
    if not joints.names:
        raise BvhError(f"{path}: the hierarchy has no joints")
    return joints


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
    returns its index (its "{" is now expected). A name of several words is joined by
    underscores, as Blender's BVH importer names the bone."""
    if (key == "ROOT") != (not stack):
        raise _LineError(f"{key} in the wrong place")
    if len(tok) < 2:
        raise _LineError(f"{key} without a name")
    name = "_".join(tok[1:])
    if name in joints.names:
        first = joints.lines[joints.names.index(name)]
        raise _LineError(f"joint {name!r} is named twice (first on line {first}): "
                         "a skeleton's joints need names of their own; rename one")
    joints.names.append(name)
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
        raise _LineError("OFFSET needs three finite numbers")
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


def _check_bone_lengths(joints: _Joints, path: str) -> None:
    """BvhError naming the first joint that would be a bone of no length: a joint (not
    the root) whose children all sit at its head (OFFSET 0 0 0) and that has no End Site
    beyond it. Blender would make it a bone of no length and no direction, and a leg
    bone like that leaves the leg without its length. A root whose children sit at its
    head (CMU's Hips) is a hub, and fine; so is a last joint without an End Site."""
    offsets = np.array(joints.offsets)
    sizes = np.linalg.norm(offsets, axis=1)
    tol = 1e-6 * max(float(sizes.max()), 1e-12)
    kids: dict[int, list[int]] = {}
    for j, p in enumerate(joints.parents):
        kids.setdefault(p, []).append(j)
    for j, name in enumerate(joints.names):
        if joints.parents[j] < 0 or j not in kids or np.linalg.norm(joints.ends[j]) > tol:
            continue
        if sizes[kids[j]].max() <= tol:
            child = kids[j][0]
            raise BvhError(f"{path}, line {joints.lines[j]}: joint {name!r} has zero length: its "
                           f"child {joints.names[child]!r} (line {joints.lines[child]}) sits at its "
                           "head (OFFSET 0 0 0), which would give a bone with no length or direction")


def _motion_header(lines: _Lines, path: str) -> tuple[int, float]:
    """(frames, frame time s) from the "Frames:" and "Frame Time:" lines after MOTION;
    BvhError naming the line when they are missing or malformed, there is nothing to
    import, or the frame time is not a number of seconds in ``FRAME_TIME_RANGE``."""

    def header(prefix):
        text = lines.next_filled()
        if text is None or not text.strip().lower().startswith(prefix.lower()):
            raise BvhError(f"{path}, line {lines.number + (text is None)}: expected '{prefix}'")
        return text.split(":", 1)[1].strip()

    try:
        frames = int(header("Frames:"))
    except ValueError:
        raise BvhError(f"{path}, line {lines.number}: bad frame count") from None
    if frames < 1:
        raise BvhError(f"{path}, line {lines.number}: {frames} frames: nothing to import")
    value = header("Frame Time:")
    try:
        frame_time = float(value)
    except ValueError:
        raise BvhError(f"{path}, line {lines.number}: bad frame time {value!r}") from None
    lo, hi = FRAME_TIME_RANGE
    if not lo <= frame_time <= hi:  # (False for nan)
        raise BvhError(f"{path}, line {lines.number}: frame time {value} s is absurd: a clip "
                       f"has {lo:g} to {hi:g} s a frame ({1 / hi:g} to {1 / lo:g} frames a second)")
    return frames, frame_time


def channel_labels(sk: BvhSkeleton) -> list[str]:
    """One label per motion column: joint name and channel, e.g. "Hips Xposition"."""
    return [f"{name} {ch.capitalize()}" for name, chans in zip(sk.names, sk.channels) for ch in chans]


def _read_motion(lines: _Lines, sk: BvhSkeleton, path: str, keep: bool) -> np.ndarray | None:
    """The ``sk.frames`` motion rows from the lines left, parsed ``_BLOCK`` at a time
    (float32 when ``keep``, else checked and dropped); BvhError naming the line, frame
    and channel of a value that is not a finite number, or a row of the wrong width."""
    labels = channel_labels(sk)
    blocks, done = [], 0
    while done < sk.frames:
        texts, numbers = [], []
        for text in lines:
            if text.strip():
                texts.append(text)
                numbers.append(lines.number)
                if len(texts) == min(_BLOCK, sk.frames - done):
                    break
        if not texts:
            break
        block = _parse_block(texts, numbers, done + 1, labels, path)
        if keep:
            blocks.append(block.astype(np.float32))
        done += len(texts)
    if done < sk.frames:
        raise BvhError(f"{path}: the header says {sk.frames} frames but the file has {done}")
    return np.concatenate(blocks) if keep else None


def _parse_block(texts: list[str], numbers: list[int], frame: int, labels: list[str], path: str
                 ) -> np.ndarray:
    """Motion rows ``texts`` (lines ``numbers``, the first being frame ``frame``) as a
    float64 array (rows, channels); BvhError at the first fault."""
    try:
        block = np.loadtxt(texts, dtype=np.float64, comments=None, ndmin=2)
    except ValueError:
        block = None
    if block is None or block.shape[1] != len(labels):
        _row_fault(texts, numbers, frame, labels, path)
    with np.errstate(invalid="ignore"):
        bad = ~(np.abs(block) <= _FLOAT32_MAX)  # nan, inf, and beyond a 32-bit float
    if bad.any():
        r, c = np.argwhere(bad)[0]
        raise BvhError(f"{path}, line {numbers[r]}: frame {frame + r}, channel {labels[c]}: "
                       f"{texts[r].split()[c]!r} is not a finite number")
    return block


def _row_fault(texts: list[str], numbers: list[int], frame: int, labels: list[str], path: str) -> None:
    """BvhError naming the first row of ``texts`` with the wrong number of values or a
    value that is not a number."""
    for r, text in enumerate(texts):
        parts = text.split()
        where = f"{path}, line {numbers[r]}: frame {frame + r}"
        if len(parts) != len(labels):
            raise BvhError(f"{where}: {len(parts)} values, expected {len(labels)}")
        for c, part in enumerate(parts):
            try:
                float(part)
            except ValueError:
                raise BvhError(f"{where}, channel {labels[c]}: {part!r} is not a number") from None
    raise BvhError(f"{path}, line {numbers[0]}: the motion data cannot be read")
