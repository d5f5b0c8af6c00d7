"""Properties of footstep_planner.core.report.metrics (quality figures of a baked walk)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from footstep_planner.core.report.metrics import (contact_point, floating, foot_skate, footprint_error,
                                           goal_error, in_body_frame, pops, penetration,
                                           quality)

HYP = dict(deadline=None, database=None, max_examples=40)

HALF_FOOT = 0.1  # m, heel and toe either side of the footprint
N_STANCES = 6
SHIFT = 15  # frames between strikes
LENGTH = 20  # frames a stance lasts (end = start + LENGTH, inclusive)


def walk(angle=0.0, shift=(0.0, 0.0, 0.0), step=0.35, width=0.2):
    """A synthetic walk: stances alternate feet (left first), each foot perfectly still
    on its footprint from strike to liftoff, swinging (lifted) in between; the whole
    scene turned by ``angle`` about +Z and moved by ``shift``. Returns
    (heel (2, F, 3), toe (2, F, 3), ground_z (2, F, 2), stances)."""
    c, s = np.cos(angle), np.sin(angle)
    fwd = np.array([c, s, 0.0])
    side = np.array([-s, c, 0.0])
    stances = []
    for i in range(N_STANCES):
        start = SHIFT * i
        pos = np.asarray(shift, float) + (i * step) * fwd + (0.5 if i % 2 == 0 else -0.5) * width * side
        stances.append({"foot": i % 2, "start": start, "end": start + LENGTH,
                        "stance": start + LENGTH // 2, "position": pos, "heading": angle})
    n = stances[-1]["end"] + 10
    mid = np.zeros((2, n, 3))
    for foot in (0, 1):
        own = [s for s in stances if s["foot"] == foot]
        mid[foot, :] = own[0]["position"]
        for a, b in zip(own, own[1:]):
            mid[foot, a["start"]:a["end"] + 1] = a["position"]
            t0, t1 = a["end"], b["start"]
            u = (np.arange(t0 + 1, t1) - t0) / (t1 - t0)
            mid[foot, t0 + 1:t1] = a["position"] + u[:, None] * (b["position"] - a["position"])
            mid[foot, t0 + 1:t1, 2] += 0.1 * np.sin(np.pi * u)
        mid[foot, own[-1]["start"]:] = own[-1]["position"]
    heel = mid - HALF_FOOT * fwd
    toe = mid + HALF_FOOT * fwd
    ground = np.full((2, n, 2), float(shift[2]))
    return heel, toe, ground, stances


def rigid_body_pose(n=60, bones=5, seed=0):
    """A body walking on a curve (about 1.5 m/s at 30 fps) and turning, with a rigid pose:
    (bone_pos (F, B, 3), body_pos (F, 3), body_heading (F,), local offsets (B, 3))."""
    rng = np.random.default_rng(seed)
    t = np.arange(n)
    heading = 0.03 * t + 0.3
    body = np.c_[np.cumsum(0.05 * np.cos(heading)), np.cumsum(0.05 * np.sin(heading)),
                 0.9 + 0.02 * np.sin(0.4 * t)]
    local = rng.normal(0, 0.4, (bones, 3))
    c, s = np.cos(heading)[:, None], np.sin(heading)[:, None]
    world = np.stack([c * local[:, 0] - s * local[:, 1], s * local[:, 0] + c * local[:, 1],
                      np.broadcast_to(local[:, 2], (n, bones))], axis=-1) + body[:, None, :]
    return world, body, heading, local


def wxyz(rot: Rotation, shape) -> np.ndarray:
    """scipy rotations -> (w, x, y, z) quaternions of the given leading shape."""
    q = rot.as_quat().reshape(shape + (4,))
    return np.concatenate([q[..., 3:], q[..., :3]], axis=-1)


# foot skate -----------------------------------------------------------------------------

@settings(**HYP)
@given(angle=st.floats(-np.pi, np.pi), dx=st.floats(-20, 20), dy=st.floats(-20, 20),
       dz=st.floats(-3, 3))
def test_still_planted_feet_do_not_skate(angle, dx, dy, dz):
    heel, toe, _, stances = walk(angle, (dx, dy, dz))
    r = foot_skate(heel, toe, stances)
    assert len(r["per_stance_mm"]) == N_STANCES
    assert max(r["per_stance_mm"]) < 1e-6
    assert r["mean_mm"] < 1e-6 and r["max_mm"] < 1e-6


@settings(**HYP)
@given(k=st.integers(0, N_STANCES - 1), speed_mm=st.floats(0.1, 10.0), frames=st.integers(1, 15),
       direction=st.floats(-np.pi, np.pi), angle=st.floats(-np.pi, np.pi))
def test_a_known_slide_is_measured(k, speed_mm, frames, direction, angle):
    """The foot slides ``speed_mm`` per frame for ``frames`` frames of the stance, then
    stands still where it got to: that stance's skate is their product, the others 0."""
    heel, toe, _, stances = walk(angle)
    s = stances[k]
    slide = speed_mm / 1000.0 * np.array([np.cos(direction), np.sin(direction), 0.0])
    a = s["start"] + 2
    steps = np.minimum(np.arange(s["end"] + 1 - a), frames)
    for arr in (heel, toe):
        arr[s["foot"], a:s["end"] + 1] += steps[:, None] * slide
    r = foot_skate(heel, toe, stances)
    assert r["per_stance_mm"][k] == pytest.approx(frames * speed_mm, abs=1e-6)
    others = [v for i, v in enumerate(r["per_stance_mm"]) if i != k]
    assert max(others) < 1e-6
    assert r["max_mm"] == pytest.approx(frames * speed_mm, abs=1e-6)
    assert r["mean_mm"] == pytest.approx(frames * speed_mm / N_STANCES, abs=1e-6)


def test_three_mm_per_frame_for_ten_frames_is_thirty_mm():
    heel, toe, _, stances = walk()
    s = stances[2]
    a = s["start"] + 3
    steps = np.minimum(np.arange(s["end"] + 1 - a), 10)
    for arr in (heel, toe):
        arr[s["foot"], a:s["end"] + 1, 0] += 0.003 * steps
    assert foot_skate(heel, toe, stances)["per_stance_mm"][2] == pytest.approx(30.0, abs=1e-6)


def test_heel_to_toe_roll_is_a_pivot_not_a_slide():
    """Heel strike (heel down, toe coming down about it), flat foot, then heel rise about
    the toe: heel and toe each still while they are the contact, and the switch between
    them (a 0.2 m jump of the contact point) is not counted."""
    heel, toe, ground, stances = walk()
    s = stances[3]
    f, a, e = s["foot"], s["start"], s["end"]
    h0, t0 = heel[f, a].copy(), toe[f, a].copy()
    foot_len = np.linalg.norm(t0 - h0)
    fwd = (t0 - h0) / foot_len
    for j, pitch in enumerate(np.radians([30, 20, 10, 4])):  # toe comes down about the heel
        toe[f, a + j] = h0 + foot_len * (np.cos(pitch) * fwd + [0, 0, np.sin(pitch)])
    for j, pitch in enumerate(np.radians([3, 8, 15, 25, 35])):  # heel rises about the toe
        heel[f, e - 4 + j] = t0 + foot_len * (-np.cos(pitch) * fwd + [0, 0, np.sin(pitch)])
    _, which = contact_point(heel, toe)
    assert which[f, a] == 0 and which[f, e] == 1  # the contact point does switch
    r = foot_skate(heel, toe, stances)
    assert r["per_stance_mm"][3] < 1e-6
    assert r["max_mm"] < 1e-6


def test_only_the_planted_part_of_a_stance_counts():
    """A foot still coming down (more than planted_height above its lowest) and moving
    at the start of the stance is landing, not skating."""
    heel, toe, _, stances = walk()
    s = stances[1]
    f, a = s["foot"], s["start"]
    for arr in (heel, toe):
        arr[f, a:a + 3, 2] += [0.08, 0.05, 0.03]
        arr[f, a:a + 3, 0] -= [0.06, 0.04, 0.02]
    assert foot_skate(heel, toe, stances)["per_stance_mm"][1] < 1e-6
    assert foot_skate(heel, toe, stances, planted_height=0.1)["per_stance_mm"][1] == \
        pytest.approx(60.0, abs=1e-6)


def test_contact_point_is_the_lower_of_heel_and_toe():
    rng = np.random.default_rng(3)
    heel, toe = rng.normal(size=(2, 2, 50, 3))
    point, which = contact_point(heel, toe)
    assert point.shape == (2, 50, 3) and which.shape == (2, 50)
    np.testing.assert_array_equal(point[..., 2], np.minimum(heel[..., 2], toe[..., 2]))
    np.testing.assert_array_equal(which, (toe[..., 2] < heel[..., 2]).astype(int))


# footprints, penetration, floating ------------------------------------------------------

@settings(**HYP)
@given(k=st.integers(0, N_STANCES - 1),
       off=st.tuples(st.floats(-0.2, 0.2), st.floats(-0.2, 0.2), st.floats(-0.05, 0.05)),
       angle=st.floats(-np.pi, np.pi))
def test_footprint_error_recovers_a_known_offset(k, off, angle):
    heel, toe, _, stances = walk(angle)
    s = stances[k]
    for arr in (heel, toe):
        arr[s["foot"], s["start"]:s["end"] + 1] += off
    r = footprint_error(heel, toe, stances)
    want = np.linalg.norm(off) * 1000.0
    assert r["per_stance_mm"][k] == pytest.approx(want, abs=1e-6)
    assert max(v for i, v in enumerate(r["per_stance_mm"]) if i != k) < 1e-6
    assert r["max_mm"] == pytest.approx(want, abs=1e-6)
    assert r["mean_mm"] == pytest.approx(want / N_STANCES, abs=1e-6)


@settings(**HYP)
@given(depth=st.floats(0.0005, 0.1).filter(lambda d: abs(d - 0.005) > 1e-9), foot=st.integers(0, 1), point=st.integers(0, 1),
       frame=st.integers(0, 90))
def test_penetration_finds_a_known_dip_and_ignores_gaps(depth, foot, point, frame):
    heel, toe, ground, _ = walk(shift=(0.0, 0.0, 0.4))
    arr = heel if point == 0 else toe
    arr[foot, frame, 2] = ground[foot, frame, point] - depth  # from wherever it was (a swing too)
    r = penetration(heel, toe, ground)
    assert r["max_mm"] == pytest.approx(depth * 1000.0, abs=1e-6)
    assert r["frames_over_tolerance"] == (1 if depth > 0.005 else 0)
    # a deeper dip over a gap (no surface) is not penetration
    other = (frame + 40) % heel.shape[1]
    heel[foot, other, 2] -= 1.0
    ground[foot, other, 0] = np.nan
    assert penetration(heel, toe, ground)["max_mm"] == pytest.approx(depth * 1000.0, abs=1e-6)


def test_no_penetration_is_zero():
    heel, toe, ground, _ = walk()
    assert penetration(heel, toe, ground) == {"max_mm": 0.0, "frames_over_tolerance": 0}
    assert penetration(heel, toe, np.full_like(ground, np.nan))["max_mm"] == 0.0


@settings(**HYP)
@given(k=st.integers(0, N_STANCES - 1), lift=st.floats(0.0, 0.05), z0=st.floats(-2, 2))
def test_floating_finds_a_known_lift(k, lift, z0):
    heel, toe, ground, stances = walk(shift=(0.0, 0.0, z0))
    s = stances[k]
    for arr in (heel, toe):
        arr[s["foot"], s["start"]:s["end"] + 1, 2] += lift
    r = floating(heel, toe, ground, stances)
    assert r["max_mm"] == pytest.approx(lift * 1000.0, abs=1e-6)
    assert r["mean_mm"] == pytest.approx(lift * 1000.0 / N_STANCES, abs=1e-6)


def test_floating_ignores_ground_gaps():
    heel, toe, ground, stances = walk()
    s = stances[0]
    ground[s["foot"], s["start"]:s["end"] + 1] = np.nan  # stance 0 over a gap
    for arr in (heel, toe):
        arr[s["foot"], s["start"]:s["end"] + 1, 2] -= 0.5  # far below the (missing) surface
    r = floating(heel, toe, ground, stances)
    assert abs(r["mean_mm"]) < 1e-9 and abs(r["max_mm"]) < 1e-9


# goal -----------------------------------------------------------------------------------

def test_goal_error_distance_and_heading_wrap():
    body = np.array([[0.0, 0.0, 0.9], [1.0, 2.0, 0.9], [3.0, 4.0, 0.95]])
    head = np.radians([0.0, 200.0, 359.0])
    r = goal_error(body, head, [0.0, 0.0, 5.0], np.radians(1.0))
    assert r["distance_m"] == pytest.approx(5.0)  # horizontal only
    assert r["heading_deg"] == pytest.approx(2.0)
    assert goal_error(body, head, [3.0, 4.0, 0.0])["heading_deg"] is None


@settings(**HYP)
@given(h=st.floats(-10, 10), delta=st.floats(-179.0, 179.0), turns=st.integers(-3, 3))
def test_goal_heading_error_is_wrapped(h, delta, turns):
    body = np.zeros((4, 3))
    head = np.full(4, h + np.radians(delta) + 2 * np.pi * turns)
    r = goal_error(body, head, np.zeros(3), h)
    assert r["heading_deg"] == pytest.approx(abs(delta), abs=1e-6)
    assert r["distance_m"] == 0.0


# pops -----------------------------------------------------------------------------------

@settings(**HYP)
@given(bone=st.integers(0, 6), frame=st.integers(1, 49), seed=st.integers(0, 1000),
       jump=st.floats(5.0, 170.0))
def test_a_rotation_jump_is_reported_with_its_bone_and_frame(bone, frame, seed, jump):
    """Every bone turns smoothly (at most 1 degree a frame) except one that jumps by
    ``jump`` degrees at ``frame``; random sign flips of the quaternions change nothing."""
    rng = np.random.default_rng(seed)
    n, b = 50, 7
    axes = rng.normal(size=(b, 3))
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    rate = np.radians(rng.uniform(0, 1.0, b))
    rate[bone] = 0.0
    rotvec = axes[None] * (rate[None, :, None] * np.arange(n)[:, None, None])
    base = Rotation.random(b, random_state=seed)
    rots = Rotation.from_rotvec(rotvec.reshape(-1, 3)) * Rotation.concatenate([base] * n)
    q = wxyz(rots, (n, b))
    axis = rng.normal(size=3)
    kick = Rotation.from_rotvec(np.radians(jump) * axis / np.linalg.norm(axis))
    q[frame:, bone] = wxyz(kick * base[bone], ())  # the bone's rotation is base[bone] throughout
    q *= rng.choice([-1.0, 1.0], size=(n, b, 1))
    pos, body, heading, _ = rigid_body_pose(n, b, seed)
    r = pops(pos, q, body, heading)
    assert r["max_rotation_deg"] == pytest.approx(jump, abs=1e-6)
    assert (r["rotation_bone"], r["rotation_frame"]) == (bone, frame)


def test_thirty_degree_jump_at_frame_k():
    n, b, k = 40, 4, 17
    q = np.zeros((n, b, 4))
    q[..., 0] = 1.0
    q[k:, 2] = wxyz(Rotation.from_euler("x", 30, degrees=True), ())
    pos, body, heading, _ = rigid_body_pose(n, b)
    r = pops(pos, q, body, heading)
    assert r["max_rotation_deg"] == pytest.approx(30.0, abs=1e-9)
    assert (r["rotation_bone"], r["rotation_frame"]) == (2, k)


def test_quaternion_sign_flips_are_not_pops():
    n, b = 30, 5
    q = np.broadcast_to(wxyz(Rotation.random(b, random_state=1), (b,)), (n, b, 4)).copy()
    q *= np.where(np.arange(n) % 2 == 0, 1.0, -1.0)[:, None, None]
    pos, body, heading, _ = rigid_body_pose(n, b)
    assert pops(pos, q, body, heading)["max_rotation_deg"] < 1e-5


@settings(**HYP)
@given(seed=st.integers(0, 1000))
def test_a_rigid_pose_carried_by_a_turning_body_has_no_offset_pop(seed):
    pos, body, heading, local = rigid_body_pose(80, 6, seed)
    q = np.zeros(pos.shape[:2] + (4,))
    q[..., 0] = 1.0
    np.testing.assert_allclose(in_body_frame(pos, body, heading),
                               np.broadcast_to(local, pos.shape), atol=1e-12)
    # the bones do move in the world (about 50 mm a frame and more) ...
    assert np.linalg.norm(np.diff(pos, axis=0), axis=-1).max() > 0.04
    # ... but not relative to the body
    assert pops(pos, q, body, heading)["max_offset_mm"] < 1e-6


@settings(**HYP)
@given(bone=st.integers(0, 5), frame=st.integers(1, 59), size_mm=st.floats(5.0, 200.0),
       seed=st.integers(0, 1000))
def test_an_offset_jump_in_the_body_frame_is_reported(bone, frame, size_mm, seed):
    pos, body, heading, _ = rigid_body_pose(60, 6, seed)
    d = np.random.default_rng(seed).normal(size=3)
    d *= size_mm / 1000.0 / np.linalg.norm(d)
    # from the frame on the bone stays displaced by d in the body frame (turned with it)
    c, s = np.cos(heading[frame:]), np.sin(heading[frame:])
    pos[frame:, bone] += np.c_[c * d[0] - s * d[1], s * d[0] + c * d[1], np.full_like(c, d[2])]
    q = np.zeros(pos.shape[:2] + (4,))
    q[..., 0] = 1.0
    r = pops(pos, q, body, heading)
    assert r["max_offset_mm"] == pytest.approx(size_mm, abs=1e-6)
    assert (r["offset_bone"], r["offset_frame"]) == (bone, frame)


def test_pops_without_frames_or_bones():
    r = pops(np.zeros((1, 3, 3)), np.tile([1.0, 0, 0, 0], (1, 3, 1)), np.zeros((1, 3)), np.zeros(1))
    assert r["max_rotation_deg"] == 0.0 and r["rotation_bone"] is None and r["offset_frame"] is None
    r = pops(np.zeros((5, 0, 3)), np.zeros((5, 0, 4)), np.zeros((5, 3)), np.zeros(5))
    assert r["max_offset_mm"] == 0.0 and r["offset_bone"] is None


# quality --------------------------------------------------------------------------------

def _scene(stances_too=True):
    heel, toe, ground, stances = walk()
    n = heel.shape[1]
    pos, body, heading, _ = rigid_body_pose(n, 4)
    q = np.zeros((n, 4, 4))
    q[..., 0] = 1.0
    ground[0, 20:25] = np.nan
    return (heel, toe, ground, stances if stances_too else [], pos, q, body, heading,
            np.array([4.0, 3.0, 0.0]))


@pytest.mark.parametrize("stances_too", [True, False])
@pytest.mark.parametrize("goal_heading", [None, 0.5])
def test_quality_is_json_ready_and_leaves_inputs_alone(stances_too, goal_heading):
    args = _scene(stances_too)
    before = [np.array(a, copy=True) if isinstance(a, np.ndarray) else
              [{k: np.array(v, copy=True) for k, v in s.items()} for s in a] for a in args]
    r = quality(*args, goal_heading=goal_heading)
    text = json.dumps(r, allow_nan=False)
    assert json.loads(text) == r
    assert set(r) == {"frames", "stances", "foot_skate", "footprint_error", "penetration",
                      "floating", "goal", "pops"}
    assert r["frames"] == args[0].shape[1]
    assert r["stances"] == (N_STANCES if stances_too else 0)
    assert r["foot_skate"]["max_mm"] == 0.0 and r["footprint_error"]["max_mm"] == 0.0
    assert len(r["foot_skate"]["per_stance_mm"]) == r["stances"]
    assert (r["goal"]["heading_deg"] is None) == (goal_heading is None)
    for a, b in zip(args, before):
        if isinstance(a, np.ndarray):
            np.testing.assert_array_equal(a, b)
        else:
            for s, t in zip(a, b):
                for key in s:
                    np.testing.assert_array_equal(s[key], t[key])


def test_every_figure_accepts_no_stances():
    heel, toe, ground, _ = walk()
    assert foot_skate(heel, toe, []) == {"per_stance_mm": [], "mean_mm": 0.0, "max_mm": 0.0}
    assert footprint_error(heel, toe, []) == {"per_stance_mm": [], "mean_mm": 0.0, "max_mm": 0.0}
    assert floating(heel, toe, ground, []) == {"mean_mm": 0.0, "max_mm": 0.0}
