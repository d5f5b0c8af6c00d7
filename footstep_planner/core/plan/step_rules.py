"""The rules and costs of the library's steps: which gaits a search leaves a footprint in
(``_start_gaits``), how far a climbing step may go (``climb_reach``, ``CLIMB_DZ``), what a
step may pass over between its footprints (gaps a swing clears, bumps, obstacles: the
``StepRules`` methods ``_between``, ``_widest_gap``, ``_no_bump``, ``_clear_along``) and
what each step costs (``_base_costs``), with the speed and extras the heuristic derives
from those costs (``_cost_speed``, ``_jump_extra``, ``_gap_steps``). ``StepRules`` is a
base of ``navgraph.Planner``: its methods read the planner's ground, steps and settings.
"""

from __future__ import annotations

import numpy as np

from ..clips.steps import StepSet
from ..footprint import PIVOT, STAND_LABEL, START_LABEL, PathFootprint
from .islands import Islands
from .search_state import SearchNode, _Search
from .surface import ground_heights


#: m: a step's curvature (``Settings.curvature_penalty``) is its veer over its clip's
#: step length, or over this for a shorter one.
MIN_STEP_LENGTH = 0.2

#: m: the ground between two footprints may rise this much above the higher of them
#: (a swinging foot steps over a bump, not up a stair and down again).
MAX_BUMP = 0.1


#: m: a step up or down more than this is a climb, held to ``climb_reach``.
CLIMB_DZ = 0.03

#: m: the ground under a way is sampled this far apart to measure its widest gap
#: (``Planner._widest_gap``).
GAP_SPACING = 0.05

#: m: a step longer than this (a jump) is checked for obstacles all along its way
LONG_WAY = 0.9

#: m above a footprint's ground: a standing body's head and hips (``Planner._between``),
#: and the hips of a body in the air along a jump (``Planner._clear_along``).
HEAD_HEIGHT = 1.6
HIPS_HEIGHT = 1.0


def _start_gaits(fp: "PathFootprint", gaits=("walk", "run")) -> tuple[str, ...]:
    """The gaits a search may leave ``fp`` in, of the library's ``gaits``: a standing foot
    (a start, a turn's pivot step) walks off (a run from standing would have no run-up: the
    sample character ran off from standing, arms popping as the idle pose handed over to
    the run), or runs off where the library has no walk (a runs-only library starts as its
    start clip, or a start made from its standing pose, sets it running); a footprint a
    walk or run reached (a waypoint passed through) goes on in its gait (and changes it at
    the gait change's cost)."""
    if fp.label in (START_LABEL, PIVOT, STAND_LABEL) or fp.gait not in ("walk", "run"):
        return ("walk",) if "walk" in gaits or "run" not in gaits else ("run",)
    return (fp.gait,)


def climb_reach(steps: StepSet) -> np.ndarray:
    """(S,) m: how far over the ground (from footprint to footprint, across included) a
    step may go where it climbs or descends: the longer step of the walk's straightest
    cycle at its clip's own stride (the cycle whose steps veer least; of several, the
    shortest), whatever the gait (a run's steps, over a metre, would leap a flight's
    treads; without a walk, each gait's own). Longer steps are for level ground."""
    out = np.full(steps.n, np.inf)
    veer = np.abs(steps.cycle_mean(steps.veer()))
    length = np.hypot(steps.fwd, steps.left)
    gaits = sorted(set(steps.gait.tolist()), key=lambda g: g != "walk")
    for gait in gaits:
        own = (steps.gait == gait) & ~steps.jump & (steps.stride == 1.0)
        if not own.any():
            continue
        straight = own & (veer <= veer[own].min() + 1e-9)
        walk = min(set(steps.label[straight].tolist()), key=lambda lab: length[straight & (steps.label == lab)].mean())
        limit = float(length[straight & (steps.label == walk)].max())  # (of straight walks, the shortest)
        if gait == "walk":
            return np.full(steps.n, limit)
        out[steps.gait == gait] = limit
    return out


class StepRules:
    """Which steps of the library may be taken where, and what they cost (a base of
    ``Planner``, whose ground, obstacles, steps, foot and settings its methods read)."""

    def _between(self, a: np.ndarray, b: np.ndarray, with_void: bool = False) -> tuple[np.ndarray, ...]:
        """For footprint pairs (rows of a, b (N, 3)): (whether a walking or running step
        may go from each ``a`` to ``b``, a jump only where not: the ground continues under
        the three points between, within a step's height, or, with ``Settings.cross_gaps``,
        the step crosses a gap from one island of the ground to another (``_bridged``); the
        way between them is clear of obstacles). The ground is no higher than MAX_BUMP
        over the higher footprint; no obstacle may stand there below head height, nor
        closer than half the clearance at the hips. ``with_void``: and (N,) whether the way
        leaves the ground (its answer then rests on the islands, which any change of the
        scene may join or part)."""
        pts, z = self._ground_between(a, b)
        ground = np.isfinite(z).all(axis=1)
        void = ~ground
        if self.settings.cross_gaps and not ground.all():
            off = np.flatnonzero(void)
            ground[off] = self._bridged(a[off], b[off])
        # a step does not pass over ground higher than both its ends (a landing's corner
        # cut from one flight to the other): the swinging foot would have to climb it
        clear = self._under_bump(a, b, z)
        if self.obstacles is not None and self.obstacles.mesh.n:
            base = np.minimum(a[:, None, 2], b[:, None, 2]) + np.zeros((1, 3))
            head = np.concatenate([pts[..., :2], (base + self._len(HEAD_HEIGHT))[..., None]], axis=2).reshape(-1, 3)
            inside = self.obstacles.ray_down(head, self._len(HEAD_HEIGHT - 0.05)).hit.reshape(len(a), 3).any(axis=1)
            hips = head.copy()
            hips[:, 2] -= self._len(HEAD_HEIGHT - HIPS_HEIGHT)
            _, d = self.obstacles.nearest(hips, max_dist=0.5 * self.clearance)
            near = (d < 0.5 * self.clearance).reshape(len(a), 3).any(axis=1)
            clear &= ~inside & ~near
            long = np.flatnonzero(clear & (np.linalg.norm((b - a)[:, :2], axis=1) > self._len(LONG_WAY)))
            if len(long):  # (a jump's three points may all fall inside a thick wall: look all along)
                clear[long] = self._clear_along(a[long], b[long])
        return (ground, clear, void) if with_void else (ground, clear)

    @property
    def islands(self) -> Islands:
        """The ground's islands (``islands.Islands``), found once per planner (its ground
        does not change)."""
        found = getattr(self, "_islands", None)
        if found is None:
            found = Islands.of(self.ground, self.max_step_height, self.settings.body_scale)
            self._islands = found
        return found

    def _bridged(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """(N,) whether a walking or running step from each ``a`` to ``b`` (N, 3), whose
        way leaves the ground, crosses a gap it spans (``_widest_gap``, no wider than
        ``_gap_spanned``) from one island of the ground to another (``Islands.apart``):
        stepping stones, two slabs, a gutter's banks; not a corner or a notch of one floor,
        which a step keeps to the ground of, going round."""
        out = self._widest_gap(a, b) <= self._gap_spanned()
        if out.any():
            out[out] = self.islands.apart(self.ground, a[out], b[out], self.settings.body_scale)
        return out

    def _gap_spanned(self) -> float:
        """m: the widest gap a step of the library that is not a jump spans with both its
        footprints standing: its longest step less the foot's length."""
        return self._step_reach() - (self.foot.back + self.foot.front)

    def _widest_gap(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """(N,) m: the longest stretch without ground (within a step's height) on the way
        from each ``a`` to ``b`` (N, 3), sampled every GAP_SPACING m; 0 for a way no longer
        than the widest gap a step spans (``_gap_spanned``: its gaps are all narrower)."""
        out = np.zeros(len(a))
        length = np.linalg.norm((b - a)[:, :2], axis=1)
        long = np.flatnonzero(length > self._gap_spanned())
        if not len(long):
            return out
        spacing = self._len(GAP_SPACING)
        n = int(np.ceil(length[long].max() / spacing)) + 1
        t = np.linspace(0.0, 1.0, n)
        a_, b_ = a[long], b[long]
        pts = a_[:, None] + (b_ - a_)[:, None] * t[None, :, None]
        pts[..., 2] = np.maximum(a_[:, 2], b_[:, 2])[:, None] + self.max_step_height
        hit = self.ground.ray_down(pts.reshape(-1, 3), 2 * self.max_step_height + self._len(0.2)).hit
        miss = ~hit.reshape(len(long), n)
        # the longest run of misses in each row
        run = np.zeros(len(long), int)
        best = np.zeros(len(long), int)
        for k in range(n):
            run = np.where(miss[:, k], run + 1, 0)
            best = np.maximum(best, run)
        out[long] = (best + 1) * length[long] / (n - 1) * (best > 0)  # (a run of k misses: k + 1 spacings at most)
        return out

    def _ground_between(self, a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(points (N, 3, 3) a quarter, half and three quarters of the way from each ``a``
        to ``b`` (N, 3), the ground's height under them (N, 3), nan where none within a
        step's height)."""
        t = np.array([0.25, 0.5, 0.75])
        pts = a[:, None] + (b - a)[:, None] * t[None, :, None]
        top = pts.copy()
        top[..., 2] = np.maximum(a[:, None, 2], b[:, None, 2]) + self.max_step_height
        z = ground_heights(self.ground, top.reshape(-1, 3), 2 * self.max_step_height + self._len(0.2))
        return pts, z.reshape(len(a), 3)

    def _under_bump(self, a: np.ndarray, b: np.ndarray, z: np.ndarray) -> np.ndarray:
        """(N,) whether the ground ``z`` (N, 3) between each ``a`` and ``b`` (N, 3) stays
        within MAX_BUMP of the higher end."""
        return np.where(np.isnan(z), -np.inf, z).max(axis=1) <= np.maximum(a[:, 2], b[:, 2]) + self._len(MAX_BUMP)

    def _no_bump(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """(K,) whether the ground from ``a`` (3,) to each of ``b`` (K, 3) (a foot's swing,
        from its last footprint to its next) stays within MAX_BUMP of the higher end:
        a foot swings over a tread between two, not over a landing's corner. (None of the
        ground is that high: every swing passes, unasked.)"""
        a = np.broadcast_to(np.asarray(a, float), b.shape)
        top = self.__dict__.get("_ground_top")
        if top is None:
            verts = self.ground.mesh.verts
            top = self.__dict__["_ground_top"] = float(verts[:, 2].max()) if len(verts) else -np.inf
        if top <= float(np.maximum(a[:, 2], b[:, 2]).min()) + self._len(MAX_BUMP):
            return np.ones(len(b), bool)
        return self._under_bump(a, b, self._ground_between(a, b)[1])

    def _clear_along(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """(N,) whether the way from each ``a`` to ``b`` (N, 3) keeps the body's clearance
        of every obstacle at points no further apart than half of it: from inside a wall
        thicker than the clearance the nearest face is out of reach, but the points where
        the way enters and leaves it are not."""
        n = int(np.ceil(np.linalg.norm((b - a)[:, :2], axis=1).max() / (0.5 * self.clearance))) + 1
        t = np.linspace(0.0, 1.0, n + 1)[1:-1]
        pts = a[:, None] + (b - a)[:, None] * t[None, :, None]
        hips = pts.copy()
        hips[..., 2] = np.minimum(a[:, None, 2], b[:, None, 2]) + self._len(HIPS_HEIGHT)
        _, d = self.obstacles.nearest(hips.reshape(-1, 3), max_dist=0.5 * self.clearance)
        return ~(d < 0.5 * self.clearance).reshape(len(a), -1).any(axis=1)

    def _within_climb_reach(self, search: _Search, node: SearchNode, steps: np.ndarray, nxt: np.ndarray,
                            z: np.ndarray) -> np.ndarray:
        """(K,) whether each walking or running step from ``node`` to (``nxt``, ``z``) that
        climbs or descends more than CLIMB_DZ goes no further over the ground than the
        walk's straight step (``climb_reach``): a running stride of a metre up or down a
        flight leaps its treads (the planner ran onto the sample Stairs and off them, and
        the legs snapped straight landing), and a stride lengthened for the level has no
        place on a stair; a person takes the walk's steps there, or shorter. Jumps are
        not held to it."""
        dz = np.abs(z - node.position[2])
        if search.climb_reach is None:
            search.climb_reach = climb_reach(self.steps)
        length = np.hypot(nxt[:, 0] - node.position[0], nxt[:, 1] - node.position[1])
        return (dz <= self._len(CLIMB_DZ)) | self.steps.jump[steps] | (length <= search.climb_reach[steps] + 1e-9)

    def _base_costs(self) -> np.ndarray:
        """(S,) s: each step's cost, its duration plus the turn, jump and run penalties
        (a gait change is added per successor)."""
        st, cfg = self.steps, self.settings
        key = (id(st), st.n, cfg.stride_penalty, cfg.turn_penalty, cfg.curvature_penalty, cfg.jump_penalty,
               cfg.run_penalty, self._len(MIN_STEP_LENGTH))
        got = self.__dict__.get("_base_costs_cache")
        if got is not None and got[0] == key:  # (priced once per planner: the distance field asks four times)
            return got[1]
        veer = np.abs(st.veer())
        length = np.maximum(np.hypot(st.fwd / st.stride, st.left), self._len(MIN_STEP_LENGTH))  # (shortened: its clip's)
        kappa = (veer + np.abs(st.sidestep()) / length) / length  # 1/m: the way's heading change and a crab's
        cost = (st.time_cost(cfg.stride_penalty) + cfg.turn_penalty * veer
                + cfg.curvature_penalty * kappa + self._gait_penalties())
        cost.setflags(write=False)
        self.__dict__["_base_costs_cache"] = (key, cost)
        return cost

    def _gait_penalties(self) -> np.ndarray:
        """(S,) s: each step's jump and run penalties (``Settings.jump_penalty``,
        ``run_penalty``)."""
        st, cfg = self.steps, self.settings
        return np.where(st.jump, cfg.jump_penalty, 0.0) + np.where(st.gait == "run", cfg.run_penalty, 0.0)

    def _tread_costs(self) -> np.ndarray:
        """(S,) s: each step's cost where it is set square on a stair's tread (``Treads``):
        its duration, without the stride penalty (every step on a flight is shortened to
        its treads, and the penalty, meant to keep a level way to the clips' own strides,
        made each tread cost up to three times a walk's step: the search flooded the
        landings before it took the stairs) and, the way being set straight, without the
        clip's own turn (the turn as placed is priced per successor), with the run and
        jump penalties."""
        st, cfg = self.steps, self.settings
        key = (id(st), st.n, cfg.jump_penalty, cfg.run_penalty)
        got = self.__dict__.get("_tread_costs_cache")
        if got is None or got[0] != key:
            cost = st.time_cost(0.0) + self._gait_penalties()
            cost.setflags(write=False)
            got = (key, cost)
            self.__dict__["_tread_costs_cache"] = got
        return got[1]

    def _step_costs(self) -> tuple[np.ndarray, np.ndarray]:
        """(length (S,) m, least cost (S,) s) of each step, its turn penalty aside."""
        return np.hypot(self.steps.fwd, self.steps.left), self._base_costs()

    def _cost_speed(self) -> tuple[float, float]:
        """(v m/s, slack m): the metres per second of cost of the two steps (one of each
        foot: the feet alternate) that cover ground cheapest, and the most one step may
        cover beyond that speed. The heuristic takes (distance - slack) / v, so it never
        overestimates a path of any number of steps."""
        length, cost = self._step_costs()
        a, b = self.steps.foot == 0, self.steps.foot == 1
        if not (a.any() and b.any()):
            v = float(np.max(length / cost))
            return v, 0.0
        v = float(np.max((length[a][:, None] + length[b][None]) / (cost[a][:, None] + cost[b][None])))
        return v, float(max(0.0, np.max(length - cost * v)))

    def _turn_cost(self) -> float:
        """s/rad: the least a radian of turning costs beyond the ground it covers, over
        the pairs of steps (one of each foot) that turn at least 0.5 rad one way."""
        length, cost = self._step_costs()
        st = self.steps
        v, _ = self._cost_speed()
        walk = ~st.jump
        a, b = np.flatnonzero(walk & (st.foot == 0)), np.flatnonzero(walk & (st.foot == 1))
        if not (len(a) and len(b)):
            return 0.0
        turn = st.turn[a][:, None] + st.turn[b][None]
        over = (cost[a][:, None] + cost[b][None]) - (length[a][:, None] + length[b][None]) / v
        ok = np.abs(turn) >= 0.5
        return float(max(np.min(over[ok] / np.abs(turn[ok])), 0.0)) if ok.any() else 0.0

    def _jump_extra(self) -> float:
        """Metres the distance field adds to a jump: what the jump step, and the running
        step it must follow (a jump is entered running, from the other foot), cost beyond
        their length at the heuristic's speed (the least of any such pair), so the
        heuristic knows a jump needs its run-up and still never overestimates."""
        st = self.steps
        run = (st.gait == "run") & ~st.jump
        if not st.jump.any() or not run.any():
            return 0.0
        v, _ = self._cost_speed()
        length, cost = self._step_costs()
        j, r = np.flatnonzero(st.jump), np.flatnonzero(run)
        over = (cost[j][:, None] + cost[r][None]) - (length[j][:, None] + length[r][None]) / v
        over = np.where(st.foot[j][:, None] != st.foot[r][None], over, np.inf)
        return float(max(np.min(over), 0.0) * v) if np.isfinite(over).any() else 0.0

    def _gap_steps(self) -> list[tuple[float, float]]:
        """(reach m, extra m) of the walk's steps and then the run's (where they reach
        further) over a gap, for the distance field's bridges: the gait's longest step,
        from footprint to footprint, less the foot's length (a step across a gap has both
        its footprints standing, one behind the gap's near edge and one past its far edge:
        the gap it spans, ``_gap_spanned``), and a field cell more (a gap's border cells lie
        up to a cell further apart than the gap), and what the gait's steps
        cost beyond their length at the heuristic's speed (the least of them: a walk's
        nothing, a run's its penalty), so the heuristic stays a lower bound."""
        st = self.steps
        length, cost = self._step_costs()
        v, _ = self._cost_speed()
        out = []
        for gait in ("walk", "run"):
            own = (st.gait == gait) & ~st.jump
            if not own.any():
                continue
            reach = float(length[own].max()) - (self.foot.back + self.foot.front) + self.field_cell
            extra = float(max(np.min(cost[own] - length[own] / v), 0.0) * v)
            if not out or reach > out[-1][0]:
                out.append((reach, extra if out else 0.0))
        return out

    def _step_reach(self) -> float:
        """m: the library's longest step that is not a jump, from footprint to footprint."""
        walk = ~self.steps.jump
        return float(np.hypot(self.steps.fwd[walk], self.steps.left[walk]).max()) if walk.any() else 0.0

    def _jump_reach(self) -> float:
        j = self.steps.jump
        return float(np.hypot(self.steps.fwd[j], self.steps.left[j]).max()) if j.any() else 0.0
