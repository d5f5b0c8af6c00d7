"""Steps across small gaps (issue 28), ``Settings.cross_gaps`` (on by default): a walk or
run step crosses any gap its swing clears when both its footprints stand, from one piece
of ground to another (stepping stones, the gaps between slabs, a gutter), never over a
floor's own corner or notch; only a gap no step spans needs a jump, and a refusal names
the gap against the longest step as well as against the jump."""

import numpy as np
import pytest

from benchmarks.scene_generator import held_out_scenes, plan_scene, sample_character, stones
from conftest import box, needs_cmu, plane, standing
from footstep_planner.core.plan.navgraph import PlanError, Planner
from footstep_planner.core.base.settings import Settings
from footstep_planner.core.plan.surface import MeshGround, TriMesh

SCENES = {s.name: s for s in held_out_scenes()}
FWD = np.array([0.0, -1.0])
EAST = np.pi / 2


def _on_a_plate(scene, p) -> bool:
    return any(x0 - 1e-6 <= p[0] <= x1 + 1e-6 and y0 - 1e-6 <= p[1] <= y1 + 1e-6 and abs(p[2] - z0) < 0.02
               for x0, x1, y0, y1, z0, _, _ in scene.plates)


@pytest.fixture(scope="module")
def sample(fp):
    """The sample character (the mannequin and its generated clips)."""
    return sample_character(fp.__name__)


def _walks_the_stones(character, name="stones_straight"):
    scene = SCENES[name]
    pl, result = plan_scene(scene, character)  # (the default settings)
    fs = result.footprints
    assert np.linalg.norm(fs[-1].position[:2] - np.asarray(scene.goal)[:2]) <= pl.settings.goal_radius
    assert all(_on_a_plate(scene, f.position) for f in fs), [f.position for f in fs]
    rocks = [k for k, p in enumerate(scene.plates) if p[1] - p[0] < 0.6]
    on = {k for f in fs for k in rocks
          if scene.plates[k][0] <= f.position[0] <= scene.plates[k][1]
          and scene.plates[k][2] <= f.position[1] <= scene.plates[k][3]}
    return fs, on, rocks


@needs_cmu
def test_cmu_walks_the_stepping_stones_every_footprint_on_a_stone(bench_character):
    fs, on, rocks = _walks_the_stones(bench_character)
    assert not any(f.jump for f in fs)  # 20 to 40 cm gaps: steps, not leaps
    assert len(on) >= len(rocks) - 1  # stone to stone, not over them


def test_the_sample_character_walks_the_stepping_stones_every_footprint_on_a_stone(sample):
    """Six stones with gaps of 20 to 30 cm: the sample character's walk (0.75 m at most,
    its foot 0.25 m long) spans 0.5 m, but from a stone's front edge only."""
    SCENES["stones_sample"] = stones(np.random.default_rng(1), "stones_sample", 6, gaps=(0.2, 0.3))
    fs, on, rocks = _walks_the_stones(sample, "stones_sample")
    assert not any(f.jump for f in fs)
    assert len(on) >= len(rocks) - 1


def test_the_sample_character_walks_stepping_stones_40_cm_apart(sample):
    """Gaps of 40 cm: a footprint landing partly on a stone is moved wholly onto it
    (``islands.Patches``), so the search finds the few centimetres of a stone's edge its
    steps span the gap from; the footprints on the stones are kept where planned."""
    SCENES["stones_40"] = stones(np.random.default_rng(1), "stones_40", 6, gaps=(0.4, 0.4))
    fs, on, rocks = _walks_the_stones(sample, "stones_40")
    assert not any(f.jump for f in fs)
    assert len(on) == len(rocks)  # (every stone stepped on)
    rocky = [f for f in fs if any(SCENES["stones_40"].plates[k][0] <= f.position[0] <= SCENES["stones_40"].plates[k][1]
                                  for k in rocks)]
    assert rocky and all(f.tread for f in rocky)


@needs_cmu
def test_cmu_walks_stepping_stones_40_cm_apart(bench_character):
    """CMU's steps (its run spans 0.9 m) on the 40 cm stones: no footprint off a stone, and
    no jump onto or off one but past the last, straight to the far floor (a gap no step
    spans along that line; the cheapest path, plain A*'s, takes it too)."""
    SCENES["stones_40"] = stones(np.random.default_rng(1), "stones_40", 6, gaps=(0.4, 0.4))
    fs, on, rocks = _walks_the_stones(bench_character, "stones_40")
    assert len(on) >= len(rocks) - 1
    far = SCENES["stones_40"].plates[-1]
    assert all(b.position[0] >= far[0] for a, b in zip(fs[:-1], fs[1:]) if b.jump)
    assert sum(f.jump for f in fs) <= 1


def _steps(jump_len=1.7):
    from test_navgraph import steps

    return steps(jump_len=jump_len)


def _two_floors(gap):
    return MeshGround(TriMesh.concat([plane(-2, 5, -1, 1, name="A"), plane(5 + gap, 12, -1, 1, name="B")]))


@pytest.mark.parametrize("gap", [0.2, 0.35])
def test_a_gap_a_walking_step_spans_is_walked_across(gap):
    """The test library's walk steps 0.62 m (0.6 on, 0.15 across) with a foot 0.26 m long:
    it spans 0.36 m; its run (1.1 m) more. A gap it spans is crossed by a step, never a
    jump."""
    pl = Planner(_two_floors(gap), None, _steps(), FWD, settings=Settings(run_penalty=1.0))
    goal = np.array([10.0, 0.0, 0.0])
    r = pl.plan(start(0, 0), goal)
    across = [b for a, b in zip(r.footprints[:-1], r.footprints[1:]) if a.position[0] < 5 < 5 + gap < b.position[0]]
    assert len(across) == 1 and not across[0].jump
    assert not any(f.jump for f in r.footprints)


def test_only_a_gap_no_step_spans_is_jumped():
    """1.0 m: beyond the run's 1.1 m step less the foot: a jump (from a run)."""
    pl = Planner(_two_floors(1.0), None, _steps(), FWD, settings=Settings(run_penalty=0.0))
    r = pl.plan(start(0, 0), np.array([10.0, 0.0, 0.0]))
    across = [(a, b) for a, b in zip(r.footprints[:-1], r.footprints[1:]) if a.position[0] < 5 < 6 < b.position[0]]
    assert len(across) == 1 and across[0][1].jump and across[0][0].gait == "run"


def test_a_refusal_names_the_gap_against_the_longest_step_and_the_jump():
    pl = Planner(_two_floors(2.5), None, _steps(), FWD)
    with pytest.raises(PlanError, match=r"the gap beyond is 2\.[45]\d m wide; the library's longest running step "
                                        r"spans a gap of 0\.8\d m \(1\.11 m from footprint to footprint, less the "
                                        r"foot's 0\.26 m\), and its jump reaches 1\.70 m"):
        pl.plan(start(0, 0), np.array([10.0, 0.0, 0.0]))


def test_without_cross_gaps_a_refusal_says_a_step_would_span_the_gap_with_it_on():
    pl = Planner(_two_floors(2.5), None, _steps(), FWD, settings=Settings(cross_gaps=False))
    with pytest.raises(PlanError, match=r"less the foot's 0\.26 m\) with Settings\.cross_gaps on \(it is off: every "
                                        r"gap is jumped\), and its jump reaches 1\.70 m"):
        pl.plan(start(0, 0), np.array([10.0, 0.0, 0.0]))


def _u_floor():
    """Two strips 2 m wide with a notch 0.3 m wide between them, joined at one end (a U
    of three rectangles: a strip's corner on the end's edge, the other shared)."""
    return MeshGround(TriMesh.concat([plane(-2, 6, -2.15, -0.15, name="A"), plane(-2, 6, 0.15, 2.15, name="B"),
                                      plane(6, 8, -2.15, 2.15, name="C")]))


def _on_the_u(p):
    x, y = p[..., 0], p[..., 1]
    return (((x >= -2) & (x <= 6) & (np.abs(y) >= 0.15) & (np.abs(y) <= 2.15))
            | ((x >= 6) & (x <= 8) & (np.abs(y) <= 2.15)))


def test_a_step_never_cuts_over_a_floors_notch():
    """Across the notch of one floor, 0.3 m (a walking step spans it), from one strip to the
    other: the path walks round by the U's end, every step's way over the floor."""
    pl = Planner(_u_floor(), None, _steps(), FWD)
    r = pl.plan(start(3, -1.15), np.array([3.0, 1.15, 0.0]))
    p = np.array([f.position for f in r.footprints])
    t = np.linspace(0.0, 1.0, 51)
    ways = p[:-1, None, :2] + (p[1:, None, :2] - p[:-1, None, :2]) * t[None, :, None]
    assert _on_the_u(ways).all()
    assert p[:, 0].max() > 6.0 and not any(f.jump for f in r.footprints)


def test_the_islands_of_a_ground():
    """Touching rectangles (a vertex shared, a corner on the other's edge) are one island;
    a stone, and a gutter's bottom deeper than a step, are islands of their own."""
    from footstep_planner.core.plan.islands import Islands

    g = MeshGround(TriMesh.concat([plane(-2, 6, -2.15, -0.15), plane(-2, 6, 0.15, 2.15), plane(6, 8, -2.15, 2.15),
                                   plane(9, 9.5, 0, 0.5), plane(10, 11, -1, 1, z=-0.5), plane(11, 12, -1, 1)]))
    isl = Islands.of(g, 0.3)
    at = isl.at(g, np.array([[0, -1, 0], [0, 1, 0], [7, 0, 0], [9.2, 0.2, 0], [10.5, 0, -0.5], [11.5, 0, 0]], float))
    assert at[0] == at[1] == at[2] and len(set(at.tolist())) == 4


def test_a_walking_step_never_crosses_a_wall_over_a_gap():
    """A step may cross a gap, not an obstacle standing in it."""
    g = _two_floors(0.3)
    wall = MeshGround(box((5.0, -1.5, -1.0), (5.3, 1.5, 2.5), name="wall"))
    with pytest.raises(PlanError):
        Planner(g, wall, _steps(), FWD).plan(start(0, 0), np.array([10.0, 0, 0]))


def start(x, y, heading=EAST):
    return standing(x, y, heading, FWD)


def test_without_cross_gaps_a_narrow_gap_is_jumped_not_stepped():
    """``Settings.cross_gaps`` off: a step walks on ground that continues under it; a 0.3 m
    gap is jumped."""
    pl = Planner(_two_floors(0.3), None, _steps(), FWD, settings=Settings(run_penalty=0.0, cross_gaps=False))
    r = pl.plan(start(0, 0), np.array([10.0, 0.0, 0.0]))
    across = [(a, b) for a, b in zip(r.footprints[:-1], r.footprints[1:]) if a.position[0] < 5 < 5.3 < b.position[0]]
    assert len(across) == 1 and across[0][1].jump
