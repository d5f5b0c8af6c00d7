"""Characters sharing a shot (``core.report.crowd``): the distance between two bodies'
capsules, planted feet and the figures per pair."""

from __future__ import annotations

import numpy as np
from hypothesis import example, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from footstep_planner.core.report.crowd import (PlayedBody, held, others_of, pair_figures, planted_feet,
                                                segment_distance)

HYP = dict(deadline=None, database=None)
coords = arrays(np.float64, (4, 3), elements=st.floats(-5.0, 5.0, allow_nan=False, width=32))


def brute_force(p0, p1, q0, q1, n=801):
    """The least distance from n points along p0-p1 to the segment q0-q1 (each point's
    nearest on it exactly): at most a step's worth above the true least distance."""
    s = np.linspace(0.0, 1.0, n)[:, None]
    p = p0 + s * (p1 - p0)
    d = q1 - q0
    dd = float(d @ d)
    t = np.clip(((p - q0) @ d) / dd, 0.0, 1.0)[:, None] if dd > 0 else np.zeros((n, 1))
    return float(np.linalg.norm(p - (q0 + t * d), axis=1).min()), float(np.linalg.norm(p1 - p0)) / (n - 1)


@settings(max_examples=300, **HYP)
@given(coords, st.sampled_from(["any", "point_p", "point_q", "parallel", "both_points"]))
@example(np.array([[0.0, 0.0, 0.0], [1e-9, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 1e-9, 0.0]]), "any")
def test_segment_distance_is_the_least_distance(c, kind):
    p0, p1, q0, q1 = c
    if kind == "point_p":
        p1 = p0
    elif kind == "point_q":
        q1 = q0
    elif kind == "parallel":
        q1 = q0 + 0.7 * (p1 - p0)
    elif kind == "both_points":
        p1, q1 = p0, q0
    got = segment_distance(p0[None], p1[None], q0[None], q1[None])[0]
    want, step = brute_force(p0, p1, q0, q1)
    # (to 1e-8 m: a segment under 1e-9 m long is taken for a point)
    assert got <= want + 1e-8
    assert got >= want - step - 1e-8
    # either way round, either end first: the same distance
    for a, b, c_, d in ((q0, q1, p0, p1), (p1, p0, q1, q0)):
        assert abs(segment_distance(a[None], b[None], c_[None], d[None])[0] - got) < 1e-8


@settings(max_examples=50, **HYP)
@given(coords, st.floats(-np.pi, np.pi), arrays(np.float64, 3, elements=st.floats(-50, 50, width=32)))
def test_segment_distance_moves_with_the_segments(c, yaw, shift):
    """Turned about Z and moved, frame by frame in one call: the same distances."""
    cz, sz = np.cos(yaw), np.sin(yaw)
    R = np.array([[cz, -sz, 0.0], [sz, cz, 0.0], [0.0, 0.0, 1.0]])
    moved = c @ R.T + shift
    both = segment_distance(*(np.stack([c[k], moved[k]]) for k in range(4)))
    assert abs(both[0] - both[1]) < 1e-7


def test_still_feet_are_planted_and_moving_ones_are_not():
    fps = 30.0
    F = 60
    t = np.arange(F) / fps
    still = np.zeros((F, 2, 3))
    swing = np.zeros((F, 2, 3))
    swing[:, :, 0] = 1.2 * t[:, None]  # 1.2 m/s
    planted = planted_feet(np.stack([still, swing]), fps)
    assert planted[0].all() and not planted[1].any()


def body(name, x, y, planted=True):
    """A standing body at (x, y) (arrays over the frames), its feet 0.1 m to either side."""
    F = len(x)
    hips = np.c_[x, y, np.full(F, 0.95)]
    head = hips + [0.0, 0.0, 0.8]
    soles = np.stack([np.c_[x - 0.1, y, np.zeros(F)], np.c_[x + 0.1, y, np.zeros(F)]])
    return PlayedBody(name, hips, head, 0.2, soles[:, :, None], np.full((2, F), planted), 0.26)


def test_two_bodies_passing_and_standing_on_one_spot():
    F = 101
    x = np.linspace(-5.0, 5.0, F)
    a = body("A", x, np.zeros(F))
    b = body("B", np.zeros(F), np.full(F, 0.2))  # standing 0.2 m off A's way
    fig = pair_figures(a, b, frame_start=10)
    assert fig["character"] == "B"
    assert abs(fig["least_distance_m"] - (0.2 - 0.4)) < 1e-9  # the capsules overlap by 0.2 m
    assert fig["least_distance_frame"] == 10 + 50  # where A passes B
    assert fig["frames_overlapping"] == int((np.hypot(x, 0.2) < 0.4).sum())
    # B's feet are 0.2 m off A's way, under a foot's length: shared while A's pass (planted)
    near = np.zeros(F, bool)
    for da in (-0.1, 0.1):  # (either foot of A's on either of B's)
        for db in (-0.1, 0.1):
            near |= np.hypot(x + da - db, 0.2) < 0.26
    assert fig["frames_on_one_footprint"] == int(near.sum())
    assert fig["first_frame_on_one_footprint"] == 10 + int(np.flatnonzero(near)[0])
    far = body("C", np.zeros(F), np.full(F, 3.0))
    fig = pair_figures(a, far, frame_start=10)
    assert fig["least_distance_m"] > 2.5 and fig["frames_overlapping"] == 0
    assert fig["frames_on_one_footprint"] == 0 and fig["first_frame_on_one_footprint"] is None
    # feet in the air never share a footprint
    assert pair_figures(a, body("D", np.zeros(F), np.full(F, 0.2), planted=False), 0)["frames_on_one_footprint"] == 0


def test_a_box_sliding_across_a_body_is_measured_in_its_own_space():
    """A 1 m box (its surface in its own space, moved by its world matrices) slides along
    x through y = 1.5 while the body stands at the origin: the nearest is where the box's
    side faces the body, 1.0 m from the body's axis (less the radius)."""
    from footstep_planner.core.plan.surface import MeshGround
    from footstep_planner.core.report.crowd import moves, obstacle_figures
    from conftest import box

    F = 81
    me = body("A", np.zeros(F), np.zeros(F))
    ground = MeshGround(box((-0.5, -0.5, 0.0), (0.5, 0.5, 1.0)))
    m = np.tile(np.eye(4), (F, 1, 1))
    m[:, 0, 3] = np.linspace(-4.0, 4.0, F)
    m[:, 1, 3] = 1.5
    assert moves(m) and not moves(np.tile(np.eye(4), (F, 1, 1)))
    fig = obstacle_figures(me, "Cart", ground, m, frame_start=1)
    assert fig["obstacle"] == "Cart"
    assert abs(fig["least_distance_m"] - (1.0 - me.radius)) < 1e-9
    assert abs(m[fig["least_distance_frame"] - 1, 0, 3]) <= 0.5 + 1e-9  # (its side faces the body there)
    assert fig["frames_touching"] == 0
    # turned a quarter about Z and sliding through y = 0.6: it reaches into the body
    c, s = 0.0, 1.0
    m[:, :3, :3] = [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]
    m[:, 1, 3] = 0.6
    fig = obstacle_figures(me, "Cart", ground, m, frame_start=1)
    assert abs(fig["least_distance_m"] - (0.1 - me.radius)) < 1e-9
    assert fig["frames_touching"] > 0
    # sliding through the body itself: its hips 5 cm under the box's top, inside it
    m[:, 1, 3] = 0.0
    fig = obstacle_figures(me, "Cart", ground, m, frame_start=1)
    assert abs(fig["least_distance_m"] - (-0.05 - me.radius)) < 1e-9


@settings(max_examples=60, **HYP)
@given(arrays(np.float64, (20, 3), elements=st.floats(-2.0, 2.0, allow_nan=False, width=32)))
def test_inside_a_box_is_inside_its_bounds_and_never_for_an_open_mesh(p):
    from footstep_planner.core.plan.surface import MeshGround
    from footstep_planner.core.report.crowd import inside
    from conftest import box, plane

    lo, hi = np.array([-0.5, -0.7, 0.1]), np.array([0.9, 0.4, 1.3])
    got = inside(MeshGround(box(lo, hi)), p)
    margin = np.minimum(p - lo, hi - p).min(axis=1)
    sure = np.abs(margin) > 1e-6
    assert np.array_equal(got[sure], (margin > 0)[sure])
    assert not inside(MeshGround(plane(-1, 1, -1, 1)), p).any()


@settings(max_examples=60, **HYP)
@given(st.integers(2, 30), st.integers(-40, 40), st.integers(1, 60))
def test_a_body_held_over_other_frames_stands_as_it_starts_and_ends(length, start, frames):
    """A body played from scene frame ``start`` read over other frames (from frame 0) is
    itself where the frames meet, and stands as it starts before them and as it ends after."""
    f = np.arange(length, dtype=float)
    hips = np.stack([f, np.zeros(length), np.ones(length)], axis=1)
    feet = np.broadcast_to(hips[None, :, None], (2, length, 2, 3)).copy()
    planted = np.zeros((2, length), bool)
    planted[:, -1] = True
    body = PlayedBody("a", hips, hips + [0, 0, 0.7], 0.2, feet, planted, 0.26)
    got = held(body, start, 0, frames)
    want = np.clip(np.arange(frames) - start, 0, length - 1)
    assert np.array_equal(got.hips[:, 0], want) and got.feet.shape == (2, frames, 2, 3)
    assert np.array_equal(got.planted[0], want == length - 1)
    others = others_of([got, got], frames, 30.0)
    assert others.hips.shape == (2, frames, 3) and np.allclose(others.times, np.arange(frames) / 30.0)


def test_others_of_no_bodies_keeps_the_frames_for_obstacles_that_move():
    """With no character but over F frames, an obstacle's outline is added at each frame."""
    others = others_of([], 5, 10.0)
    moved = others.with_movers(["door"], np.zeros((1, 5, 3)), 0.05)
    assert len(others.times) == 5 and moved.hips.shape == (1, 5, 3)
