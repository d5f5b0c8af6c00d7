"""The rotation helpers of the Blender layer (scipy's Rotation underneath), checked against
Blender's own mathutils: matrices and quaternions of Rigify keying, the minimal swing, and
the rotations of BVH channels as the importer keys them."""

from importlib import import_module

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

QUATS = st.lists(st.tuples(*[st.floats(-1, 1, allow_nan=False)] * 4).filter(lambda q: np.linalg.norm(q) > 0.1),
                 min_size=1, max_size=12)
VECTORS = st.tuples(*[st.floats(-1, 1, allow_nan=False)] * 3).filter(lambda v: np.linalg.norm(v) > 0.1)
ANGLES = st.lists(st.tuples(*[st.floats(-720, 720, allow_nan=False)] * 3), min_size=1, max_size=8)


@pytest.fixture(scope="module")
def rigify(fp):
    return import_module(fp.__name__ + ".blender.rigify.solver")


@pytest.fixture(scope="module")
def clips(fp):
    return import_module(fp.__name__ + ".blender.read.bvh_import")


def _unit(q):
    q = np.asarray(q, float)
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def _blender_matrix(q_wxyz):
    from mathutils import Quaternion

    return np.array(Quaternion(q_wxyz).to_matrix())


@settings(max_examples=60, deadline=None)
@given(QUATS)
def test_quaternions_to_matrices_as_blender_makes_them(rigify, quats):
    q = _unit(quats)
    got = rigify._quat_to_mat(q)
    assert got.shape == (len(q), 3, 3)
    for qi, m in zip(q, got):
        assert np.allclose(m, _blender_matrix(qi), atol=2e-5)  # (mathutils is single precision)
    # any leading shape
    assert np.allclose(rigify._quat_to_mat(np.stack([q, -q])), np.stack([got, got]), atol=1e-12)


@settings(max_examples=60, deadline=None)
@given(QUATS)
def test_matrices_to_quaternions_signs_continuous(rigify, quats):
    q = _unit(quats)
    mats = np.array([_blender_matrix(qi) for qi in q])
    got = rigify._mat_to_quat(mats)
    assert np.allclose(np.linalg.norm(got, axis=1), 1.0)
    for qi, m in zip(got, mats):
        assert np.allclose(_blender_matrix(qi), m, atol=2e-5)  # the same rotation (mathutils: single precision)
    assert got[0, 0] >= 0  # the first on w >= 0, and no flips between samples
    assert np.all(np.einsum("ij,ij->i", got[1:], got[:-1]) >= 0)


@settings(max_examples=60, deadline=None)
@given(VECTORS, VECTORS)
@example((0.0, 0.0, 1.0), (0.0, 1e-5, -1.0))  # (nearly opposite: was turned about y, 1e-5 off)
def test_the_swing_is_the_shortest_turn_from_a_to_b(rigify, a, b):
    a, b = _unit(a), _unit(b)
    r = rigify._swing(a[None], b[None])[0]
    assert np.allclose(r @ r.T, np.eye(3), atol=1e-9) and np.isclose(np.linalg.det(r), 1.0)
    assert np.allclose(r @ a, b, atol=1e-7)
    turned = np.arccos(np.clip((np.trace(r) - 1) / 2, -1, 1))
    assert np.isclose(turned, np.arccos(np.clip(a @ b, -1, 1)), atol=1e-6)


def test_the_swing_of_opposite_vectors_is_a_half_turn(rigify):
    a = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])
    r = rigify._swing(a, -a)
    assert np.allclose(np.einsum("nij,nj->ni", r, a), -a, atol=1e-12)


@settings(max_examples=60, deadline=None)
@given(st.permutations("XYZ"), ANGLES, QUATS)
def test_bvh_channels_rotate_as_blender_composes_them(clips, axes, degrees, rest):
    """R = R0 R1 R2 in the file's channel order, seen in the bone's rest axes, w >= 0."""
    from mathutils import Matrix

    to_bone = _blender_matrix(_unit(rest[0]))
    deg = np.array(degrees, float)
    got = clips.bvh_quats(list(axes), deg, to_bone)
    assert got.shape == (len(deg), 4) and np.all(got[:, 0] >= 0)
    for q, row in zip(got, deg):
        r = np.eye(3)
        for axis, angle in zip(axes, row):
            r = r @ np.array(Matrix.Rotation(np.radians(angle), 3, axis))
        assert np.allclose(_blender_matrix(q), to_bone @ r @ to_bone.T, atol=2e-5)  # (mathutils is single precision)


def test_bvh_channels_pinned_figures(clips):
    """A quarter turn about Z, then about the bone's axes: the figures the importer keyed
    before scipy did the work."""
    c = np.cos(np.pi / 4)
    q = clips.bvh_quats(["Z", "X", "Y"], np.array([[90.0, 0.0, 0.0], [0.0, -90.0, 0.0], [90.0, 90.0, 0.0]]),
                        np.eye(3))
    assert np.allclose(q, [[c, 0, 0, c], [c, -c, 0, 0], [0.5, 0.5, 0.5, 0.5]], atol=1e-12)
    # a file whose Y is the bone's Z: its Y channel turns the bone about Z
    swap = np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]])
    q = clips.bvh_quats(["Y"], np.array([[90.0]]), swap)
    assert np.allclose(q, [[c, 0, 0, c]], atol=1e-12)
