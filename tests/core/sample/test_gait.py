"""The sample character's generated clip library (core.gait), held to human figures by the
project's own analysis: the same code that reads motion capture."""

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from footstep_planner.core.sample import gait, mannequin, specs
from footstep_planner.core.clips.analysis import analyze_clip
from footstep_planner.core.clips.clip import clip_motion
from footstep_planner.core.clips.rig import forward_kinematics

FPS = 30.0
RIG = mannequin.rig()
SPECS = {s.name: s for s in gait.library_specs()}


@pytest.fixture(scope="module")
def clips():
    out = {}
    for name, spec in SPECS.items():
        c = gait.generate(RIG, spec, FPS)
        m = clip_motion(RIG, name, c.basis, FPS)
        out[name] = (c, m, analyze_clip(m))
    return out


def stance_drift(m) -> float:
    """Largest horizontal travel (m) of a heel or toe point while it is down (within 3 mm
    of the clip's ground): a planted part of the foot must not slide."""
    worst = 0.0
    for k in range(2):
        for pts in (m.heel[k], m.toe[k]):
            idx = np.flatnonzero(pts[:, 2] < 0.003)
            for run in np.split(idx, np.flatnonzero(np.diff(idx) > 1) + 1):
                if len(run) > 1:
                    worst = max(worst, float(np.linalg.norm(pts[run, :2] - pts[run[0], :2], axis=1).max()))
    return worst


def test_the_library_has_every_clip_the_planner_needs():
    assert {"walk", "walk_turn_left_sharp", "walk_turn_right_sharp", "walk_turn_left_wide",
            "walk_turn_right_wide", "run", "run_turn_left", "run_turn_right", "run_jump",
            "walk_start", "walk_stop", "idle"} == set(SPECS)
    radii = sorted(abs(1 / s.tau) for s in SPECS.values() if s.gait is specs.WALK and s.tau)
    assert radii == pytest.approx([0.8, 0.8, 2.5, 2.5])


@pytest.mark.parametrize("name", [n for n, s in SPECS.items() if s.gait is specs.WALK and s.kind == "cycle"])
def test_walks_have_human_speed_and_stride_and_no_flight(clips, name):
    c, m, a = clips[name]
    assert a.kind == "cycle" and a.gait == "walk" and a.is_loop
    assert 1.2 <= a.speed <= 1.5, a.speed
    assert not a.flights
    if not c.spec.tau:
        assert 1.3 <= a.stride <= 1.6, a.stride
    # both feet down between the steps, each about 60 % of the cycle
    share = np.mean([s.liftoff - s.strike for s in a.stances if not (s.open_start or s.open_end)]) / a.cycle
    assert 0.55 < share < 0.68


@pytest.mark.parametrize("name", [n for n, s in SPECS.items() if s.gait is specs.RUN and s.kind == "cycle"])
def test_runs_have_human_speed_and_flight_phases(clips, name):
    c, m, a = clips[name]
    assert a.kind == "cycle" and a.gait == "run" and a.is_loop
    assert 2.8 <= a.speed <= 3.5, a.speed
    # a flight between every two steps
    steps = [s for s in a.stances if not (s.open_start or s.open_end)]
    assert len(a.flights) >= len(steps) - 1 >= 3
    # every flight inside the clip (clip times) lasts as a jog's does
    lengths = [end - begin for begin, end in a.flights if begin > 0.01 and end < m.duration - 0.01]
    assert all(0.05 < x < 0.2 for x in lengths)


@pytest.mark.parametrize("name", [n for n, s in SPECS.items() if s.tau])
def test_turning_clips_turn_at_the_curvature_they_were_made_for(clips, name):
    c, m, a = clips[name]
    assert a.tau == pytest.approx(c.spec.tau, rel=0.10)
    assert np.sign(a.tau) == np.sign(c.spec.tau)


@pytest.mark.parametrize("name", list(SPECS))
def test_no_foot_slides_in_a_source_clip(clips, name):
    c, m, a = clips[name]
    assert stance_drift(m) < 0.002


@pytest.mark.parametrize("name", list(SPECS))
def test_feet_never_go_into_the_floor_and_the_legs_stay_in_reach(clips, name):
    c, m, a = clips[name]
    assert m.heel[:, :, 2].min() > -0.001 and m.toe[:, :, 2].min() > -0.001
    pose = forward_kinematics(RIG, c.basis)
    for side in "LR":
        d = np.linalg.norm(pose[:, RIG.index(f"foot.{side}"), :3, 3] - pose[:, RIG.index(f"thigh.{side}"), :3, 3], axis=1)
        assert d.max() < 0.99 * 0.84
    # the hips are lowered a little, if at all, to keep the legs in reach
    assert c.hips_drop.max() < 0.11


def test_the_running_jump_starts_and_ends_in_a_run_and_clears_more_than_a_metre(clips):
    c, m, a = clips["run_jump"]
    assert a.kind == "jump" and a.entry_gait == "run" and a.exit_gait == "run"
    assert len(a.jump_flights) == 1
    take_off, landing = a.jump_flights[0]  # clip times, s
    flight = landing - take_off
    assert 0.25 <= flight <= 0.45
    before = max((s for s in a.stances if s.liftoff <= take_off + 1e-6), key=lambda s: s.liftoff)
    after = min((s for s in a.stances if s.strike >= landing - 1e-6), key=lambda s: s.strike)
    gap = np.linalg.norm(after.footprint.heel[:2] - before.footprint.toe[:2])
    # the take-off toe and the landing heel: a 1.2 m gap with room for the planner's
    # shorter (-10 %) jumps
    assert 1.45 < gap < 2.0, gap
    # the hips fly a ballistic arc: higher than when running
    hips = m.hips_in_root[:, 2, 3]
    i0, i1 = int(take_off * FPS), int(landing * FPS)
    assert hips[i0:i1].max() > hips[:i0].max() + 0.05


def test_start_stop_and_idle_rest_at_their_ends(clips):
    _, _, start = clips["walk_start"]
    _, _, stop = clips["walk_stop"]
    _, _, idle = clips["idle"]
    assert start.kind == "start" and start.starts_at_rest and not start.ends_at_rest
    assert start.exit_gait == "walk" and 1.2 <= start.speed <= 1.5
    assert stop.kind == "stop" and stop.ends_at_rest and not stop.starts_at_rest and stop.entry_gait == "walk"
    assert idle.kind == "idle" and idle.gait == "stand"


def test_cycle_clips_loop_seamlessly(clips):
    for name, (c, m, a) in clips.items():
        if c.spec.kind != "cycle":
            continue
        # the last frame is the first frame one loop on: same pose, moved along the path
        q = np.delete(m.local_rot, m.hips_index, axis=1)  # (the hips turn with the path)
        err = np.degrees(np.arccos(np.clip((np.trace(q[0].transpose(0, 2, 1) @ q[-1], axis1=-2, axis2=-1) - 1) / 2, -1, 1)))
        assert err.max() < 0.5, name


@settings(max_examples=15, deadline=None)
@given(tau=st.floats(-1.3, 1.3), speed=st.floats(1.0, 1.6), fps=st.sampled_from([24.0, 30.0, 60.0]))
def test_any_walk_on_any_arc_keeps_its_feet_planted_and_its_curvature(tau, speed, fps):
    spec = specs.ClipSpec("w", specs.WALK, tau=tau, speed=speed)
    c = gait.generate(RIG, spec, fps)
    m = clip_motion(RIG, "w", c.basis, fps)
    assert stance_drift(m) < 0.002
    a = analyze_clip(m)
    assert a.gait == "walk"
    assert a.tau == pytest.approx(tau, abs=0.1 * max(abs(tau), 0.2))


def test_the_numpy_rig_matches_blenders_bone_matrices():
    # Blender's rule for a bone's axes (roll 0): Y along the bone, X from the least rotation
    m = mannequin.bone_matrix((0, 0, 0), (0, 0, 1))
    np.testing.assert_allclose(m[:3, :3], [[1, 0, 0], [0, 0, -1], [0, 1, 0]], atol=1e-12)
    for row in mannequin.bone_table():
        r = mannequin.bone_matrix(row[1], row[2])[:3, :3]
        np.testing.assert_allclose(r @ r.T, np.eye(3), atol=1e-9)
        assert np.linalg.det(r) == pytest.approx(1.0)


def _scaled_rig(s: float):
    """The mannequin's skeleton scaled by s (a child, a tall adult)."""
    from footstep_planner.core.clips.rig import Rig

    rest = RIG.rest.copy()
    rest[:, :3, 3] *= s
    return Rig.build("scaled", RIG.names, RIG.parents, rest, RIG.tails * s)


@pytest.mark.parametrize("s", [0.75, 1.15])
@pytest.mark.parametrize("name", ["walk", "run", "walk_turn_left_sharp"])
def test_a_rig_of_other_proportions_gets_the_gait_scaled_to_its_legs(s, name):
    rig = _scaled_rig(s)
    spec = SPECS[name]
    c = gait.generate(rig, spec, FPS)
    m = clip_motion(rig, name, c.basis, FPS)
    a = analyze_clip(m)
    ref = analyze_clip(clip_motion(RIG, name, gait.generate(RIG, spec, FPS).basis, FPS))
    # equal Froude numbers: speed by sqrt(s), stride and radius by s
    assert a.gait == ref.gait
    assert a.speed == pytest.approx(ref.speed * np.sqrt(s), rel=0.05)
    assert a.stride == pytest.approx(ref.stride * s, rel=0.05)
    assert a.tau == pytest.approx(ref.tau / s, rel=0.05, abs=0.005)
    assert stance_drift(m) < 0.002
    assert m.heel[:, :, 2].min() > -0.001 and m.toe[:, :, 2].min() > -0.001
    pose = forward_kinematics(rig, c.basis)
    for side in "LR":
        d = np.linalg.norm(pose[:, rig.index(f"foot.{side}"), :3, 3] - pose[:, rig.index(f"thigh.{side}"), :3, 3], axis=1)
        assert d.max() < 0.99 * 0.84 * s


def test_a_rig_without_the_metarig_legs_or_with_feet_off_the_ground_is_refused_by_name():
    from footstep_planner.core.clips.rig import Rig

    names = [n.replace("thigh", "UpLeg") for n in RIG.names]
    other = Rig.build("Hero", names, RIG.parents, RIG.rest, RIG.tails)
    with pytest.raises(gait.GaitError, match=r"'Hero'.*no thigh\.L, thigh\.R"):
        gait.generate(other, SPECS["walk"])
    rest = RIG.rest.copy()
    rest[:, 2, 3] += 0.3  # standing 30 cm above its ground
    high = Rig.build("Floating", RIG.names, RIG.parents, rest, RIG.tails + [0, 0, 0.3])
    with pytest.raises(gait.GaitError, match=r"'Floating': foot\.L does not stand flat"):
        gait.generate(high, SPECS["walk"])


def test_the_reference_proportions_are_the_mannequins():
    from footstep_planner.core.solve.legs import leg_lengths

    assert sum(leg_lengths(RIG, "l")) == pytest.approx(gait.REF_LEG, abs=1e-9)
    assert RIG.rest[RIG.role_index("hips"), 2, 3] == pytest.approx(gait.REF_HIPS, abs=1e-9)


@pytest.mark.parametrize("name", ["walk", "run_jump"])
def test_a_clip_generated_again_is_the_one_made_from_its_rig_spec_and_rate(name):
    """``generate`` gives a clip made before from an equal rig, spec and rate again (read
    only), the very clip a fresh generation makes; another rig, spec or rate makes its own."""
    spec = SPECS[name]
    again = gait.generate(mannequin.rig(), spec, FPS)
    assert again is gait.generate(RIG, spec, FPS)
    fresh = gait._generate(RIG, spec, FPS)
    assert np.array_equal(again.basis, fresh.basis) and np.array_equal(again.hips_drop, fresh.hips_drop)
    with pytest.raises(ValueError):
        again.basis[0, 0, 0, 0] = 2.0
    for other in (gait.generate(_scaled_rig(1.1), spec, FPS), gait.generate(RIG, spec, 24.0),
                  gait.generate(RIG, SPECS["run"], FPS)):
        assert other is not again and not (other.basis.shape == again.basis.shape
                                            and np.array_equal(other.basis, again.basis))
