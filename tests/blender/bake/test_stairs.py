"""Stairs it never saw, square and straight (issue 28): the held-out planner scenes' real
stairs (17 cm risers, 28 cm treads, 1.1 to 1.5 m wide, a landing and a 90-degree turn),
climbed and descended with the sample character and with CMU: every footprint on a tread
faces along its flight within 10 degrees, the body's way (between the feet) within 10 cm
of a straight line along each flight. (That the treads are found wherever stairs stand,
turned and moved, is ``tests/core/plan/test_treads.py``'s.)"""

import numpy as np
import pytest

from benchmarks.scene_generator import held_out_scenes, plan_scene, sample_character
from conftest import needs_cmu
from stairs_checks import square_and_straight

STAIRS = {s.name: s for s in held_out_scenes() if s.kind == "stairs"}


def _check(pl, result):
    pos = np.array([f.position for f in result.footprints], float)
    head = np.array([f.heading for f in result.footprints], float)
    square_and_straight(pl, pos, head)
    assert abs(pos[-1, 2] - pos[0, 2]) > 1.5  # (both flights: up or down 12 risers)


@pytest.fixture(scope="module")
def sample(fp):
    return sample_character(fp.__name__)


@pytest.mark.parametrize("name", sorted(STAIRS))
def test_the_sample_character_takes_unseen_stairs_square_and_straight(sample, name):
    pl, result = plan_scene(STAIRS[name], sample)
    _check(pl, result)


@needs_cmu
@pytest.mark.parametrize("name", sorted(STAIRS))
def test_cmu_takes_unseen_stairs_square_and_straight(bench_character, name):
    pl, result = plan_scene(STAIRS[name], bench_character)
    _check(pl, result)
