"""The synthesis pipeline (thesis 3.3 to 3.7) on a synthetic clip library: curvature and
speed found from the path, weights, surfaces, and the report."""

from __future__ import annotations

import functools

import numpy as np
import pytest

from footstep_planner.core.clips.analysis import analyze_clip
from footstep_planner.core.synth.blend_groups import speed_parameter
from footstep_planner.core.synth.schedule import PlanStep
from footstep_planner.core.synth.tracks import BlendError, make_track
from footstep_planner.core.clips.library import propose_library
from footstep_planner.core.footprint import PathFootprint
from footstep_planner.core.synth.passes import speed_pins
from footstep_planner.core.synth.pipeline import STAGES, surface_snap, synthesize
from footstep_planner.core.base.settings import Settings
from footstep_planner.core.plan.surface import FootShape, MeshGround, TriMesh
from synth import synthetic_gait

WALK = dict(speed=1.3, stride=1.4, duty=0.62)
CLIPS = {
    "walk": WALK,
    "walk_veer_left": dict(WALK, curvature=0.5),
    "walk_veer_right": dict(WALK, curvature=-0.5),
    "walk_turn_left": dict(WALK, speed=1.1, stride=1.3, curvature=1.5),
    "walk_turn_right": dict(WALK, speed=1.1, stride=1.3, curvature=-1.5),
    "run": dict(speed=3.0, stride=2.4, duty=0.35),
    "run_veer_left": dict(speed=3.0, stride=2.4, duty=0.35, curvature=0.4),
    "run_veer_right": dict(speed=3.0, stride=2.4, duty=0.35, curvature=-0.4),
}
FORWARD = np.array([0.0, -1.0])  # the synthetic rig's rest forward


@functools.lru_cache(maxsize=None)
def library():
    analyses = [analyze_clip(synthetic_gait(name=n, cycles=4, **kw)[0]) for n, kw in CLIPS.items()]
    return propose_library(analyses), analyses


def floor():
    v = np.array([[-100, -100, 0], [100, -100, 0], [100, 100, 0], [-100, 100, 0]], float)
    return MeshGround(TriMesh(v, np.array([[0, 1, 2], [0, 2, 3]]), np.zeros(2, np.int64), ("floor",)))


def arc_footsteps(n, curvature, label="walk", step=0.7, width=0.18, gait="walk"):
    """Footprints of a walk along an arc (curvature 1/m, + left) heading along FORWARD at
    the start; headings relative to FORWARD; times one step apart."""
    s = np.arange(n) * step
    fa = np.arctan2(FORWARD[1], FORWARD[0])
    if abs(curvature) < 1e-9:
        h = np.zeros(n)
        c = s[:, None] * FORWARD[None]
    else:
        r = 1.0 / curvature
        h = s * curvature
        c = r * np.c_[np.sin(h + fa) - np.sin(fa), -np.cos(h + fa) + np.cos(fa)]
    left = np.c_[-np.sin(h + fa), np.cos(h + fa)]
    side = np.where(np.arange(n) % 2 == 0, 0.5, -0.5) * width
    p = c + side[:, None] * left
    return [PathFootprint(i % 2, np.array([p[i, 0], p[i, 1], 0.0]), float(h[i]), 0.55 * i,
                     "start" if i == 0 else label, gait) for i in range(n)]


def run(footsteps, **kw):
    lib, analyses = library()
    g = floor()
    snap = surface_snap(g, None, FORWARD, FootShape())
    return synthesize(footsteps, lib, analyses, settings=Settings(**kw), fps=30.0, forward=FORWARD, snap=snap)


def middle(x, frac=0.25):
    n = len(x)
    return x[int(n * frac):int(n * (1 - frac))]


def test_a_straight_line_gives_no_curvature_and_a_walk():
    syn = run(arc_footsteps(24, 0.0))
    assert np.abs(middle(syn.tau_final)).max() < 0.03
    assert np.all(syn.s_final == 0.0)
    w = syn.weights
    np.testing.assert_allclose(w.sum(axis=1), 1.0, atol=1e-9)
    walk_cols = [i for i, c in enumerate(syn.clips) if c.startswith("walk")]
    assert w[:, walk_cols].sum(axis=1).min() > 1 - 1e-9
    assert w[:, syn.clips.index("walk")].mean() > 0.95


@pytest.mark.parametrize("radius", [-4.0, -2.5, 1.25, 2.5, 4.0])
def test_a_constant_radius_arc_gives_tau_one_over_r(radius):
    """The plan walks the arc with the blend of the walking group the planner would pick
    for it: the blend groups find the arc's curvature from the body trajectory, within
    5 %, all along the middle of the path."""
    syn = run(arc_footsteps(30, 1.0 / radius, label=f"walk_turn@{1.0 / radius:+.3f}"))
    tau = middle(syn.tau_final, 0.3)
    np.testing.assert_allclose(tau, 1.0 / radius, rtol=0.05)
    # and the turning clips that bracket it carry the weight there
    w = middle(syn.weights, 0.3)
    lib, _ = library()
    taus = {c.clip: c.tau for c in lib.turn_groups["walk"].clips}
    blended = sum(w[:, syn.clips.index(c)] * t for c, t in taus.items())
    np.testing.assert_allclose(blended, tau, atol=1e-6)


def test_a_plan_with_the_wrong_clips_still_finds_the_arc_roughly():
    """Walked with the straight clip only, the first refinement pulls the path towards
    the clip's straight steps between its fixed ends (a curve-shortening), so the arc
    comes out tighter: tau is found within 25 % (about 23 % over)."""
    syn = run(arc_footsteps(30, 1.0 / 2.5))
    np.testing.assert_allclose(middle(syn.tau_final, 0.3), 0.4, rtol=0.25)


def test_smoothing_keeps_the_planned_turns():
    """The shrink-free kernel (the default) keeps an arc's radius through the smoothing;
    the thesis's plain kernel tightens it."""
    fs = arc_footsteps(30, 0.4, label="walk_turn@+0.400")
    keep = run(fs).smoothed.position
    plain = run(fs, smoothing_keep_arcs=False).smoothed.position
    plan = np.array([f.position for f in fs])

    def radius(p):
        A = np.c_[p[:, 0], p[:, 1], np.ones(len(p))]
        c = np.linalg.lstsq(A, p[:, 0] ** 2 + p[:, 1] ** 2, rcond=None)[0]
        return np.sqrt(c[2] + c[0] ** 2 / 4 + c[1] ** 2 / 4)

    mid = slice(5, 25)
    assert radius(keep[mid]) == pytest.approx(radius(plan[mid]), rel=0.01)
    assert radius(plain[mid]) < 0.9 * radius(plan[mid])


def test_outputs_are_finite_and_footprints_stay_on_the_surface():
    # an S-bend plan with mixed labels, on a floor with a hole the path must keep off
    fs = arc_footsteps(12, 0.6, label="walk_veer_left") + []
    tail = arc_footsteps(12, -0.6, label="walk_veer_right")
    # continue the second arc from the end of the first
    a, h = fs[-1].position, fs[-1].heading
    fa = np.arctan2(FORWARD[1], FORWARD[0])
    rot = np.array([[np.cos(h), -np.sin(h)], [np.sin(h), np.cos(h)]])
    for k, f in enumerate(tail[2:], start=1):
        p = a[:2] + rot @ (f.position[:2] - tail[1].position[:2])
        fs.append(PathFootprint(1 - fs[-1].foot, np.array([p[0], p[1], 0.0]), h + f.heading - tail[1].heading,
                           fs[-1].time + 0.55, f.label, "walk"))
    syn = run(fs)
    for arr in (syn.body_position, syn.body_heading, syn.weights, syn.clip_time, syn.tau_final,
                syn.s_final, *syn.footprints):
        assert np.isfinite(arr).all()
    np.testing.assert_allclose(syn.weights.sum(axis=1), 1.0, atol=1e-9)
    pos, _ = syn.footprints
    np.testing.assert_allclose(pos[:, 2], 0.0, atol=1e-9)  # on the floor
    assert set(syn.seconds) >= set(STAGES)
    fa = fa  # noqa: PLW0127 (kept for symmetry with arc_footsteps)


def test_each_footprint_is_planted_around_its_stance():
    syn = run(arc_footsteps(16, 0.3))
    planted = syn.planted()
    S = syn.final.schedule
    for (a, t, b), T in zip(planted, S.footprint_times):
        assert a <= t <= b and t == pytest.approx(T)
    inner = planted[1:-1]
    assert all(b - a > 0.3 for a, _, b in inner)  # a walk's stance: most of a step


def test_speed_pins_make_s_one_at_a_jump_and_ramp_over_sigma_steps():
    """A jump clip entered and left running: s = 1 at its take-off and landing, walking
    at the start and the end, and each ramp spans sigma steps."""
    _, analyses = library()
    tracks = {a.name: make_track(a) for a in analyses}
    jump = tracks["run"]
    jump = type(jump)(**{**jump.__dict__, "name": "leap", "kind": "jump", "entry_gait": "run",
                         "exit_gait": "run"})
    tracks["leap"] = jump
    steps = [PlanStep(j % 2, "leap" if j == 10 else None, None if j == 10 else np.array([1.0]))
             for j in range(20)]
    pins = speed_pins(steps, tracks)
    assert pins == [(0.0, 0.0), (10.0, 1.0), (11.0, 1.0), (20.0, 0.0)]
    for sigma in (1.0, 2.0, 3.0):
        u = np.linspace(0, 20, 2001)
        s = speed_parameter(u, *zip(*pins), sigma=sigma)
        at = lambda x: s[np.argmin(abs(u - x))]  # noqa: E731
        assert at(10.0) == 1.0 and at(11.0) == 1.0 and at(0.0) == 0.0 and at(20.0) == 0.0
        rising = u[(s > 0) & (s < 1) & (u < 10)]
        assert rising.max() - rising.min() == pytest.approx(sigma, abs=0.02)


def test_the_report_has_the_curves_and_the_planted_frames():
    syn = run(arc_footsteps(10, 0.4))
    d = syn.to_dict(frame0=1.0)
    assert len(d["footprints"]) == 10
    assert {"time", "u", "tau", "s", "tau_first", "speed_pins"} <= set(d["curves"])
    assert len(d["curves"]["tau"]) == d["frames"] == len(d["body"]["position"])
    f = d["footprints"][3]
    assert f["planted"][0] <= f["frame"] <= f["planted"][1]
    assert set(d["weights"]) == set(syn.clips)


def test_a_path_of_one_footprint_or_an_unknown_clip_is_refused():
    fs = arc_footsteps(6, 0.0)
    with pytest.raises(BlendError, match="single footprint"):
        run(fs[:1])
    bad = fs[:3] + [PathFootprint(1, fs[3].position, 0.0, 2.0, "moonwalk", "walk")]
    with pytest.raises(BlendError, match="moonwalk"):
        run(bad)


def test_easing_the_end_onto_the_goal_moves_a_refused_footprint_part_of_the_way():
    """A footprint the surface refuses at its full new place goes half (or a quarter) of
    the way where it may stand, instead of staying behind and kinking the path."""
    from footstep_planner.core.synth.passes import ease_end

    pos = np.array([[float(i), 0.0, 0.0] for i in range(8)])
    heading = np.zeros(8)

    def snap(p, h):  # a wall at y = 0.3 the footprints may not cross
        return p, p[:, 1] <= 0.3

    out = ease_end(pos, heading, [0.0, 0.2], snap)
    np.testing.assert_allclose(out[-2:, 1], 0.2)  # allowed: the whole way
    out = ease_end(pos, heading, [0.0, 0.5], snap)
    np.testing.assert_allclose(out[-2:, 1], 0.25)  # refused at 0.5, standing at half of it
    assert np.all(out[-6:, 1] > 0) and np.all(out[:, 1] <= 0.3)  # each moved towards it, none past the wall
    out = ease_end(pos, heading, [0.0, 1.0], snap)
    np.testing.assert_allclose(out[-2:, 1], 0.25)  # refused at 1 and 0.5, a quarter of the way
    assert np.all(out[:, 1] <= 0.3)
