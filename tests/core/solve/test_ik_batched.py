"""The IK's ground asked once per swing (issue 28): ``swing_targets`` gives what it gave
when it asked the ground along every frame's way (planted frames and all, every way as
densely as the longest), and it asks only along the swings that change height, each by
its own length."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from footstep_planner.core.solve.easing import planted_either_side, smoothstep
from footstep_planner.core.solve.swing import CLIMB_MIN, _stair_swing, swing_targets
from footstep_planner.core.plan.surface import steps_along


def _every_frame(planted, A0, R0, ankle, rot, ground_z):
    """``swing_targets`` as it was before issue 28: the ground asked along the way of
    every frame's last and next planted frames, whatever the frame."""
    F = len(planted)
    idx = np.flatnonzero(planted)
    off, turn = np.zeros((F, 3)), np.zeros((F, 3))
    off[idx] = ankle[idx] - A0[idx]
    turn[idx] = Rotation.from_matrix(rot[idx] @ np.transpose(R0[idx], (0, 2, 1))).as_rotvec()
    f = np.arange(F)
    prev, nxt = planted_either_side(planted)
    prev_c, nxt_c = np.where(prev < 0, nxt, prev), np.where(nxt >= F, prev, nxt)
    x = (f - prev_c) / np.maximum(nxt_c - prev_c, 1)
    u = smoothstep(x)[:, None]
    A = A0 + (1 - u) * off[prev_c] + u * off[nxt_c]
    R = Rotation.from_rotvec((1 - u) * turn[prev_c] + u * turn[nxt_c]).as_matrix() @ R0
    A[idx], R[idx] = ankle[idx], rot[idx]
    swing = ~planted & (prev >= 0) & (nxt < F)
    pairs, inv = np.unique(np.c_[prev_c, nxt_c], axis=0, return_inverse=True)
    pa, pb = A[pairs[:, 0]], A[pairs[:, 1]]
    jump = steps_along(ground_z, pa, pb, 0.5 * (pa[:, 2] + pb[:, 2]))
    edge = (np.nan_to_num(jump, nan=0.0) > CLIMB_MIN).any(axis=1)[np.ravel(inv)]
    return _stair_swing(A, swing & edge, prev_c, nxt_c, x), R


def _stairs(p):
    """A flight of 17 cm risers and 28 cm treads along x from x = 0.5 m, level before it."""
    p = np.asarray(p, float)
    return 0.17 * np.floor(np.clip(p[:, 0] - 0.5, 0.0, None) / 0.28 + 1.0) * (p[:, 0] >= 0.5)


def _walk(stances, lengths, F):
    """One foot's planted frames and targets: stances of ``lengths`` frames starting at
    ``stances``, each footprint on the stairs ahead of the last, the clip's own foot
    sweeping along x at a height of its own."""
    planted = np.zeros(F, bool)
    ankle = np.zeros((F, 3))
    for i, (a, n) in enumerate(zip(stances, lengths)):
        x = 0.1 + 0.28 * i
        planted[a:a + n] = True
        ankle[a:a + n] = [x, 0.05 * (-1) ** i, _stairs([[x, 0.0, 0.0]])[0] + 0.08]
    t = np.arange(F) / 30.0
    A0 = np.c_[0.9 * t, np.zeros(F), 0.08 + 0.05 * np.sin(7.0 * t) ** 2]
    R0 = Rotation.from_euler("y", 0.2 * np.sin(5.0 * t)[:, None]).as_matrix()
    rot = Rotation.from_euler("z", 0.1 * np.cos(3.0 * t)[:, None]).as_matrix() @ R0
    return planted, A0, R0, ankle, rot


@settings(max_examples=30, deadline=None)
@given(st.lists(st.tuples(st.integers(4, 14), st.integers(3, 12)), min_size=2, max_size=7), st.integers(0, 6))
def test_swing_targets_ask_the_ground_per_swing_and_give_what_every_frame_gave(steps, lead):
    """On stairs (level ground, then a flight), random stances: the same targets as the
    every-frame way, and the ground asked only along the swings that climb or descend."""
    starts, at = [], lead
    for gap, n in steps:
        starts.append(at)
        at += n + gap
    F = at + 5
    planted, A0, R0, ankle, rot = _walk(starts, [n for _, n in steps], F)
    asked = []

    def ground(p):
        asked.append(len(p))
        return _stairs(p)

    A, R = swing_targets(planted, A0, R0, ankle, rot, ground)
    A_ref, R_ref = _every_frame(planted, A0, R0, ankle, rot, _stairs)
    np.testing.assert_allclose(A, A_ref, atol=1e-12)
    np.testing.assert_allclose(R, R_ref, atol=1e-12)
    # the ground asked along each swing that changes height by more than CLIMB_MIN, once,
    # by its own length (at most 3 cm between samples)
    prev, nxt = planted_either_side(planted)
    swing = ~planted & (prev >= 0) & (nxt < F)
    ways = {(a, b) for a, b in zip(prev[swing], nxt[swing]) if abs(ankle[b, 2] - ankle[a, 2]) > CLIMB_MIN}
    if not ways:
        assert not asked
    else:
        (n,) = asked
        assert n == sum(int(np.ceil(np.hypot(*(ankle[b, :2] - ankle[a, :2])) / 0.03)) + 1 for a, b in ways)


def test_a_swing_on_level_ground_asks_nothing():
    """A walk on level ground (no footprint higher than another): no ground asked."""
    F = 60
    planted, A0, R0, ankle, rot = _walk([0, 20, 40], [10, 10, 10], F)
    ankle[planted, 2] = 0.08
    asked = []
    swing_targets(planted, A0, R0, ankle, rot, lambda p: asked.append(len(p)) or np.zeros(len(p)))
    assert not asked


@settings(max_examples=40, deadline=None)
@given(st.lists(st.tuples(st.floats(-2, 2), st.floats(-2, 2), st.floats(-2, 2), st.floats(-2, 2)),
                min_size=1, max_size=8), st.integers(3, 50))
def test_each_way_sampled_by_its_own_length_finds_the_largest_step(ways, samples):
    """``largest_step_along``: on ways all as long as one another (the same samples
    ``steps_along`` takes), the largest of ``steps_along``'s steps (no ground: ``missing``);
    a way no longer than the spacing takes its two ends."""
    from footstep_planner.core.plan.surface import largest_step_along

    a = np.array([[x, y, 0.0] for x, y, _, _ in ways])
    length = (samples - 0.5) * 0.03  # (half a spacing short of ``samples`` spacings: no rounding)
    ang = np.array([np.arctan2(v, u) for _, _, u, v in ways])
    b = a + length * np.c_[np.cos(ang), np.sin(ang), np.zeros(len(a))]

    def ground(p):  # terraces 7 cm high every 0.3 m along x + y, no ground where x > 1.5
        p = np.asarray(p, float)
        return np.where(p[:, 0] > 1.5, np.nan, 0.07 * np.floor((p[:, 0] + p[:, 1]) / 0.3))

    z = np.full(len(a), 0.5)
    ref = steps_along(ground, a, b, z)
    for missing in (0.0, np.inf):
        got = largest_step_along(ground, a, b, z, missing=missing)
        np.testing.assert_allclose(got, np.nan_to_num(ref, nan=missing).max(axis=1))
    short = largest_step_along(ground, a, a + [0.01, 0.0, 0.0], z)
    np.testing.assert_allclose(short, np.nan_to_num(np.abs(ground(a + [0.01, 0.0, 0.0]) - ground(a)), nan=np.inf))
