"""Standing to let another character pass (issue 29): a plan round the characters already
in the shot may stop on its way, bring the other foot beside, stand a while and go on.

Reads: a ``Planner`` whose ``others`` are set, the start footprints, and the search to run
(``plan(planner, start)``: the planner's own, or one that turns in place). Returns a
``PlanResult`` whose ``waits`` say where it stands and how long (its footprints' times
include the stands). Never: reads the scene, or changes the others.

The search alone does not wait: where another character blocks the way for a while (a
passage too narrow for two, a doorway), every way on is refused until it has passed, and
a search of footprints floods the ground before it looking for one. So the plan is made
as path and timing apart (Kant and Zucker's path-velocity decomposition): the way as if
alone, the first step of it that meets another, and at the footprints before that step,
the latest first, the shortest stand after which the same way, that much later, is clear;
the way on is then searched again from the stand, at its time (``Planner.start_time``),
round anyone still near. A plan that goes round or ahead of the others (the search with
them) is weighed against the stand by cost: a second stood costs ``WAIT_RATE`` of a second
walked, and ``Settings.wait_penalty`` once. Where no stand lets them pass, the search round
them is given ``ROUND_TIMES`` the way alone's expansions (``ROUND_FLOOR`` at least): a
block they keep (a passage, the goal) is refused without flooding the ground for the
whole budget.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Callable

import numpy as np

from ..footprint import STAND_HALF_WIDTH, STAND_LABEL, PathFootprint, beside_position
from .navgraph import PlanError, PlanResult, Planner
from .search_state import BlockedError

#: s: the stands tried at one spot, shortest first (the longest a character stands there).
STAND_TIMES = (0.5, 1.0, 1.5, 2.0, 3.0, 4.0, 5.0, 6.0, 8.0, 10.0, 12.0, 16.0)
#: a second stood costs this much of a second walked: a person waits for another to pass
#: rather than walk a loop that takes as long
WAIT_RATE = 0.5
#: footprints back from the first that meets another tried as the spot to stand on (and
#: the start)
STAND_BACK = (1, 2, 3, 5)
#: of the expansion budget: what the search from a stand may spend, and the search round
#: the others once a stand was found (where none is near, it takes few)
TRY_SHARE = 0.1
ROUND_SHARE = 0.02
#: where no stand lets the others pass, the search round them may expand this many times
#: the footprints the way alone took (at least ROUND_FLOOR, at most the budget): a way
#: round is a detour the search finds near the way alone; one that takes more floods the
#: ground before an others' block (a passage or a goal they keep) and is refused
ROUND_TIMES = 20
ROUND_FLOOR = 1000

PlanFn = Callable[[Planner, list], PlanResult]


def plan_round(planner: Planner, start: list[PathFootprint], plan: PlanFn) -> PlanResult:
    """``plan(planner, start)`` round ``planner.others``, standing on the way where that
    costs less than going round or ahead of them (see the module). Without others, or
    where the way alone meets none, that way. Raises BlockedError when neither a stand nor
    a way round is found (the way round's refusal, and that alone there is a way)."""
    others = planner.others
    if others is None or others.empty:
        return plan(planner, start)
    alone = plan(replace(planner, others=None), start)
    clear = planner.clear_in_time(alone.footprints)
    if clear.all():
        return alone
    k = int(np.argmin(clear))
    best = _stand(planner, start, plan, alone, k)
    cfg = planner.settings
    if best is None:  # (no stand: a way round near the way alone, or none)
        cap = min(cfg.max_expansions, max(ROUND_FLOOR, ROUND_TIMES * alone.expanded))
        round_it = replace(planner, settings=cfg.replace(max_expansions=cap))
    else:
        share = cfg.replace(max_expansions=max(1, int(cfg.max_expansions * ROUND_SHARE)))
        round_it = replace(planner, settings=share, cost_limit=best[0])
    try:
        way = plan(round_it, start)
    except PlanError as ex:
        if best is None:
            raise _blocked(others, f"{ex}; alone it has a way there ({len(alone.footprints)} footprints) but {{}} "
                           "block it", ex) from None
        return best[1]
    ends_clear = planner.clear_in_time(way.footprints)[-1]  # (or it ends where another comes by later)
    if best is not None and (best[0] < way.cost or not ends_clear):
        return best[1]
    if not ends_clear:
        raise _blocked(others, "the way there round {} ends where one of them comes by later", way)
    return way


def _blocked(others, why: str, search) -> BlockedError:
    """The BlockedError of a plan round ``others``: ``why`` with their names put in, that
    no stand lets them pass, and ``search``'s (a PlanError's or a PlanResult's) expanded
    and explored footprints."""
    names = tuple(dict.fromkeys(others.names))
    return BlockedError(why.format(", ".join(names) or "the others") + f", and standing up to {max(STAND_TIMES):g} "
                        "s on the way does not let them pass", search.expanded, search.explored, names)


def _stand(planner: Planner, start, plan: PlanFn, alone: PlanResult, k: int) -> tuple[float, PlanResult] | None:
    """(cost, plan) of the latest stand before footprint ``k`` of ``alone`` (the first that
    meets another) after which the way on is clear, or None."""
    fs, cfg = alone.footprints, planner.settings
    spots = sorted({max(k - b, 0) for b in STAND_BACK} | {0}, reverse=True)
    share = cfg.replace(max_expansions=max(1, int(cfg.max_expansions * TRY_SHARE)))
    for i in spots:
        if i == 0:  # (at the start: its pair stands already)
            feet, t_from, first = np.array([f.position for f in start[:2]], float), 0.0, list(start)
            if len(feet) < 2:
                feet = np.repeat(feet, 2, axis=0)
        else:
            other = _beside(planner, fs[i], fs[i].time + (fs[i].time - fs[i - 1].time))
            if other is None:
                continue
            feet, t_from, first = np.array([fs[i].position, other.position]), other.time, [other]
        for w in STAND_TIMES:
            if not planner.stand_clear(feet, fs[i].time, t_from + w):
                break  # (someone comes onto the spot: standing longer there won't help)
            later = t_from + w - fs[i].time
            if not planner.clear_in_time(fs[i:], later=later)[1:].all():
                continue  # (the way alone, that much later, still meets someone)
            went = replace(planner, start_time=planner.start_time + t_from + w, settings=share)
            try:
                rest = plan(went, [replace(f, time=0.0) for f in first])
            except PlanError:
                continue
            return _joined(planner, alone, i, first, t_from, w, rest)
    return None


def _beside(planner: Planner, fp: PathFootprint, t: float) -> PathFootprint | None:
    """The other foot brought beside ``fp`` (side by side, on the ground there) at ``t``
    s, or None where it can't stand."""
    p = beside_position(fp, 1 - fp.foot, planner.forward, 2 * planner.settings.length(STAND_HALF_WIDTH))
    got = planner._support(p[None, :], np.array([fp.heading]))
    z = float(got.z[0])
    if not got.ok[0] or abs(z - fp.position[2]) > planner.max_step_height:
        return None
    return PathFootprint(1 - fp.foot, np.array([p[0], p[1], z]), fp.heading, float(t), STAND_LABEL, fp.gait)


def _joined(planner: Planner, alone: PlanResult, i: int, first, t_from: float, w: float,
            rest: PlanResult) -> tuple[float, PlanResult]:
    """(cost, plan): ``alone`` up to footprint ``i``, the stand there (``first``: the other
    foot beside it from ``t_from`` s, or the start's pair) for ``w`` s, then ``rest``."""
    shift = t_from + w
    on = [replace(f, time=f.time + shift) for f in rest.footprints]
    if i == 0:
        fps = on
    else:
        # (the other foot beside as a waypoint's stop has it: labelled by the step that arrived)
        fps = list(alone.footprints[:i + 1]) + [replace(first[0], label=alone.footprints[i].label)] + on[1:]
    cost = t_from + WAIT_RATE * w + planner.settings.wait_penalty + rest.cost  # (the way to the stand: its time)
    return cost, replace(rest, footprints=fps, expanded=alone.expanded + rest.expanded,
                         generated=alone.generated + rest.generated, seconds=alone.seconds + rest.seconds,
                         cost=cost, waits=((i, float(w)),))


__all__ = ["STAND_TIMES", "WAIT_RATE", "plan_round"]
