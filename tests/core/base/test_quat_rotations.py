"""``quat.rotations``: the rotations of matrices, as ``Rotation.from_matrix`` gives them,
with the SVD kept for the matrices that are not rotations as they stand (a scale, a
shear, rounding): a mix of both in one stack gives each its own."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from footstep_planner.core.base.quat import RIGID_TOL, rotations


def _same_rotations(a: Rotation, b: Rotation, tol: float) -> None:
    dot = np.abs(np.sum(a.as_quat() * b.as_quat(), axis=1))
    np.testing.assert_allclose(dot, 1.0, atol=tol)


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), n=st.integers(1, 40),
       scale=st.floats(0.01, 100.0), shear=st.floats(0.0, 0.3), noise=st.floats(0.0, 1e-3))
def test_the_same_rotations_as_scipys_from_matrix(seed, n, scale, shear, noise):
    rng = np.random.default_rng(seed)
    m = Rotation.random(n, random_state=seed).as_matrix()
    bent = rng.random(n) < 0.5  # (some scaled, sheared or rounded; the rest rotations as they are)
    k = np.flatnonzero(bent)
    m[k] = m[k] * scale
    m[k, 0, 1] += shear * scale  # (right-handed still: the determinant stays positive)
    m[k] += noise * scale * rng.standard_normal((len(k), 3, 3))
    got = rotations(m)
    assert len(got) == n
    _same_rotations(got, Rotation.from_matrix(m), 1e-9)


def test_a_rotation_as_it_stands_and_an_empty_stack():
    m = Rotation.random(100, random_state=3).as_matrix().astype(np.float32).astype(np.float64)  # (as read from Blender)
    assert np.abs(np.swapaxes(m, 1, 2) @ m - np.eye(3)).max() < RIGID_TOL
    _same_rotations(rotations(m), Rotation.from_matrix(m), 1e-12)
    assert len(rotations(np.zeros((0, 3, 3)))) == 0
