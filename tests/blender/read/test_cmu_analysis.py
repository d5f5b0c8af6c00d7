"""Clip analysis on real motion capture (../shared/mocap/cmu), against the figures its
README gives, measured independently."""

import os
from importlib import import_module

import numpy as np
import pytest

from conftest import CMU, analyse_bvh, cmu, needs_cmu

pytestmark = needs_cmu

SUBJECT16 = sorted(f for f in os.listdir(CMU) if f.startswith("cmu_16_")) if os.path.isdir(CMU) else []


@pytest.fixture(scope="module")
def at120(fp):
    return analyse_bvh(fp, [os.path.join(CMU, f) for f in sorted(os.listdir(CMU)) if f.endswith(".bvh")], 120)


def test_straight_walk_speed_stride_cycle(at120):
    a = at120["cmu_16_16_walk"]
    assert a.gait == "walk" and a.kind == "cycle"
    assert a.speed == pytest.approx(1.02, rel=0.05)
    assert a.stride == pytest.approx(1.2, rel=0.05)
    assert a.cycle == pytest.approx(1.18, rel=0.05)
    assert a.cadence == pytest.approx(120 / a.cycle)
    assert abs(a.tau) < 0.05
    assert not a.flights  # walking: always a foot down


def test_jog_is_a_run(at120):
    a = at120["cmu_16_35_run_jog"]
    assert a.gait == "run"
    assert 2.6 <= a.speed <= 2.9
    assert len(a.flights) >= 2  # a flight between steps


@pytest.mark.parametrize("name", [f[:-4] for f in SUBJECT16 if "run_jog" in f])
def test_every_jog_clip_is_a_run(at120, name):
    assert at120[name].gait == "run"


@pytest.mark.parametrize("name", [f[:-4] for f in SUBJECT16 if "_walk" in f])
def test_every_walk_clip_is_a_walk(at120, name):
    assert at120[name].gait == "walk"


def test_turn_signs_and_sharpness(at120):
    tau = {k: at120[k].tau for k in at120}
    left_veer, left_90 = tau["cmu_16_11_walk_veer_left"], tau["cmu_16_17_walk_turn90_left"]
    right_veer, right_90 = tau["cmu_16_13_walk_veer_right"], tau["cmu_16_19_walk_turn90_right"]
    assert left_veer > 0 and left_90 > 0
    assert right_veer < 0 and right_90 < 0
    assert abs(left_90) > abs(left_veer) and abs(right_90) > abs(right_veer)
    # the jog turns too
    assert tau["cmu_16_37_run_jog_veer_left"] > 0 > tau["cmu_16_39_run_jog_veer_right"]
    assert tau["cmu_16_41_run_jog_turn90_left"] > 0 > tau["cmu_16_43_run_jog_turn90_right"]


def test_running_leap_has_one_long_flight(at120):
    a = at120["cmu_49_05_run_leap_run"]
    assert a.kind == "jump" and (a.entry_gait, a.exit_gait) == ("run", "run")
    assert len(a.jump_flights) == 1
    start, end = a.jump_flights[0]
    assert end - start == pytest.approx(0.48, abs=0.05)
    # the README: airborne about frames 50-106 of the file
    assert float(a.motion.frame_of(start)) == pytest.approx(50, abs=4)
    assert float(a.motion.frame_of(end)) == pytest.approx(106, abs=4)


def test_other_jumps(at120):
    hurdle = at120["cmu_127_26_run_jump_over_obstacle"]
    assert hurdle.kind == "jump" and (hurdle.entry_gait, hurdle.exit_gait) == ("run", "run")
    assert [round(b - a, 1) for a, b in hurdle.jump_flights] == [0.6]  # README: about 0.57 s
    in_place = at120["cmu_16_01_jump_in_place"]
    assert in_place.kind == "jump" and (in_place.entry_gait, in_place.exit_gait) == ("stand", "stand")


def test_starts_and_stops(at120):
    start = at120["cmu_16_31_walk_start_from_standing"]
    assert start.kind == "start" and start.starts_at_rest and not start.ends_at_rest
    assert (start.entry_gait, start.exit_gait) == ("stand", "walk")
    stop = at120["cmu_16_33_slow_walk_to_stop"]
    assert stop.kind == "stop" and stop.ends_at_rest and not stop.starts_at_rest
    assert (stop.entry_gait, stop.exit_gait) == ("walk", "stand")
    run_stop = at120["cmu_16_57_run_jog_sudden_stop"]
    assert run_stop.kind == "stop" and run_stop.entry_gait == "run"
    for name in ("cmu_16_16_walk", "cmu_16_35_run_jog", "cmu_16_17_walk_turn90_left"):
        assert not at120[name].starts_at_rest and not at120[name].ends_at_rest


def test_events_are_ordered_and_footprints_lie_on_the_ground(at120):
    for a in at120.values():
        for st in a.stances:
            assert st.strike <= st.land + 1e-9 and st.lift <= st.liftoff + 1e-9
            assert st.strike <= st.stance <= st.liftoff
            fp = st.footprint
            assert abs(fp.position[2]) < 0.12, a.name
            assert 0.1 < np.linalg.norm(fp.toe[:2] - fp.heel[:2]) < 0.3
        for k in (0, 1):
            iv = a.contact_intervals(k)
            assert all(e1 <= s2 for (_, e1), (s2, _) in zip(iv[:-1], iv[1:])), a.name


def test_footprint_headings_follow_the_walk(at120):
    """A straight walk's footprints point the way the character walks."""
    a = at120["cmu_16_16_walk"]
    fps_ = a.footprints()
    travel = fps_[-1].position[:2] - fps_[0].position[:2]
    fwd = a.motion.rest_forward
    walk_yaw = np.arctan2(travel[1], travel[0]) - np.arctan2(fwd[1], fwd[0])
    for f in fps_:
        assert abs(np.angle(np.exp(1j * (f.heading - walk_yaw)))) < np.radians(25)


def _threshold_contacts(fp, path):
    """An independent detector: a foot is down while its ball or ankle joint is within
    4 cm of its lowest height and moving slower than 0.6 m/s. Joint positions come from
    Blender's own pose evaluation (frame_set), not from the analysis."""
    import bpy

    clips = import_module(fp.__name__ + ".blender.read.clips")
    bpy.ops.wm.read_homefile(use_empty=True)
    scene = bpy.context.scene
    scene.render.fps = 120
    ob, (act,) = clips.import_clips([path])
    ob.animation_data_create()
    ob.animation_data.action = act
    ob.animation_data.action_slot = act.slots[0]
    n = int(round(act.frame_range[1]))
    joints = {j: np.empty((n, 3)) for j in ("LeftFoot", "LeftToeBase", "RightFoot", "RightToeBase")}
    for f in range(1, n + 1):
        scene.frame_set(f)
        for j, arr in joints.items():
            arr[f - 1] = ob.pose.bones[j].head
    out = []
    for side in ("Left", "Right"):
        down = np.zeros(n, bool)
        for j in (f"{side}Foot", f"{side}ToeBase"):
            p = joints[j]
            v = np.linalg.norm(np.gradient(p[:, :2], 1 / 120, axis=0), axis=1)
            down |= (p[:, 2] < p[:, 2].min() + 0.04) & (v < 0.6)
        edges = np.flatnonzero(np.diff(np.r_[0, down.astype(int), 0]))
        out.append([(a / 120, (b - 1) / 120) for a, b in zip(edges[0::2], edges[1::2]) if b - a >= 12])
    return out, n / 120


@pytest.mark.parametrize("name", ["16_16", "16_17", "16_19", "16_31", "16_33", "16_35", "16_43"])
def test_contacts_agree_with_an_independent_threshold_detector(fp, at120, name):
    path = cmu(name)
    a = at120[os.path.basename(path)[:-4]]
    detected, duration = _threshold_contacts(fp, path)
    strikes, liftoffs = [], []
    for k in (0, 1):
        mine = a.contact_intervals(k)
        for x, y in detected[k]:
            hits = [(s, e) for s, e in mine if s < y and e > x]
            assert len(hits) == 1, f"{name} foot {k}: detector stance {x:.2f}-{y:.2f} s matches {hits}"
            s, e = hits[0]
            if x > 0.01:
                strikes.append(s - x)
            if y < duration - 0.02:
                liftoffs.append(e - y)
    strikes, liftoffs = np.array(strikes), np.array(liftoffs)
    # Strikes agree within a few frames. Johansen's liftoff is the onset of the toe's
    # rise, which a 4 cm height band reports later: about 60 ms on these clips. A pivot
    # step in a sharp turn may differ by up to 0.2 s (the detector's speed cut ends it).
    assert np.median(np.abs(strikes)) < 0.07 and np.abs(strikes).max() < 0.2
    assert -0.12 < np.median(liftoffs) <= 0.03 and np.abs(liftoffs).max() < 0.2


@pytest.mark.parametrize("fps", [60, 30])
def test_figures_do_not_depend_on_the_frame_rate(fp, at120, fps):
    names = ["16_16", "16_17", "16_19", "16_35", "16_41", "49_05"]
    other = analyse_bvh(fp, [cmu(n) for n in names], fps)
    for key, b in other.items():
        a = at120[key]
        assert (b.gait, b.kind, b.entry_gait, b.exit_gait) == (a.gait, a.kind, a.entry_gait, a.exit_gait)
        assert b.speed == pytest.approx(a.speed, rel=0.02), key
        if a.cycle is not None:
            assert b.cycle == pytest.approx(a.cycle, rel=0.02), key
            assert b.stride == pytest.approx(a.stride, rel=0.02), key
        assert b.tau == pytest.approx(a.tau, rel=0.02, abs=0.02), key
        fl_a = [y - x for x, y in a.jump_flights]
        fl_b = [y - x for x, y in b.jump_flights]
        assert fl_b == pytest.approx(fl_a, rel=0.02), key
        assert b.frames == int(np.floor((a.frames - 1) * fps / 120)) + 1 or abs(b.frames - a.frames * fps / 120) <= 1


def test_proposed_library(fp, at120):
    lib = import_module(fp.__name__ + ".core.clips.library").propose_library(
        [at120[f[:-4]] for f in SUBJECT16])
    walk = [c.clip for c in lib.turn_groups["walk"].clips]
    run = [c.clip for c in lib.turn_groups["run"].clips]
    assert walk[0] == "cmu_16_19_walk_turn90_right" and walk[-1] == "cmu_16_17_walk_turn90_left"
    assert set(walk) == {"cmu_16_11_walk_veer_left", "cmu_16_13_walk_veer_right", "cmu_16_16_walk",
                         "cmu_16_17_walk_turn90_left", "cmu_16_19_walk_turn90_right"}
    assert len(run) == 5 and lib.speed_group == ("walk", "run")
    kinds = {s.clip: s.kind for s in lib.specials}
    assert kinds == {"cmu_16_01_jump_in_place": "jump", "cmu_16_31_walk_start_from_standing": "start",
                     "cmu_16_33_slow_walk_to_stop": "stop", "cmu_16_57_run_jog_sudden_stop": "stop"}
    w = lib.turn_groups["walk"].weights(0.3)
    assert sum(w.values()) == pytest.approx(1.0) and len(w) == 2
