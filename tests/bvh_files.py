"""Small BVH files written by the tests: broken, legless, floating, too short."""

import os
import re

import numpy as np


def write_bvh(path, joints, frames, frame_time=1 / 120):
    """``joints``: list of (name, parent name or None, offset xyz, end-site offset or None);
    root has 6 channels, the others 3; ``frames`` (F, channels) array."""
    children = {}
    for name, parent, _, _ in joints:
        children.setdefault(parent, []).append(name)
    info = {j[0]: j for j in joints}
    lines = ["HIERARCHY"]

    def emit(name, depth):
        _, parent, off, end = info[name]
        pad = "  " * depth
        lines.append(f"{pad}{'ROOT' if parent is None else 'JOINT'} {name}")
        lines.append(pad + "{")
        lines.append(f"{pad}  OFFSET {off[0]:.4f} {off[1]:.4f} {off[2]:.4f}")
        if parent is None:
            lines.append(f"{pad}  CHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation")
        else:
            lines.append(f"{pad}  CHANNELS 3 Zrotation Yrotation Xrotation")
        for c in children.get(name, []):
            emit(c, depth + 1)
        if end is not None:
            lines.extend([f"{pad}  End Site", pad + "  {", f"{pad}    OFFSET {end[0]} {end[1]} {end[2]}",
                          pad + "  }"])
        lines.append(pad + "}")

    emit(children[None][0], 0)
    lines += ["MOTION", f"Frames: {len(frames)}", f"Frame Time: {frame_time:.7f}"]
    lines += [" ".join(f"{v:.4f}" for v in row) for row in frames]
    with open(path, "w") as fh:
        fh.write("\n".join(lines) + "\n")
    return path


def legless(path):
    joints = [("Hips", None, (0, 0, 0), None), ("Spine", "Hips", (0, 10, 0), None),
              ("Neck", "Spine", (0, 30, 0), None), ("Head", "Neck", (0, 10, 0), (0, 10, 0)),
              ("LeftArm", "Spine", (15, 25, 0), (25, 0, 0)), ("RightArm", "Spine", (-15, 25, 0), (-25, 0, 0))]
    frames = np.zeros((20, 6 + 3 * 5))
    frames[:, 1] = 100.0
    return write_bvh(path, joints, frames)


def edit_frames(src, dst, fn):
    """Copy a BVH file, passing its motion (F, C) array through ``fn``."""
    with open(src) as fh:
        text = fh.read()
    head, motion = text.split("MOTION", 1)
    mlines = motion.strip().splitlines()
    data = np.array([[float(v) for v in ln.split()] for ln in mlines[2:]])
    data = fn(data)
    ft = mlines[1]
    with open(dst, "w") as fh:
        fh.write(head + "MOTION\n" + f"Frames: {len(data)}\n{ft}\n")
        fh.write("\n".join(" ".join(f"{v:.5f}" for v in row) for row in data) + "\n")
    return dst


def broken_variants(src, folder):
    """Malformed copies of a good BVH file, each with the problem it has."""
    with open(src) as fh:
        text = fh.read()
    out = {}
    def put(name, body):
        p = os.path.join(folder, name + ".bvh")
        with open(p, "w") as fh:
            fh.write(body)
        out[name] = p
    put("not_bvh", "hello\nworld\n")
    put("bad_channels", text.replace("CHANNELS 3 Zrotation Yrotation Xrotation", "CHANNELS 4 Zrotation Yrotation Xrotation", 1))
    put("truncated_motion", text[: text.index("MOTION") + 200])
    lines = text.rstrip("\n").split("\n")
    last = lines[-1].split()
    put("not_a_number", "\n".join(lines[:-1] + [" ".join(["x"] + last[1:])]) + "\n")
    put("short_line", "\n".join(lines[:-1] + [" ".join(last[:-2])]) + "\n")
    put("unclosed", text[: text.index("MOTION")].rsplit("}", 1)[0] + "\nMOTION\nFrames: 1\nFrame Time: 0.01\n0\n")
    put("empty", "")
    return out


def walker(path, frames=60, frame_time=1 / 120):
    """A small legged skeleton in centimetres (Hips, Spine, and per side UpLeg, Leg, Foot,
    ToeBase) walking on: its thighs swing at 1 Hz while the hips move 1.2 m/s along -Z.
    Needs nothing from outside the project."""
    joints = walker_joints()
    t = np.arange(frames) * frame_time
    motion = np.zeros((frames, 6 + 3 * (len(joints) - 1)))
    motion[:, 1], motion[:, 2] = 98.0, -120.0 * t
    for k, sign in ((3, 1), (7, -1)):  # the thighs' X rotation columns
        motion[:, 6 + 3 * (k - 1) + 2] = sign * 25.0 * np.sin(2 * np.pi * t)
    return write_bvh(path, joints, motion, frame_time)


def walker_joints():
    joints = [("Hips", None, (0, 0, 0), None), ("Spine", "Hips", (0, 10, 0), (0, 50, 0))]
    for side, x in (("Left", 10), ("Right", -10)):
        joints += [(f"{side}UpLeg", "Hips", (x, 0, 0), None), (f"{side}Leg", f"{side}UpLeg", (0, -45, 0), None),
                   (f"{side}Foot", f"{side}Leg", (0, -45, 0), None),
                   (f"{side}ToeBase", f"{side}Foot", (0, -8, 12), (0, 0, 6))]
    return joints


def poison(src, dst, frame, column, text):
    """Copy a BVH file with the value of motion row ``frame`` (1-based), ``column``
    (0-based) replaced by ``text``; returns (dst, the 1-based line number of that row)."""
    with open(src) as fh:
        lines = fh.read().split("\n")
    first = next(i for i, ln in enumerate(lines) if ln.strip().lower().startswith("frame time")) + 1
    row = first + frame - 1
    values = lines[row].split()
    values[column] = text
    lines[row] = " ".join(values)
    with open(dst, "w") as fh:
        fh.write("\n".join(lines))
    return dst, row + 1


def bad_data_variants(folder):
    """Well-formed BVH files with bad data, built from ``walker``: name -> (path, the
    words the refusal must hold: file, line, and frame and channel or joint or value)."""
    base = walker(os.path.join(folder, "walker.bvh"), frames=30)
    out = {}
    for name, frame, col, text, channel in (("nan_motion", 7, 0, "nan", "Hips Xposition"),
                                            ("inf_motion", 12, 8, "-inf", "Spine Xrotation"),
                                            ("overflow_motion", 30, 13, "1e400", "LeftLeg Yrotation")):
        path, line = poison(base, os.path.join(folder, name + ".bvh"), frame, col, text)
        out[name] = (path, [f"{name}.bvh", f"line {line}", f"frame {frame}", f"channel {channel}"])
    text = open(base).read()
    # the knee at the hip: the thigh would be a bone of no length
    lines = text.split("\n")
    stripped = [ln.strip() for ln in lines]
    knee, thigh = stripped.index("JOINT LeftLeg"), stripped.index("JOINT LeftUpLeg") + 1
    lines[knee + 2] = "OFFSET 0.0000 0.0000 0.0000"
    out["zero_length"] = _put(folder, "zero_length", "\n".join(lines),
                              [f"line {thigh}", "'LeftUpLeg'", "zero length", "'LeftLeg'", f"line {knee + 1}"])
    # two joints of one name: the bones would be told apart by Blender's ".001" only
    lines = text.split("\n")
    stripped = [ln.strip() for ln in lines]
    left, right = stripped.index("JOINT LeftLeg"), stripped.index("JOINT RightLeg")
    lines[right] = lines[right].replace("RightLeg", "LeftLeg")
    out["joint_named_twice"] = _put(folder, "joint_named_twice", "\n".join(lines),
                                    [f"line {right + 1}", "'LeftLeg'", "named twice",
                                     f"first on line {left + 1}"])
    ft_line = text.split("\n").index(next(ln for ln in text.split("\n") if ln.startswith("Frame Time"))) + 1
    for name, value in (("frame_time_zero", "0"), ("frame_time_negative", "-0.0083333"),
                        ("frame_time_nan", "nan"), ("frame_time_tiny", "1e-300"), ("frame_time_huge", "5")):
        body = re.sub(r"Frame Time: \S+", f"Frame Time: {value}", text)
        out[name] = _put(folder, name, body, [f"line {ft_line}", f"frame time {value} s"])
    return out


def _put(folder, name, body, words):
    path = os.path.join(folder, name + ".bvh")
    with open(path, "w") as fh:
        fh.write(body)
    return path, [f"{name}.bvh", *words]
