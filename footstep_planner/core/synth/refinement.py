"""Refinement (thesis 3.5): pull the desired footprints towards what the clips do locally.

The clips are played without adjustment (``blending.playback``); they leave footprints
p^O, q^O. Each interior desired footprint i is replaced by its original footprint mapped
with the similarity transform (offset, rotation about +Z, uniform scale) that carries the
original neighbours p^O_{i-1}, p^O_{i+1} onto the desired neighbours p^D_{i-1},
p^D_{i+1}. All footprints are updated together, half-way to their targets (a damped
Jacobi sweep; see ``DAMPING``), ``iterations`` times,
each result snapped to the traversable surface; a footprint the surface refuses keeps
its previous place. The first and the last footprints never move.

Positions are (N, 3) metres, headings (N,) radians about +Z (positive counter-clockwise),
both feet in one sequence. Heights: the transform is horizontal; a footprint's height is
its desired neighbour's plus the original height difference, then the snap's.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

#: Each sweep moves a footprint this share of the way to its target. With 1 (the plain
#: simultaneous update) the odd and even footprints trade places every sweep: with the
#: neighbours on the centre line the target puts a foot a full step width aside, and
#: from there the next target puts it back. A half step removes that mode at once.
DAMPING = 0.5

SnapFn = Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]


@dataclass
class Refined:
    position: np.ndarray  # (N, 3)
    heading: np.ndarray  # (N,)
    mismatch: np.ndarray  # (iterations + 1,) mean distance of the interior footprints from
    #                       their similarity-mapped originals, before each sweep and after the last
    rejected: np.ndarray  # (N,) sweeps in which the surface refused the footprint's new place


def local_targets(orig_pos, orig_heading, pos, heading) -> tuple[np.ndarray, np.ndarray]:
    """For interior footprints 1..N-2: the original footprint mapped by the similarity
    of its original neighbours onto the current (desired) neighbours. Returns
    (positions (N-2, 3), headings (N-2,))."""
    o = orig_pos[:, 0] + 1j * orig_pos[:, 1]
    d = pos[:, 0] + 1j * pos[:, 1]
    den = o[2:] - o[:-2]
    num = d[2:] - d[:-2]
    ok = np.abs(den) > 1e-9
    # neighbours at one spot (a turn on the spot): rotate by the heading change only
    spin = np.exp(1j * (heading[:-2] - orig_heading[:-2]))
    a = np.where(ok, num / np.where(ok, den, 1.0), spin)
    p = d[:-2] + a * (o[1:-1] - o[:-2])
    z = pos[:-2, 2] + (orig_pos[1:-1, 2] - orig_pos[:-2, 2])
    h = orig_heading[1:-1] + np.angle(a)
    # keep the heading's winding close to the current one
    h = heading[1:-1] + (h - heading[1:-1] + np.pi) % (2 * np.pi) - np.pi
    return np.c_[p.real, p.imag, z], h


def mismatch(orig_pos, orig_heading, pos, heading) -> float:
    """Mean horizontal distance (m) of interior desired footprints from their targets."""
    if len(pos) < 3:
        return 0.0
    tp, _ = local_targets(orig_pos, orig_heading, pos, heading)
    return _mismatch_of(tp, pos)


def _mismatch_of(targets: np.ndarray, pos: np.ndarray) -> float:
    """``mismatch`` of footprints ``pos`` (N, 3) whose interior targets are ``targets``
    (N-2, 3) (``local_targets``)."""
    return float(np.mean(np.linalg.norm(targets[:, :2] - pos[1:-1, :2], axis=1)))


def refine(orig_pos, orig_heading, desired_pos, desired_heading, iterations: int = 10,
           snap: SnapFn | None = None, fixed: np.ndarray | None = None,
           height: Callable[[np.ndarray], np.ndarray] | None = None) -> Refined:
    """Thesis 3.5 with ``iterations`` damped sweeps (see the module docstring).

    ``orig_*``: the footprints the unadjusted animation left; ``desired_*``: the path
    (smoothed). ``fixed`` (N,) bool marks footprints that never move (default: the
    first and the last). ``snap`` is the full check (surface and obstacles) after each
    sweep. With ``height`` (positions (M, 3) -> the same on the surface) the sweeps in
    between only drop the footprints onto the surface, and ``snap`` checks the last
    sweep: a footprint it refuses goes back to its place before refinement (which the
    path already held). A ``snap`` with ``crosses_edge(a, b) -> (M,) bool`` (see
    ``pipeline.surface_snap``) keeps each footprint on the side of every step edge it
    was desired on: a move across one is refused (a footprint planned on a stair tread
    stays on it). Inputs are not modified."""
    op = np.asarray(orig_pos, float)
    oh = np.asarray(orig_heading, float)
    pos = np.array(desired_pos, dtype=float, copy=True)
    head = np.array(desired_heading, dtype=float, copy=True)
    n = len(pos)
    if op.shape != pos.shape or oh.shape != head.shape or pos.ndim != 2 or pos.shape[1] != 3 \
            or head.shape != (n,):
        raise ValueError("refine: original and desired footprints must be (N, 3) positions and (N,) headings")
    rejected = np.zeros(n, int)
    errs = [mismatch(op, oh, pos, head)]
    if n < 3:
        return Refined(pos, head, np.array(errs * (iterations + 1)), rejected)
    move = np.ones(n, bool)
    move[[0, -1]] = False
    if fixed is not None:
        move &= ~np.asarray(fixed, bool)
    idx = np.flatnonzero(move[1:-1]) + 1
    start_p, start_h = pos[idx].copy(), head[idx].copy()
    edge = getattr(snap, "crosses_edge", None)
    tp, th = local_targets(op, oh, pos, head)  # (each sweep's targets: the last sweep's mismatch's)
    for it in range(iterations):
        # half-way: a simultaneous update alone flips left and right feet every sweep
        new_p = pos[idx] + DAMPING * (tp[idx - 1] - pos[idx])
        new_h = head[idx] + DAMPING * (th[idx - 1] - head[idx])
        last = it == iterations - 1
        if height is not None and not last:
            new_p = height(new_p)
            if edge is not None:
                across = edge(start_p, new_p)
                new_p[across], new_h[across] = pos[idx][across], head[idx][across]
        elif snap is not None:
            sp, ok = snap(new_p, new_h)
            if edge is not None:
                ok &= ~edge(start_p, sp)
            rejected[idx[~ok]] += 1
            back_p, back_h = (start_p, start_h) if height is not None else (pos[idx], head[idx])
            new_p = np.where(ok[:, None], sp, back_p)
            new_h = np.where(ok, new_h, back_h)
        pos[idx], head[idx] = new_p, new_h
        tp, th = local_targets(op, oh, pos, head)
        errs.append(_mismatch_of(tp, pos))
    return Refined(pos, head, np.array(errs), rejected)
