"""The search around other characters in time (``core.plan.others``): a body is never
brought within the bodies' clearance of another's at the same time, a foot never lands on
a footprint another stands on then, and a path with no one near is the path without them."""

import numpy as np
from hypothesis import given, settings as hsettings, strategies as hs

from conftest import plane, standing
from footstep_planner.core.base.settings import Settings
from footstep_planner.core.plan.navgraph import HIPS_HEIGHT, Planner
from footstep_planner.core.plan.others import BODY_RADIUS, SAMPLE_SPACING, TIME_SLACK, Others
from footstep_planner.core.plan.stands import plan_round
from footstep_planner.core.plan.surface import MeshGround
from test_navgraph import EAST, FWD, steps

FASTEST = Settings(run_penalty=0.0)
FPS = 30.0


def _walker(name, times, xy, z=0.0, radius=BODY_RADIUS):
    """One other character whose hips follow ``xy`` (F, 2) at ``times`` (F,), feet never planted."""
    f = len(times)
    hips = np.c_[xy, np.full(f, z + HIPS_HEIGHT)]
    soles = np.zeros((2, f, 3))
    return name, hips, radius, soles, np.zeros((2, f), bool)


def _others(*walkers, times, feet=None):
    names, hips, radius, soles, planted = zip(*walkers)
    soles, planted = np.array(soles), np.array(planted)
    if feet is not None:  # ((n, foot, frames, point (3,)), ...): planted there over those frames
        for n, k, frames, at in feet:
            soles[n, k, frames] = at
            planted[n, k, frames] = True
    return Others.of(names, times, np.array(hips), np.array(radius), soles, planted, np.full(len(names), 0.26))


def _body_track(result, settings=FASTEST, scale=1.0):
    """(times (T,), body xy (T, 2)): the search's body between its feet, as ``_clear_of_others`` puts it."""
    fs = result.footprints
    t = np.array([f.time for f in fs])
    p = np.array([f.position[:2] for f in fs])
    mid = np.vstack([p[:1], 0.5 * (p[1:] + p[:-1])])
    return t, mid


def test_no_one_near_plans_the_path_alone():
    g = MeshGround(plane(-2, 12, -6, 6))
    goal = np.array([8.0, 0.0, 0.0])
    alone = Planner(g, None, steps(), FWD, settings=FASTEST).plan(standing(0, 0, EAST, FWD), goal)
    times = np.arange(0, 20, 1 / FPS)
    far = _others(_walker("far", times, np.c_[np.full(len(times), 5.0), np.full(len(times), 30.0)]), times=times)
    beside = Planner(g, None, steps(), FWD, settings=FASTEST, others=far).plan(standing(0, 0, EAST, FWD), goal)
    assert [tuple(f.position) for f in beside.footprints] == [tuple(f.position) for f in alone.footprints]
    assert beside.cost == alone.cost


def test_a_character_standing_in_the_way_is_gone_round():
    g = MeshGround(plane(-2, 12, -6, 6))
    goal = np.array([8.0, 0.0, 0.0])
    times = np.arange(0, 20, 1 / FPS)
    still = np.tile([4.0, 0.0], (len(times), 1))
    others = _others(_walker("Bystander", times, still), times=times,
                     feet=[(0, 0, slice(None), [4.0, 0.1, 0.0]), (0, 1, slice(None), [4.0, -0.1, 0.0])])
    pl = Planner(g, None, steps(), FWD, settings=FASTEST, others=others)
    res = pl.plan(standing(0, 0, EAST, FWD), goal)
    t, body = _body_track(res)
    need = 2 * BODY_RADIUS + FASTEST.character_clearance
    assert np.min(np.linalg.norm(body - [4.0, 0.0], axis=1)) >= need - 1e-9
    alone = Planner(g, None, steps(), FWD, settings=FASTEST).plan(standing(0, 0, EAST, FWD), goal)
    assert res.cost > alone.cost  # (the way round is longer)
    assert np.linalg.norm(res.footprints[-1].position[:2] - goal[:2]) <= FASTEST.goal_radius


def test_a_character_crossing_is_let_by_or_passed_behind():
    """Another walks across the way from the right at 1.2 m/s, through the path's middle
    when this one would reach it: this one's body keeps clear of it at every time."""
    g = MeshGround(plane(-2, 14, -8, 8))
    goal = np.array([10.0, 0.0, 0.0])
    alone = Planner(g, None, steps(), FWD, settings=FASTEST).plan(standing(0, 0, EAST, FWD), goal)
    ta, ba = _body_track(alone)
    t_mid = float(np.interp(5.0, ba[:, 0], ta))
    times = np.arange(0, 30, 1 / FPS)
    xy = np.c_[np.full(len(times), 5.0), -1.2 * (times - t_mid)]  # (at x = 5 when this one would be)
    others = _others(_walker("Passer", times, xy), times=times)
    pl = Planner(g, None, steps(), FWD, settings=FASTEST, others=others)
    res = pl.plan(standing(0, 0, EAST, FWD), goal)
    t, body = _body_track(res)
    # (the search's own clock: at each of its footprints the other, within the time slack, is clear)
    need = 2 * BODY_RADIUS + FASTEST.character_clearance
    for ti, b in zip(t, body):
        near = (times >= ti - TIME_SLACK) & (times <= ti + TIME_SLACK)
        assert np.min(np.linalg.norm(xy[near] - b, axis=1)) >= need - 1e-9
    # (alone, its body is where the other crosses, then)
    y_then = np.interp(np.interp(5.0, ba[:, 0], ta), times, xy[:, 1])
    assert abs(y_then - np.interp(5.0, ba[:, 0], ba[:, 1])) < 0.05
    assert res.cost > alone.cost


def test_a_character_blocking_a_corridor_is_waited_for():
    """A bystander stands in a corridor a metre wide for 6 s, then leaves: there is no way
    round, so the plan (``stands.plan_round``) stops before it, brings the other foot
    beside, stands, and goes on once it has gone, its body never near the bystander's while
    it is there; the footprints' times hold the stand."""
    calm = Settings()  # (running costs its penalty: it walks)
    g = MeshGround(plane(-2, 12, -0.5, 0.5))
    goal = np.array([8.0, 0.0, 0.0])
    times = np.arange(0, 20, 1 / FPS)
    there = times < 6.0
    xy = np.where(there[:, None], [4.0, 0.0], [4.0, 40.0])  # (gone, far off, after 6 s)
    others = _others(_walker("Bystander", times, xy), times=times)
    pl = Planner(g, None, steps(), FWD, settings=calm, others=others)
    res = plan_round(pl, standing(0, 0, EAST, FWD), lambda p, s: p.plan(s, goal))
    assert len(res.waits) == 1, "it should stand and let the bystander go"
    t, body = _body_track(res)
    need = 2 * BODY_RADIUS + calm.character_clearance
    for ti, b in zip(t, body):
        near = (times >= ti - TIME_SLACK) & (times <= ti + TIME_SLACK) & there
        if near.any():
            assert np.min(np.linalg.norm(xy[near] - b, axis=1)) >= need - 1e-9
    fs = res.footprints
    (i, w), = res.waits
    assert w > 0 and fs[i + 1].foot != fs[i].foot and fs[i + 1].label == fs[i].label
    assert np.linalg.norm(fs[i + 1].position - fs[i].position) < 0.3  # (side by side)
    assert fs[i + 2].time >= fs[i + 1].time + w and fs[i + 2].foot == fs[i].foot
    assert fs[i + 2].time >= 6.0 - TIME_SLACK  # (it goes on once the bystander has gone)
    assert np.all(np.diff([f.time for f in fs]) >= 0)
    assert np.linalg.norm(fs[-1].position[:2] - goal[:2]) <= calm.goal_radius
    # (alone it walks straight through, sooner; with no one near, the plan alone)
    alone = Planner(g, None, steps(), FWD, settings=calm).plan(standing(0, 0, EAST, FWD), goal)
    assert res.cost > alone.cost + calm.wait_penalty
    gone = _others(_walker("Gone", times, np.tile([4.0, 40.0], (len(times), 1))), times=times)
    free = plan_round(Planner(g, None, steps(), FWD, settings=calm, others=gone), standing(0, 0, EAST, FWD),
                      lambda p, s: p.plan(s, goal))
    assert not free.waits and [tuple(f.position) for f in free.footprints] == [tuple(f.position) for f in alone.footprints]


def test_a_footprint_stood_on_is_not_stepped_on_until_it_is_left():
    """Feet alone (no body near: the other's hips far above, on another level): the
    footprints of the other's stance are refused while it stands there, free after."""
    times = np.arange(0, 10, 1 / FPS)
    hips = np.tile([0.0, 0.0], (len(times), 1))
    others = _others(_walker("Above", times, hips, z=5.0), times=times,
                     feet=[(0, 0, slice(0, 60), [1.0, 0.0, 0.0])])  # (stands there the first 2 s)
    at = np.array([[1.0, 0.05, 0.0], [1.0, 0.05, 0.0], [2.0, 0.0, 0.0]])
    t0 = np.array([1.0, 3.0, 1.0])
    ok = others.feet_clear(at, t0, t0 + 0.5, 0.26)
    assert ok.tolist() == [False, True, True]
    # (bodies on different levels never meet)
    assert others.bodies_apart(np.zeros((1, 2)), np.zeros((1, 2)), np.zeros(1), np.ones(1), np.full(1, HIPS_HEIGHT),
                               BODY_RADIUS, 0.15).all()


@hsettings(max_examples=60, deadline=None)
@given(hs.floats(-3, 3), hs.floats(-3, 3), hs.floats(0, 8), hs.floats(0.05, 0.4), hs.floats(0, 0.5))
def test_bodies_apart_is_the_distance_at_the_times_within_the_slack(x, y, t, r, clearance):
    """``bodies_apart`` of a body standing still at (x, y) against one walking the x axis at
    1 m/s: apart exactly where every distance within the slack of the time exceeds the radii
    and clearance (up to a frame's travel)."""
    times = np.arange(0, 10, 1 / FPS)
    xy = np.c_[times - 2.0, np.zeros(len(times))]
    others = _others(_walker("Walker", times, xy, radius=r), times=times)
    ok = others.bodies_apart(np.array([[x, y]]), np.array([[x, y]]), np.array([t]), np.array([t]),
                             np.array([HIPS_HEIGHT]), BODY_RADIUS, clearance)[0]
    near = (times >= t - TIME_SLACK - 1e-9) & (times <= t + TIME_SLACK + 1e-9)
    d = np.linalg.norm(xy[near] - [x, y], axis=1).min() if near.any() else np.linalg.norm(xy[-1] - [x, y])
    need = r + BODY_RADIUS + clearance
    frame = 1.0 / FPS
    if d > need + frame:
        assert ok
    elif d < need - frame:
        assert not ok


@hsettings(max_examples=80, deadline=None)
@given(hs.floats(-3, 3), hs.floats(-1, 1), hs.floats(0.5, 4.0), hs.floats(-np.pi, np.pi), hs.floats(0, 0.5))
def test_a_long_way_past_a_standing_body_is_refused_by_its_nearest_point(x, y, length, angle, clearance):
    """A body going ``length`` m in a straight line (a run's step, a jump) past another that
    stands still at the origin the whole time: kept where the way's nearest point to it is
    clear of the radii and clearance, refused where it comes within them by more than the
    check's points can miss (half their spacing, ``SAMPLE_SPACING``, sideways), wherever
    along the way that is (a way checked at its ends and middle alone went 0.36 m from a
    body it needed 0.55 from)."""
    times = np.arange(0, 10, 1 / FPS)
    others = _others(_walker("Stander", times, np.zeros((len(times), 2))), times=times)
    a = np.array([x, y])
    b = a + length * np.array([np.cos(angle), np.sin(angle)])
    ok = others.bodies_apart(a[None], b[None], np.array([2.0]), np.array([2.5]), np.array([HIPS_HEIGHT]),
                             BODY_RADIUS, clearance)[0]
    u = np.clip(-a @ (b - a) / ((b - a) @ (b - a)), 0.0, 1.0)
    d = np.linalg.norm(a + u * (b - a))
    need = 2 * BODY_RADIUS + clearance
    if d > need + 1e-9:
        assert ok, (d, need)
    elif np.hypot(d, 0.5 * SAMPLE_SPACING) < need - 1e-9:
        assert not ok, (d, need)


def _apart_frame_by_frame(others, a, b, t0, t1, hips_z, radius, clearance, scale=1.0):
    """``bodies_apart`` the long way: every point of every way against every body at every
    frame within the slack of its time (what the boxes only spare it)."""
    t0, t1 = others._shot(t0), others._shot(t1)
    n = np.maximum(np.ceil(np.linalg.norm(b - a, axis=1) / (SAMPLE_SPACING * scale)).astype(np.int64), 2)
    s = np.minimum(np.arange(int(n.max()) + 1)[None, :] / n[:, None], 1.0)
    pos = a[:, None, :] + (b - a)[:, None, :] * s[..., None]
    t = t0[:, None] + (t1 - t0)[:, None] * s
    ok = np.ones(len(a), bool)
    for i in range(len(a)):
        for j in range(s.shape[1]):
            near = others._hips_near(t[i, j:j + 1])[:, 0]  # (N, W, 3)
            gap = np.linalg.norm(near[..., :2] - pos[i, j], axis=-1)
            level = np.abs(near[..., 2] - hips_z[i]) < 1.2 * scale
            if (level & (gap < (others.radius + radius + clearance)[:, None])).any():
                ok[i] = False
    return ok


@hsettings(max_examples=40, deadline=None)
@given(hs.integers(0, 2**32 - 1), hs.integers(1, 6), hs.floats(0.0, 0.6), hs.floats(0.3, 2.0))
def test_bodies_apart_is_the_frame_by_frame_check(seed, bodies, clearance, scale):
    """Over random bodies wandering at several heights (some moving obstacles' outline
    points among them) and random ways at random times, before, within and after the shot
    and on clocks shifted and stretched: ``bodies_apart`` answers exactly what checking
    each point against each body at each frame within the slack answers."""
    rng = np.random.default_rng(seed)
    times = np.arange(0, 4, 1 / FPS)
    walkers = []
    for i in range(bodies):
        start, v = rng.uniform(-3, 3, 2), rng.normal(0, 1.0, 2)
        z = rng.choice([0.0, 0.0, 0.8, 1.5])
        walkers.append(_walker(f"W{i}", times, start + np.outer(times, v), z=z, radius=rng.uniform(0.05, 0.3)))
    others = _others(*walkers, times=times)
    if rng.random() < 0.5:
        pts = rng.uniform(-2, 2, (5, 1, 3)) + np.outer(times, rng.normal(0, 0.5, 3))[None]
        pts[..., 2] = rng.uniform(0, 2)
        others = others.with_movers(["Cart"] * 5, pts, 0.05)
    others = others.on_clock(rng.uniform(-1, 1), rng.uniform(0.5, 2.0)).widened(rng.uniform(0.5, 3.0))
    k = 25
    a = rng.uniform(-3, 3, (k, 2))
    t0 = rng.uniform(-2, 6, k)
    near = rng.random(k) < 0.5  # (half the ways set off beside a body where it is then)
    frame = np.clip(others._frame(others._shot(t0)), 0, len(times) - 1)
    who = rng.integers(0, len(others.hips), near.sum())
    a[near] = others.hips[who, frame[near], :2] + rng.normal(0, 0.4, (near.sum(), 2))
    b = a + rng.normal(0, 0.8, (k, 2))
    t1 = t0 + rng.uniform(0, 0.8, k)
    z = rng.choice([0.0, 0.8, 1.5], k) + HIPS_HEIGHT
    got = others.bodies_apart(a, b, t0, t1, z, BODY_RADIUS, clearance, scale)
    want = _apart_frame_by_frame(others, a, b, t0, t1, z, BODY_RADIUS, clearance, scale)
    assert (got == want).all(), np.nonzero(got != want)


@hsettings(max_examples=40, deadline=None)
@given(hs.integers(0, 2**32 - 1), hs.integers(1, 5), hs.floats(0.15, 0.35))
def test_feet_clear_is_the_check_of_every_footprint(seed, bodies, foot):
    """Over random walkers planting their feet at random (several heights, feet of several
    lengths) and random feet at random times on shifted clocks: ``feet_clear`` answers
    what holding each foot against every footprint of the shot answers."""
    rng = np.random.default_rng(seed)
    times = np.arange(0, 4, 1 / FPS)
    walkers, feet = [], []
    for i in range(bodies):
        z = rng.choice([0.0, 0.0, 0.3, 1.5])
        walkers.append(_walker(f"W{i}", times, rng.uniform(-2, 2, 2) + np.outer(times, rng.normal(0, 0.5, 2)), z=z))
        for k in (0, 1):
            for a in rng.integers(0, len(times), 3):
                feet.append((i, k, slice(a, a + int(rng.integers(1, 20))), [*rng.uniform(-2, 2, 2), z]))
    names, hips, radius, soles, planted = zip(*walkers)
    soles, planted = np.array(soles), np.array(planted)
    for n, k, frames, at in feet:
        soles[n, k, frames], planted[n, k, frames] = at, True
    others = Others.of(names, times, np.array(hips), np.array(radius), soles, planted,
                       rng.uniform(0.2, 0.3, bodies)).on_clock(rng.uniform(-1, 1), rng.uniform(0.5, 2.0))
    k = 40
    pick = rng.integers(0, len(others.prints), k)
    at = others.prints[pick] + np.c_[rng.normal(0, 0.25, (k, 2)), np.zeros(k)]
    at[::4, 2] += rng.choice([0.0, 0.3, 1.5], len(at[::4]))
    t0 = rng.uniform(-1, 5, k)
    t1 = t0 + rng.uniform(0, 1.0, k)
    got = others.feet_clear(at, t0, t1, foot)
    s0, s1 = others._shot(t0), others._shot(t1)
    span = others.print_span
    reach = np.maximum(others.foot_length[others.print_owner], foot)
    want = np.array([not any(span[j, 0] <= s1[i] + others.slack and span[j, 1] >= s0[i] - others.slack
                             and abs(others.prints[j, 2] - at[i, 2]) < 0.5 * reach[j]
                             and np.linalg.norm(others.prints[j, :2] - at[i, :2]) < reach[j]
                             for j in range(len(span))) for i in range(k)])
    assert (got == want).all(), np.nonzero(got != want)


def test_a_path_that_ends_where_another_comes_by_later_is_not_clear():
    """A path whose last footprint is clear when it arrives, but where another walks through
    a second later (a bake holds its last pose: the character stands there): its last
    footprint is not clear; ending 2 m aside of that, or where the other never comes, it is."""
    times = np.arange(0, 10, 1 / FPS)
    xy = np.c_[np.full(len(times), 3.0), 4.0 - times]  # (down x = 3 from y = 4: there at 4 s)
    others = _others(_walker("Passer", times, xy), times=times)
    g = MeshGround(plane(-2, 12, -3, 3))
    pl = Planner(g, None, steps(), FWD, settings=FASTEST, others=others)
    path = pl.plan(standing(0, 0, EAST, FWD), np.array([3.0, 0.0, 0.0])).footprints
    passes = times[np.argmin(np.abs(xy[:, 1]))]  # (the animation's time the passer crosses y = 0)
    assert path[-1].time < passes  # (the path's last footprint is stood on before that, in the same animation)
    assert not pl.clear_in_time(path)[-1]
    far = Planner(g, None, steps(), FWD, settings=FASTEST, others=_others(
        _walker("Passer", times, xy + [2.0, 0.0]), times=times))
    assert far.clear_in_time(path)[-1]


@hsettings(max_examples=30, deadline=None)
@given(hs.floats(0.2, 3.0), hs.floats(0.05, 2.0), hs.floats(0.1, 2.5))
def test_an_obstacles_outline_is_points_along_its_sides_no_further_apart_than_the_step(w, d, h):
    """``outline_points`` of a box seen from above: every point within its footprint (on
    an edge of its triangles, at its middle height), and every point of its outline within
    a step (and a cell's rounding) of one of them."""
    from footstep_planner.core.plan.others import OUTLINE_STEP, outline_points

    x, y = np.meshgrid([0.0, w], [0.0, d])
    corners = np.array([[a, b, z] for z in (0.0, h) for a, b in zip(x.ravel(), y.ravel())])
    faces = [(0, 1, 3), (0, 3, 2), (4, 5, 7), (4, 7, 6), (0, 1, 5), (0, 5, 4), (2, 3, 7), (2, 7, 6),
             (0, 2, 6), (0, 6, 4), (1, 3, 7), (1, 7, 5)]
    pts = outline_points(corners, np.array(faces))
    assert np.allclose(pts[:, 2], 0.5 * h)
    assert (pts[:, 0] >= -1e-9).all() and (pts[:, 0] <= w + 1e-9).all()
    assert (pts[:, 1] >= -1e-9).all() and (pts[:, 1] <= d + 1e-9).all()
    t = np.linspace(0, 1, 200)[:, None]
    rim = np.vstack([np.c_[t * w, 0 * t], np.c_[t * w, 0 * t + d], np.c_[0 * t, t * d], np.c_[0 * t + w, t * d]])
    gap = np.linalg.norm(rim[:, None, :] - pts[None, :, :2], axis=2).min(axis=1)
    assert gap.max() <= OUTLINE_STEP * (0.5 + np.sqrt(0.5)) + 1e-9


def test_a_passage_another_keeps_is_refused_without_flooding_the_budget():
    """The goal at the far end of a dead-end passage 0.9 m wide off an open floor, a
    bystander standing in its mouth for good: alone the way goes in, no stand lets the
    bystander pass, and round it there is no way. It is refused as blocked (naming the
    bystander, saying alone it has a way) after at most ``ROUND_TIMES`` the way alone's
    expansions (``ROUND_FLOOR`` at least), not the search's whole budget of the floor."""
    from footstep_planner.core.plan.search_state import BlockedError
    from footstep_planner.core.plan.stands import ROUND_FLOOR, ROUND_TIMES
    from footstep_planner.core.plan.surface import TriMesh
    from conftest import box

    g = MeshGround(plane(-12, 14, -12, 12))
    walls = MeshGround(TriMesh.concat([box((6, 0.45, -0.1), (10.2, 0.8, 2.0)), box((6, -0.8, -0.1), (10.2, -0.45, 2.0)),
                                       box((10.0, -0.45, -0.1), (10.2, 0.45, 2.0))]))
    goal = np.array([9.0, 0.0, 0.0])
    times = np.arange(0, 40, 1 / FPS)
    others = _others(_walker("Bystander", times, np.tile([6.3, 0.0], (len(times), 1))), times=times)
    calm = Settings(max_expansions=200_000)
    alone = Planner(g, walls, steps(), FWD, settings=calm).plan(standing(0, 0, EAST, FWD), goal)
    pl = Planner(g, walls, steps(), FWD, settings=calm, others=others)
    try:
        plan_round(pl, standing(0, 0, EAST, FWD), lambda p, s: p.plan(s, goal))
    except BlockedError as ex:
        assert "Bystander" in str(ex) and "alone it has a way" in str(ex), str(ex)
        assert ex.expanded <= max(ROUND_FLOOR, ROUND_TIMES * alone.expanded) + 1, ex.expanded
    else:
        raise AssertionError("a passage another stands in for good was gone through")
