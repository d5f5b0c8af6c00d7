"""Characters sharing a shot, measured as played: how near two bodies come and whether two
feet stand on one footprint at once, and how near a body comes to an obstacle that moves
(issue 29's figures per pair of characters, and per character and moving obstacle).

A body is a capsule: the segment from its hips to the top of its head, and a radius (a
human's half shoulder width, ``BODY_RADIUS``, times the body's size). Two bodies meet
where their capsules overlap: the least distance between their segments is under the sum
of their radii. A foot is planted at a frame where it is still (its ankle and ball move
under ``PLANTED_SPEED``); two planted feet share a footprint where their soles' middles
(between the ankle and the ball) are nearer than a foot's length (``foot_length``, the
longer of the two characters').

Everything here is plain arrays of what Blender played (``blender.planning`` reads them
through the depsgraph): world positions in metres, frames counted from the shot's first.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..clips.body import body_scale
from ..clips.clip import SIDES
from ..clips.rig import Rig
from ..plan.others import BODY_RADIUS, Others
from ..plan.surface import Ground

#: m/s: a foot whose ankle and ball move slower than this (a human's) is planted.
PLANTED_SPEED = 0.25


@dataclass(frozen=True, eq=False)
class PlayedBody:
    """One character as played over F frames, for ``pair_figures``:

    - ``name``: the character (its object's name);
    - ``hips``, ``head`` (F, 3): the ends of its body's segment (the hips, the top of the head);
    - ``radius``: m, its capsule's radius;
    - ``feet`` (2, F, P, 3): each foot's points (its ankle and ball), left then right;
    - ``planted`` (2, F) bool: where each foot stands (``planted_feet``);
    - ``foot_length``: m, the foot's length (heel to toe)."""

    name: str
    hips: np.ndarray
    head: np.ndarray
    radius: float
    feet: np.ndarray
    planted: np.ndarray
    foot_length: float

    @property
    def soles(self) -> np.ndarray:
        """(2, F, 3) the middle of each foot's sole: the mean of its points."""
        return self.feet.mean(axis=2)


def segment_distance(p0: np.ndarray, p1: np.ndarray, q0: np.ndarray, q1: np.ndarray) -> np.ndarray:
    """(F,) the least distance between the segments p0-p1 and q0-q1 (each (F, 3)), frame by
    frame; a segment may be a point (its ends equal). The closest points are found in
    closed form on each segment's parameter in [0, 1], clamped, then each again against
    the other's clamped point (Ericson, Real-Time Collision Detection, 5.1.9)."""
    p0, p1, q0, q1 = (np.asarray(v, float) for v in (p0, p1, q0, q1))
    d1, d2, r = p1 - p0, q1 - q0, p0 - q0
    a = np.einsum("fi,fi->f", d1, d1)
    e = np.einsum("fi,fi->f", d2, d2)
    f = np.einsum("fi,fi->f", d2, r)
    c = np.einsum("fi,fi->f", d1, r)
    b = np.einsum("fi,fi->f", d1, d2)
    tiny = 1e-18
    along_p, along_q = a > tiny, e > tiny  # (a segment, not a point)
    denom = a * e - b * b
    skew = along_p & along_q & (denom > tiny * np.maximum(a * e, tiny))
    # s on p's segment from the lines' closest points (0 where they are parallel or p is a
    # point); t on q's segment for that s, clamped; then s again for the clamped t
    s = np.where(skew, np.clip((b * f - c * e) / np.where(skew, denom, 1.0), 0.0, 1.0), 0.0)
    t = np.where(along_q, np.clip((b * s + f) / np.where(along_q, e, 1.0), 0.0, 1.0), 0.0)
    s = np.where(along_p, np.clip((t * b - c) / np.where(along_p, a, 1.0), 0.0, 1.0), 0.0)
    gap = (p0 + s[:, None] * d1) - (q0 + t[:, None] * d2)
    return np.sqrt(np.einsum("fi,fi->f", gap, gap))


def planted_feet(points: np.ndarray, fps: float, scale: float = 1.0) -> np.ndarray:
    """(2, F) bool: each foot planted at each frame: every one of its points ``points``
    (2, F, K, 3) (the ankle and the ball, say) still, moving under ``PLANTED_SPEED`` times
    ``scale`` (by the central difference of its positions, one-sided at the ends; a
    single frame is still)."""
    points = np.asarray(points, float)
    if points.shape[1] < 2:
        return np.ones(points.shape[:2], bool)
    speed = np.linalg.norm(np.gradient(points, axis=1), axis=-1) * float(fps)  # (2, F, K)
    return (speed < PLANTED_SPEED * scale).all(axis=-1)


#: A foot is this many times as long as from its ankle to its ball (a human's: 26 cm to 19).
FOOT_OVER_ANKLE_BALL = 1.35


def body_of(name: str, rig: Rig, world: np.ndarray, fps: float) -> PlayedBody:
    """The ``PlayedBody`` of a character whose ``rig``'s bones played at ``world`` (F, B,
    4, 4) world matrices (metres) at ``fps``: its body from the hips to the top of the
    head (the tail of the rig's highest bone at rest, carried by that bone), a human's
    radius times its size (``core.clips.body.body_scale``), and each foot's ankle (the foot
    bone's head) and ball (``Rig.ball_local``), still where planted."""
    world = np.asarray(world, float)
    scale = body_scale(rig)
    top = int(np.argmax(rig.tails[:, 2]))
    tail = np.linalg.inv(rig.rest[top]) @ np.append(rig.tails[top], 1.0)
    head = (world[:, top] @ tail)[:, :3]
    hips = world[:, rig.role_index("hips"), :3, 3]
    feet = np.empty((2, len(world), 2, 3))
    reach = 0.0
    for k, side in enumerate(SIDES):
        foot = rig.foot_chain(side)[0]
        ball_local = rig.ball_local(side)
        feet[k, :, 0] = world[:, foot, :3, 3]
        feet[k, :, 1] = (world[:, foot] @ ball_local)[:, :3]
        reach = max(reach, float(np.linalg.norm(ball_local[:3])))
    return PlayedBody(name, hips, head, BODY_RADIUS * scale, feet, planted_feet(feet, fps, scale),
                      FOOT_OVER_ANKLE_BALL * reach)


def held(body: PlayedBody, start: int, first: int, frames: int) -> PlayedBody:
    """``body``, played from scene frame ``start``, over ``frames`` frames from scene frame
    ``first``: standing as it starts before its own frames and as it ends after them (a
    bake's strip holds its last frame)."""
    i = np.clip(np.arange(int(frames)) + (int(first) - int(start)), 0, len(body.hips) - 1)
    return PlayedBody(body.name, body.hips[i], body.head[i], body.radius, body.feet[:, i], body.planted[:, i],
                      body.foot_length)


def others_of(bodies: list[PlayedBody], frames: int, fps: float) -> Others:
    """``core.plan.others.Others`` of ``bodies`` played over the same ``frames`` frames
    (``held``) at ``fps``, the first at time 0: the characters a search goes round."""
    return Others.of([b.name for b in bodies], np.arange(frames) / float(fps),
                     np.array([b.hips for b in bodies]).reshape(-1, frames, 3), [b.radius for b in bodies],
                     np.array([b.soles for b in bodies]).reshape(-1, 2, frames, 3),
                     np.array([b.planted for b in bodies], bool).reshape(-1, 2, frames),
                     [b.foot_length for b in bodies])


def pair_figures(a: PlayedBody, b: PlayedBody, frame_start: int) -> dict:
    """What two characters played over the same F frames (from scene frame ``frame_start``)
    do to each other: the least distance between their bodies (the capsules' surfaces,
    negative where they overlap) and its scene frame, how many frames the bodies overlap,
    and how many frames a foot of each stands on one footprint (planted, nearer than a
    foot's length), with the first of them (None where none)."""
    between = segment_distance(a.hips, a.head, b.hips, b.head) - (a.radius + b.radius)
    i = int(np.argmin(between))
    reach = max(a.foot_length, b.foot_length)
    shared = np.zeros(len(between), bool)
    sa, sb = a.soles, b.soles
    for ka in range(2):
        for kb in range(2):
            near = np.linalg.norm(sa[ka, :, :2] - sb[kb, :, :2], axis=-1) < reach
            shared |= near & a.planted[ka] & b.planted[kb]
    on = np.flatnonzero(shared)
    return {"character": b.name,
            "least_distance_m": round(float(between[i]), 4),
            "least_distance_frame": int(frame_start + i),
            "frames_overlapping": int((between < 0.0).sum()),
            "frames_on_one_footprint": int(len(on)),
            "first_frame_on_one_footprint": int(frame_start + on[0]) if len(on) else None}


#: Points along a body's segment, hips to head, tested against a moving obstacle (7 cm
#: apart on a human: where an obstacle touches the capsule, the distance they give is at
#: most 3 mm more than the capsule's; more only deep inside it).
SEGMENT_SAMPLES = 25


def moves(matrices: np.ndarray, tol: float = 1e-6) -> bool:
    """Whether an object whose world matrices over the frames are ``matrices`` (F, 4, 4)
    moves (any entry changes by more than ``tol``)."""
    m = np.asarray(matrices, float)
    return bool(len(m) > 1 and np.abs(m - m[:1]).max() > tol)


def obstacle_figures(body: PlayedBody, name: str, local: Ground, matrices: np.ndarray, frame_start: int) -> dict:
    """How near ``body`` comes to a moving obstacle ``name`` whose surface is ``local`` (a
    ground query in the obstacle's own space) and whose world matrices over the same F
    frames are ``matrices`` (F, 4, 4): the least distance from the body's capsule
    (``SEGMENT_SAMPLES`` points hips to head, less its radius) or either foot's ankle and
    ball to the obstacle's surface, negative where the capsule reaches into it, its scene
    frame (from ``frame_start``), and the frames they touch. The nearest surface point
    is found in the obstacle's space and measured in the world's; a point within a closed
    obstacle (``inside``) is that far into it."""
    m = np.asarray(matrices, float)
    F = len(m)
    u = np.linspace(0.0, 1.0, SEGMENT_SAMPLES)[None, :, None]
    seg = body.hips[:, None] + u * (body.head - body.hips)[:, None]  # (F, K, 3)
    feet = body.feet.transpose(1, 0, 2, 3).reshape(F, -1, 3)  # (F, 2 * P, 3)
    pts = np.concatenate([seg, feet], axis=1)
    inv = np.linalg.inv(m)
    here = np.einsum("fij,fkj->fki", inv[:, :3, :3], pts) + inv[:, None, :3, 3]
    near, _ = local.nearest(here.reshape(-1, 3))
    back = np.einsum("fij,fkj->fki", m[:, :3, :3], near.reshape(F, -1, 3)) + m[:, None, :3, 3]
    d = np.linalg.norm(back - pts, axis=-1)  # (F, K + 2P), nan where the obstacle has no surface
    d = np.where(inside(local, here.reshape(-1, 3)).reshape(d.shape), -d, d)  # (within a solid: how deep)
    d[:, :SEGMENT_SAMPLES] -= body.radius
    d = np.where(np.isfinite(d), d, np.inf).min(axis=1)
    i = int(np.argmin(d))
    return {"obstacle": name, "least_distance_m": round(float(d[i]), 4) if np.isfinite(d[i]) else None,
            "least_distance_frame": int(frame_start + i), "frames_touching": int((d < 0.0).sum())}


#: A point is inside a solid where a ray down from it crosses its surface an odd number
#: of times, counted up to this many crossings.
MAX_CROSSINGS = 16


def inside(ground: Ground, points: np.ndarray) -> np.ndarray:
    """(N,) bool: each point (N, 3) within the solid ``ground``'s surface closes (never,
    for a surface that closes none: ``TriMesh.closed_owners``), by the parity of the
    surfaces a ray down from it crosses (each crossing found by a ray down from just below
    the one before)."""
    p = np.array(points, float).reshape(-1, 3)
    count = np.zeros(len(p), np.int64)
    if not ground.mesh.n or not ground.mesh.closed_owners().all():
        return count > 0
    lo, hi = ground.mesh.bounds()
    reach = float(hi[2] - lo[2]) + 1.0
    todo = np.flatnonzero(p[:, 2] >= lo[2])
    for _ in range(MAX_CROSSINGS):
        if not len(todo):
            break
        hit = ground.ray_down(p[todo], reach)
        count[todo[hit.hit]] += 1
        p[todo[hit.hit], 2] = hit.z[hit.hit] - 1e-7 * max(reach, 1.0)
        todo = todo[hit.hit]
    return count % 2 == 1


def obstacle_line(fig: dict) -> str:
    """One line of the command line's summary for ``obstacle_figures``."""
    if fig["least_distance_m"] is None:
        return f"with {fig['obstacle']} (moving): no surface to measure"
    return (f"with {fig['obstacle']} (moving): {fig['least_distance_m']:.2f} m from the body at the nearest "
            f"(frame {fig['least_distance_frame']})"
            + (f", touching {fig['frames_touching']} frames" if fig["frames_touching"] else ""))


def pair_line(fig: dict) -> str:
    """One line of the command line's summary for ``pair_figures``."""
    line = (f"with {fig['character']}: bodies {fig['least_distance_m']:.2f} m apart at the nearest "
            f"(frame {fig['least_distance_frame']})")
    if fig["frames_overlapping"]:
        line += f", overlapping {fig['frames_overlapping']} frames"
    n = fig["frames_on_one_footprint"]
    line += (f"; feet on one footprint {n} frames (from frame {fig['first_frame_on_one_footprint']})"
             if n else "; never a foot on the other's footprint")
    return line


__all__ = ["BODY_RADIUS", "FOOT_OVER_ANKLE_BALL", "MAX_CROSSINGS", "PLANTED_SPEED", "PlayedBody", "SEGMENT_SAMPLES",
           "body_of", "inside", "moves", "obstacle_figures", "obstacle_line", "pair_figures", "pair_line",
           "planted_feet", "segment_distance"]
