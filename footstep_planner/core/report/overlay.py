"""Geometry of the viewport overlay, as plain arrays (the drawing itself is in
``blender/ui/overlay.py`` and does nothing but hand these to the GPU).

- footprints: one quad (two triangles) each, coloured by foot (left blue, right red),
  shaded by the clip that carries the foot there, jumps yellow;
- sampled footprints (optional): small crosses where the search tested a footprint;
- the body trajectory: a polyline a little above the ground, orange;
- several characters at once (a shot baked together): each in its own colour
  (``character_tint``), its left foot lighter than its right, its body path in its colour.
"""

from __future__ import annotations

import colorsys

import numpy as np

from ..plan.surface import FootShape

LEFT = (0.15, 0.35, 0.95)
RIGHT = (0.95, 0.2, 0.15)
JUMP = (1.0, 0.8, 0.1)
BODY = (1.0, 0.5, 0.0, 1.0)
SAMPLED = (0.6, 0.6, 0.6, 0.6)
MARKER = (0.2, 0.85, 0.3, 1.0)  # the Start and Goal facing arrows
LOCKED = (1.0, 1.0, 1.0, 1.0)  # rings round locked footprints
REPLANNED = (0.95, 0.3, 0.9, 1.0)  # rings round the footprints the last re-plan made
WAYPOINT = (0.2, 0.85, 0.3, 1.0)  # rings round waypoints
WARNING = (1.0, 0.15, 0.1, 1.0)  # a footprint an edit put where it can't be
LIFT = 0.01  # m above the surface, so the overlay is not hidden in the floor


def clip_shades(labels) -> dict[str, float]:
    """A brightness per distinct clip (or blend group) label, 0.55 .. 1, in order of
    first appearance; a blend "group@tau" counts as its group."""
    keys = []
    for label in labels:
        key = str(label).split("@")[0]
        if key not in keys:
            keys.append(key)
    n = max(len(keys), 1)
    return {k: 1.0 - 0.45 * i / max(n - 1, 1) for i, k in enumerate(keys)}


#: each character's colour when several are shown (a shot: the overlay, the review sheet),
#: in the order they were planned, and its name for captions
CHARACTER_COLOURS = ((0.12, 0.47, 0.71), (1.0, 0.5, 0.05), (0.17, 0.63, 0.17), (0.84, 0.15, 0.16),
                     (0.58, 0.4, 0.74), (0.55, 0.34, 0.29), (0.89, 0.47, 0.76), (0.5, 0.5, 0.5),
                     (0.74, 0.74, 0.13), (0.09, 0.75, 0.81))
COLOUR_NAMES = ("blue", "orange", "green", "red", "purple", "brown", "pink", "grey", "olive", "cyan")
#: a character's right foot is its colour this dark (its left foot its colour)
RIGHT_SHADE = 0.65


def character_tint(i: int) -> tuple[float, float, float]:
    """The colour of the ``i``-th character (from 0) of several shown at once."""
    return CHARACTER_COLOURS[i % len(CHARACTER_COLOURS)]


def _feet_of(tint) -> tuple:
    """(left, right, jump) base colours: the classic blue, red, yellow, or a character's
    ``tint`` for the left foot and ``RIGHT_SHADE`` of it for the right, a jump halfway to
    yellow."""
    if tint is None:
        return LEFT, RIGHT, JUMP
    return tuple(tint), tuple(RIGHT_SHADE * c for c in tint), tuple(0.5 * (a + b) for a, b in zip(tint, JUMP))


def footprint_colours(feet, labels, jumps, tint=None) -> np.ndarray:
    """(N, 4) RGBA per footprint; in a character's ``tint`` (RGB) when given."""
    shade = clip_shades(labels)
    left, right, jump = _feet_of(tint)
    out = np.empty((len(feet), 4))
    for i, (f, lab, j) in enumerate(zip(feet, labels, jumps)):
        base = jump if j else (left if f == 0 else right)
        h, l_, s = colorsys.rgb_to_hls(*base)
        r, g, b = colorsys.hls_to_rgb(h, min(1.0, l_ * shade[str(lab).split("@")[0]] + 0.1), s)
        out[i] = (r, g, b, 0.9)
    return out


def footprint_triangles(pos, heading, forward, foot: FootShape = FootShape(), feet=None, labels=None,
                        jumps=None, tint=None) -> tuple[np.ndarray, np.ndarray]:
    """(vertices (N*6, 3), colours (N*6, 4)): two triangles per footprint, lifted by LIFT;
    in a character's ``tint`` when given (``footprint_colours``)."""
    pos = np.atleast_2d(np.asarray(pos, float))
    n = len(pos)
    if n == 0:
        return np.zeros((0, 3)), np.zeros((0, 4))
    c = foot.corners(pos, np.asarray(heading, float), forward)[:, :4]  # (N, 4, 2)
    z = pos[:, 2] + LIFT
    quad = np.concatenate([c, np.repeat(z[:, None, None], 4, axis=1)], axis=2)
    # corners: back right, back left, front right, front left: round the quad as 0 1 3 2
    tri = quad[:, [0, 1, 3, 0, 3, 2]]
    feet = np.zeros(n, int) if feet is None else np.asarray(feet)
    labels = [""] * n if labels is None else list(labels)
    jumps = np.zeros(n, bool) if jumps is None else np.asarray(jumps, bool)
    col = np.repeat(footprint_colours(feet, labels, jumps, tint), 6, axis=0)
    return tri.reshape(-1, 3), col


def polyline_segments(points, lift: float = 0.05) -> np.ndarray:
    """(2 (M-1), 3) line-segment end points of a polyline, lifted by ``lift``."""
    p = np.atleast_2d(np.asarray(points, float)).copy()
    if len(p) < 2:
        return np.zeros((0, 3))
    p[:, 2] += lift
    return np.stack([p[:-1], p[1:]], axis=1).reshape(-1, 3)


def crosses(points, size: float = 0.04) -> np.ndarray:
    """(4 M, 3) segment end points of a small cross at each point (sampled footprints)."""
    p = np.atleast_2d(np.asarray(points, float))
    if not len(p):
        return np.zeros((0, 3))
    d = np.array([[size, 0, 0], [-size, 0, 0], [0, size, 0], [0, -size, 0]])
    out = p[:, None, :] + d[None] + [0.0, 0.0, LIFT]
    return out.reshape(-1, 3)


def rings(points, radius: float = 0.15, segments: int = 16) -> np.ndarray:
    """(2 segments M, 3) segment end points of a flat ring round each point (locked,
    re-planned and refused footprints, waypoints)."""
    p = np.atleast_2d(np.asarray(points, float))
    if not len(p):
        return np.zeros((0, 3))
    a = np.linspace(0.0, 2 * np.pi, segments + 1)
    circle = np.c_[radius * np.cos(a), radius * np.sin(a), np.zeros_like(a)]
    seg = np.stack([circle[:-1], circle[1:]], axis=1).reshape(-1, 3)  # (2 segments, 3)
    return (p[:, None, :] + seg[None] + [0.0, 0.0, LIFT]).reshape(-1, 3)


def facing_arrow(position, z_rotation: float, length: float = 0.6, head: float = 0.15) -> np.ndarray:
    """(6, 3) segment end points of an arrow on the ground at ``position`` (3,) pointing
    the way something turned ``z_rotation`` (rad) about Z from facing -Y faces (the
    convention of the Start and Goal empties and of Blender's characters)."""
    p = np.asarray(position, float) + [0.0, 0.0, LIFT]
    d = np.array([np.sin(z_rotation), -np.cos(z_rotation), 0.0])  # -Y turned by z_rotation
    side = np.array([-d[1], d[0], 0.0])
    tip = p + length * d
    back = tip - head * d
    return np.array([p, tip, tip, back + 0.6 * head * side, tip, back - 0.6 * head * side])
