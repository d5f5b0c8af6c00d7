"""The overlay's geometry (core/report/overlay.py): what the viewport draws, as arrays."""

import numpy as np

from footstep_planner.core.report import overlay as geo
from footstep_planner.core.plan.surface import FootShape


def test_footprint_triangles_cover_each_foot_and_sit_just_above_it():
    pos = np.array([[0.0, 0.0, 0.0], [1.0, 2.0, 0.5]])
    head = np.array([0.0, np.pi / 2])
    foot = FootShape(back=0.1, front=0.16, half_width=0.05)
    tri, col = geo.footprint_triangles(pos, head, np.array([0.0, -1.0]), foot, [0, 1], ["walk", "leap"],
                                       [False, True])
    assert tri.shape == (12, 3) and col.shape == (12, 4)
    for i in range(2):
        t = tri[6 * i:6 * i + 6].reshape(2, 3, 3)
        area = sum(0.5 * np.linalg.norm(np.cross(a[1] - a[0], a[2] - a[0])) for a in t)
        assert area == np.float64(area) and abs(area - 0.26 * 0.1) < 1e-9  # the foot's rectangle
        np.testing.assert_allclose(tri[6 * i:6 * i + 6, 2], pos[i, 2] + geo.LIFT)
        centre = tri[6 * i:6 * i + 6, :2].mean(axis=0)
        assert np.linalg.norm(centre - pos[i, :2]) < 0.1
    assert np.allclose(col[6:, :3], col[6, :3])  # one colour a footprint
    assert min(col[6, 0], col[6, 1]) > col[6, 2] + 0.3  # the jump is yellow
    assert col[0, 2] > col[0, 0]  # a left foot is blue


def test_colours_tell_feet_and_clips_apart():
    c = geo.footprint_colours([0, 1], ["walk", "walk"], [False, False])
    assert not np.allclose(c[0], c[1])  # left and right differ
    c = geo.footprint_colours([0, 0, 0], ["walk", "run", "walk_turn@+0.3"], [False] * 3)
    assert not np.allclose(c[0], c[1])  # clips differ in shade
    same = geo.footprint_colours([0, 0], ["walk_turn@+0.3", "walk_turn@-0.2"], [False, False])
    np.testing.assert_allclose(same[0], same[1])  # blends of one group share its shade


def test_polyline_and_crosses():
    seg = geo.polyline_segments(np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0.2]], float), lift=0.05)
    assert seg.shape == (4, 3)
    np.testing.assert_allclose(seg[1], seg[2])  # joined end to start
    np.testing.assert_allclose(seg[:, 2], [0.05, 0.05, 0.05, 0.25])
    assert geo.polyline_segments(np.zeros((1, 3))).shape == (0, 3)
    c = geo.crosses(np.array([[1.0, 1.0, 0.0]]), size=0.1)
    assert c.shape == (4, 3) and np.isclose(np.linalg.norm(c[0] - c[1]), 0.2)


def test_the_facing_arrow_points_along_minus_y_turned_by_the_z_rotation():
    from footstep_planner.core.report.overlay import facing_arrow

    for z, want in ((0.0, (0, -1)), (np.pi / 2, (1, 0)), (np.pi, (0, 1)), (-np.pi / 2, (-1, 0))):
        seg = facing_arrow([1.0, 2.0, 0.5], z, length=0.6)
        assert seg.shape == (6, 3)
        shaft = seg[1] - seg[0]
        np.testing.assert_allclose(shaft[:2] / 0.6, want, atol=1e-12)
        assert np.allclose(seg[:, 2], seg[0, 2]) and seg[0, 2] > 0.5  # flat, just above the ground
        # the head's two strokes start at the tip and lean back either side of the shaft
        assert np.allclose(seg[2], seg[1]) and np.allclose(seg[4], seg[1])
        assert (seg[3] - seg[1]) @ shaft < 0 and (seg[5] - seg[1]) @ shaft < 0


def test_rings_lie_flat_round_each_point():
    from footstep_planner.core.report.overlay import LIFT, rings

    pts = np.array([[0.0, 0.0, 0.0], [2.0, 1.0, 0.5]])
    seg = rings(pts, radius=0.2, segments=12)
    assert seg.shape == (2 * 12 * 2, 3)
    for k, p in enumerate(pts):
        mine = seg[k * 24:(k + 1) * 24]
        assert np.allclose(np.linalg.norm(mine[:, :2] - p[:2], axis=1), 0.2)
        assert np.allclose(mine[:, 2], p[2] + LIFT)
    assert rings(np.zeros((0, 3))).shape == (0, 3)
