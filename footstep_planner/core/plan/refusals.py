"""Why a plan was refused, in words: the goal off every surface (``_check_goal``), no
way on the walking-distance map (``_refuse_unreachable``), a search that found no path
(``_dead_end``, ``_blocker``), and what blocks the library's steps where the search got to
(``Rejections`` and ``_explain``: the wall and the clearance, the step's height, the
treads' depth against the foot, the gap's width against the steps' and the jump's reach).
``Refusals`` is a base of ``navgraph.Planner``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..footprint import PathFootprint
from .distance_field import DistanceField
from .search_state import PlanError, SearchNode, _Search
from ..base.angles import wrap


class Refusals:
    """The planner's refusals: each raises or returns a ``PlanError`` whose message says
    what blocks the way (a base of ``Planner``)."""

    def _check_goal(self, goal: np.ndarray, goal_heading: float | None) -> None:
        """PlanError when no traversable surface lies under (or near above) the goal."""
        gsup = self._support(goal[None], np.array([goal_heading or 0.0]))
        if not gsup.ok[0] and gsup.reason[0] in ("off surface", "uneven", "steep"):
            hit = self.ground.ray_down(np.array([[goal[0], goal[1], goal[2] + self._len(2.0)]]), self._len(10.0))
            if not hit.hit[0]:
                raise PlanError(f"the goal ({goal[0]:.2f}, {goal[1]:.2f}, {goal[2]:.2f}) is off every "
                                "traversable surface")

    def _refuse_unreachable(self, dist: "DistanceField", start: list[PathFootprint], goal: np.ndarray) -> None:
        """PlanError before any search when the walking-distance map has no way from the
        start to the goal, saying what blocks the library's steps at the nearest point
        the map reaches (``Rejections``)."""
        if not np.isfinite(dist.at_many(np.array([f.position for f in start], float))).any():
            near = dist.nearest_reachable(np.asarray(start[0].position, float), goal)
            ang = np.arctan2(goal[1] - near[1], goal[0] - near[0]) - np.arctan2(self.forward[1], self.forward[0])
            left = 0.1 * np.array([-np.sin(ang + np.arctan2(self.forward[1], self.forward[0])),
                                   np.cos(ang + np.arctan2(self.forward[1], self.forward[0])), 0.0])
            nodes = [SearchNode(foot, gait, near + sign * left, float(ang), 0.0, -1, -1)
                     for foot, sign in ((0, 1), (1, -1)) for gait in ("walk", "run")]
            d0 = float(np.linalg.norm(goal[:2] - near[:2]))
            blocker = Rejections.of(self, nodes, goal, d0).words(self, near, goal)
            raise PlanError(
                f"the goal ({goal[0]:.2f}, {goal[1]:.2f}) cannot be reached: no walkable way, nor a "
                f"gap a step or a jump clip can clear, leads there from the start; the nearest reachable "
                f"point is ({near[0]:.2f}, {near[1]:.2f}), {d0:.2f} m from the goal"
                + (f"; {blocker}" if blocker else ""))

    def _refuse_apart(self, start: list[PathFootprint], goal: np.ndarray) -> None:
        """PlanError before any search when the goal stands on ground that no step and no
        jump of the library can reach from the start's: their islands (``islands.Islands``)
        lie further apart, through any others, than the widest gap a step spans and the
        jump's length. (The distance map, on its coarser cells, may still bridge them: the
        search would flood the start's ground before it said so.)"""
        isl = self.islands
        if len(isl) <= 1:
            return
        span = self._gap_spanned()
        jump = self._jump_reach()
        # (also with cross_gaps off: a crack between the three points a step's ground test
        # looks at, a quarter of its length apart, is stepped over)
        reach = max(span, 0.25 * self._step_reach(), jump)
        scale = self.settings.body_scale
        at = isl.at(self.ground, np.array([f.position for f in start] + [goal], float), scale,
                    self._len(0.05) + self.max_step_height)
        if (at < 0).any():
            return  # (a start or goal off the islands' ground: the map says the rest)
        group = isl.linked(reach)
        if group is None or group[at[-1]] in set(group[at[:-1]].tolist()):
            return
        jumps = (f"the jump clips' longest leap {jump:.2f} m" if jump > 0 else "the library has no jump clip")
        steps = f"the widest gap its longest step spans is {span:.2f} m"
        raise PlanError(f"the goal ({goal[0]:.2f}, {goal[1]:.2f}) cannot be reached: it stands on ground apart "
                        f"from the start's by gaps wider than {reach:.2f} m ({steps}; {jumps}); "
                        "join the ground, or give the character a jump clip that leaps the gap")

    def _dead_end(self, search: _Search) -> PlanError:
        """The PlanError of a search that found no path: where it got to (the footprint it
        reached nearest the goal) and what blocks the library's steps from there."""
        goal, (d_near, near) = search.goal, search.nearest
        why = "the search ran out of its budget" if search.heap else "no step of the library leads further"
        msg = (f"the goal ({goal[0]:.2f}, {goal[1]:.2f}) cannot be reached ({why}, "
               f"{search.expanded} footprints expanded)")
        if near is None:
            return PlanError(msg + "; no footprint of the start could be stood on", search.expanded, search.nodes)
        if d_near <= self.settings.goal_radius and search.goal_heading is not None:
            return PlanError(msg + f"; it reached the goal's place ({d_near:.2f} m off) but never facing the "
                             f"goal's heading within {np.degrees(self.settings.goal_heading_tolerance):.0f} deg: "
                             "turn the goal (or give --goal-heading), or raise goal_heading_tolerance",
                             search.expanded, search.nodes)
        at_start = all(n.parent < 0 for n in search.nodes if np.array_equal(n.position, near))
        where = (f"; the nearest reachable point is ({near[0]:.2f}, {near[1]:.2f}, {near[2]:.2f}), "
                 f"{d_near:.2f} m from the goal")
        where += (", the start itself: no step of the library leaves it towards the goal" if at_start
                  else ", where the search got to")
        blocker = self._blocker(search, near)
        return PlanError(msg + where + (f"; {blocker}" if blocker else ""), search.expanded, search.nodes)

    def _blocker(self, search: _Search, near: np.ndarray) -> str:
        """Words for what stops the library's steps from the footprints the search reached
        within 0.6 m of ``near``: the commonest reason their steps towards the goal were
        refused (``Rejections``)."""
        goal = search.goal
        d0 = np.linalg.norm(goal[:2] - near[:2])
        frontier = [n for n in search.nodes if np.linalg.norm(n.position[:2] - near[:2]) < self._len(0.6)]
        rej = Rejections.of(self, frontier[:64], goal, d0)
        return rej.words(self, near, goal)



@dataclass
class Rejections:
    """Why steps from some footprints were refused: reason -> (count, a landing point (3,)).
    Reasons: "obstacle" (the body would meet one), "off surface", "uneven" (a step edge
    under the foot), "steep", "step height", "obstacle between", "jump on ground" (a jump
    where no gap is that a step could not span)."""

    counts: dict

    @staticmethod
    def of(planner: "Planner", nodes: list, goal: np.ndarray, d0: float) -> "Rejections":
        """The reasons of every step of ``nodes`` that would land nearer ``goal`` than d0."""
        counts: dict = {}
        st = planner.steps
        for node in nodes:
            sel = np.flatnonzero(st.foot == node.foot)
            ang = node.heading + np.arctan2(planner.forward[1], planner.forward[0])
            f_, l_ = np.array([np.cos(ang), np.sin(ang)]), np.array([-np.sin(ang), np.cos(ang)])
            nxt = node.position[:2] + st.fwd[sel, None] * f_ + st.left[sel, None] * l_
            keep = np.linalg.norm(goal[:2] - nxt, axis=1) < d0
            if node.gait == "walk":
                keep &= ~st.jump[sel]
            sel, nxt = sel[keep], nxt[keep]
            if not len(sel):
                continue
            psi = wrap(node.heading + st.turn[sel])
            sup = planner._support(np.c_[nxt, np.full(len(sel), node.position[2])], psi)
            reason = np.where(sup.ok, "", sup.reason).astype(object)
            reason[(reason == "") & (np.abs(sup.z - node.position[2]) > planner.max_step_height)] = "step height"
            ok = reason == ""
            if ok.any():
                to = np.c_[nxt[ok], sup.z[ok]]
                ground, clear = planner._between(np.repeat(node.position[None], ok.sum(), axis=0), to)
                jump = st.jump[sel[ok]]
                sub = np.where(~clear, "obstacle between", np.where(jump & ground, "jump on ground",
                               "")).astype(object)
                reason[np.flatnonzero(ok)] = sub
            for r, p, z in zip(reason.tolist(), nxt, sup.z):
                if r:
                    c, _ = counts.get(r, (0, None))
                    counts[r] = (c + 1, np.array([p[0], p[1], node.position[2] if np.isnan(z) else z]))
        return Rejections(counts)

    def words(self, planner: "Planner", near: np.ndarray, goal: np.ndarray) -> str:
        """The commonest reason, in words with its figures (``_explain``)."""
        real = {k: v for k, v in self.counts.items() if k != "jump on ground"}
        if not real:
            return ""
        total = sum(c for c, _ in real.values())
        reason = max(real, key=lambda k: real[k][0])
        share = f"{real[reason][0]} of the {total} refused steps towards the goal"
        stairs = _steps_ahead(planner, near, goal) if reason in ("uneven", "off surface", "step height") else None
        if stairs is not None:
            foot = planner.foot
            return (f"what blocks it: steps ahead, rising {stairs[0]:.2f} m with treads {stairs[1]:.2f} m deep: no "
                    f"step of the library lands the whole foot ({foot.back + foot.front:.2f} m long, "
                    f"{2 * foot.half_width:.2f} m wide) on one tread ({share})")
        return f"what blocks it: {_explain(planner, reason, real[reason][1], near, goal)} ({share})"



def _explain(planner: "Planner", reason: str, at: np.ndarray, near: np.ndarray, goal: np.ndarray) -> str:
    """One reason of ``Rejections`` in words, with the figures that matter: the wall's
    place and the clearance, the step's height, the gap's width against the jump's reach."""
    st = planner.steps
    walk = ~st.jump
    shortest = float(np.hypot(st.fwd[walk], st.left[walk]).min())
    sharpest = float(np.degrees(np.abs(st.turn[walk]).max()))
    if reason == "obstacle":
        _, d = planner.obstacles.nearest(np.array([[near[0], near[1], near[2] + planner._len(0.9)]]))
        p, _ = planner.obstacles.nearest(np.array([[at[0], at[1], at[2] + planner._len(0.9)]]))
        return (f"an obstacle (a wall or an object) at ({p[0, 0]:.2f}, {p[0, 1]:.2f}), {d[0]:.2f} m away: "
                f"every step of the library towards the goal (the shortest goes {shortest:.2f} m, the "
                f"sharpest turns {sharpest:.0f} degrees) brings the body within its clearance "
                f"({planner.clearance:.2f} m) of it")
    if reason in ("off surface", "gap"):
        return _gap_words(planner, at, near, goal, shortest, sharpest)
    if reason == "uneven":
        rise = _rise_ahead(planner, near, goal)
        return (f"a step edge under the foot at ({at[0]:.2f}, {at[1]:.2f}), {rise:.2f} m high: no step of the "
                f"library lands the whole foot ({planner.foot.back + planner.foot.front:.2f} m long) on one side "
                "of it")
    if reason == "step height":
        return (f"a step up or down at ({at[0]:.2f}, {at[1]:.2f}) higher than the "
                f"{planner.max_step_height:.2f} m a step may climb")
    if reason == "steep":
        return f"ground steeper than 30 degrees at ({at[0]:.2f}, {at[1]:.2f})"
    return f"an obstacle between the footprints at ({at[0]:.2f}, {at[1]:.2f}) (through a wall or under a bar)"


def _gap_words(planner: "Planner", at: np.ndarray, near: np.ndarray, goal: np.ndarray, shortest: float,
               sharpest: float) -> str:
    """The edge of the surface towards the goal from ``near`` and the gap beyond it, against
    the library's jump; or, with ground all the way towards the goal, the edge beside the
    way (at ``at``) that the library's steps cannot keep on."""
    d = goal[:2] - near[:2]
    d = d / max(np.linalg.norm(d), 1e-9)
    far_off, spacing = planner._len(6.0), planner._len(0.05)
    t = np.arange(0.0, far_off, spacing)
    pts = np.c_[near[:2] + t[:, None] * d, np.full(len(t), near[2] + planner.max_step_height)]
    hit = planner.ground.ray_down(pts, 2 * planner.max_step_height).hit
    hit[1:-1] |= hit[:-2] & hit[2:]  # a ray lost between two triangles is no gap
    t = t[:int(np.ceil(np.linalg.norm(goal[:2] - near[:2]) / spacing))]
    hit = hit[:len(t)]
    if hit.all():
        return (f"the edge of the surface at ({at[0]:.2f}, {at[1]:.2f}): every step of the library towards "
                f"the goal (the shortest goes {shortest:.2f} m, the sharpest turns {sharpest:.0f} degrees) "
                "puts a foot off it")
    edge = int(np.argmin(hit))
    far = edge + int(np.argmax(hit[edge:])) if hit[edge:].any() else -1
    where = f"the surface ends at ({pts[edge, 0]:.2f}, {pts[edge, 1]:.2f})"
    gap = f"no ground beyond it within {far_off:.0f} m" if far < 0 else f"the gap beyond is {t[far] - t[edge]:.2f} m wide"
    return f"{where} and {gap}; {_reach_words(planner)}"


def _reach_words(planner: "Planner") -> str:
    """What the library's steps span over a gap, in words: its longest step (not a jump)
    less the foot's length, and its jump's reach (or that it has no jump)."""
    step, foot = planner._step_reach(), planner.foot.back + planner.foot.front
    gait = "running" if (planner.steps.gait[~planner.steps.jump] == "run").any() \
        and np.hypot(planner.steps.fwd, planner.steps.left)[~planner.steps.jump & (planner.steps.gait == "run")].max() \
        >= step - 1e-9 else "walking"
    words = (f"the library's longest {gait} step spans a gap of {max(step - foot, 0.0):.2f} m ({step:.2f} m from "
             f"footprint to footprint, less the foot's {foot:.2f} m)")
    if not planner.settings.cross_gaps:  # (steps walk on ground only: any gap is jumped)
        words += " with Settings.cross_gaps on (it is off: every gap is jumped)"
    reach = planner._jump_reach()
    return words + (f", and its jump reaches {reach:.2f} m from take-off to landing, after a running step"
                    if reach > 0 else ", and it has no jump clip for a wider one")


def _steps_ahead(planner: "Planner", near: np.ndarray, goal: np.ndarray) -> tuple[float, float] | None:
    """(rise m, tread m) of the steps within 2 m of ``near`` towards the goal (the first
    rise, and the shortest run of level ground between two rises), or None where the
    ground ahead rises once at most."""
    t, z = _ground_ahead(planner, near, goal)
    at = np.flatnonzero(np.abs(np.diff(z)) > planner._len(0.02))
    if len(at) < 2:
        return None
    return float(z[at[0] + 1] - z[at[0]]), float(np.diff(t[at]).min())


def _ground_ahead(planner: "Planner", near: np.ndarray, goal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(t (K,) m, z (K,) m): the ground's height every cm within 2 m of ``near`` towards
    the goal, where there is ground."""
    d = goal[:2] - near[:2]
    d = d / max(np.linalg.norm(d), 1e-9)
    t = np.arange(0.0, planner._len(2.0), planner._len(0.01))
    z = planner.ground.ray_down(np.c_[near[:2] + t[:, None] * d, np.full(len(t), near[2] + planner._len(2.0))],
                                planner._len(4.0)).z
    ok = np.isfinite(z)
    return t[ok], z[ok]


def _rise_ahead(planner: "Planner", near: np.ndarray, goal: np.ndarray) -> float:
    """m: the highest step up or down of the ground within 2 m of ``near`` towards the
    goal (0 where it is level)."""
    _, z = _ground_ahead(planner, near, goal)
    return float(np.abs(np.diff(z)).max()) if len(z) > 1 else 0.0
