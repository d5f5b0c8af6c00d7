"""Small BVH files written by the tests: broken, legless, floating, too short."""

import os

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
