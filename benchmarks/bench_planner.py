"""The planner on thirty generated scenes (``scene_generator.benchmark_scenes``) with the
CMU subject-16 library: path length, footprints, footprints expanded, plan time (the
distance field and the search, with a fresh support cache; the process's CPU time, so
other work on the machine does not count), the cost found over the cost
of plain A* (heuristic_weight 1, a large expansion budget), and the result or the
failure message. Prints the table with medians and worsts; writes nothing.

    .venv/bin/python benchmarks/bench_planner.py [--only NAME,...] [--no-reference] [--seed 15]
        [--library cmu|sample] [--held-out] [--repeat N] [--vs CHECKOUT]

The reference searches take tens of CPU minutes in all (plain A* expands up to hundreds
of thousands of footprints per scene; ``--reference-budget``, default REFERENCE_BUDGET);
``--write-reference > ref.jsonl`` once, then ``--reference ref.jsonl``, compares the
planner against them without searching again (the references do not depend on the
planner's weighted-search tuning). Each reference carries the fingerprint of the step
set it was searched with; a reference of another library (the clips' analysis changed
since) is left out, saying so. ``--character FILE.npz`` freezes the library: read from
the file when it exists, else analysed and written there, so runs compare on the same
steps while the analysis changes. ``--vs CHECKOUT`` (a reference commit's worktree) plans
each scene in this checkout and that one in turn, in two long-lived processes, and prints
both trees' least CPU times over ``--repeat`` rounds: this machine's speed swings by half
within a minute, and whole runs one after the other do not compare.
"""

import argparse
import json
import os
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))
sys.path.insert(0, HERE)
from scene_generator import benchmark_scenes, cmu_character, held_out_scenes, make_planner, sample_character  # noqa: E402,E501

#: Plain A*'s expansion budget for the reference cost; a scene whose plain A* does not
#: finish within it takes weighted A* with weight FALLBACK_WEIGHT (its ratio is then
#: marked "*": the true ratio is at most that weight times the one printed).
REFERENCE_BUDGET = 1_500_000
FALLBACK_WEIGHT = 1.05


#: the Settings fields every plan of the benchmark uses (``--no-cross-gaps``)
SETTINGS: dict = {}

def path_length(fs) -> float:
    """Metres along the midpoints of consecutive footprints (the body's way)."""
    p = np.array([f.position for f in fs], float)
    if len(p) < 3:
        return 0.0
    mid = 0.5 * (p[1:] + p[:-1])
    return float(np.linalg.norm(np.diff(mid[:, :2], axis=0), axis=1).sum())


def loops(fs) -> int:
    """How many footprints stand within 0.15 m of an earlier one of the same foot three
    or more steps before (the path came back on itself)."""
    p = np.array([f.position[:2] for f in fs], float)
    foot = np.array([f.foot for f in fs])
    d = np.linalg.norm(p[:, None] - p[None], axis=2)
    k = np.arange(len(p))
    near = (d < 0.15) & (foot[:, None] == foot[None]) & (k[:, None] - k[None] >= 3)
    return int(near.any(axis=1).sum())


from footstep_planner.core.clips.steps import FIELDS as STEP_FIELDS  # noqa: E402


def save_character(character, path: str) -> None:
    """Write a character's steps, forward and foot shape to ``path`` (npz)."""
    st = character.steps
    np.savez(path, **{f: (np.asarray(getattr(st, f)).astype(str) if f in ("gait", "label")
                          else np.asarray(getattr(st, f))) for f in STEP_FIELDS},
             forward=np.asarray(character.forward, float),
             foot_shape=np.array([character.foot.back, character.foot.front, character.foot.half_width]))


def read_character(path: str):
    """The character ``save_character`` wrote to ``path``."""
    from scene_generator import Character

    from footstep_planner.core.clips.steps import StepSet
    from footstep_planner.core.plan.surface import FootShape

    d = np.load(path, allow_pickle=False)
    steps = StepSet(*(d[f].astype(object) if f in ("gait", "label") else d[f] for f in STEP_FIELDS if f in d))  # (older: no stride)
    return Character(steps, d["forward"], FootShape(*d["foot_shape"].tolist()))


def load_character(path: str = "", library: str = "cmu"):
    """The CMU subject-16 character (``library`` "sample": the sample character), from
    ``path`` (npz) when it exists, else analysed (and written to ``path`` when one is
    given)."""
    if path and os.path.exists(path):
        return read_character(path)
    ch = sample_character() if library == "sample" else cmu_character()
    if path:
        save_character(ch, path)
    return ch


def fingerprint(character) -> str:
    """A short hash of the step set (its geometry, durations, feet, gaits and jumps)."""
    import hashlib

    st = character.steps
    num = np.round(np.c_[st.fwd, st.left, st.turn, st.duration, st.foot, st.jump], 4)
    h = hashlib.sha1(num.tobytes() + "|".join(map(str, st.gait)).encode())
    return h.hexdigest()[:12]


def run_scene(scene, character, reference: bool, repeat: int = 1):
    """One row: (name, kind, length, footprints, expanded, ms, ratio, loops, ok, message);
    ms the least of ``repeat`` plans, each with a fresh planner and support cache (the
    search is deterministic: only the time differs, with what else the machine does)."""
    from footstep_planner.core.plan.navgraph import PlanError
    from footstep_planner.core.base.settings import Settings

    ms, r, err = np.inf, None, None
    for _ in range(max(1, repeat)):
        pl, start, goal = make_planner(scene, character, Settings(**SETTINGS))
        t = time.process_time()
        try:
            r = pl.plan(start, goal)
        except PlanError as e:
            err = e
        ms = min(ms, (time.process_time() - t) * 1e3)
    if err is not None:
        return (scene.name, scene.kind, np.nan, 0, err.expanded, ms, np.nan, 0, False, str(err))
    ratio, marked = np.nan, False
    if isinstance(reference, dict):
        ratio, marked = (r.cost / reference[scene.name][0], reference[scene.name][1]) \
            if scene.name in reference else (np.nan, False)
    elif reference:
        ratio, marked = r.cost / reference_cost(scene, character)[0], reference_cost(scene, character)[1]
    return (scene.name, scene.kind, path_length(r.footprints), len(r.footprints), r.expanded, ms, ratio,
            loops(r.footprints), True, "reached" + (" (ratio against weight 1.05)" if marked else ""))


_REFERENCE = {}


def reference_cost(scene, character) -> tuple[float, bool]:
    """(cost of plain A*, or of FALLBACK_WEIGHT A* where plain A* runs out of its budget;
    whether it is the fallback's). nan when neither finds a path."""
    from footstep_planner.core.plan.navgraph import PlanError
    from footstep_planner.core.base.settings import Settings

    if scene.name not in _REFERENCE:
        _REFERENCE[scene.name] = (np.nan, False)
        for w, marked in ((1.0, False), (FALLBACK_WEIGHT, True)):
            ref, s, g = make_planner(scene, character, Settings(**{**SETTINGS, "heuristic_weight": w,
                                                                    "max_expansions": REFERENCE_BUDGET}))
            try:
                _REFERENCE[scene.name] = (ref.plan(s, g).cost, marked)
                break
            except PlanError:
                continue
    return _REFERENCE[scene.name]


def print_table(rows, scenes, repeat: int = 1) -> None:
    head = (f"{'scene':20s} {'kind':9s} {'path m':>6s} {'footprints':>10s} {'expanded':>8s} {'cpu ms':>7s} "
            f"{'cost ratio':>10s} {'loops':>5s}  result")
    print(head)
    print("-" * len(head))
    for row, sc in zip(rows, scenes):
        name, kind, length, n, exp, ms, ratio, lp, ok, msg = row
        want = "" if ok == sc.reachable else "  (meant to be reachable)" if sc.reachable else "  (meant not to be)"
        print(f"{name:20s} {kind:9s} {length:6.1f} {n:10d} {exp:8d} {ms:7.0f} {ratio:10.3f} {lp:5d}  "
              f"{msg}{want}")
    ms = np.array([r[5] for r in rows])
    ratio = np.array([r[6] for r in rows])
    ok = np.array([r[8] for r in rows])
    fin = ratio[np.isfinite(ratio)]
    least = f" (each scene's least of {repeat} plans)" if repeat > 1 else ""
    print(f"\nplan cpu ms{least}: median {np.median(ms):.0f}, worst {ms.max():.0f} ({rows[int(ms.argmax())][0]}); "
          f"unreachable answered in at most {ms[~ok].max() if (~ok).any() else 0:.0f} ms")
    if len(fin):
        print(f"cost ratio vs plain A*: median {np.median(fin):.3f}, worst {fin.max():.3f} "
              f"({len(fin)} scenes with a reference)")
    print(f"reached {ok.sum()} of {len(rows)}; loops in {sum(r[7] > 0 for r in rows)} paths; "
          f"machine: {os.cpu_count()} cores, load {os.getloadavg()[0]:.2f}")


#: A process that plans scenes of the checkout at ``argv[1]`` one at a time as their names
#: come on its standard input, printing each one's CPU ms and result (``--vs``): only the
#: benchmark helpers every checkout since issue 15 has (``scene_generator``,
#: ``load_character``), so a reference commit needs nothing of today's.
_WORKER = """
import json, sys, time
root, library, seed, held, cross = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4] == "1", sys.argv[5] == "1"
sys.path[:0] = [root + "/benchmarks", root]
from scene_generator import benchmark_scenes, held_out_scenes, make_planner
import bench_planner as bp
from footstep_planner.core.base.settings import Settings
from footstep_planner.core.plan.navgraph import PlanError
character = bp.load_character("", library)
scenes = {s.name: s for s in benchmark_scenes(seed) + (held_out_scenes() if held else [])}
print(json.dumps(list(scenes)), flush=True)
for line in sys.stdin:
    pl, start, goal = make_planner(scenes[line.strip()], character, Settings(cross_gaps=cross))
    t = time.process_time()
    try:
        r = pl.plan(start, goal)
        got = [r.expanded, round(r.cost, 6)]
    except PlanError as e:
        got = [e.expanded, None]
    print(json.dumps([(time.process_time() - t) * 1e3, got]), flush=True)
"""


def side_by_side(other: str, args, names) -> None:
    """Plan each scene in this checkout and in ``other``, in two long-lived processes (the
    library analysed once in each), scene by scene in turn for ``args.repeat`` rounds (the
    order of the two swapped each round), and print each scene's least CPU ms for both,
    their medians and worsts and the ratio: a comparison that holds while the machine's
    speed drifts, which whole runs one after the other do not."""
    import statistics
    import subprocess

    def start(root):
        cmd = [sys.executable, "-c", _WORKER, root, args.library, str(args.seed), "1" if args.held_out else "0",
               "0" if args.no_cross_gaps else "1"]
        p = subprocess.Popen(cmd, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
        return p, json.loads(p.stdout.readline())

    today, ref = start(os.path.dirname(HERE)), start(os.path.abspath(other))
    ms = {n: ([], []) for n in names}
    same = {}
    for r in range(max(1, args.repeat)):
        for n in names:
            order = ((today, 0), (ref, 1)) if r % 2 == 0 else ((ref, 1), (today, 0))
            got = {}
            for (p, _), k in order:
                p.stdin.write(n + "\n")
                p.stdin.flush()
                t, got[k] = json.loads(p.stdout.readline())
                ms[n][k].append(t)
            same[n] = got[0] == got[1]
    for p, _ in (today, ref):
        p.stdin.close()
        p.wait()
    print(f"{'scene':20s} {'today ms':>9s} {'other ms':>9s} {'ratio':>6s}  same path")
    a, b = [], []
    for n in names:
        a.append(min(ms[n][0]))
        b.append(min(ms[n][1]))
        print(f"{n:20s} {a[-1]:9.0f} {b[-1]:9.0f} {a[-1] / b[-1]:6.2f}  {'yes' if same[n] else 'no'}")
    print(f"\nplan cpu ms, each scene's least of {max(1, args.repeat)}, side by side with {other}: today median "
          f"{statistics.median(a):.0f}, worst {max(a):.0f}; other median {statistics.median(b):.0f}, worst "
          f"{max(b):.0f}; today's total {sum(a) / sum(b):.2f} of the other's, the median scene's "
          f"{statistics.median(x / y for x, y in zip(a, b)):.2f}; the same expansions and cost on "
          f"{sum(same.values())} of {len(names)} scenes; machine: {os.cpu_count()} cores, load "
          f"{os.getloadavg()[0]:.2f}")


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--only", default="")
    ap.add_argument("--repeat", type=int, default=1, help="plan each scene this many times and print the least "
                    "CPU time (the machine's speed drifts; the paths are the same each time)")
    ap.add_argument("--seed", type=int, default=15)
    ap.add_argument("--no-reference", action="store_true")
    ap.add_argument("--reference", default="", help="JSON lines {name, cost, fallback} of reference costs "
                    "computed before (by --write-reference on stdout), instead of searching again")
    ap.add_argument("--write-reference", action="store_true", help="print only the reference costs, as JSON lines")
    ap.add_argument("--reference-budget", type=int, default=REFERENCE_BUDGET,
                    help="plain A*'s expansion budget for a reference")
    ap.add_argument("--progress", action="store_true", help="each scene's figures on stderr as it ends")
    ap.add_argument("--character", default="", help="an npz of the library's steps: read when it exists, "
                    "else analysed and written there")
    ap.add_argument("--library", choices=("cmu", "sample"), default="cmu",
                    help="the CMU subject-16 library (default) or the sample character's generated clips")
    ap.add_argument("--no-cross-gaps", action="store_true",
                    help="plan without Settings.cross_gaps (steps keep to the ground; every gap is jumped)")
    ap.add_argument("--vs", default="", metavar="CHECKOUT",
                    help="plan side by side with another checkout (a reference commit's worktree), scene by scene "
                         "in turn, --repeat rounds, and print both trees' times instead of the table")
    ap.add_argument("--held-out", action="store_true",
                    help="also the scenes of kinds the planner was never tuned on (scene_generator.held_out_scenes)")
    args = ap.parse_args()
    globals()["REFERENCE_BUDGET"] = args.reference_budget
    SETTINGS["cross_gaps"] = not args.no_cross_gaps
    scenes = benchmark_scenes(args.seed) + (held_out_scenes() if args.held_out else [])
    if args.only:
        keep = args.only.split(",")
        scenes = [s for s in scenes if any(k in s.name for k in keep)]
    if args.vs:
        return side_by_side(args.vs, args, [s.name for s in scenes])
    character = load_character(args.character, args.library)
    library = fingerprint(character)
    if args.write_reference:
        for sc in scenes:
            cost, marked = reference_cost(sc, character)
            print(json.dumps({"name": sc.name, "cost": None if np.isnan(cost) else cost, "fallback": marked,
                              "library": library}), flush=True)
        return
    reference = not args.no_reference
    if args.reference:
        with open(args.reference) as fh:
            rows_ = [json.loads(line) for line in fh if line.strip()]
        other = sorted(r["name"] for r in rows_ if r.get("library", library) != library)
        if other:
            print(f"left out {len(other)} references searched with another library: {', '.join(other)}",
                  file=sys.stderr)
        reference = {r["name"]: (r["cost"], r.get("fallback", False)) for r in rows_
                     if r["cost"] and r.get("library", library) == library}
    rows = []
    for sc in scenes:
        rows.append(run_scene(sc, character, reference, args.repeat))
        if args.progress:
            print(rows[-1][:8], file=sys.stderr, flush=True)
    which = "the sample character's library" if args.library == "sample" else "CMU subject-16 library"
    print(f"Planner benchmark: {len(scenes)} generated scenes (seed {args.seed}"
          f"{', and the held-out kinds' if args.held_out else ''}), {which} "
          f"({character.steps.n} steps, fingerprint {library})")
    print_table(rows, scenes, args.repeat)


if __name__ == "__main__":
    main()
