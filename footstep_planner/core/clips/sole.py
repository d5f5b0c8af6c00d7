"""The soles of a rig's feet from its skinned mesh: each foot's heel, ball and toe tip.

Pure numpy: this module never imports bpy. The Blender layer (``blender.read.scene.mesh_sole``)
reads the rest positions of the mesh's vertices near the feet (armature space) and their
weights to the foot and toe bones; :func:`sole_from_mesh` turns them into points in each
foot bone's rest frame, where the planner keeps a foot's points (``ClipMotion.heel_local``,
``toe_local``):

* the **heel**: as far back as the foot's lowest vertices go (those within ``SOLE_BAND``
  of the foot's length above its lowest one), across the foot in the middle of the low
  vertices there, on the sole (the lowest height of the foot's back half);
* the **ball**: where the toe bone starts (its rest head; without a toe bone the foot
  bone's tail), on the sole beneath it (the lowest vertex within ``SOLE_BAND`` along the
  foot of it);
* the **tip**: as far front as the foot's and toes' vertices go, in the middle of the
  front-most ones (within ``TIE`` of the foot's length), at the lowest of them.

"Back" and "front" are along the foot's own horizontal direction (from its head to the
ball; the rig's forward where the foot bone stands upright). A vertex belongs to the foot
when at least ``SOLE_WEIGHT`` of it follows the foot and toe bones together.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: The least share of a vertex's weight on the foot and toe bones for it to be the foot's
#: (the ankle's vertices, shared with the shin, are left to the shin).
SOLE_WEIGHT = 0.5
#: How far above its lowest vertex (and along it, about the ball) a foot's sole reaches,
#: as a share of the foot's length (heel to tip).
SOLE_BAND = 0.1
#: Vertices this share of the foot's length from the front-most are as far front (the
#: tip is their middle, at the lowest of them).
TIE = 0.01
#: The fewest vertices a foot must have for a sole to be read from them.
MIN_VERTICES = 4


@dataclass(frozen=True)
class Sole:
    """Each foot's heel, ball and toe tip, (2, 3) (left, right) in its foot bone's rest
    frame (``Rig.rest``), and where they were found."""

    heel: np.ndarray
    ball: np.ndarray
    tip: np.ndarray
    source: str = "mesh"

    def local(self, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(heel, ball, tip) of foot ``k`` (0 left, 1 right) as homogeneous 4-vectors."""
        return tuple(np.append(p[k], 1.0) for p in (self.heel, self.ball, self.tip))


def sole_from_mesh(rig, points: np.ndarray, weights: np.ndarray) -> Sole | None:
    """The sole of ``rig``'s feet from a skinned mesh: ``points`` (V, 3) vertices' rest
    positions in armature space, ``weights`` (V, 2, 2) each vertex's weight to the
    [left, right] [foot, toe] bones (0 where the rig has no toe bone). None when a foot has
    fewer than ``MIN_VERTICES`` vertices of its own (``SOLE_WEIGHT``): the bones then stand
    for the sole. Never changes its inputs."""
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    weights = np.asarray(weights, dtype=np.float64).reshape(len(points), 2, 2)
    out = []
    for k, side in enumerate(("l", "r")):
        mine = weights[:, k].sum(axis=1) >= SOLE_WEIGHT
        if mine.sum() < MIN_VERTICES:
            return None
        out.append(_foot_sole(rig, side, points[mine]))
    heel, ball, tip = (np.array([o[i] for o in out]) for i in range(3))
    return Sole(heel, ball, tip)


def _foot_sole(rig, side: str, pts: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(heel, ball, tip) (3,) of one foot in its bone's rest frame from its vertices
    ``pts`` (M, 3, armature space)."""
    foot, toe = rig.foot_chain(side)
    ball_bone = rig.rest[toe, :3, 3] if toe is not None else rig.tails[foot]
    fwd = ball_bone - rig.rest[foot, :3, 3]
    fwd[2] = 0.0
    if np.linalg.norm(fwd) < 1e-6 * max(float(np.ptp(pts, axis=0).max()), 1e-9):
        fwd = rig.forward_axis()
    fwd = fwd / np.linalg.norm(fwd)
    along = pts @ fwd
    band = SOLE_BAND * max(float(np.ptp(along)), 1e-9)
    z = pts[:, 2]
    low = z <= z.min() + band
    rear = low & (along <= along[low].min() + band)  # the heel's low vertices ...
    across = np.cross([0.0, 0.0, 1.0], fwd)
    back = along <= 0.5 * (along.min() + along.max())
    heel = along[low].min() * fwd + float((pts[rear] @ across).mean()) * across  # ... their middle
    heel[2] = z[back].min()
    near = np.abs(along - float(ball_bone @ fwd)) <= band
    ball = np.array([ball_bone[0], ball_bone[1], z[near].min() if near.any() else z.min()])
    front = along >= along.max() - TIE * (along.max() - along.min())  # the front-most vertices ...
    tip = along.max() * fwd + float((pts[front] @ across).mean()) * across  # ... their middle, their lowest
    tip[2] = z[front].min()
    inv = np.linalg.inv(rig.rest[foot])
    return tuple((inv @ np.append(p, 1.0))[:3] for p in (heel, ball, tip))


__all__ = ["Sole", "sole_from_mesh", "SOLE_WEIGHT", "SOLE_BAND", "TIE", "MIN_VERTICES"]
