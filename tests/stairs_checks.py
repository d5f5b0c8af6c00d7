"""The checks of stairs climbed square and straight (issue 28), shared by the tests that
climb the sample Stairs and the held-out stairs."""

import numpy as np


def square_and_straight(planner, pos, head, body_xy=None, square_deg=10.0, line_m=0.10):
    """Issue 28: on each flight of ``planner``'s stairs every footprint (positions ``pos``
    (N, 3), headings ``head`` (N,) in the planner's frame) faces along the flight within
    ``square_deg``, and the body (``body_xy`` (F, 2) as played; else the middle of each
    two footprints) keeps within ``line_m`` of a straight line along the flight, from its
    first tread's middle to its last's."""
    from footstep_planner.core.base.angles import wrap, yaw

    tr = planner.treads
    assert len(tr), "no stairs found"
    on = tr.under(pos[:, :2], pos[:, 2], 0.03)
    assert (on >= 0).sum() >= 4, "the path does not go up or down the stairs"
    world = head + yaw(planner.forward)
    for i, t in zip(np.flatnonzero(on >= 0), on[on >= 0]):
        a = np.arctan2(*tr.up[t][::-1])
        off = min(abs(float(wrap(world[i] - a))), abs(float(wrap(world[i] - a - np.pi))))
        assert np.degrees(off) <= square_deg, (pos[i], np.degrees(off))
    mids = body_xy if body_xy is not None else 0.5 * (pos[1:, :2] + pos[:-1, :2])
    flights = {}
    for t in range(len(tr)):  # (treads of one flight: one up, in a line)
        across = float(tr.center[t] @ np.array([-tr.up[t][1], tr.up[t][0]]))
        key = (round(float(tr.up[t][0]), 2), round(float(tr.up[t][1]), 2), round(across, 0))
        flights.setdefault(key, []).append(t)
    for ts in flights.values():
        up = tr.up[ts[0]]
        side = np.array([-up[1], up[0]])
        along = (tr.center[ts] - tr.center[ts[0]]) @ up
        lo, hi = along.min(), along.max()  # (from the first tread's middle to the last's: on the flight)
        a = (mids - tr.center[ts[0]]) @ up
        across = (mids - tr.center[ts[0]]) @ side
        over = (a >= lo) & (a <= hi) & (np.abs(across) <= 0.5 * tr.width[ts[0]])
        if over.sum() < 2:
            continue
        spread = 0.5 * (across[over].max() - across[over].min())
        assert spread <= line_m, ("the body leaves the flight's line by", spread, "m")
