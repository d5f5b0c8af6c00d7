"""Properties of footstep_planner.core.ik (thesis 3.8) on a small hand-built rig: the
least rotation, the swing targets, and the closed-form legs (targets met, knees bending
forward only, hips lowered for far targets)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from footstep_planner.core.ik import MAX_REACH, body_frames, min_rotation, solve_ik, swing_targets
from footstep_planner.core.rig import Rig, forward_kinematics

HYP = dict(deadline=None, database=None, max_examples=40)


def biped() -> Rig:
    """Hips at 0.9 m, legs of 0.42 + 0.42 m, feet pointing -Y (rest forward -Y); bones
    point down the legs (Blender's Y axis along the bone)."""
    names = ["Hips", "LeftUpLeg", "LeftLeg", "LeftFoot", "LeftToeBase",
             "RightUpLeg", "RightLeg", "RightFoot", "RightToeBase", "Spine"]
    parents = [-1, 0, 1, 2, 3, 0, 5, 6, 7, 0]
    heads = {"Hips": (0, 0, 0.9), "LeftUpLeg": (0.1, 0, 0.88), "LeftLeg": (0.1, 0, 0.46),
             "LeftFoot": (0.1, 0, 0.04), "LeftToeBase": (0.1, -0.14, 0.0),
             "RightUpLeg": (-0.1, 0, 0.88), "RightLeg": (-0.1, 0, 0.46), "RightFoot": (-0.1, 0, 0.04),
             "RightToeBase": (-0.1, -0.14, 0.0), "Spine": (0, 0, 1.0)}
    tails = {"Hips": (0, 0, 1.0), "LeftUpLeg": (0.1, 0, 0.46), "LeftLeg": (0.1, 0, 0.04),
             "LeftFoot": (0.1, -0.14, 0.0), "LeftToeBase": (0.1, -0.2, 0.0),
             "RightUpLeg": (-0.1, 0, 0.46), "RightLeg": (-0.1, 0, 0.04), "RightFoot": (-0.1, -0.14, 0.0),
             "RightToeBase": (-0.1, -0.2, 0.0), "Spine": (0, 0, 1.3)}
    rest = []
    for n in names:
        h, t = np.array(heads[n], float), np.array(tails[n], float)
        y = (t - h) / np.linalg.norm(t - h)
        x = np.cross(y, [0, -1.0, 0]) if abs(y[1]) < 0.9 else np.array([1.0, 0, 0])
        x /= np.linalg.norm(x)
        z = np.cross(x, y)
        m = np.eye(4)
        m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = x, y, z, h
        rest.append(m)
    return Rig.build("biped", names, parents, np.array(rest), np.array([tails[n] for n in names]))


RIG = biped()
HEEL = np.array([[0.0, 0.0, 0.0, 1.0]] * 2)
TOE = np.array([[0.0, 0.0, 0.0, 1.0]] * 2)
for k, side in enumerate("lr"):
    foot, _ = RIG.foot_chain(side)
    inv = np.linalg.inv(RIG.rest[foot])
    x = 0.1 if side == "l" else -0.1
    HEEL[k] = inv @ np.array([x, 0.03, 0.0, 1.0])
    TOE[k] = inv @ np.array([x, -0.14, 0.0, 1.0])


unit = st.tuples(st.floats(-1, 1), st.floats(-1, 1), st.floats(-1, 1)).filter(
    lambda v: np.linalg.norm(v) > 0.1)


@settings(**HYP)
@given(a=unit, b=unit)
def test_min_rotation_takes_a_onto_b_by_the_least_angle(a, b):
    a, b = np.array([a], float), np.array([b], float)
    r = min_rotation(a, b)[0]
    np.testing.assert_allclose(r @ r.T, np.eye(3), atol=1e-9)
    assert np.linalg.det(r) == pytest.approx(1.0)
    ua, ub = a[0] / np.linalg.norm(a), b[0] / np.linalg.norm(b)
    np.testing.assert_allclose(r @ ua, ub, atol=1e-9)
    if abs(ua @ ub) < 1 - 1e-6:  # the axis is perpendicular to both: nothing else turns
        axis = np.cross(ua, ub) / np.linalg.norm(np.cross(ua, ub))
        np.testing.assert_allclose(r @ axis, axis, atol=1e-9)


def test_swing_targets_hold_the_footprint_and_ease_between():
    F = 40
    planted = np.zeros(F, bool)
    planted[5:12] = planted[25:32] = True
    A0 = np.c_[np.linspace(0, 4, F), np.zeros(F), np.zeros(F)]
    R0 = np.tile(np.eye(3), (F, 1, 1))
    ankle = np.zeros((F, 3))
    ankle[5:12] = [0.6, 0.1, 0.0]
    ankle[25:32] = [2.9, -0.1, 0.0]
    A, R = swing_targets(planted, A0, R0, ankle, R0)
    np.testing.assert_allclose(A[planted], ankle[planted])
    off = A - A0
    np.testing.assert_allclose(off[12:25, 1], np.clip(off[12:25, 1], -0.1, 0.1))  # no overshoot
    assert np.all(np.abs(np.diff(off[11:26, 1])) < 0.05)  # eased, not snapped
    np.testing.assert_allclose(off[:5], np.broadcast_to(off[5], (5, 3)))  # held before the first


def _stand(F=20, spread=0.0):
    basis = np.tile(np.eye(4), (F, len(RIG.names), 1, 1))
    body = np.zeros((F, 3))
    body[:, 1] = -np.linspace(0, spread, F)
    return basis, body


def _feet_world(basis, body, heading, spin=0.0):
    w = body_frames(body, spin + heading)[:, None] @ forward_kinematics(RIG, basis)
    return w


def _run(targets_l, targets_r, planted_frames, body, basis, **kw):
    """Plant footprint 0 (left) and 1 (right) at the given positions over the frames."""
    F = len(body)
    t = np.arange(F) / 30.0
    pos = np.array([targets_l, targets_r], float)
    head = np.zeros(2)
    normal = np.tile([0.0, 0.0, 1.0], (2, 1))
    a, b = planted_frames
    planted = [(t[a], t[(a + b) // 2], t[b]), (t[a], t[(a + b) // 2], t[b])]
    return solve_ik(RIG, basis, t, body, np.zeros(F), 0.0, HEEL, TOE, np.array([0, 1]), planted, pos, head,
                    normal, np.array([0.0, -1.0]), **kw)


@settings(deadline=None, database=None, max_examples=25)
@given(dx=st.floats(-0.15, 0.15), dy=st.floats(-0.25, 0.25), dz=st.floats(-0.05, 0.15))
def test_planted_feet_reach_their_footprints_and_knees_bend_forward(dx, dy, dz):
    basis, body = _stand()
    res = _run((0.1 + dx, -0.055 + dy, dz), (-0.1 + dx, -0.055 - dy, 0.0), (2, 17), body, basis)
    w = _feet_world(res.basis, res.body_pos, res.body_heading)
    for k, side in enumerate("lr"):
        foot = RIG.foot_chain(side)[0]
        got = (w[:, foot] @ HEEL[k])[2:18, :3]
        target = res.targets.pin[k, 2:18]
        np.testing.assert_allclose(got, target, atol=1e-6)
        hip = w[:, RIG.role_index(f"thigh_{side}"), :3, 3]
        knee = w[:, RIG.role_index(f"shin_{side}"), :3, 3]
        ankle = w[:, foot, :3, 3]
        # the knee is ahead of the hip-ankle line (forward is -Y): it bends one way only
        u = (ankle - hip) / np.linalg.norm(ankle - hip, axis=1, keepdims=True)
        side_ = (knee - hip) - np.einsum("fi,fi->f", knee - hip, u)[:, None] * u
        fwd = np.array([0.0, -1.0, 0.0]) - u[:, 1:2] * -1.0 * u  # forward, off the line
        assert np.all(np.einsum("fi,fi->f", side_, fwd)[2:18] >= -1e-9)
        # never past straight, never longer than the leg
        assert np.all(np.linalg.norm(ankle - hip, axis=1) <= 0.84 * MAX_REACH + 1e-6)


def test_a_target_out_of_reach_lowers_the_hips_instead_of_popping_the_knee():
    basis, body = _stand()
    res = _run((0.1, -0.55, 0.0), (-0.1, 0.0, 0.0), (2, 17), body, basis)  # a long stride
    assert res.hips_drop.max() > 0.01
    w = _feet_world(res.basis, res.body_pos, res.body_heading)
    foot = RIG.foot_chain("l")[0]
    np.testing.assert_allclose((w[:, foot] @ HEEL[0])[2:18, :3], res.targets.pin[0, 2:18], atol=1e-5)
    assert np.all(np.diff(res.hips_drop) ** 2 < 0.01 ** 2)  # smooth, no sudden drop


def test_a_foot_in_the_air_clears_the_ground():
    basis, body = _stand()
    body[:, 2] = -0.08  # the body sunk: the free feet would go through the floor
    res = _run((0.1, -0.1, 0.0), (-0.1, 0.1, 0.0), (0, 3), body, basis,
               ground_z=lambda p: np.zeros(len(p)))
    w = _feet_world(res.basis, res.body_pos, res.body_heading)
    for k, side in enumerate("lr"):
        foot = RIG.foot_chain(side)[0]
        for loc in (HEEL[k], TOE[k]):
            z = (w[:, foot] @ loc)[6:, 2]
            assert z.min() > -1e-6
