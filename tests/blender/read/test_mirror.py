"""A clip's mirror image (core.mirror): reflected across the sagittal plane, left and
right swapped, so a jump taking off from one foot gives a jump from the other.

The core tests build symmetric rigs in numpy (the Footstep Mannequin's bone table, the
whole rig turned by any yaw, its bones rolled at random) and random poses; the last ones
plan with the real CMU library (subject 16 and the 49_05 leap) and skip without it."""

from __future__ import annotations

import functools
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from footstep_planner.core.sample import mannequin
from footstep_planner.core.clips.analysis import analyze_clip
from footstep_planner.core.synth.schedule import special_window
from footstep_planner.core.synth.tracks import make_track
from footstep_planner.core.clips.clip import clip_motion, root_frames
from footstep_planner.core.clips.library import Library, SpecialClip
from footstep_planner.core.clips.mirror import (Mirror, bone_mirror, mirror_analysis, mirror_motion, mirrored_jumps,
                                          mirrored_name, take_off_foot)
from footstep_planner.core.clips.rig import Rig, forward_kinematics
from footstep_planner.core.clips.steps import library_steps
from conftest import needs_cmu
from synth import synthetic_gait

FAST = settings(max_examples=20, deadline=None)


# ----------------------------------------------------------------------------- rigs, poses

@functools.lru_cache(maxsize=64)
def make_rig(yaw: float = 0.0, seed: int | None = None, mirrored_rolls: bool = True) -> Rig:
    """The mannequin's skeleton (symmetric), turned ``yaw`` about Z; with ``seed`` its
    left bones rolled at random and the right ones the mirror of the left's (Blender's
    X-mirror: the roll negated), or with ``mirrored_rolls`` False every bone rolled
    independently (rest frames that are no mirror images, as a BVH import may give)."""
    table = mannequin.bone_table()
    names = [row[0] for row in table]
    parents = [names.index(row[3]) if row[3] else -1 for row in table]
    rng = np.random.default_rng(seed)
    base = {n: (rng.uniform(-np.pi, np.pi) if seed is not None else 0.0) for n in names}
    if mirrored_rolls:  # the centre line's bones are their own mirror images: unrolled
        base.update({n: 0.0 for n in names if not n.endswith((".L", ".R"))})
    c, s = np.cos(yaw), np.sin(yaw)
    turn = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])
    rest, tails = [], []
    for name, head, tail, *_ in table:
        roll = base[name]
        if name.endswith(".R"):
            roll = -base[name[:-2] + ".L"] if mirrored_rolls else roll
        h, t = turn @ np.asarray(head), turn @ np.asarray(tail)
        rest.append(mannequin.bone_matrix(h, t, roll))
        tails.append(t)
    rest = np.array(rest)
    # exact rotations (Blender's formula is an approximation, to 1e-5, for a bone pointing
    # nearly along -Y; the mirror's exactness is that of the rest frames)
    rest[:, :3, :3] = Rotation.from_matrix(rest[:, :3, :3]).as_matrix()
    return Rig.build("Mirrored", names, parents, rest, np.array(tails))


def random_clip(rig: Rig, seed: int, n: int = 6, fps: float = 30.0):
    """A clip of ``n`` random poses of ``rig`` (every bone turned up to about 60 degrees,
    the hips moved about), as ``clip.clip_motion`` reads it."""
    rng = np.random.default_rng(seed)
    nb = len(rig.names)
    basis = np.tile(np.eye(4), (n, nb, 1, 1))
    basis[..., :3, :3] = Rotation.from_rotvec(rng.normal(0, 0.6, (n * nb, 3))).as_matrix().reshape(n, nb, 3, 3)
    basis[:, rig.role_index("hips"), :3, 3] = rng.normal(0, 0.4, (n, 3))
    return clip_motion(rig, f"random{seed}", basis, fps)


def played(rig: Rig, m) -> np.ndarray:
    """(N, B, 4, 4) the bones' matrices as the clip plays them: the pose (the bones'
    rotations, the hips at ``hips_in_root``, as ``pose.pose_bases`` keys them) carried
    by the root frames."""
    nb = len(rig.names)
    h = rig.role_index("hips")
    basis = np.tile(np.eye(4), (m.n, nb, 1, 1))
    basis[..., :3, :3] = m.local_rot
    basis[:, h] = np.linalg.inv(rig.rest[h]) @ m.hips_in_root
    return root_frames(m.root_pos, m.root_heading)[:, None] @ forward_kinematics(rig, basis)


def fk_reflection_error(rig: Rig, m) -> tuple[float, float, float]:
    """(bone positions, bone orientations, heel and toe points): the largest distance of
    the mirrored clip as played from the reflection of the clip as played; orientations
    compared as ``M G C`` (``core.mirror``), the feet's points from the mirrored foot
    bones and the mirrored clip's own heel and toe points."""
    mi = Mirror(rig)
    mm = mi.motion(m)
    w, wm = played(rig, m), played(rig, mm)
    pos = np.abs(wm[..., :3, 3] - mi.point(w[:, mi.perm][..., :3, 3])).max()
    rot = np.abs(wm[..., :3, :3] - np.einsum("ij,nbjk,bkl->nbil", mi.M, w[:, mi.perm][..., :3, :3], mi.C)).max()
    feet = 0.0
    for k, f in enumerate(mi.feet):
        for pts, local in ((mm.heel, mm.heel_local), (mm.toe, mm.toe_local)):
            feet = max(feet, np.abs((wm[:, f] @ local[k])[:, :3] - pts[k]).max())
    return float(pos), float(rot), float(feet)


# ----------------------------------------------------------------------------- the pose

def test_the_mannequins_sides_pair_by_name_and_the_centre_stays():
    rig = mannequin.rig()
    perm = bone_mirror(rig)
    names = rig.names
    pairs = {names[i]: names[j] for i, j in enumerate(perm)}
    assert pairs["thigh.L"] == "thigh.R" and pairs["hand.R"] == "hand.L" and pairs["heel.02.L"] == "heel.02.R"
    assert all(pairs[n] == n for n in names if n.startswith("spine"))
    assert (perm[perm] == np.arange(len(perm))).all()


@FAST
@given(yaw=st.floats(-np.pi, np.pi), rig_seed=st.integers(0, 2**16), pose_seed=st.integers(0, 2**16),
       mirrored_rolls=st.booleans())
def test_fk_of_the_mirrored_pose_is_the_reflection_of_fk_of_the_pose(yaw, rig_seed, pose_seed, mirrored_rolls):
    rig = make_rig(round(yaw, 3), rig_seed % 8, mirrored_rolls)
    pos, rot, feet = fk_reflection_error(rig, random_clip(rig, pose_seed))
    assert pos < 1e-6 and rot < 1e-6 and feet < 1e-6, (pos, rot, feet)


@FAST
@given(rig_seed=st.integers(0, 7), pose_seed=st.integers(0, 2**16))
def test_bones_whose_rest_frames_are_mirror_images_negate_two_quaternion_components(rig_seed, pose_seed):
    """The usual trick, as the derivation gives it: with the rest frames Blender's
    X-mirror gives (the rig facing -Y, the right bones' rolls the left's negated), a
    bone's mirrored rotation is its partner's with y and z negated."""
    rig = make_rig(0.0, rig_seed, True)
    m = random_clip(rig, pose_seed)
    mi = Mirror(rig)
    np.testing.assert_allclose(mi.C, np.broadcast_to(np.diag([-1.0, 1.0, 1.0]), mi.C.shape), atol=1e-9)
    q = Rotation.from_matrix(m.local_rot[:, mi.perm].reshape(-1, 3, 3)).as_quat()
    qm = Rotation.from_matrix(mi.motion(m).local_rot.reshape(-1, 3, 3)).as_quat()
    want = q * np.array([1.0, -1.0, -1.0, 1.0])
    assert np.abs(np.abs(np.einsum("ij,ij->i", want, qm)) - 1.0).max() < 1e-9


@FAST
@given(yaw=st.floats(-np.pi, np.pi), rig_seed=st.integers(0, 7), pose_seed=st.integers(0, 2**16),
       mirrored_rolls=st.booleans())
def test_mirroring_a_clip_twice_gives_it_back(yaw, rig_seed, pose_seed, mirrored_rolls):
    rig = make_rig(round(yaw, 3), rig_seed, mirrored_rolls)
    m = random_clip(rig, pose_seed)
    once = mirror_motion(m, rig)
    twice = mirror_motion(once, rig)
    assert once.name == "random%d~mirror" % pose_seed and twice.name == m.name
    for f in ("root_pos", "root_heading", "hips_in_root", "local_rot", "heel", "toe", "heel_local", "toe_local"):
        np.testing.assert_allclose(getattr(twice, f), getattr(m, f), atol=1e-9, err_msg=f)
    # and the mirror image is another clip: the root's heading turns the other way
    np.testing.assert_allclose(once.root_heading, -m.root_heading)


def test_a_rig_whose_sides_cannot_be_paired_is_refused_by_name():
    from footstep_planner.core.clips.mirror import MirrorError

    rig = mannequin.rig()
    names = list(rig.names)
    names[names.index("hand.R")] = "paw"  # no name pairs it, and...
    tails = rig.tails.copy()
    tails[names.index("paw")] += [0.0, 0.0, 0.3]  # ... it is not where hand.L's mirror is
    odd = Rig.build("Odd", names, rig.parents, rig.rest, tails)
    with pytest.raises(MirrorError, match="Odd.*hand.L"):
        bone_mirror(odd)


# ----------------------------------------------------------------------------- the analysis

RIG = mannequin.rig()


def gait_clip(curvature=0.0, rotation=0.0, duty=0.62, speed=1.2, stride=1.4, seed=0, name="gait"):
    """A synthetic gait (tests/synth.py: its feet alternate on known footprints) as a clip
    of the mannequin rig: random bone rotations (they do not move the feet here; the
    analysis reads them only to compare poses) and the synthetic root and feet."""
    m, truth = synthetic_gait(speed=speed, stride=stride, curvature=curvature, duty=duty, rotation=rotation,
                              cycles=3, fps=60.0, name=name)
    rng = np.random.default_rng(seed)
    nb = len(RIG.names)
    rot = Rotation.from_rotvec(rng.normal(0, 0.3, (m.n * nb, 3))).as_matrix().reshape(m.n, nb, 3, 3)
    return replace(m, local_rot=rot, hips_index=RIG.role_index("hips")), truth


def same_analysis(a, b, atol=1e-9):
    """Assert two analyses hold the same events, footprints and figures."""
    assert a.name == b.name and a.kind == b.kind and a.gait == b.gait
    for f in ("speed", "stride", "cycle", "tau"):
        assert getattr(a, f) == pytest.approx(getattr(b, f), abs=atol), f
    assert [s.foot for s in a.stances] == [s.foot for s in b.stances]
    np.testing.assert_allclose([(s.stance, s.strike, s.land, s.lift, s.liftoff) for s in a.stances],
                               [(s.stance, s.strike, s.land, s.lift, s.liftoff) for s in b.stances], atol=atol)
    for p, q in zip(a.footprints(), b.footprints()):
        assert p.foot == q.foot and p.heading == pytest.approx(q.heading, abs=atol)
        np.testing.assert_allclose(p.position, q.position, atol=atol)
    assert (a.contact == b.contact).all()
    np.testing.assert_allclose(a.balance, b.balance, atol=atol)


@functools.lru_cache(maxsize=32)
def analysed(**kw):
    m, truth = gait_clip(**kw)
    return analyze_clip(m), truth


#: headings the synthetic clips run at (rad): analyses are cached per clip
ROTATIONS = st.sampled_from([-2.5, -0.7, 0.0, 1.2, 3.0])
GAIT = settings(max_examples=8, deadline=None)


@GAIT
@given(curvature=st.sampled_from([-0.6, 0.0, 0.35]), rotation=ROTATIONS, duty=st.sampled_from([0.35, 0.62]))
def test_feet_contacts_and_stances_swap_sides(curvature, rotation, duty):
    a, _ = analysed(curvature=curvature, rotation=rotation, duty=duty)
    b = mirror_analysis(a, RIG)
    assert b.name == "gait~mirror" and b.tau == pytest.approx(-a.tau) and b.kind == a.kind and b.gait == a.gait
    assert [s.stance for s in b.stances] == sorted(s.stance for s in a.stances)
    by_time = {(round(s.stance, 9), s.foot): s for s in a.stances}
    for s in b.stances:
        o = by_time[(round(s.stance, 9), 1 - s.foot)]  # the same stance, on the other foot
        assert (s.strike, s.land, s.lift, s.liftoff) == (o.strike, o.land, o.lift, o.liftoff)
        f, g = s.footprint, o.footprint
        assert f.foot == s.foot and f.heading == pytest.approx(-g.heading, abs=1e-12)
        np.testing.assert_allclose(f.position, g.position * [-1, 1, 1], atol=1e-12)  # x -> -x: rest forward -Y
    assert (b.contact == a.contact[::-1]).all() and (b.balance == a.balance[::-1]).all()
    assert b.contact_intervals(0) == a.contact_intervals(1) and b.contact_intervals(1) == a.contact_intervals(0)
    same_analysis(mirror_analysis(b, RIG), a)


@settings(max_examples=4, deadline=None)
@given(curvature=st.sampled_from([-0.6, 0.0, 0.35]), rotation=ROTATIONS, duty=st.sampled_from([0.35, 0.62]))
def test_the_mirrored_analysis_is_the_analysis_of_the_mirrored_clip(curvature, rotation, duty):
    a, _ = analysed(curvature=curvature, rotation=rotation, duty=duty)
    same_analysis(analyze_clip(mirror_motion(a.motion, RIG)), mirror_analysis(a, RIG), atol=1e-6)


def as_jump(a, k: int):
    """Analysis ``a`` of a run, made a running jump whose flight is its ``k``-th."""
    return replace(a, kind="jump", entry_gait="run", exit_gait="run", jump_flights=[a.flights[k]])


@GAIT
@given(curvature=st.sampled_from([-0.4, 0.0, 0.3]), rotation=ROTATIONS, k=st.integers(0, 3),
       stride=st.sampled_from([1.9, 2.3]))
def test_the_mirrored_jump_takes_off_from_the_other_foot_with_the_same_length(curvature, rotation, k, stride):
    run, _ = analysed(curvature=curvature, rotation=rotation, duty=0.35, speed=3.0, stride=stride)
    jump = as_jump(run, min(k, len(run.flights) - 1))
    mirror = mirror_analysis(jump, RIG)
    assert take_off_foot(mirror) == 1 - take_off_foot(jump)
    lib = Library(specials=[SpecialClip(a.name, "jump", "run", "run") for a in (jump, mirror)])
    steps = library_steps(lib, [jump, mirror])
    one, other = steps.label == jump.name, steps.label == mirror.name
    assert one.sum() == other.sum() == 9 and steps.jump.all()
    assert set(steps.foot[one]) == {take_off_foot(jump)} and set(steps.foot[other]) == {1 - take_off_foot(jump)}
    # row for row (3 lengths x 3 turns, the turns' order reversed in the mirror): as
    # long, as long in time, sideways and turning the other way
    row = lambda f, sel: getattr(steps, f)[sel].reshape(3, 3)  # noqa: E731
    mine = lambda f: row(f, other)[:, ::-1]  # noqa: E731
    np.testing.assert_allclose(np.hypot(mine("fwd"), mine("left")), np.hypot(row("fwd", one), row("left", one)),
                               atol=1e-9)
    np.testing.assert_allclose(mine("fwd"), row("fwd", one), atol=1e-9)
    np.testing.assert_allclose(mine("left"), -row("left", one), atol=1e-9)
    np.testing.assert_allclose(mine("turn"), -row("turn", one), atol=1e-9)
    np.testing.assert_allclose(mine("duration"), row("duration", one), atol=1e-12)
    # the synthesis plays the mirror's step from the other foot over the same clip times
    foot = take_off_foot(jump)
    tr, tm = make_track(jump), make_track(mirror)
    assert special_window(tm, 1 - foot) == pytest.approx(special_window(tr, foot))
    # and what it plays is the reflection of the clip's track: in the root frame (the
    # rest axes) the sideways axis flips, the turning rate and the feet swap
    mi = Mirror(RIG)
    np.testing.assert_allclose(tm.vel, tr.vel @ mi.M[:2, :2].T, atol=1e-9)
    np.testing.assert_allclose(tm.yaw_rate, -tr.yaw_rate, atol=1e-9)
    for f in ("heel", "toe", "contact_point"):
        np.testing.assert_allclose(getattr(tm, f), getattr(tr, f)[::-1] @ mi.M.T, atol=1e-9, err_msg=f)
    np.testing.assert_allclose(tm.contact, tr.contact[::-1])
    np.testing.assert_allclose(tm.hips_in_root, mi.hips_in_root(tr.hips_in_root), atol=1e-12)
    assert sorted((1 - k, t) for k, t in tr.stances) == sorted(tm.stances)


def test_jumps_are_mirrored_only_where_the_other_foot_lacks_one():
    run, _ = analysed(duty=0.35, speed=3.0, stride=2.2)
    jump = as_jump(run, 1)
    other = as_jump(run, 2)
    assert take_off_foot(jump) != take_off_foot(other)
    made = mirrored_jumps([run, jump], RIG)
    assert [a.name for a in made] == [mirrored_name(jump.name)]
    # two clips of the same gaits from both feet: none; one from each foot of other gaits: both
    both = [jump, replace(other, name="jump2")]
    assert mirrored_jumps(both, RIG) == []
    walk_in = replace(other, name="jump2", entry_gait="walk")
    assert sorted(a.name for a in mirrored_jumps([jump, walk_in], RIG)) == ["gait~mirror", "jump2~mirror"]
    assert mirrored_jumps([made[0]], RIG) == []  # a mirror is never mirrored again


# ----------------------------------------------------------------------------- CMU, end to end

GAP = (8.0, 9.0)  # y (m) of the gap across the runway


@pytest.fixture(scope="module")
def cmu_setup(fp):
    """The CMU library's armature in a scene with the runway (nothing else), analysed
    for planning, with what the analysis added to Blender's data."""
    import bpy
    from importlib import import_module

    from conftest import cmu_armature

    bpy.ops.wm.read_homefile(use_empty=True)
    scene = bpy.context.scene
    scene.render.fps = 30
    ob = cmu_armature(fp)
    character = import_module(fp.__name__ + ".blender.read.character")
    before = {k: len(getattr(bpy.data, k)) for k in ("actions", "objects", "meshes", "armatures", "collections")}
    res = character.analyze_character(ob, mirrors=True)
    after = {k: len(getattr(bpy.data, k)) for k in before}
    lib = character.library_for(ob, res)
    return {"ob": ob, "clips": res, "library": lib, "made": (before, after), "character": character}


def runway_planner(setup):
    """A core Planner on a 3 m wide runway north, cut by a 1 m gap at y = 8..9, with the
    CMU library's steps, and the heading (rad) that faces north."""
    from footstep_planner.core.plan.navgraph import Planner
    from footstep_planner.core.plan.surface import MeshGround, TriMesh
    from conftest import plane

    analyses = setup["clips"].analyses
    steps = library_steps(setup["library"], analyses)
    ground = MeshGround(TriMesh.concat([plane(-1.5, 1.5, -12, GAP[0], name="A"),
                                        plane(-1.5, 1.5, GAP[1], 16, name="B")]))
    forward = np.asarray(analyses[0].motion.rest_forward, float)  # the armature stands unturned
    north = float(np.arctan2(1.0, 0.0) - np.arctan2(forward[1], forward[0]))
    return Planner(ground, None, steps, forward), steps, north


@needs_cmu
def test_cmu_jumps_from_both_feet_and_the_mirror_makes_nothing_in_blender(cmu_setup):
    res, lib = cmu_setup["clips"], cmu_setup["library"]
    before, after = cmu_setup["made"]
    assert before == after  # no action, object, mesh or collection made
    leap = "cmu_49_05_run_leap_run"
    assert res.mirrors == {leap + "~mirror": leap} and not res.errors
    assert [a.name for a in res.own] == [a.name for a in res.analyses if not a.name.endswith("~mirror")]
    assert [a.name for a in character_of(cmu_setup).analyze_character(cmu_setup["ob"]).analyses] == \
        [a.name for a in res.own]  # without ``mirrors``: the clips alone
    assert {sp.clip for sp in lib.specials if sp.kind == "jump"} == {leap, leap + "~mirror"}
    by = {a.name: a for a in res.analyses}
    steps = library_steps(lib, res.analyses)
    rows = {name: steps.foot[steps.label == name] for name in (leap, leap + "~mirror")}
    print("CMU jump rows per take-off foot:",
          {name: {"LR"[f]: int((feet == f).sum()) for f in (0, 1)} for name, feet in rows.items()})
    assert set(steps.foot[steps.jump]) == {0, 1}
    assert len(set(rows[leap])) == 1 and set(rows[leap + "~mirror"]) == {1 - rows[leap][0]}
    one, other = steps.label == leap, steps.label == leap + "~mirror"
    np.testing.assert_allclose(np.hypot(steps.fwd[other], steps.left[other]),
                               np.hypot(steps.fwd[one], steps.left[one]), atol=1e-9)
    # the mirror's analysis is the analysis of the mirrored clip
    rig = res.rig
    again = analyze_clip(mirror_motion(by[leap].motion, rig))
    m = by[leap + "~mirror"]
    assert [s.foot for s in again.stances] == [s.foot for s in m.stances]
    np.testing.assert_allclose([s.stance for s in again.stances], [s.stance for s in m.stances], atol=1e-6)
    # the CMU rig's sides pair by name; FK reflects the bones' orientations exactly and
    # their positions within the measured skeleton's own asymmetry
    pairs = dict(zip(rig.names, np.array(rig.names)[bone_mirror(rig)]))
    assert pairs["LHipJoint"] == "RHipJoint" and pairs["LeftHand"] == "RightHand" and pairs["Spine"] == "Spine"
    pos, rot, feet = fk_reflection_error(rig, by[leap].motion)
    mi = Mirror(rig)
    heads = rig.rest[:, :3, 3]
    off = np.linalg.norm(heads[mi.perm] - mi.point(heads), axis=1)
    legs = [rig.role_index(f"{part}_{x}") for part in ("thigh", "shin", "foot") for x in "lr"]
    print(f"CMU FK reflection error: positions {pos * 1000:.2f} mm (the rest skeleton's own asymmetry: "
          f"{off.max() * 1000:.2f} mm at {rig.names[int(np.argmax(off))]}, {off[legs].max() * 1000:.2f} mm "
          f"in the legs), orientations {rot:.1e}, heel/toe {feet * 1000:.2f} mm")
    assert rot < 1e-6 and pos < 0.05


@needs_cmu
def test_a_gap_can_be_jumped_from_either_foot(cmu_setup):
    """On a straight runway with a gap, the plans from starts 0.2 m apart take off from
    either foot, with the leap or its mirror; with the leap alone (the mirror's steps
    left out) they all take off from the leap's foot."""
    from footstep_planner.core.plan.navgraph import PlanError
    from conftest import standing

    planner, steps, north = runway_planner(cmu_setup)
    one_footed = replace(planner, steps=_without(steps, "~mirror"))
    leap = "cmu_49_05_run_leap_run"
    goal = np.array([0.0, 13.0, 0.0])
    take_offs = {}
    for k, y0 in enumerate(np.arange(-6.0, -2.9, 0.2)):
        start = standing(0.0, float(y0), north, planner.forward)
        got = {}
        # (the leap alone from every other start: it takes off from its one foot from any)
        for key, pl in (("both", planner), ("one", one_footed))[:2 if k % 2 == 0 else 1]:
            try:
                res = pl.plan(start, goal)
            except PlanError:
                continue
            fs = res.footprints
            jumps = [j for j in range(len(fs) - 1) if fs[j + 1].jump]
            assert len(jumps) == 1
            a, b = fs[jumps[0]], fs[jumps[0] + 1]
            assert a.position[1] < GAP[0] < GAP[1] < b.position[1]
            got[key] = (a.foot, b.label, len(fs), jumps[0], round(res.cost, 2))
        take_offs[round(float(y0), 1)] = got
    print("per start y: (take-off foot, clip, footprints, take-off footprint, cost):", take_offs)
    both = [g["both"] for g in take_offs.values() if "both" in g]
    assert len(both) >= 6
    assert {got[0] for got in both} == {0, 1}  # either foot, by where the run-up starts
    assert {got[1] for got in both} == {leap, leap + "~mirror"}
    assert all(got[1].endswith("~mirror") == (got[0] != both_feet(cmu_setup)[leap]) for got in both)
    one = [g["one"] for g in take_offs.values() if "one" in g]
    assert {got[0] for got in one} == {both_feet(cmu_setup)[leap]}  # the leap alone: its foot only
    # starts a step apart: one takes off from each foot
    ys = sorted(take_offs)
    assert any(take_offs[a]["both"][0] != take_offs[b]["both"][0]
               for a, b in zip(ys[:-1], ys[1:]) if "both" in take_offs[a] and "both" in take_offs[b])


@needs_cmu
def test_an_edited_library_mirrors_the_jumps_it_keeps_and_never_lists_a_mirror(cmu_setup):
    ob, character = cmu_setup["ob"], cmu_setup["character"]
    leap = "cmu_49_05_run_leap_run"
    props = ob.data.footstep
    try:
        character.write_library(ob, cmu_setup["library"], cmu_setup["clips"].analyses, edited=True)
        assert leap in [c.name for c in props.clips] and not [c.name for c in props.clips if "~" in c.name]
        res = character.analyze_character(ob, mirrors=True)
        lib = character.library_for(ob, res)
        assert res.mirrors == {leap + "~mirror": leap}
        assert {sp.clip for sp in lib.specials if sp.kind == "jump"} == {leap, leap + "~mirror"}
        next(c for c in props.clips if c.name == leap).usage = "EXCLUDED"  # the user leaves the leap out
        res = character.analyze_character(ob, mirrors=True)
        lib = character.library_for(ob, res)
        assert res.mirrors == {} and not [sp for sp in lib.specials if sp.kind == "jump"]
        # the clips' own analyses (the default: for the panel and the tables) hold no mirror
        assert [a.name for a in character.analyze_character(ob).analyses] == [a.name for a in res.analyses]
    finally:
        props.library_edited = False


@needs_cmu
def test_the_jumps_scene_planned_and_synthesized_with_the_mirror(fp, monkeypatch):
    """The whole planning stage with the mirrors (``planning.plan_setup`` analysing the
    character with ``mirrors=True``): the Jumps scene's gaps are jumped, a jump from the
    mirror plays that clip whole across its step, and the synthesized footprints stand
    on the surfaces."""
    from importlib import import_module

    from conftest import plan_sample

    planning = import_module(fp.__name__ + ".blender.planning")
    character = import_module(fp.__name__ + ".blender.read.character")
    monkeypatch.setattr(planning, "analyze_character", functools.partial(character.analyze_character, mirrors=True))
    scene, result, setup, goal = plan_sample(fp, "jumps")
    leap = "cmu_49_05_run_leap_run"
    assert leap + "~mirror" in setup.library.clips()
    syn = planning.synthesize(scene, result, setup)
    fs = list(syn.plan)
    jumps = [j for j in range(len(fs) - 1) if fs[j + 1].jump]
    print("Jumps scene: take-off foot and clip of each jump:", [("LR"[fs[j].foot], fs[j + 1].label) for j in jumps])
    assert len(jumps) == 2 and {fs[j + 1].label for j in jumps} <= {leap, leap + "~mirror"}
    feet = both_feet({"clips": setup})
    for j in jumps:
        assert fs[j].foot == feet[fs[j + 1].label]  # each clip from its own foot
    S = syn.final.schedule
    for j in jumps:
        inside = (S.t >= S.footprint_times[j]) & (S.t <= S.footprint_times[j + 1])
        assert inside.any() and np.all(S.weights[inside, S.clips.index(fs[j + 1].label)] == 1.0)
    core = import_module(fp.__name__ + ".core.plan.surface")
    pl = setup.planner
    pos, head = syn.footprints
    assert core.footprint_support(pl.ground, pl.obstacles, pos, head, setup.forward, pl.foot,
                                  core.SupportLimits(clearance=pl.clearance)).ok.all()
    assert np.linalg.norm(result.footprints[-1].position[:2] - goal[:2]) <= pl.settings.goal_radius


def character_of(setup):
    return setup["character"]


def both_feet(setup) -> dict[str, int]:
    """Clip name -> the foot its jump takes off from, for the jumps of ``setup["clips"]``
    (anything with ``analyses``)."""
    return {a.name: take_off_foot(a) for a in setup["clips"].analyses if a.kind == "jump"}


def _without(steps, suffix):
    """The StepSet ``steps`` without the rows whose label ends with ``suffix``."""
    from footstep_planner.core.clips.steps import StepSet

    keep = np.array([not str(lb).endswith(suffix) for lb in steps.label])
    return StepSet(*(getattr(steps, f)[keep] for f in ("fwd", "left", "turn", "duration", "foot", "gait", "jump",
                                                         "label")))
