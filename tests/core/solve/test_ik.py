"""Properties of footstep_planner.core.solve.ik (thesis 3.8) on a small hand-built rig: the
least rotation, the swing targets, and the closed-form legs (targets met, knees bending
forward only, hips lowered for far targets, at most HIPS_DROP_MAX on level ground where
rolling the foot reaches instead), and a swinging foot over uneven ground."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from hypothesis import given, settings
from hypothesis import strategies as st

from footstep_planner.core.solve.easing import ease_peaks
from footstep_planner.core.solve.ik import solve_ik
from footstep_planner.core.solve.legs import MAX_REACH, body_frames, min_rotation
from footstep_planner.core.solve.reach import HIPS_DROP_MAX, MAX_ROLL, roll_to_reach
from footstep_planner.core.solve.swing import swing_targets
from footstep_planner.core.solve.targets import BodyMotion, FootPoints, Footprints
from footstep_planner.core.solve.toes import toe_tip
from footstep_planner.core.clips.rig import Rig, forward_kinematics

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


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**31), step=st.booleans())
def test_swing_targets_of_both_feet_at_once_are_each_foot_alone(seed, step):
    """Stacked (K, F), each foot's targets are those of the foot alone: its swings read its
    own footprints only, whatever the other's, and a foot never planted keeps its clip's."""
    rng = np.random.default_rng(seed)
    F = 60
    planted = rng.random((3, F)) < 0.4
    planted[2] = False
    A0 = np.cumsum(rng.normal(0.0, 0.05, (3, F, 3)), axis=1)
    R0 = Rotation.from_rotvec(rng.normal(0.0, 0.3, (3 * F, 3))).as_matrix().reshape(3, F, 3, 3)
    ankle = A0 + rng.normal(0.0, 0.05, (3, F, 3)) + (np.arange(3)[:, None, None] * [0.0, 0.0, 0.3] if step else 0.0)
    rot = Rotation.from_rotvec(rng.normal(0.0, 0.3, (3 * F, 3))).as_matrix().reshape(3, F, 3, 3) @ R0
    ground = (lambda p: np.where(p[:, 0] > 0.1, 0.2, 0.0)) if step else None
    A, R = swing_targets(planted, A0, R0, ankle, rot, ground)
    for k in range(3):
        a, r = swing_targets(planted[k], A0[k], R0[k], ankle[k], rot[k], ground)
        np.testing.assert_allclose(A[k], a, rtol=0, atol=1e-12)
        np.testing.assert_allclose(R[k], r, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(A[2], A0[2])


def _step_swing(rise: float, ground):
    """A foot's swing from (0, 0, 0.1) to (0.56, 0, 0.1 + rise) over 20 frames, the clip
    sweeping it along at its own pace; ``ground(points) -> heights``."""
    F = 40
    planted = np.zeros(F, bool)
    planted[:10] = planted[30:] = True
    A0 = np.c_[np.linspace(-0.28, 0.84, F), np.zeros(F), np.full(F, 0.1)]
    R0 = np.tile(np.eye(3), (F, 1, 1))
    ankle = np.zeros((F, 3))
    ankle[:10] = [0.0, 0.0, 0.1]
    ankle[30:] = [0.56, 0.0, 0.1 + rise]
    plain, _ = swing_targets(planted, A0, R0, ankle, R0)
    A, _ = swing_targets(planted, A0, R0, ankle, R0, ground)
    return plain, A, slice(10, 30)


@pytest.mark.parametrize("rise", [0.34, -0.34])
def test_a_swing_up_or_down_a_stair_rises_first_or_goes_over_first(rise):
    """Two 17 cm risers between a foot's footprints (treads 0.28 m deep): up, the foot
    rises ahead of the plain swing and goes forward behind it; down, the other way
    round; never past either footprint. A slope as steep is left as it is."""
    def stairs(p):
        p = np.asarray(p, float)
        return np.floor(np.clip(p[:, 0] + 0.14, 0.0, 0.84) / 0.28) * (0.17 if rise > 0 else -0.17)

    plain, A, sw = _step_swing(rise, stairs)
    dz = (A[sw, 2] - plain[sw, 2]) * np.sign(rise)
    dx = A[sw, 0] - plain[sw, 0]
    if rise > 0:
        assert dz.min() > -1e-9 and dz.max() > 0.02 and dx.max() < 1e-9 and dx.min() < -0.02
    else:
        assert dz.max() < 1e-9 and dz.min() < -0.02 and dx.min() > -1e-9 and dx.max() > 0.02
    assert A[sw, 0].min() >= -1e-9 and A[sw, 0].max() <= 0.56 + 1e-9
    np.testing.assert_allclose(A[:10], plain[:10])
    np.testing.assert_allclose(A[30:], plain[30:])
    slope, A2, _ = _step_swing(rise, lambda p: np.asarray(p, float)[:, 0] * rise / 0.56)
    np.testing.assert_allclose(A2, slope)


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
    return solve_ik(RIG, basis, BodyMotion(t, body, np.zeros(F), 0.0), FootPoints(HEEL, TOE),
                    Footprints(np.array([0, 1]), planted, pos, head, normal), np.array([0.0, -1.0]), **kw)


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


@settings(**HYP)
@given(back=st.floats(0.2, 0.45), short=st.floats(0.0, 0.04), toe_pinned=st.booleans())
def test_rolling_a_planted_foot_keeps_its_pin_and_brings_the_ankle_within_reach(back, short, toe_pinned):
    """A planted foot the hip cannot reach rolls about its pinned ball (heel rising) or
    heel (toe rising): the pin stays, the ankle comes within reach (or the roll stops at
    MAX_ROLL, never further from the hip), and the free end rises, never sinks."""
    heel_l, toe_l = np.array([0.0, -0.04, -0.04]), np.array([0.0, 0.14, -0.04])  # foot frame: +Y forward
    sign = -1.0 if toe_pinned else 1.0  # the foot behind the hip (toe pinned) or ahead (heel)
    ankle = np.array([[0.0, sign * back, 0.04]])
    hip = np.array([[0.0, 0.0, 0.04 + np.sqrt(max(0.83 ** 2 - back ** 2, 0.01)) - short]])
    rot = np.array([np.eye(3)])  # the foot's frame is the world's
    pin_l = toe_l if toe_pinned else heel_l
    pin = ankle + rot[0] @ pin_l
    reach = 0.83 - 0.01
    a2, r2 = roll_to_reach(hip, ankle, rot, pin, np.array([toe_pinned]), np.array([True]), toe_l - heel_l, reach)
    np.testing.assert_allclose(a2[0] + r2[0] @ pin_l, pin[0], atol=1e-9)  # the pin stays put
    d0, d1 = np.linalg.norm(ankle - hip), np.linalg.norm(a2 - hip)
    assert d1 <= d0 + 1e-12
    angle = np.arccos(np.clip((np.trace(r2[0] @ rot[0].T) - 1) / 2, -1, 1))
    assert angle <= MAX_ROLL + 1e-9
    if d0 > reach:
        assert d1 == pytest.approx(reach, abs=1e-9) or angle == pytest.approx(MAX_ROLL)
    free = heel_l if toe_pinned else toe_l
    assert (a2[0] + r2[0] @ free)[2] >= (ankle[0] + rot[0] @ free)[2] - 1e-12  # the free end rises


def test_on_level_ground_the_hips_come_down_at_most_the_cap_for_a_reachable_stride():
    """A stride the legs reach once the hips come down 2 cm: lowered by that, no roll."""
    basis, body = _stand()
    res = _run((0.1, -0.18, 0.0), (-0.1, 0.0, 0.0), (2, 17), body, basis)
    assert 0.005 < res.hips_drop.max() <= HIPS_DROP_MAX + 1e-9


def test_toe_tip_lies_ahead_of_the_ball_on_the_sole_and_bends_with_the_toe():
    pose = forward_kinematics(RIG, np.tile(np.eye(4), (2, len(RIG.names), 1, 1)))
    foot, toe = RIG.foot_chain("l")
    bent = pose.copy()
    up = np.eye(4)
    up[:3, :3] = Rotation.from_rotvec([0.5, 0.0, 0.0]).as_matrix()  # the toe bent about the foot's X axis
    bent[1, toe] = pose[1, toe] @ up
    tip = toe_tip(RIG, "l", pose[:, foot], bent[:, toe], HEEL[0, :3], TOE[0, :3])
    world = (pose[0, foot] @ np.append(tip[0], 1.0))[:3]
    np.testing.assert_allclose(world, [0.1, -0.2, 0.0], atol=1e-9)  # the toe's tail, on the sole
    assert np.linalg.norm(tip[1] - TOE[0, :3]) == pytest.approx(0.06)  # the toe's length from the ball
    assert not np.allclose(tip[1], tip[0])


def test_a_swinging_foot_rises_over_a_bump_between_its_footprints():
    """Level footprints with a 6 cm bump under the feet once they are free: the heel,
    the ball and the toe tip pass over it."""
    basis, body = _stand(30)
    bump = lambda p: np.where(np.abs(p[:, 1]) < 0.5, 0.06, 0.0)  # noqa: E731
    res = _run((0.1, -0.1, 0.0), (-0.1, 0.1, 0.0), (0, 3), body, basis, ground_z=bump)
    w = _feet_world(res.basis, res.body_pos, res.body_heading)
    pose = forward_kinematics(RIG, res.basis)
    for k, side in enumerate("lr"):
        foot, toe = RIG.foot_chain(side)
        tip = toe_tip(RIG, side, pose[:, foot], pose[:, toe], HEEL[k, :3], TOE[k, :3])
        for loc in (np.tile(HEEL[k], (30, 1)), np.tile(TOE[k], (30, 1)), np.c_[tip, np.ones(len(tip))]):
            p = (w[:, foot] @ loc[..., None])[:, :3, 0]
            assert (p[5:, 2] - bump(p[5:])).min() > -1e-6


@settings(**HYP)
@given(v=st.lists(st.floats(0.0, 1.0), min_size=1, max_size=40), rate=st.floats(0.01, 0.5))
def test_ease_peaks_covers_the_values_and_changes_no_faster_than_its_rate(v, rate):
    v = np.array(v)
    out = ease_peaks(v, rate)
    assert np.all(out >= v - 1e-12)
    assert np.all(np.abs(np.diff(out)) <= rate + 1e-9)


def test_the_body_height_is_eased_only_where_the_feet_stand_at_different_heights():
    """``_on_steps``: 0 where both feet's last footprints are level (a take-off keeps the
    fine fit of the body's height), 1 around stances a step apart (a stair), eased."""
    from footstep_planner.core.solve.ik import _on_steps
    from footstep_planner.core.solve.targets import FootTargets

    F = 120
    weight = np.zeros((2, F))
    weight[0, 0:20] = weight[1, 15:40] = weight[0, 35:60] = weight[1, 55:80] = weight[0, 75:100] = 1.0
    weight[1, 95:] = 1.0
    pin = np.zeros((2, F, 3))
    pin[1, 55:80, 2] = 0.17  # one footprint up a step; the others level
    tg = FootTargets(weight, np.zeros((2, F), int), pin, np.zeros((2, F, 3)), np.zeros((2, F, 3, 3)),
                     np.zeros((2, F, 3)))
    w = _on_steps(tg, 30.0)
    assert w[:30].max() < 1e-6 and w[116:].max() < 1e-3  # level stances: the fine fit
    assert w[60:92].min() > 0.99  # the right foot's last footprint up the step, the left's below
    assert np.abs(np.diff(w)).max() < 0.25  # eased in and out


def _leaving_a_tread(F=40, liftoff=10, strike=30):
    """A foot planted with its toe tip 3 cm short of a 17 cm riser (at x = 0.2), swinging
    on at once to a footprint up the step: ankle targets, rotations, planted frames,
    sole points (heel, ball, toe tip), swing planes and the ground."""
    from footstep_planner.core.solve.lift import _swing_planes

    planted = np.zeros(F, bool)
    planted[:liftoff] = planted[strike:] = True
    index = np.where(planted, (np.arange(F) >= strike).astype(int), -1)
    planes = _swing_planes(index, np.array([[0.0, 0.0, 0.0], [0.45, 0.0, 0.17]]), np.tile([0.0, 0.0, 1.0], (2, 1)))
    x = np.clip((np.arange(F) - liftoff + 1) / (strike - liftoff + 1), 0.0, 1.0)
    ankle = np.c_[0.45 * x, np.zeros(F), 0.08 + 0.17 * x + 0.05 * np.sin(np.pi * x)]
    rot = np.tile(np.eye(3), (F, 1, 1))
    sole = [(np.tile(loc, (F, 1)), np.zeros(F)) for loc in ([-0.08, 0, -0.08], [0.1, 0, -0.08], [0.17, 0, -0.08])]
    return ankle, rot, planted, sole, planes, (lambda p: np.where(np.asarray(p)[:, 0] >= 0.2, 0.17, 0.0))


def test_a_foot_leaving_a_tread_by_the_next_riser_rises_before_it_goes_on():
    """Swinging straight on, the toe would sweep into the riser the frame after the
    liftoff and the lift would jump 15 cm in a frame. Kept over its footprint, the foot
    rises at about the lift's rate first, then goes on; its targets stay between where
    they were and the footprint; on flat ground nothing changes."""
    from footstep_planner.core.solve.lift import LIFT_RATE, _ground_lift, _kept_over_footprints

    ankle, rot, planted, sole, planes, ground = _leaving_a_tread()
    before = _ground_lift(ankle, rot, planted, sole, planes, ground)
    a, r = _kept_over_footprints(ankle, rot, planted, sole, planes, ground)
    after = _ground_lift(a, r, planted, sole, planes, ground)
    assert np.diff(before).max() > 0.1  # the case is real
    assert np.diff(after).max() <= 2 * LIFT_RATE
    held = a[:, 0] - ankle[:, 0]
    assert held.max() <= 1e-12 and held[10:13].min() < -0.01  # held back over the footprint
    assert a[:, 0].min() >= -1e-12
    np.testing.assert_allclose(a[:, 2], ankle[:, 2])  # the height is the lift's
    flat = _kept_over_footprints(ankle, rot, planted, sole, planes, lambda p: np.zeros(len(p)))
    np.testing.assert_allclose(flat[0], ankle)
    np.testing.assert_allclose(flat[1], rot)


@settings(**HYP)
@given(pull=st.floats(0.01, 0.05), rate_deg=st.floats(2.0, 10.0))
def test_a_roll_for_reach_comes_and_goes_no_faster_than_its_rate(pull, rate_deg):
    """A hip drawing away from a planted foot by ``pull`` m a frame: rolled with a rate,
    the foot's turn changes by at most that rate a frame, its pinned ball stays put, and
    on every frame the ankle is no further from the hip than the unhurried roll leaves it
    (rolling early never loses reach)."""
    F = 30
    heel_l, toe_l = np.array([0.0, -0.04, -0.04]), np.array([0.0, 0.14, -0.04])
    ankle = np.tile([0.0, -0.3, 0.04], (F, 1))
    hip = np.c_[np.zeros(F), np.zeros(F), np.full(F, 0.78) + pull * np.clip(np.arange(F) - 10, 0, 8)]
    rot = np.tile(np.eye(3), (F, 1, 1))
    pin = ankle + toe_l
    args = (hip, ankle, rot, pin, np.ones(F, bool), np.ones(F, bool), toe_l - heel_l, 0.82)
    a0, r0 = roll_to_reach(*args)
    rate = np.radians(rate_deg)
    a1, r1 = roll_to_reach(*args, rate=rate)
    turn = Rotation.from_matrix(r1).magnitude()
    assert Rotation.from_matrix(r0).magnitude().max() > 0.05  # the hip does draw away
    assert np.abs(np.diff(turn)).max() <= rate + 1e-9
    np.testing.assert_allclose(a1 + np.einsum("fij,j->fi", r1, toe_l), pin, atol=1e-9)
    assert (np.linalg.norm(a1 - hip, axis=1) <= np.linalg.norm(a0 - hip, axis=1) + 1e-9).all()


@settings(**HYP)
@given(rise=st.floats(0.0, 0.2), dz=st.floats(-0.2, 0.2), still=st.floats(0.0, 1.0))
def test_a_pivot_step_barely_lifts_the_foot(rise, dz, still):
    """``_low_swing``: turning in place (``still`` 1), a swing's rise over the way between
    its footprints' heights is at most PIVOT_LIFT; walking (0) it is the clip's; in
    between, in between; the planted frames and the way across the ground never move."""
    from footstep_planner.core.solve.swing import PIVOT_LIFT, _low_swing

    F = 30
    planted = np.ones(F, bool)
    planted[10:20] = False
    x = np.clip((np.arange(F) - 9) / 11.0, 0.0, 1.0)
    ankle = np.c_[0.4 * x, np.zeros(F), 0.08 + dz * x + rise * np.sin(np.pi * x)]
    out = _low_swing(ankle, planted, np.full(F, still))
    np.testing.assert_allclose(out[:, :2], ankle[:, :2])
    np.testing.assert_allclose(out[planted], ankle[planted])
    over = out[:, 2] - (0.08 + dz * x)
    allowed = (1 - still) * rise + still * min(rise, PIVOT_LIFT)
    assert over.max() <= allowed + 1e-9
    assert over.max() >= min(rise, PIVOT_LIFT) * np.sin(np.pi * 5 / 11) - 1e-9
    np.testing.assert_allclose(_low_swing(ankle, planted, np.zeros(F)), ankle)


@settings(max_examples=40, deadline=None)
@given(st.floats(5.0, 45.0), st.floats(0.03, 0.09))
def test_a_foot_rolled_far_onto_its_ball_bends_its_toes_enough_to_keep_the_tip_out(pitch_deg, length):
    """A planted foot rolled onto its ball (a long step's toe-off held on its footprint:
    CMU's run-up before a jump pitched it past 45 degrees) gets the toe bend that keeps
    its tip within TIP_SINK of the floor, up to 45 degrees of roll; 30 degrees at most let
    the tip sink 19 mm there. The bend never goes past MAX_TOE_BEND."""
    from footstep_planner.core.solve.lift import TIP_SINK, _swing_planes
    from footstep_planner.core.solve.toes import MAX_TOE_BEND, toe_bend

    F = 60
    pitch = np.radians(pitch_deg) * np.clip(np.arange(F) / 30.0, 0.0, 1.0)  # (rolls up over a second, holds)
    rot = Rotation.from_rotvec(np.c_[np.zeros(F), pitch, np.zeros(F)]).as_matrix()  # (the toes turned down)
    ball = np.array([0.15, 0.0, -0.08])  # (in the foot's frame)
    ankle = -rot @ ball  # (the ball on the floor, at the origin)
    tip = (np.tile(ball + [length, 0.0, 0.0], (F, 1)), np.zeros(F))  # (its clip's tip on its floor)
    planes = _swing_planes(np.zeros(F, np.int64), np.zeros((1, 3)), np.array([[0.0, 0.0, 1.0]]))
    bend = toe_bend(ankle, rot, np.ones(F, bool), tip, ball, planes, fps=30.0)
    need = pitch - np.arcsin(TIP_SINK / length)
    assert np.all(bend >= need - 1e-9) and bend.max() <= MAX_TOE_BEND + 1e-12
