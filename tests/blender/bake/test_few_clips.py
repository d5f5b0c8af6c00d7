"""A character that arrives with one walk: its straight steps are bent into arcs up to
``bend_curvature`` (core.steps), so the planner still turns, and the synthesis follows
the bent footprints (the refinement pulls towards the clip bent as the plan bent it)."""

from __future__ import annotations

import functools
from importlib import import_module

import numpy as np
import pytest

from footstep_planner.core.clips.analysis import analyze_clip
from footstep_planner.core.clips.library import propose_library
from footstep_planner.core.footprint import Leg, PathFootprint
from footstep_planner.core.plan.navgraph import PlanError, Planner
from footstep_planner.core.synth.labels import label_weights
from footstep_planner.core.synth.pipeline import surface_snap, synthesize
from footstep_planner.core.base.settings import Settings
from footstep_planner.core.clips.steps import bend_chain, bent_step, library_steps
from footstep_planner.core.plan.surface import FootShape, MeshGround, TriMesh, footprint_support
from conftest import plane, standing
from synth import synthetic_gait

FWD = np.array([0.0, -1.0])  # the synthetic rig's rest forward
EAST = np.pi / 2  # heading of +x
WALK = dict(speed=1.3, stride=1.4, duty=0.62)


@functools.lru_cache(maxsize=None)
def analysed(name, **kw):
    return analyze_clip(synthetic_gait(name=name, cycles=4, **kw)[0])


def one_walk():
    a = analysed("walk", **WALK)
    return propose_library([a]), [a]


def label_tau(label):
    return float(label.rsplit("@", 1)[1]) if "@" in label else 0.0


def start(x, y, heading=EAST):
    return standing(x, y, heading, FWD)


def corridor():
    """An L of ground 2 m wide: east from x = -1 to 6, then north from y = 1 to 8."""
    return MeshGround(TriMesh.concat([plane(-1, 6, -1, 1, name="A"), plane(4, 6, 1, 8, name="B")]))


GOAL = np.array([5.0, 6.5, 0.0])  # round the bend


def chain(steps, label, n, foot=0):
    """Footprints walking ``n`` steps of ``label`` from the origin, heading 0."""
    fs = [PathFootprint(foot, np.zeros(3), 0.0, 0.0, "start", "walk")]
    for _ in range(n):
        f = fs[-1]
        j = int(np.flatnonzero((steps.label == label) & (steps.foot == f.foot))[0])
        ang = f.heading + np.arctan2(FWD[1], FWD[0])
        fw, lf = np.array([np.cos(ang), np.sin(ang)]), np.array([-np.sin(ang), np.cos(ang)])
        p = f.position[:2] + steps.fwd[j] * fw + steps.left[j] * lf
        fs.append(PathFootprint(1 - f.foot, np.array([p[0], p[1], 0.0]), f.heading + float(steps.turn[j]),
                           f.time + float(steps.duration[j]), label, "walk"))
    return fs


# ----------------------------------------------------------------------------- steps

@pytest.mark.parametrize("bend", [0.8, 0.5])
def test_one_straight_walk_gives_steps_turning_both_ways_up_to_the_bend_limit(bend):
    lib, analyses = one_walk()
    st = library_steps(lib, analyses, bend_curvature=bend)
    straight = (st.label == "walk") & (st.stride == 1.0)  # (the clip's own stride)
    assert straight.sum() == 2 and np.abs(st.turn[straight]).max() < 1e-3
    fwd0 = float(st.fwd[straight].mean())  # the straight step's length along its centre line
    taus = np.array([label_tau(s) for s in st.label])
    assert taus.max() == pytest.approx(bend) and taus.min() == pytest.approx(-bend)
    assert np.all(np.diff(np.unique(taus)) <= 0.2 + 1e-9)  # a few curvatures between
    # each bent step turns by its curvature times the straight step's length, and no further
    np.testing.assert_allclose(st.turn, taus * fwd0, atol=2e-3)
    assert np.abs(st.turn).max() <= bend * fwd0 + 2e-3
    assert st.turn.max() > 0 > st.turn.min()
    # the bent steps play the walk: its own group, whose one clip takes all the weight
    for s in set(st.label):
        np.testing.assert_allclose(label_weights(s, lib, ["walk"]), [1.0])
    # bent: the same arc length, the same duration
    assert np.allclose(st.duration[st.foot == 0], st.duration[straight & (st.foot == 0)][0])
    # without the limit (and without adapted strides) only the clip's own steps are left
    none = library_steps(lib, analyses, bend_curvature=0.0, stride=(1.0, 1.0))
    assert none.n == 2 and np.abs(none.turn).max() < 1e-3


def test_bent_steps_walk_an_arc_of_their_curvature():
    """Chained, the steps bent to k put the feet either side of a circle of radius 1/k,
    as far apart as the straight walk's feet."""
    lib, analyses = one_walk()
    st = library_steps(lib, analyses)
    width = abs(float(st.left[st.label == "walk"][0]))
    for k in (0.8, -0.4):
        fs = chain(st, f"walk_turn@{k:+.3f}", 16)
        p = np.array([f.position[:2] for f in fs])
        r = np.abs(1.0 / k)
        # heading 0 walks along -y, its left is +x; the first footprint is the left foot's
        centre = np.array([-width / 2 + 1.0 / k, 0.0])
        d = np.linalg.norm(p - centre, axis=1)
        np.testing.assert_allclose(np.abs(d - r), width / 2, atol=0.01)


def test_a_clip_bent_to_its_own_curvature_is_unchanged_and_a_turning_library_keeps_its_own_turns():
    veer = analysed("walk_veer_left", curvature=0.5, **WALK)
    walk = analysed("walk", **WALK)
    lib = propose_library([walk, veer])
    st = library_steps(lib, [walk, veer])
    taus = np.array([label_tau(s) if "@" in s else {"walk": 0.0}.get(s, 0.5) for s in st.label])
    # bent beyond the veer (0.5 .. 0.8, from the veer) and right of the straight walk
    assert taus.max() == pytest.approx(0.8) and taus.min() == pytest.approx(-0.8)
    assert not np.any((taus > 0.501) & (taus < 0.6))  # BEND_SPACING: 0.65 then 0.8
    # the veer's own steps come back when bent to its own curvature
    own = {f: np.r_[st.fwd[i], st.left[i], st.turn[i], st.duration[i]]
           for i, f in enumerate(st.foot) if st.label[i] == "walk_veer_left"}
    for foot in (0, 1):
        np.testing.assert_allclose(bent_step(own, foot, by=0.0), own[foot], atol=1e-9)
    # a library whose walks turn to +-1.5 1/m gets no bent steps at all, nor do its runs
    kw = dict(WALK, speed=1.1, stride=1.3)
    run = dict(speed=3.0, stride=2.4, duty=0.35)
    full = [walk, analysed("walk_turn_left", curvature=1.5, **kw), analysed("walk_turn_right", curvature=-1.5, **kw),
            analysed("run", **run)]
    lib = propose_library(full)
    a, b = library_steps(lib, full), library_steps(lib, full, bend_curvature=0.0)
    assert a.n == b.n and list(a.label) == list(b.label)
    np.testing.assert_array_equal(a.fwd, b.fwd)
    assert lib.bend_of("walk_turn@+0.800") == 0.0 and lib.bend_of("walk") == 0.0


def test_bend_chain_bends_the_played_steps_as_the_plan_bent_them():
    lib, analyses = one_walk()
    st = library_steps(lib, analyses)
    straight, bent = chain(st, "walk", 12), chain(st, "walk_turn@+0.600", 12)
    p = np.array([f.position for f in straight])
    h = np.array([f.heading for f in straight])
    bends = np.array([lib.bend_of(f.label) for f in bent[1:]])
    assert np.allclose(bends, 0.6)
    bp, bh = bend_chain(p, h, bends, FWD)
    np.testing.assert_allclose(bp, [f.position for f in bent], atol=1e-6)
    np.testing.assert_allclose(bh, [f.heading for f in bent], atol=1e-6)
    same = bend_chain(p, h, np.zeros(len(p) - 1), FWD)
    assert same[0] is p and same[1] is h


# ----------------------------------------------------------------------------- planning

@functools.lru_cache(maxsize=None)
def corridor_plan():
    lib, analyses = one_walk()
    pl = Planner(corridor(), None, library_steps(lib, analyses), FWD)
    return pl, pl.plan(start(0, 0), GOAL)


def test_one_walk_plans_round_a_bend_that_it_cannot_pass_without_bending():
    lib, analyses = one_walk()
    straight = Planner(corridor(), None, library_steps(lib, analyses, bend_curvature=0.0), FWD,
                       settings=Settings(bend_curvature=0.0))
    with pytest.raises(PlanError, match="cannot be reached"):
        straight.plan(start(0, 0), GOAL)
    pl, r = corridor_plan()
    fs = r.footprints
    assert np.linalg.norm(fs[-1].position[:2] - GOAL[:2]) <= pl.settings.goal_radius
    assert [f.foot for f in fs[1:]] == [1 - f.foot for f in fs[:-1]]
    sup = footprint_support(pl.ground, None, np.array([f.position for f in fs[1:]]),
                            np.array([f.heading for f in fs[1:]]), FWD, pl.foot)
    assert sup.ok.all(), sup.reason
    taus = [label_tau(f.label) for f in fs[1:]]
    assert max(taus) > 0.3 and all(abs(t) <= 0.8 + 1e-9 for t in taus)
    # the heading turned left by about a quarter turn
    assert np.degrees(np.angle(np.exp(1j * (fs[-1].heading - fs[0].heading)))) == pytest.approx(90, abs=35)


# ----------------------------------------------------------------------------- synthesis

def run(footsteps, ground, goal=None):
    lib, analyses = one_walk()
    snap = surface_snap(ground, None, FWD, FootShape())
    return synthesize(footsteps, lib, analyses, Leg(goal=goal), Settings(), fps=30.0, forward=FWD, snap=snap), snap


def test_the_motion_of_the_bent_plan_follows_its_footprints_round_the_bend():
    pl, r = corridor_plan()
    planned = np.array([f.position for f in r.footprints])
    syn, snap = run(r.footprints, pl.ground)
    pos, head = syn.footprints
    for arr in (syn.body_position, syn.body_heading, syn.weights, syn.clip_time, syn.tau_final, pos, head):
        assert np.isfinite(arr).all()
    assert np.linalg.norm(pos[:, :2] - planned[:, :2], axis=1).max() < 0.03
    assert snap(pos, head)[1].all()  # every footprint on the corridor
    # the body turns the corner: about a quarter turn, at about the bend's curvature; cut
    # off mid-stride at the last footprint (no standing), it lags the feet by up to about
    # 15 degrees, and stopping to standing (as every bake does) it ends facing them
    turned = np.degrees(np.unwrap(syn.body_heading)[-1] - syn.body_heading[0])
    h = np.unwrap([f.heading for f in r.footprints])
    assert turned == pytest.approx(np.degrees(h[-4:].mean() - h[0]), abs=20)  # the last steps' heading
    lib, analyses = one_walk()
    stood = synthesize(r.footprints, lib, analyses, Leg(standing=True), Settings(), fps=30.0, forward=FWD, snap=snap)
    turned = np.degrees(np.unwrap(stood.body_heading)[-1] - stood.body_heading[0])
    assert turned == pytest.approx(np.degrees(h[-2:].mean() - h[0]), abs=5)
    assert 0.5 < syn.tau_final.max() < 1.0 and syn.tau_final.min() > -0.5
    # with the goal, the body ends on it
    syn, _ = run(r.footprints, pl.ground, goal=GOAL)
    assert np.linalg.norm(syn.body_position[-1, :2] - GOAL[:2]) < 0.02


@pytest.mark.parametrize("k", [0.8, -0.4])
def test_an_arc_of_bent_steps_is_walked_at_its_curvature(k):
    lib, analyses = one_walk()
    fs = chain(library_steps(lib, analyses), f"walk_turn@{k:+.3f}", 24)
    ground = MeshGround(plane(-20, 20, -20, 20))
    syn, _ = run(fs, ground)
    pos, _ = syn.footprints
    assert np.linalg.norm(pos[:, :2] - np.array([f.position[:2] for f in fs]), axis=1).max() < 0.03
    n = len(syn.tau_final)
    np.testing.assert_allclose(syn.tau_final[int(0.3 * n):int(0.7 * n)], k, rtol=0.05)


# ----------------------------------------------------------------------------- Blender

def test_the_sample_character_with_only_its_walk_reaches_the_goal_of_the_turns_scene(fp):
    import bpy

    bpy.ops.wm.read_homefile(use_empty=True)
    scene = import_module(fp.__name__ + ".blender.sample.sample_scenes").build("turns", bpy.context.scene)
    scene.render.fps = 30
    m = import_module(fp.__name__ + ".blender.sample.mannequin")
    ob, _ = m.add_to_scene(scene, "Start", clips=False)
    m.generate_clips(ob, names=["walk"])
    clips = import_module(fp.__name__ + ".blender.read.character").analyze_and_propose(ob)
    assert [a.name for a in clips.analyses] == ["walk"]
    planning = import_module(fp.__name__ + ".blender.planning")
    doc = planning.run(scene, ob, np.array(scene.objects["Goal"].location), start_marker=scene.objects["Start"])
    q = doc["quality"]
    assert q["goal"]["distance_m"] < 0.05
    assert q["footprint_error"]["max_mm"] < 5.0 and q["foot_skate"]["max_mm"] < 10.0
    labels = [f["clip"] for f in doc["footprints"][1:]]
    assert any(label.startswith("walk_turn@") for label in labels)
    assert set(labels) <= {"walk"} | {s for s in labels if s.startswith("walk_turn@")}
