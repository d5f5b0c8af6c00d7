"""``quat.multiply``: scipy's composition of rotations, in numpy (issue 28: the pose blend
closes every cyclic clip's seam with one product per bone and frame)."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from footstep_planner.core.base.quat import multiply

quats = st.lists(st.floats(-1, 1), min_size=4, max_size=4).filter(lambda v: np.linalg.norm(v) > 0.1)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(quats, quats), min_size=1, max_size=20))
def test_multiply_is_scipys_composition(pairs):
    a = np.array([p for p, _ in pairs])
    b = np.array([q for _, q in pairs])
    a /= np.linalg.norm(a, axis=1, keepdims=True)
    b /= np.linalg.norm(b, axis=1, keepdims=True)
    got = multiply(a, b)
    want = (Rotation.from_quat(a) * Rotation.from_quat(b)).as_quat()
    np.testing.assert_allclose(got, want, atol=1e-12)  # (the same sign, not only the same rotation)
    np.testing.assert_allclose(np.linalg.norm(got, axis=1), 1.0, atol=1e-12)
    # broadcast: one rotation applied after many
    np.testing.assert_allclose(multiply(a[:1], b), (Rotation.from_quat(a[0]) * Rotation.from_quat(b)).as_quat(),
                               atol=1e-12)
