"""Property tests of footstep_planner.core.synth.smoothing (Granberg 2017, 3.3): the binomial
kernel on positions, the corrected rotation kernel, the end padding, fixed footprints,
snapping, heading wrap-around, invariances and input validation. Pure core, no Blender.

The reference below (``binomial_ref``) is written independently of the module, one index at
a time: the 1-4-6-4-1 / 16 kernel on a sequence extended by point reflection through its
ends (x_{-k} = 2 x_0 - x_k, x_{N-1+k} = 2 x_{N-1} - x_{N-1-k}).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from footstep_planner.core.synth.smoothing import (
    Smoothed, heading_of, smooth_footprints, smooth_headings, smooth_positions,
    smooth_rotations, yaw_rotation)

HYP = dict(deadline=None, database=None)
K = np.array([1.0, 4.0, 6.0, 4.0, 1.0]) / 16.0

coord = st.floats(-20.0, 20.0)


# ----------------------------------------------------------------------------- helpers

def wrap(a):
    return (np.asarray(a) + math.pi) % (2 * math.pi) - math.pi


def default_fixed(n):
    m = np.zeros(n, dtype=bool)
    if n:
        m[0] = m[-1] = True
    return m


def binomial_ref(x, fixed=None):
    """The binomial kernel on x (N,) or (N, D), ends reflected, fixed entries kept."""
    x = np.asarray(x, dtype=float)
    n = len(x)
    if n < 3:
        return x.copy()
    fixed = default_fixed(n) if fixed is None else np.asarray(fixed)

    def ext(i):
        if i < 0:
            return 2 * x[0] - x[-i]
        if i > n - 1:
            return 2 * x[n - 1] - x[2 * (n - 1) - i]
        return x[i]

    out = np.array([sum(K[j + 2] * ext(i + j) for j in range(-2, 3)) for i in range(n)])
    out[fixed] = x[fixed]
    return out


def rot_dist(a: Rotation, b: Rotation) -> np.ndarray:
    """Angle (radians) between corresponding rotations."""
    return (a.inv() * b).magnitude()


def chain(q0: Rotation, increments) -> Rotation:
    """Rotations q_0, q_0 exp(v_0), q_0 exp(v_0) exp(v_1), ... (body-frame increments)."""
    out = [q0]
    for v in increments:
        out.append(out[-1] * Rotation.from_rotvec(v))
    return Rotation.concatenate(out)


def path_length(p):
    return float(np.linalg.norm(np.diff(p, axis=0), axis=1).sum())


@st.composite
def masks(draw, n):
    """None (the default mask) or a random boolean mask of length n."""
    if draw(st.booleans()):
        return None
    return np.array(draw(st.lists(st.booleans(), min_size=n, max_size=n)), dtype=bool)


@st.composite
def unit_axes(draw):
    v = np.array(draw(st.lists(st.floats(-1.0, 1.0), min_size=3, max_size=3)))
    norm = np.linalg.norm(v)
    if norm < 0.1:
        v, norm = np.array([0.0, 0.0, 1.0]), 1.0
    return v / norm


@st.composite
def angle_sequences(draw, min_size=1, max_size=12, step=3.0):
    """Angles whose consecutive differences are below pi (one principal log each)."""
    n = draw(st.integers(min_size, max_size))
    start = draw(st.floats(-10.0, 10.0))
    steps = draw(st.lists(st.floats(-step, step), min_size=n - 1, max_size=n - 1))
    return start + np.concatenate([[0.0], np.cumsum(steps)])


@st.composite
def point_paths(draw, min_size=3, max_size=12, dim=3):
    n = draw(st.integers(min_size, max_size))
    return np.array(draw(st.lists(st.lists(coord, min_size=dim, max_size=dim),
                                  min_size=n, max_size=n)))


@st.composite
def rotation_paths(draw, min_size=3, max_size=12):
    """Rotations with body-frame increments below 2.5 rad."""
    n = draw(st.integers(min_size, max_size))
    q0 = Rotation.from_rotvec(draw(st.lists(st.floats(-3.0, 3.0), min_size=3, max_size=3)))
    inc = []
    for _ in range(n - 1):
        axis = draw(unit_axes())
        inc.append(axis * draw(st.floats(-2.5, 2.5)))
    return chain(q0, inc)


# ----------------------------------------------------------------------------- kernels

@settings(max_examples=25, **HYP)
@given(data=st.data(), theta=angle_sequences(), axis=unit_axes())
def test_rotation_kernel_is_binomial_on_one_axis(data, theta, axis):
    """The corrected kernel on rotations about one axis is the binomial kernel on their
    angles, ends and fixed footprints included."""
    fixed = data.draw(masks(len(theta)))
    q = Rotation.from_rotvec(theta[:, None] * axis)
    expected = binomial_ref(theta, fixed)
    got = smooth_rotations(q, fixed)
    assert len(got) == len(theta)
    assert np.all(rot_dist(got, Rotation.from_rotvec(expected[:, None] * axis)) < 1e-9)
    # and the position kernel is the same reference
    assert np.allclose(smooth_positions(theta[:, None], fixed)[:, 0], expected,
                       rtol=0, atol=1e-12)


def apply_increment_weights(theta, axis, weights, offsets, i):
    """q_i exp(sum_k weights[k] w_{i + offsets[k]} / 16), interior i only (no padding)."""
    q = Rotation.from_rotvec(theta[:, None] * axis)
    w = (q[:-1].inv() * q[1:]).as_rotvec()
    delta = sum(c * w[i + o] for c, o in zip(weights, offsets)) / 16.0
    return q[i] * Rotation.from_rotvec(delta)


def test_thesis_uncorrected_weights_are_not_the_binomial_kernel():
    """Documented check of the correction: the thesis prints weights (-1, -5, 0, 5, 1) on
    w_{i-2} .. w_{i+2}; on one-axis rotations that is not the binomial kernel on the
    angles (on theta = c i^2 it moves by 28c/16 instead of c), while the corrected weights
    (-1, -5, 5, 1) on w_{i-2} .. w_{i+1} are, to rounding."""
    axis = np.array([0.3, -0.4, 0.866])
    axis /= np.linalg.norm(axis)
    rng = np.random.default_rng(7)
    for theta in (0.05 * np.arange(10.0) ** 2, np.cumsum(rng.uniform(-1.0, 1.0, 10))):
        expected = binomial_ref(theta)
        for i in range(2, len(theta) - 3):  # w_{i-2} .. w_{i+2} exist without padding
            target = Rotation.from_rotvec(expected[i] * axis)
            good = apply_increment_weights(theta, axis, (-1, -5, 5, 1), (-2, -1, 0, 1), i)
            bad = apply_increment_weights(theta, axis, (-1, -5, 0, 5, 1), (-2, -1, 0, 1, 2), i)
            assert (target.inv() * good).magnitude() < 1e-9
            assert (target.inv() * bad).magnitude() > 1e-3, i
    theta = 0.05 * np.arange(10.0) ** 2  # the closed form on the quadratic
    bad = apply_increment_weights(theta, axis, (-1, -5, 0, 5, 1), (-2, -1, 0, 1, 2), 4)
    assert (Rotation.from_rotvec(theta[4] * axis).inv() * bad).magnitude() == pytest.approx(
        28 * 0.05 / 16)


@settings(max_examples=20, **HYP)
@given(n=st.integers(1, 12), origin=st.lists(coord, min_size=3, max_size=3),
       step=st.lists(st.floats(-2.0, 2.0), min_size=3, max_size=3), data=st.data())
def test_straight_evenly_spaced_positions_unchanged(n, origin, step, data):
    p = np.asarray(origin) + np.arange(n)[:, None] * np.asarray(step)
    fixed = data.draw(masks(n))
    assert np.allclose(smooth_positions(p, fixed), p, rtol=0, atol=1e-12)
    r = smooth_footprints(p, np.zeros(n), iterations=5, fixed=fixed)
    assert np.allclose(r.position, p, rtol=0, atol=1e-12)
    assert np.all(r.rejected == 0) and r.iterations == 5


@settings(max_examples=20, **HYP)
@given(n=st.integers(1, 12), rv=st.lists(st.floats(-3.0, 3.0), min_size=3, max_size=3),
       inc=st.lists(st.floats(-2.0, 2.0), min_size=3, max_size=3), data=st.data())
def test_constant_and_constant_increment_rotations_unchanged(n, rv, inc, data):
    fixed = data.draw(masks(n))
    q = Rotation.from_rotvec(np.tile(rv, (n, 1)))
    assert np.all(rot_dist(smooth_rotations(q, fixed), q) < 1e-12)
    # q_0 exp(k w): evenly turning, the rotation analogue of a straight line
    q = chain(Rotation.from_rotvec(rv), [inc] * (n - 1))
    assert np.all(rot_dist(smooth_rotations(q, fixed), q) < 1e-9)


@settings(max_examples=20, **HYP)
@given(data=st.data(), p=point_paths(min_size=1), iterations=st.integers(1, 4))
def test_fixed_footprints_never_move(data, p, iterations):
    n = len(p)
    fixed = data.draw(masks(n))
    mask = default_fixed(n) if fixed is None else fixed
    heading = wrap(np.array(data.draw(st.lists(st.floats(-4.0, 4.0), min_size=n, max_size=n))))
    q = Rotation.from_rotvec(np.array(data.draw(st.lists(
        st.lists(st.floats(-1.0, 1.0), min_size=3, max_size=3), min_size=n, max_size=n))))
    assert np.array_equal(smooth_positions(p, fixed)[mask], p[mask])
    assert np.array_equal(smooth_headings(heading, fixed)[mask], heading[mask])
    assert np.all(rot_dist(smooth_rotations(q, fixed), q)[mask] < 1e-12)

    def snap(pos, h):  # moves everything onto z = 1, rejects half the footprints
        out = pos.copy()
        out[:, 2] = 1.0
        return out, np.arange(len(pos)) % 2 == 0

    r = smooth_footprints(p, heading, iterations, snap=snap, fixed=fixed)
    assert np.array_equal(r.position[mask], p[mask])
    assert np.array_equal(r.heading[mask], heading[mask])
    assert np.all(r.rejected[mask] == 0)


def test_default_fixed_ends_are_fixed_points_of_the_padded_kernel():
    """The reflection makes the ends their own smoothed value: with no mask at all the
    first and last footprints stay (positions and rotations alike)."""
    rng = np.random.default_rng(3)
    p = rng.normal(size=(7, 3))
    none = np.zeros(7, dtype=bool)
    out = smooth_positions(p, none)
    assert np.allclose(out[[0, -1]], p[[0, -1]], rtol=0, atol=1e-12)
    q = chain(Rotation.from_rotvec([0.1, 0.2, 0.3]), rng.uniform(-0.8, 0.8, (6, 3)))
    assert np.all(rot_dist(smooth_rotations(q, none)[[0, -1]], q[[0, -1]]) < 1e-12)


# ----------------------------------------------------------------------------- alternation

@settings(max_examples=20, **HYP)
@given(n=st.integers(5, 20), origin=st.lists(coord, min_size=3, max_size=3),
       step=st.lists(st.floats(-1.0, 1.0), min_size=3, max_size=3),
       side=st.lists(st.floats(-0.5, 0.5), min_size=3, max_size=3),
       h0=st.floats(-3.0, 3.0), dh=st.floats(-0.5, 0.5), dsplay=st.floats(-0.4, 0.4))
def test_left_right_alternation_removed(n, origin, step, side, h0, dh, dsplay):
    """The response to (-1)^i is zero: in the interior the smoothed footprints of both
    feet lie on the centre line (and the headings on the mean turn)."""
    i = np.arange(n)
    alt = (-1.0) ** i
    centre = np.asarray(origin) + i[:, None] * np.asarray(step)
    out = smooth_positions(centre + alt[:, None] * np.asarray(side))
    assert np.allclose(out[2:-2], centre[2:-2], rtol=0, atol=1e-9)
    assert np.allclose(smooth_positions(alt[:, None])[2:-2], 0.0, rtol=0, atol=1e-15)
    heading = h0 + dh * i + dsplay * alt
    got = smooth_headings(wrap(heading))
    assert np.allclose(wrap(got - (h0 + dh * i))[2:-2], 0.0, rtol=0, atol=1e-9)


# ----------------------------------------------------------------------------- geometry

@settings(max_examples=25, **HYP)
@given(p=point_paths(dim=2) | point_paths(dim=3), iterations=st.integers(1, 4))
def test_smoothing_never_lengthens_the_path(p, iterations):
    """Default mask (the ends, which the reflection keeps anyway): each pass is a convex
    combination of the (evenly reflected) step vectors, so the length cannot grow."""
    before = path_length(p)
    for _ in range(iterations):
        q = smooth_positions(p)
        assert path_length(q) <= path_length(p) + 1e-9 * (1.0 + path_length(p))
        p = q
    r = smooth_footprints(np.c_[p, np.zeros(len(p))] if p.shape[1] == 2 else p,
                          np.zeros(len(p)), iterations)
    assert path_length(r.position) <= before + 1e-9 * (1.0 + before)


def test_zig_zag_gets_shorter_and_straighter():
    n = 12
    i = np.arange(n)
    p = np.c_[0.35 * i, 0.12 * (-1.0) ** i, np.zeros(n)]
    r = smooth_footprints(p, np.zeros(n), iterations=4)
    assert path_length(r.position) < 0.9 * path_length(p)
    # the fixed ends keep their offset, which decays inwards: the middle is near the centre
    assert np.abs(r.position[3:-3, 1]).max() < 0.25 * 0.12


@settings(max_examples=20, **HYP)
@given(p=point_paths(), rv=st.lists(st.floats(-3.0, 3.0), min_size=3, max_size=3),
       t=st.lists(coord, min_size=3, max_size=3), data=st.data())
def test_positions_equivariant_under_rigid_motion(p, rv, t, data):
    fixed = data.draw(masks(len(p)))
    R = Rotation.from_rotvec(rv).as_matrix()
    moved = p @ R.T + np.asarray(t)
    assert np.allclose(smooth_positions(moved, fixed), smooth_positions(p, fixed) @ R.T + t,
                       rtol=0, atol=1e-9)


@settings(max_examples=20, **HYP)
@given(q=rotation_paths(), rv=st.lists(st.floats(-3.0, 3.0), min_size=3, max_size=3))
def test_rotations_equivariant_under_a_common_rotation(q, rv):
    g = Rotation.from_rotvec(rv)
    a = smooth_rotations(Rotation.concatenate([g] * len(q)) * q)
    b = Rotation.concatenate([g] * len(q)) * smooth_rotations(q)
    assert np.all(rot_dist(a, b) < 1e-9)


@settings(max_examples=20, **HYP)
@given(p=point_paths(), yaw=st.floats(-10.0, 10.0), t=st.lists(coord, min_size=3, max_size=3),
       data=st.data(), iterations=st.integers(1, 4))
def test_footprints_equivariant_under_yaw_and_translation(p, yaw, t, data, iterations):
    n = len(p)
    heading = wrap(np.cumsum(data.draw(st.lists(st.floats(-2.5, 2.5), min_size=n, max_size=n))))
    R = Rotation.from_rotvec([0.0, 0.0, yaw]).as_matrix()
    base = smooth_footprints(p, heading, iterations)
    moved = smooth_footprints(p @ R.T + t, heading + yaw, iterations)
    assert np.allclose(moved.position, base.position @ R.T + t, rtol=0, atol=1e-9)
    assert np.allclose(wrap(moved.heading - base.heading - yaw), 0.0, rtol=0, atol=1e-9)


# ----------------------------------------------------------------------------- snapping

CENTRE, RADIUS = np.array([0.0, 0.0]), 1.0


def plane_disc_snap(pos, heading):
    """Project onto z = 0; a footprint inside the disc obstacle is not ok."""
    out = pos.copy()
    out[:, 2] = 0.0
    return out, np.linalg.norm(out[:, :2] - CENTRE, axis=1) >= RADIUS


def check_plane_and_disc(p, r, iterations, fixed):
    outside = np.linalg.norm(r.position[:, :2] - CENTRE, axis=1) >= RADIUS
    assert outside.all(), "a footprint entered the obstacle"
    never_moved = (r.rejected == iterations) | fixed
    assert np.all(r.position[~never_moved, 2] == 0.0), "a footprint left the surface"
    assert np.array_equal(r.position[never_moved], p[never_moved])
    assert np.all((0 <= r.rejected) & (r.rejected <= iterations))
    assert np.all(r.rejected[fixed] == 0)


def test_snap_keeps_footprints_out_of_an_obstacle():
    """Footprints hugging the disc: smoothing cuts the corner into the obstacle, the snap
    rejects those moves, and the counts say so."""
    a = np.linspace(-1.6, 1.6, 11)
    p = np.c_[1.04 * np.cos(a), 1.04 * np.sin(a), 0.02 * (-1.0) ** np.arange(11)]
    p[[0, -1], 2] = 0.0
    heading = a + np.pi / 2
    iterations = 4
    r = smooth_footprints(p, heading, iterations, snap=plane_disc_snap)
    assert isinstance(r, Smoothed) and r.iterations == iterations
    assert r.rejected.dtype.kind == "i" and r.rejected.shape == (11,)
    assert r.rejected.sum() > 0
    check_plane_and_disc(p, r, iterations, default_fixed(11))
    # without the snap the same smoothing would have entered the disc
    free = smooth_footprints(p, heading, iterations)
    assert (np.linalg.norm(free.position[:, :2], axis=1) < RADIUS).any()
    # a rejected footprint kept its heading of before the pass: all headings are finite,
    # within pi of the input, and equal to the input where it never moved
    stuck = r.rejected == iterations
    assert np.array_equal(r.heading[stuck], heading[stuck])


@settings(max_examples=20, **HYP)
@given(data=st.data(), iterations=st.integers(0, 5))
def test_snap_properties_random_paths(data, iterations):
    n = data.draw(st.integers(3, 12))
    ang = np.array(data.draw(st.lists(st.floats(-math.pi, math.pi), min_size=n, max_size=n)))
    rad = np.array(data.draw(st.lists(st.floats(RADIUS + 1e-6, 4.0), min_size=n, max_size=n)))
    z = np.array(data.draw(st.lists(st.floats(-0.3, 0.3), min_size=n, max_size=n)))
    p = np.c_[rad * np.cos(ang), rad * np.sin(ang), z]
    p = p[np.argsort(ang)]  # roughly around the disc
    fixed = data.draw(masks(n))
    mask = default_fixed(n) if fixed is None else fixed
    heading = wrap(np.sort(ang) + np.pi / 2)
    r = smooth_footprints(p, heading, iterations, snap=plane_disc_snap, fixed=fixed)
    check_plane_and_disc(p, r, iterations, mask)
    assert np.all(np.isfinite(r.position)) and np.all(np.isfinite(r.heading))
    # the documented semantics, replayed with the one-pass functions
    pos, head, rej = p.copy(), heading.copy(), np.zeros(n, dtype=int)
    for _ in range(iterations):
        new_pos, new_head = smooth_positions(pos, mask), smooth_headings(head, mask)
        snapped, ok = plane_disc_snap(new_pos, new_head)
        stay = ~ok & ~mask
        rej += stay
        new_pos = np.where((ok & ~mask)[:, None], snapped, pos)
        new_head = np.where(stay, head, new_head)
        pos, head = new_pos, new_head
    assert np.array_equal(r.position, pos) and np.array_equal(r.heading, head)
    assert np.array_equal(r.rejected, rej)


def test_snap_output_validated():
    p = np.c_[np.arange(5.0), np.zeros(5), np.zeros(5)]
    with pytest.raises(ValueError, match="snap must return"):
        smooth_footprints(p, np.zeros(5), 1, snap=lambda pos, h: (pos[:, :2], np.ones(5, bool)))
    # a non-finite snapped position counts as not ok
    bad = lambda pos, h: (np.full_like(pos, np.nan), np.ones(len(pos), bool))  # noqa: E731
    p[2, 1] = 0.5
    r = smooth_footprints(p, np.zeros(5), 2, snap=bad)
    assert np.array_equal(r.position, p) and np.array_equal(r.rejected, [0, 2, 2, 2, 0])


# ----------------------------------------------------------------------------- headings

@settings(max_examples=25, **HYP)
@given(data=st.data(), theta=angle_sequences(min_size=1, max_size=12, step=3.0))
def test_headings_wrap_around(data, theta):
    """Headings given wrapped to (-pi, pi] are smoothed as their unwrapped sequence, and
    each result stays within pi of its input (no 2 pi jump)."""
    fixed = data.draw(masks(len(theta)))
    h = wrap(theta)
    out = smooth_headings(h, fixed)
    assert out.shape == h.shape and np.all(np.isfinite(out))
    assert np.all(np.abs(out - h) <= math.pi + 1e-12)
    assert np.allclose(wrap(out - binomial_ref(theta, fixed)), 0.0, rtol=0, atol=1e-9)


def test_headings_near_pi_do_not_jump():
    h = np.array([3.10, -3.12, 3.08, -3.10, 3.13, -3.09, 3.11])
    out = smooth_headings(h)
    assert np.all(np.abs(out - h) < 0.1), out
    unwrapped = np.unwrap(h)
    assert np.allclose(wrap(out - binomial_ref(unwrapped)), 0.0, atol=1e-12)
    r = smooth_footprints(np.c_[np.arange(7.0), np.zeros(7), np.zeros(7)], h, 4)
    assert np.all(np.abs(r.heading - h) < 0.1)


def test_yaw_helpers_round_trip():
    h = np.array([-math.pi + 1e-3, -1.0, 0.0, 0.5, 2.0, math.pi - 1e-3])
    assert np.allclose(heading_of(yaw_rotation(h)), h, atol=1e-12)
    q = yaw_rotation(np.array([0.7]))
    # counter-clockwise seen from above: +X turns towards +Y
    assert q.apply([1.0, 0.0, 0.0])[0, 1] > 0
    # the yaw of a tilted rotation is its twist about +Z
    tilted = yaw_rotation(np.array([1.2])) * Rotation.from_rotvec([[0.2, 0.0, 0.0]])
    assert heading_of(tilted)[0] == pytest.approx(1.2, abs=0.05)


# ----------------------------------------------------------------------------- hygiene

@settings(max_examples=20, **HYP)
@given(data=st.data(), p=point_paths(min_size=0), iterations=st.integers(0, 4))
def test_inputs_untouched_and_outputs_finite(data, p, iterations):
    n = len(p)
    p = p.reshape(n, 3)
    heading = np.array(data.draw(st.lists(st.floats(-10.0, 10.0), min_size=n, max_size=n)))
    fixed = data.draw(masks(n))
    q = Rotation.from_rotvec(np.array(data.draw(st.lists(
        st.lists(st.floats(-3.0, 3.0), min_size=3, max_size=3), min_size=n,
        max_size=n))).reshape(n, 3))
    copies = (p.copy(), heading.copy(), None if fixed is None else fixed.copy(), q.as_quat())
    calls = 0

    def snap(pos, h):
        nonlocal calls
        calls += 1
        pos[:, 0] += 1.0  # scribbling on its arguments must not reach the caller
        return pos, np.ones(len(pos), bool)

    outs = [smooth_positions(p, fixed), smooth_headings(heading, fixed),
            smooth_footprints(p, heading, iterations, snap=snap, fixed=fixed)]
    outs.append(smooth_rotations(q, fixed))
    assert np.array_equal(p, copies[0]) and np.array_equal(heading, copies[1])
    assert fixed is None or np.array_equal(fixed, copies[2])
    assert np.array_equal(q.as_quat(), copies[3])
    for a in (outs[0], outs[1], outs[2].position, outs[2].heading, outs[3].as_quat()):
        assert np.all(np.isfinite(a))
    assert outs[0] is not p and outs[1] is not heading and outs[2].position is not p
    if iterations == 0 or n < 3:
        assert calls == 0
        assert np.array_equal(outs[2].position, p) and np.array_equal(outs[2].heading, heading)
        assert np.all(outs[2].rejected == 0)
    else:
        assert calls == iterations


def test_short_sequences_unchanged():
    for n in (0, 1, 2):
        p = np.arange(3.0 * n).reshape(n, 3)
        none = np.zeros(n, dtype=bool)
        assert np.array_equal(smooth_positions(p, none), p)
        assert np.array_equal(smooth_headings(np.arange(float(n)), none), np.arange(float(n)))
        r = smooth_footprints(p, np.zeros(n), 3, snap=plane_disc_snap, fixed=none)
        assert np.array_equal(r.position, p) and r.rejected.shape == (n,)
    q = Rotation.from_rotvec([[0.1, 0.2, 0.3], [0.3, 0.2, 0.1]])
    assert np.all(rot_dist(smooth_rotations(q, np.zeros(2, dtype=bool)), q) < 1e-15)


@pytest.mark.parametrize("call", [
    lambda: smooth_positions(np.zeros(5)),
    lambda: smooth_positions(np.zeros((5, 0))),
    lambda: smooth_positions(np.zeros((5, 3)), fixed=np.zeros(4, dtype=bool)),
    lambda: smooth_positions(np.zeros((5, 3)), fixed=np.array([0, 4])),
    lambda: smooth_positions(np.full((5, 3), np.nan)),
    lambda: smooth_rotations(Rotation.from_rotvec([0.0, 0.0, 1.0])),
    lambda: smooth_rotations(np.zeros((5, 4))),
    lambda: smooth_headings(np.zeros((5, 1))),
    lambda: smooth_footprints(np.zeros((5, 2)), np.zeros(5)),
    lambda: smooth_footprints(np.zeros((5, 3)), np.zeros(4)),
    lambda: smooth_footprints(np.zeros((5, 3)), np.zeros(5), iterations=-1),
    lambda: smooth_footprints(np.zeros((5, 3)), np.zeros(5), iterations=1.5),
    lambda: smooth_footprints(np.zeros((5, 3)), np.full(5, np.inf)),
], ids=["1d", "zero-dim", "mask-length", "mask-indices", "nan", "single-rotation",
        "not-rotation", "heading-2d", "position-2d", "heading-length", "negative-iterations",
        "float-iterations", "inf-heading"])
def test_shape_validation(call):
    with pytest.raises(ValueError):
        call()
