"""Properties of footstep_planner.core.synth.refinement (thesis 3.5)."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from footstep_planner.core.synth.refinement import local_targets, mismatch, refine
from footstep_planner.core.synth.smoothing import smooth_footprints

HYP = dict(deadline=None, database=None, max_examples=60)


def walk_path(n=14, step=0.65, width=0.18, curvature=0.0, seed=None):
    """Footprints of a walk (alternating feet, left first) along an arc of the given
    curvature; headings tangent (yaw about +Z)."""
    s = np.arange(n) * step
    if abs(curvature) < 1e-9:
        c = np.c_[s, np.zeros(n)]
        h = np.zeros(n)
    else:
        r = 1.0 / curvature
        h = s * curvature
        c = np.c_[r * np.sin(h), r * (1 - np.cos(h))]
    side = np.where(np.arange(n) % 2 == 0, 0.5, -0.5) * width
    p = c + side[:, None] * np.c_[-np.sin(h), np.cos(h)]
    pos = np.c_[p, np.zeros(n)]
    if seed is not None:
        rng = np.random.default_rng(seed)
        pos[:, :2] += rng.normal(0, 0.01, (n, 2))
    return pos, h


def similarity(pos, head, angle, scale, shift):
    c, s = np.cos(angle), np.sin(angle)
    out = pos.copy()
    out[:, 0] = scale * (c * pos[:, 0] - s * pos[:, 1]) + shift[0]
    out[:, 1] = scale * (s * pos[:, 0] + c * pos[:, 1]) + shift[1]
    out[:, 2] = pos[:, 2] + shift[2]
    return out, head + angle


@settings(**HYP)
@given(angle=st.floats(-np.pi, np.pi), scale=st.floats(0.5, 2.0), dx=st.floats(-50, 50),
       dy=st.floats(-50, 50), dz=st.floats(-2, 2), curvature=st.floats(-1.5, 1.5),
       seed=st.integers(0, 1000))
def test_a_path_that_matches_its_clips_is_left_unchanged(angle, scale, dx, dy, dz, curvature, seed):
    """Desired footprints that are the played ones under one similarity transform (the
    clips' own shape, moved, turned and scaled): refinement changes nothing."""
    op, oh = walk_path(curvature=curvature, seed=seed)
    dp, dh = similarity(op, oh, angle, scale, (dx, dy, dz))
    r = refine(op, oh, dp, dh, iterations=10)
    np.testing.assert_allclose(r.position, dp, atol=1e-7)
    np.testing.assert_allclose(r.heading, dh, atol=1e-9)
    assert r.mismatch.max() < 1e-7


@settings(**HYP)
@given(curvature=st.floats(-1.0, 1.0), bend=st.floats(-0.6, 0.6), noise=st.floats(0.0, 0.1),
       seed=st.integers(0, 1000))
def test_refinement_reduces_the_mismatch(curvature, bend, noise, seed):
    """Desired footprints that differ from the clips (a plan of another curvature, with
    noise, then smoothed as the pipeline does): the mismatch goes down and the ends stay
    put."""
    op, oh = walk_path(curvature=curvature)
    pp, ph = walk_path(curvature=curvature + bend)
    rng = np.random.default_rng(seed)
    pp[1:-1, :2] += rng.normal(0, noise, (len(pp) - 2, 2))
    sm = smooth_footprints(pp, ph, 4)
    dp, dh = sm.position, sm.heading
    r = refine(op, oh, dp, dh, iterations=10)
    assert r.mismatch[-1] < r.mismatch[0]
    np.testing.assert_array_equal(r.position[[0, -1]], dp[[0, -1]])
    assert np.isfinite(r.position).all() and np.isfinite(r.heading).all()


def test_refinement_restores_the_left_right_offsets_smoothing_removed():
    op, oh = walk_path(n=20)
    sm = smooth_footprints(op, oh, 4)
    assert np.abs(sm.position[4:16, 1]).max() < 0.005  # smoothing put them on the centre line
    r = refine(op, oh, sm.position, sm.heading, iterations=10)
    side = r.position[1:19, 1] * np.where(np.arange(1, 19) % 2 == 0, 1, -1)
    # each foot back on its side (the middle first: the ends pull a little)
    np.testing.assert_allclose(side, 0.09, atol=0.015)
    np.testing.assert_allclose(side[6:12], 0.09, atol=0.003)
    assert r.mismatch[-1] < 0.05 * r.mismatch[0]


def test_one_sweep_does_not_swap_the_feet():
    """A plain simultaneous update would put every foot a full width aside, then back:
    the damped sweep converges without that flip."""
    op, oh = walk_path(n=20)
    sm = smooth_footprints(op, oh, 4)
    r = refine(op, oh, sm.position, sm.heading, iterations=10)
    assert np.all(np.diff(r.mismatch) <= 1e-12)


def test_a_refused_place_keeps_the_footprint_and_is_counted():
    """A wall just left of the centre line: the left feet may not go back to their side,
    so they stay where the smoothing left them, and each refusal is counted; the right
    feet are free."""
    op, oh = walk_path(n=16)
    sm = smooth_footprints(op, oh, 4)

    def snap(p, h):
        return p, p[:, 1] <= 0.03

    r = refine(op, oh, sm.position, sm.heading, iterations=10, snap=snap)
    inner = np.arange(1, 15)
    left, right = inner[inner % 2 == 0], inner[inner % 2 == 1]
    assert (r.position[inner, 1] <= 0.03).all()
    assert (r.rejected[left] > 0).any() and (r.rejected[right] == 0).all()
    assert (r.position[right, 1] < -0.05).all()  # the right feet went to their side


def test_inputs_are_not_modified_and_targets_match_mismatch():
    op, oh = walk_path(seed=3)
    dp, dh = walk_path(curvature=0.2)
    copies = [a.copy() for a in (op, oh, dp, dh)]
    refine(op, oh, dp, dh)
    for a, b in zip((op, oh, dp, dh), copies):
        np.testing.assert_array_equal(a, b)
    tp, _ = local_targets(op, oh, dp, dh)
    assert mismatch(op, oh, dp, dh) == np.mean(np.linalg.norm(tp[:, :2] - dp[1:-1, :2], axis=1))
