"""The command line's tables and reports as text: clip analyses, blend groups, a plan's
footprints, stage times (thesis Table 4.1 layout) and a bake's quality figures. Plain
formatting of dicts and analysis objects; no Blender here."""

from __future__ import annotations

import math

import numpy as np

from .crowd import obstacle_line, pair_line


def format_table(title: str, analyses, refused=()) -> str:
    """One row per clip analysis: rate, length, kind, gait, speed, stride, cycle, tau; then
    one per clip ``refused`` ((name, reason) pairs), with its reason."""
    head = (f"{'clip':38s} {'fps':>5s} {'frames':>6s} {'kind':6s} {'gait':5s} {'entry>exit':12s} "
            f"{'speed':>6s} {'stride':>6s} {'cycle':>6s} {'cad.':>5s} {'tau':>7s} {'flights (s)':14s}")
    lines = [f"{title}:", head, "-" * len(head)]
    f = lambda v, fmt: "-" if v is None else format(v, fmt)  # noqa: E731
    for a in analyses:
        fl = ",".join(f"{b - x:.2f}" for x, b in a.jump_flights) or (
            f"{len(a.flights)}x{sum(b - x for x, b in a.flights) / max(len(a.flights), 1):.2f}" if a.flights else "-")
        lines.append(
            f"{a.name:38s} {a.fps:5.0f} {a.frames:6d} {a.kind:6s} {a.gait:5s} "
            f"{a.entry_gait + '>' + a.exit_gait:12s} {a.speed:6.2f} {f(a.stride, '6.2f'):>6s} "
            f"{f(a.cycle, '6.2f'):>6s} {f(a.cadence, '5.0f'):>5s} {a.tau:+7.3f} {fl:14s}"
            + (" (in place: root motion from its feet)" if a.in_place else "")
            + (f" (loop of {a.loop.frames} frames, read round its seam)" if getattr(a, "loop", None)
               else " (loop)" if a.is_loop else ""))
    lines += [f"{name:38s} refused: {reason}" for name, reason in refused]
    lines.append("units: speed m/s, stride m, cycle s, cadence steps/min, tau 1/m (+ turns left); "
                 "flights: jump flights, else count x mean")
    return "\n".join(lines)


def format_library(lib) -> str:
    """A character's blend groups and special clips."""
    lines = ["blend groups" + (" (edited)" if lib.edited else " (proposed)") + ":"]
    for gait, g in lib.turn_groups.items():
        lines.append(f"  {g.name}: " + ", ".join(f"{c.clip} ({c.tau:+.2f})" for c in g.clips))
    if lib.speed_group:
        lines.append("  speed: walk_turn (s=0) <-> run_turn (s=1)")
    for sp in lib.specials:
        lines.append(f"  {sp.kind}: {sp.clip} ({sp.entry_gait} -> {sp.exit_gait})")
    return "\n".join(lines)


def format_stages(rows, names=None) -> str:
    """Rows of stage_row as a table in the layout of thesis Table 4.1."""
    cols = [("footprints", "footprints", "d"), ("frames", "frames", "d"), ("search_ms", "search", ".0f"),
            ("smoothing_ms", "smoothing", ".1f"), ("refinement_ms", "refinement", ".1f"),
            ("body_trajectory_ms", "body traj.", ".1f"), ("blend_groups_ms", "blend groups", ".1f"),
            ("synthesis_ms", "total", ".1f"), ("per_frame_ms", "per frame", ".3f")]
    names = names or [""] * len(rows)
    w0 = max([8] + [len(n) for n in names])
    head = f"{'':{w0}s} " + " ".join(f"{h:>12s}" for _, h, _ in cols)
    lines = ["stage times (ms), thesis Table 4.1 layout (IK and bake: issue 5):", head, "-" * len(head)]
    for n, r in zip(names, rows):
        lines.append(f"{n:{w0}s} " + " ".join(f"{format(r[k], f):>12s}" for k, _, f in cols))
    return "\n".join(lines)


def format_plan(character: str, goal, result, syn, frame0: float, rate: float, stages: dict) -> str:
    """A plan (``result``, a PlanResult) and its synthesis (``syn``): one line per
    footprint with the frame it is planted at (``frame0`` + seconds x ``rate``), the
    search's figures, the stage times and the range of tau and s."""
    lines = [f"{character}: {len(result.footprints)} footprints to ({goal[0]:.2f}, {goal[1]:.2f}, "
             f"{goal[2]:.2f}) in {syn.t[-1]:.2f} s of motion ({len(syn.t)} frames)",
             f"{'#':>3s} {'foot':4s} {'x':>7s} {'y':>7s} {'z':>6s} {'head':>6s} {'frame':>7s}  clip"]
    planted = syn.planted()
    pos, head = syn.footprints
    for i, f in enumerate(result.footprints):
        fr = frame0 + planted[i][1] * rate
        lines.append(f"{i:3d} {'LR'[f.foot]:4s} {pos[i, 0]:7.2f} {pos[i, 1]:7.2f} {pos[i, 2]:6.2f} "
                     f"{math.degrees(head[i]):6.0f} {fr:7.1f}  {f.label}{' (jump)' if f.jump else ''}")
    lines.append(f"search: {result.expanded} footprints expanded, {result.generated} generated, "
                 f"{result.seconds * 1e3:.0f} ms")
    lines += format_turns([dict(t, frames=[frame0 + f for f in t["frames"]]) for t in getattr(syn, "turns", [])])
    lines.append(format_stages([stages]))
    lines.append(f"tau {syn.tau_final.min():+.2f} to {syn.tau_final.max():+.2f} 1/m; running "
                 f"(s > 0.5) {np.mean(syn.s_final > 0.5) * 100:.0f} % of the frames")
    return "\n".join(lines)


def format_bake(doc) -> str:
    """The stage times (Table 4.1 layout) and the quality figures of one bake."""
    st, q = doc["stages"], doc["quality"]
    cols = [("footprints", "d"), ("frames", "d"), ("search_ms", ".0f"), ("smoothing_ms", ".1f"),
            ("refinement_ms", ".1f"), ("body_trajectory_ms", ".1f"), ("blend_groups_ms", ".1f"),
            ("pose_blend_ms", ".1f"), ("ik_ms", ".1f"), ("bake_ms", ".1f"), ("synthesis_ms", ".1f"),
            ("per_frame_ms", ".3f")]
    head = " ".join(f"{k.replace('_ms', ''):>13s}" for k, _ in cols)
    row = " ".join(f"{format(st[k], f):>13s}" for k, f in cols)
    pops = q["pops"]
    intro = pops["introduced"]
    lines = [
        f"{doc['character']}: baked {doc['name']!r} into NLA track {doc['track']!r}, frames "
        f"{doc['frame_start']}-{doc['frame_end']}",
        "stage times (ms; thesis Table 4.1 layout; 'pose_blend' plays the clips' bone rotations; "
        "'synthesis' sums smoothing to IK):", head, row,
        f"foot skate per stance: mean {q['foot_skate']['mean_mm']:.2f} mm, max {q['foot_skate']['max_mm']:.2f} mm; "
        f"planted foot to footprint: mean {q['footprint_error']['mean_mm']:.2f} mm, max "
        f"{q['footprint_error']['max_mm']:.2f} mm",
        f"ground penetration: heel and ball max {q['penetration']['max_mm']:.2f} mm "
        f"({q['penetration']['frames_over_tolerance']} frames over 5 mm)"
        + (f", toe tip max {q['penetration']['tip_max_mm']:.2f} mm" if "tip_max_mm" in q["penetration"] else "")
        + f"; floating while planted: max {q['floating']['max_mm']:.2f} mm",
        f"goal: {q['goal']['distance_m'] * 100:.1f} cm" + (
            f", heading {q['goal']['heading_deg']:.1f} deg" if q['goal'].get('heading_deg') is not None else ""),
        f"pops: largest step {pops['max_rotation_deg']:.1f} deg ({pops['rotation_bone']}, as in its clip); "
        f"made by the planner: {intro['count']} steps over the clips' own, worst "
        f"{intro['max_excess_deg']:.1f} deg over" + (f" ({intro['bone']}, frame {intro['frame']})"
                                                     if intro['bone'] else ""),
    ]
    lines += [pair_line(fig) for fig in q.get("others", [])]
    lines += [obstacle_line(fig) for fig in q.get("moving_obstacles", [])]
    lines += format_turns(doc.get("turns_in_place", []))
    if doc.get("waypoints"):
        lines.append(format_waypoints(doc["waypoints"]))
    return "\n".join(lines)


def format_turns(turns: list[dict]) -> list[str]:
    """One line per turn in place (the report's ``turns_in_place``)."""
    return [f"turns in place at the {t['where']}: {abs(t['degrees']):.0f} deg "
            f"{'left' if t['degrees'] > 0 else 'right'} in {t['steps']} pivot steps, frames "
            f"{t['frames'][0]:g}-{t['frames'][1]:g} ({t['seconds']:.1f} s)" for t in turns]


def format_waypoints(rows: list[dict]) -> str:
    """The waypoints' timing: per waypoint (the goal last) the frame asked for, the frame
    the plan reaches it on and the frame the played scene does, the pause where it stops
    there (0 where it stops only to wait), the walk's pace to it, the jog's walk/run blend
    where it jogged, the seconds waited before and what met the frame."""
    f = lambda v, spec: "-" if v is None else format(v, spec)  # noqa: E731
    lines = ["waypoints (frames; 'played' as Blender plays the saved scene):",
             f"{'waypoint':<16s} {'asked':>7s} {'planned':>8s} {'played':>8s} {'pause s':>8s} {'pace':>6s} "
             f"{'jog':>5s} {'waited s':>8s} {'met by':>6s}"]
    for k, r in enumerate(rows):
        pause = r["pause"] if r.get("stops") and k + 1 < len(rows) else None  # (the goal: its hold is the settings')
        lines.append(f"{r['name'][:16]:<16s} {f(r['arrive'], '.0f'):>7s} {f(r['planned'], '.1f'):>8s} "
                     f"{f(r.get('achieved'), '.1f'):>8s} {f(pause, '.2f'):>8s} {r['pace']:>6.2f} "
                     f"{f(r.get('blend'), '.2f'):>5s} {f(r['waited'] or None, '.2f'):>8s} "
                     f"{r.get('met_by') or '-':>6s}")
    return "\n".join(lines)


def format_demo_plan(doc, fps: float, seconds: float) -> str:
    """The demo's one line about its bake (report ``doc``): footprints, jumps, frames."""
    jumps = sum(1 for f in doc["footprints"] if f.get("jump"))
    return (f"plan: {len(doc['footprints'])} footprints ({jumps} jumps), "
            f"{doc['frame_end'] - doc['frame_start'] + 1} frames at {fps:g} fps, planned, synthesized, "
            f"solved and baked in {seconds:.2f} s")
