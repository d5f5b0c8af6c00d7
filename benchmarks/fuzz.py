"""The fuzz campaign of issue 13, as a benchmark: generated cases (scenes, clip files, job
lists, hostile paths; ``fuzz_cases.py``) run through the command line, each in a fresh
folder, as a subprocess; for each case, its exit status and message, whether it showed a
traceback, and a byte compare of every file that was there before.

    python benchmarks/fuzz.py --cases 1000 --seed 1 [--jobs 2] [--kinds plan,jobs] [--out fuzz.json]
    python benchmarks/fuzz.py --only jobs-1-17          # one case again, its folder kept

The target: 0 tracebacks, 0 timeouts, 0 files changed that the command did not own, no
litter, stdout of ``--json`` exactly one JSON document. A command owns the outputs it was
given (``--out``, ``--report``, a job's files, the pictures in a plot folder) and may
write them only when it succeeds (exit 0; a job list: the jobs that baked). Its inputs,
and FIFOs and devices, it may never replace. Litter: whatever a failed command leaves,
and temporary files left by any (``TMPDIR`` is the case's own). A case may also expect
the command to succeed (valid unusual names) or to fail (an output that is an input, a
folder nobody can write): "unexpected" when it does not. A case still running after
``--timeout`` gets a Ctrl-C, then (10 s later) SIGKILL.

The base scenes are built once (``--pool`` of them) in Blender subprocesses and cached
under ``--work`` (default: the system's temporary folder), keyed by the builder's
sources. Functions are importable: ``tests/blender/command/test_fuzz_sample.py`` runs a fixed sample.
"""

from __future__ import annotations

import argparse
import concurrent.futures
import hashlib
import json
import os
import re
import shlex
import shutil
import signal
import stat
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
if HERE not in sys.path:
    sys.path.insert(0, HERE)

import fuzz_cases as fc  # noqa: E402

TRACEBACK = "Traceback (most recent call last)"
ERROR_LINE = re.compile(r"^footstep(?: [\w-]+)?: error: ")
#: Blender's own log lines, which belong on stderr
NOISE = re.compile(r"^(\d\d:\d\d\.\d{3} |Info: |Read blend: |Warning: |BVH Exported)")
CMU_WALK = os.path.join(os.path.dirname(ROOT), "shared", "mocap", "cmu", "cmu_16_16_walk.bvh")
#: the pool is cached under a hash of these and ``fuzz_cases.POOL_VERSION`` (bump it when the builder changes)
POOL_SOURCES = ["footstep_planner/blender/sample/mannequin.py", "footstep_planner/blender/sample/sample_scenes.py"] + [
    f"footstep_planner/core/sample/{m}.py" for m in ("mannequin", "gait", "specs", "course", "feet", "body")] + [
    "benchmarks/fuzz_cases.py"]


def default_python() -> str:
    venv = os.path.join(ROOT, ".venv", "bin", "python")
    return venv if os.path.exists(venv) else sys.executable


def child_env(extra: dict | None = None) -> dict:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([ROOT] + ([env["PYTHONPATH"]] if env.get("PYTHONPATH") else []))
    env["PYTHONDONTWRITEBYTECODE"] = "1"
    env.update(extra or {})
    return env


# ============================================================== the pool of base scenes

def _pool_tag() -> str:
    h = hashlib.sha256(str(fc.POOL_VERSION).encode())
    for rel in POOL_SOURCES:
        with open(os.path.join(ROOT, rel), "rb") as fh:
            h.update(fh.read())
    return h.hexdigest()[:10]


def pool_items(folder: str, needs: set) -> tuple[dict, list]:
    """(pool key -> path, items the worker must build for the missing ones)."""
    paths, items = {}, []
    sample, report = os.path.join(folder, "sample.blend"), os.path.join(folder, "report.json")
    paths.update({"@sample": sample, "@report": report, "@bvh": os.path.join(folder, "walk.bvh")})
    paths["@cmu"] = CMU_WALK if os.path.exists(CMU_WALK) else paths["@bvh"]
    if needs & {"@sample", "@report"} and not (os.path.exists(sample) and os.path.exists(report)):
        items.append({"what": "sample", "path": sample, "report": report})
    if needs & {"@bvh", "@cmu"} and not os.path.exists(paths["@bvh"]):
        items.append({"what": "bvh", "path": paths["@bvh"]})
    for key in sorted(k for k in needs if k.startswith("@sacred:")):
        variant = key.split(":", 1)[1]
        paths[key] = os.path.join(folder, f"sacred-{variant}.blend")
        if not os.path.exists(paths[key]):
            items.append({"what": "sacred", "variant": variant, "path": paths[key]})
    for key in sorted(k for k in needs if k.startswith("@scene:")):
        _, seed, j = key.split(":")
        spec = fc.scene_spec(int(seed), int(j))
        paths[key] = os.path.join(folder, f"scene-{hashlib.sha256(json.dumps(spec).encode()).hexdigest()[:12]}.blend")
        if not os.path.exists(paths[key]):
            items.append({"what": "scene", "spec": spec, "path": paths[key]})
    return paths, items


def build_pool(work: str, needs: set, python: str, jobs: int = 2, log=print) -> dict:
    """Build the pool items ``needs`` asks for (cached in ``work``); returns key -> path."""
    folder = os.path.join(work, f"pool-{_pool_tag()}")
    os.makedirs(folder, exist_ok=True)
    paths, items = pool_items(folder, needs)
    if items:
        t0 = time.perf_counter()
        chunks = [items[k::jobs] for k in range(jobs) if items[k::jobs]]
        with concurrent.futures.ThreadPoolExecutor(len(chunks)) as ex:
            for ok in ex.map(lambda c: _pool_worker(c, folder, python), chunks):
                if not ok:
                    log("fuzz: some base scenes failed to build (see pool-worker.log); their cases are skipped")
        log(f"fuzz: built {len(items)} pool item(s) in {time.perf_counter() - t0:.1f} s ({folder})")
    return {k: p for k, p in paths.items() if os.path.exists(p)}


def _pool_worker(items: list, folder: str, python: str) -> bool:
    fd, spec = tempfile.mkstemp(prefix="items-", suffix=".json", dir=folder)
    with os.fdopen(fd, "w") as fh:
        json.dump(items, fh)
    with open(os.path.join(folder, "pool-worker.log"), "ab") as log:
        proc = subprocess.run([python, os.path.abspath(__file__), "--pool-worker", spec], cwd=folder,
                              env=child_env(), stdout=log, stderr=log, stdin=subprocess.DEVNULL)
    os.unlink(spec)
    return proc.returncode == 0


# ============================================================== before and after

def entry(path: str) -> tuple:
    """What a file is, to compare: its kind and content (a file's hash and mtime, a link's
    target); never opens a FIFO or a device."""
    st = os.lstat(path)
    if stat.S_ISREG(st.st_mode):
        h = hashlib.sha256()
        with open(path, "rb") as fh:
            for block in iter(lambda: fh.read(1 << 20), b""):
                h.update(block)
        return ("file", h.hexdigest(), st.st_mtime_ns, st.st_size)
    if stat.S_ISLNK(st.st_mode):
        return ("link", os.readlink(path))
    if stat.S_ISDIR(st.st_mode):
        return ("dir",)
    return ("special", stat.S_IFMT(st.st_mode), st.st_ino)


def snapshot(root: str) -> dict:
    """Every entry under ``root`` (hidden ones, links, folders): relative path -> ``entry``."""
    out = {}
    for folder, dirs, files in os.walk(root):
        for name in dirs + files:
            path = os.path.join(folder, name)
            try:
                out[os.path.relpath(path, root)] = entry(path)
            except OSError as ex:  # (unreadable: record why)
                out[os.path.relpath(path, root)] = ("error", ex.errno)
    return out


@dataclass
class Run:
    status: int | None
    stdout: str
    stderr: str
    seconds: float
    timed_out: bool = False
    killed: bool = False  # (still running after Ctrl-C: killed, so it could not clean up)


def run_command(python: str, argv: list, cwd: str, env: dict, timeout: float, grace: float = 10.0) -> Run:
    """``python -m footstep_planner ARGV`` in ``cwd``; after ``timeout`` seconds its process
    group gets a Ctrl-C (SIGINT), and ``grace`` seconds later a SIGKILL."""
    t0 = time.perf_counter()
    proc = subprocess.Popen([python, "-m", "footstep_planner", *argv], cwd=cwd, env=env, stdin=subprocess.DEVNULL,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True)
    timed_out = killed = False
    try:
        out, err = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        timed_out = True
        os.killpg(proc.pid, signal.SIGINT)
        try:
            out, err = proc.communicate(timeout=grace)
        except subprocess.TimeoutExpired:
            killed = True
            os.killpg(proc.pid, signal.SIGKILL)
            out, err = proc.communicate()
    text = lambda b: b.decode("utf-8", "replace")  # noqa: E731
    status = None if timed_out else proc.returncode
    return Run(status, text(out), text(err), time.perf_counter() - t0, timed_out, killed)


# ============================================================== judging a case

def _rel(path: str, root: str) -> str | None:
    rel = os.path.relpath(path, root)
    return None if rel == ".." or rel.startswith("../") else rel


def claims(case: fc.Case, root: str) -> dict:
    """Who owns what, resolved before the command runs: "*" (the command) and each job
    number -> {"files": [paths], "dirs": [paths]}, each path a tuple of its spellings
    inside ``root`` (as given, and through links)."""
    work = os.path.join(root, "work")

    def resolve(paths):
        out = []
        for p in paths:
            full = os.path.normpath(os.path.join(work, fc.fill(p, root, work)))
            spellings = tuple(dict.fromkeys(r for r in (_rel(full, root), _rel(os.path.realpath(full), root)) if r))
            out += [spellings] if spellings else []
        return out

    inputs = [sp for sp in resolve(input_args(case.argv)) if os.path.lexists(os.path.join(root, sp[0]))]
    own = {"*": {"files": resolve(case.owned), "dirs": resolve(case.owned_dirs), "inputs": inputs}}
    for n, paths in case.job_owned.items():
        own[n] = {"files": resolve(paths), "dirs": []}
    return own


OUTPUT_FLAGS = ("--out", "--report", "--plot")


def input_args(argv: list) -> list:
    """The arguments that may name input files: all but the verb, options and the
    values of output options."""
    return [a for k, a in enumerate(argv) if k and not a.startswith("--") and argv[k - 1] not in OUTPUT_FLAGS]


def job_statuses(stdout: str) -> dict:
    """Job number -> baked/failed/invalid, from a batch's summary table."""
    out = {}
    for line in stdout.splitlines():
        m = re.match(r"job (\d+)\b", line)
        if m and len(line) > 49 and line[41:49].strip() in ("baked", "failed", "invalid"):
            out[m.group(1)] = line[41:49].strip()
    return out


def outcome(case: fc.Case, run: Run, jobs: dict) -> str:
    """ok, partial, refused (an expected failure: exit 2 with one message, a job list none
    of whose jobs baked, an import-clips that imported nothing), traceback, timeout or
    other. import-clips and analyze count the files and clips they refused in their exit
    status: partial when the others were imported (and saved) or analysed."""
    errors = [ln for ln in run.stderr.splitlines() if ERROR_LINE.match(ln)]
    if run.timed_out:
        return "timeout"
    if TRACEBACK in run.stderr:
        return "traceback"
    if run.status == 0:
        return "ok"
    if case.batch and jobs and 1 <= run.status <= 100:
        return "partial" if "baked" in jobs.values() else "refused"
    saved = any(ln.startswith("saved ") for ln in run.stdout.splitlines())
    if case.argv[0] == "import-clips" and 1 <= run.status <= 100 and errors and saved:
        return "partial"  # (some files or takes were refused; the others imported and saved)
    if run.status == 2 and len(errors) == 1:
        return "refused"
    if case.argv[0] in ("analyze", "import-clips") and 1 <= run.status <= 100 and errors:
        return "partial" if case.argv[0] == "analyze" else "refused"  # (each refused file or clip named)
    return "other"


def allowed(case: fc.Case, result: str, jobs: dict, own: dict) -> tuple[set, set]:
    """(files, folders) the command may have written, given how it ended."""
    if result == "ok" or (result == "partial" and not case.batch):
        keys = list(own)
    elif result == "partial":
        keys = ["*"] + [n for n, s in jobs.items() if s == "baked" and n in own]
    else:
        keys = []
    flat = lambda what: {p for k in keys for spellings in own[k][what] for p in spellings}  # noqa: E731
    return flat("files"), flat("dirs")


def _may_write(rel: str, kind: tuple | None, files: set, dirs: set) -> bool:
    """Whether an owned output is at ``rel``: one of the files, a picture in one of the
    folders, or (``kind`` a new folder) a folder made on the way to them."""
    if rel in files or (rel.endswith(".png") and os.path.dirname(rel) in dirs):
        return True
    made_for_one = rel in dirs or any(p.startswith(rel + "/") for p in files | dirs)
    return kind is not None and kind[0] == "dir" and made_for_one


def missing_outputs(own: dict, after: dict) -> list[str]:
    """The command's own files that are not there (after it said it succeeded)."""
    return sorted(sp[0] for sp in own["*"]["files"] if not any(p in after for p in sp))


def _stdout_problems(case: fc.Case, run: Run) -> tuple[bool, bool]:
    """(bad JSON: --json and stdout not exactly one JSON document (empty is fine after a
    failure); noise: Blender's log lines on stdout)."""
    noise = any(NOISE.match(ln) for ln in run.stdout.splitlines())
    if "--json" not in case.argv or run.timed_out:
        return False, noise
    if not run.stdout.strip():
        return run.status == 0, noise
    try:
        json.loads(run.stdout)
    except ValueError:
        return True, noise
    return False, noise


def changes(before: dict, after: dict, protected: set, files: set, dirs: set) -> tuple[list, list]:
    """(entries there before that changed or went and were not the command's to write, or
    are ``protected``; new entries that are not the command's outputs)."""
    changed = [r for r, e in before.items() if e[0] != "dir" and after.get(r) != e
               and (r in protected or not _may_write(r, None, files, dirs))]
    changed += [r for r, e in before.items() if e[0] == "dir" and r not in after]
    new = [r for r, e in after.items() if r not in before and not _may_write(r, e, files, dirs)]
    return sorted(changed), sorted(new)


def judge(case: fc.Case, before: dict, after: dict, run: Run, own: dict) -> dict:
    """The record of one case: how it ended, what it changed that it did not own, what it
    left behind, and whether its stdout was clean."""
    jobs = job_statuses(run.stdout) if case.batch else {}
    result = outcome(case, run, jobs)
    files, dirs = allowed(case, result, jobs, own)
    protected = {p for spellings in own["*"]["inputs"] for p in spellings}
    protected |= {r for r, e in before.items() if e[0] == "special"}  # (a FIFO, a device: never replaced)
    changed, litter = changes(before, after, protected, files, dirs)
    bad_json, noise = _stdout_problems(case, run)
    unexpected = (case.expect == "ok" and result != "ok") or (case.expect == "fail" and result in ("ok", "partial"))
    err = [ln for ln in run.stderr.splitlines() if ln.strip()]
    return {"id": case.id, "kind": case.kind, "argv": case.argv, "note": case.note, "status": run.status,
            "outcome": result, "seconds": round(run.seconds, 2), "last_line": err[-1] if err else "",
            "stderr_tail": err[-6:], "error_lines": sum(bool(ERROR_LINE.match(ln)) for ln in err),
            "traceback": TRACEBACK in run.stderr, "killed": run.killed, "changed": changed,
            "litter": [] if run.killed else litter,  # (killed: it had no chance to clean up)
            "missing_outputs": missing_outputs(own, after) if result == "ok" and not case.batch else [],
            "bad_json": bad_json, "stdout_noise": noise, "unexpected": f"expected {case.expect}" if unexpected else "",
            "jobs": jobs}


FAILURE_FLAGS = ("traceback", "timeout", "other", "changed", "litter", "bad_json", "missing_outputs", "unexpected")


def failures(rec: dict) -> list[str]:
    """Which targets a case missed."""
    out = ["traceback"] if rec["traceback"] else []
    out += [f for f in ("timeout", "other") if rec["outcome"] == f]
    return list(dict.fromkeys(out + [f for f in FAILURE_FLAGS[3:] if rec.get(f)]))


# ============================================================== running cases

def _remove(folder: str, locked) -> None:
    fc.unlock(locked)
    shutil.rmtree(folder, ignore_errors=True)


def run_case(case: fc.Case, work: str, pool: dict, python: str, keep: bool = False,
             timeout: float | None = None) -> dict:
    """Lay out the case in a fresh folder, snapshot, run, snapshot, judge."""
    root = os.path.join(work, "cases", case.id)
    if os.path.lexists(root):
        subprocess.run(["chattr", "-R", "-i", root], capture_output=True)
        shutil.rmtree(root)
    missing = case.needs() - set(pool)
    if missing:
        return {"id": case.id, "kind": case.kind, "argv": case.argv, "note": case.note, "outcome": "skipped",
                "why": f"pool items missing: {sorted(missing)}"}
    locked = fc.materialise(case, root, pool)
    try:
        cwd = os.path.join(root, "work")
        argv = [fc.fill(a, root, cwd) for a in case.argv]
        own, before = claims(case, root), snapshot(root)
        env = child_env({"TMPDIR": os.path.join(root, "tmp"),
                         "BLENDER_USER_RESOURCES": os.path.join(work, "blender_user")})
        run = run_command(python, argv, cwd, env, min(case.timeout, timeout or case.timeout))
        rec = judge(case, before, snapshot(root), run, own)
        rec["folder"] = root
    finally:
        if not keep:
            _remove(root, locked)
        else:
            fc.unlock(locked)
    return rec


def run_cases(cases: list, work: str, jobs: int = 2, python: str | None = None, keep: bool = False,
              timeout: float | None = None, progress=None) -> list[dict]:
    """Build the pool the cases need, then run them ``jobs`` at a time; records in case order."""
    python = python or default_python()
    os.makedirs(work, exist_ok=True)
    pool = build_pool(work, set().union(*(c.needs() for c in cases)), python, jobs, log=progress or (lambda *_: None))
    pool_before = {k: entry(p) for k, p in pool.items()}
    records = [None] * len(cases)
    with concurrent.futures.ThreadPoolExecutor(jobs) as ex:
        futures = {ex.submit(run_case, c, work, pool, python, keep, timeout): i for i, c in enumerate(cases)}
        for done, fut in enumerate(concurrent.futures.as_completed(futures), 1):
            records[futures[fut]] = fut.result()
            if progress:
                rec = records[futures[fut]]
                missed = " ".join(failures(rec)) if "status" in rec else ""
                progress(f"[{done}/{len(cases)}] {rec['id']}: {rec['outcome']} {missed}")
    changed = [p for k, p in pool.items() if entry(p) != pool_before[k]]
    if changed and progress:
        progress(f"fuzz: the shared pool files changed during the run (a case reached outside its folder): {changed}")
    return records


# ============================================================== the report

COLUMNS = [("cases", lambda r: True), ("exit-0", lambda r: r["outcome"] == "ok"),
           ("partial", lambda r: r["outcome"] == "partial"), ("exp-fail", lambda r: r["outcome"] == "refused"),
           ("other-exit", lambda r: r["outcome"] == "other"), ("traceback", lambda r: r.get("traceback")),
           ("timeout", lambda r: r["outcome"] == "timeout"), ("changed", lambda r: bool(r.get("changed"))),
           ("litter", lambda r: bool(r.get("litter"))), ("bad-json", lambda r: r.get("bad_json")),
           ("no-output", lambda r: bool(r.get("missing_outputs"))), ("unexpected", lambda r: bool(r.get("unexpected"))),
           ("failing", lambda r: bool(failures(r)))]


def table(records: list[dict]) -> str:
    ran = [r for r in records if r["outcome"] != "skipped"]
    kinds = list(dict.fromkeys(r["kind"] for r in ran))
    head = f"{'kind':<16s}" + "".join(f"{name:>11s}" for name, _ in COLUMNS)
    rows = [head, "-" * len(head)]
    for kind in kinds + ["total"]:
        rs = [r for r in ran if kind in ("total", r["kind"])]
        rows.append(f"{kind:<16s}" + "".join(f"{sum(bool(fn(r)) for r in rs):>11d}" for _, fn in COLUMNS))
        if kind == kinds[-1]:
            rows.append("-" * len(head))
    skipped = len(records) - len(ran)
    noise = sum(bool(r.get("stdout_noise")) for r in ran)
    rows.append(f"(exp-fail: exit 2 with one message, or a job list none of whose jobs baked; "
                f"stdout with Blender's log lines: {noise}" + (f"; skipped: {skipped}" if skipped else "") + ")")
    return "\n".join(rows)


def repro(rec: dict, pool: int) -> str:
    return f"python benchmarks/fuzz.py --only {rec['id']}" + (f" --pool {pool}" if pool != 20 else "")


def _clip(line: str, width: int = 220) -> str:
    return line if len(line) <= width else f"{line[:90]} ... {line[-(width - 95):]}"


def describe(rec: dict, pool: int, lines: int = 3) -> str:
    out = [f"{rec['id']} [{', '.join(failures(rec))}] exit {rec['status']} ({rec['note']})",
           f"  $ footstep {_clip(shlex.join(rec['argv']), 300)}"]
    out += [f"  stderr: {_clip(ln)}" for ln in rec["stderr_tail"][-lines:]]
    for key in ("changed", "litter", "missing_outputs"):
        if rec.get(key):
            out.append(f"  {key}: {', '.join(rec[key][:5])[:300]}")
    out.append(f"  again: {repro(rec, pool)}")
    return "\n".join(out)


def write_json_atomic(path: str, doc) -> None:
    folder = os.path.dirname(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(prefix=".fuzz-", suffix=".json", dir=folder)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            json.dump(doc, fh, indent=1, ensure_ascii=False)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


# ============================================================== command line

def _args(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--cases", type=int, default=200)
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--jobs", type=int, default=2, help="cases run at a time")
    p.add_argument("--kinds", help=f"comma-separated, of: {', '.join(fc.KINDS)}")
    p.add_argument("--pool", type=int, default=20, help="base scenes built per run")
    p.add_argument("--only", help="run these case ids (comma-separated), keep their folders, show everything")
    p.add_argument("--out", help="write every case's record here (JSON)")
    p.add_argument("--work", default=os.path.join(tempfile.gettempdir(), "footstep-fuzz"),
                   help="folder for the pool (cached) and the cases")
    p.add_argument("--timeout", type=float, default=120.0, help="seconds a case may take")
    p.add_argument("--keep", action="store_true", help="keep every case's folder")
    p.add_argument("--show", type=int, default=12, help="failing cases to describe")
    p.add_argument("--python", default=default_python())
    p.add_argument("--pool-worker", help=argparse.SUPPRESS)
    return p.parse_args(argv)


def _cases(args) -> list:
    ctx = fc.Ctx(seed=args.seed, pool=args.pool, immutable=fc.immutable_works(args.work))
    if args.only:
        out = []
        for cid in args.only.split(","):
            kind, seed, index = fc.parse_id(cid.strip())
            out.append(fc.make_case(kind, seed, index, fc.Ctx(seed, args.pool, ctx.immutable)))
        return out
    kinds = args.kinds.split(",") if args.kinds else None
    unknown = set(kinds or ()) - set(fc.KINDS)
    if unknown:
        sys.exit(f"fuzz: no such kind(s): {', '.join(sorted(unknown))}; kinds: {', '.join(fc.KINDS)}")
    return fc.generate(args.seed, args.cases, kinds, ctx)


def _show_only(records: list, pool: int) -> None:
    for rec in records:
        if rec["outcome"] == "skipped":
            print(f"{rec['id']}: skipped ({rec['why']})")
            continue
        print(describe(rec, pool, lines=30))
        print(f"  outcome: {rec['outcome']}; folder kept: {rec['folder']}; {rec['seconds']} s")


def main(argv=None) -> int:
    args = _args(argv)
    if args.pool_worker:
        with open(args.pool_worker, encoding="utf-8") as fh:
            fc.build_pool(json.load(fh))
        return 0
    os.makedirs(args.work, exist_ok=True)
    cases = _cases(args)
    t0 = time.perf_counter()
    records = run_cases(cases, args.work, args.jobs, args.python, keep=args.keep or bool(args.only),
                        timeout=args.timeout, progress=lambda line: print(line, file=sys.stderr, flush=True))
    wall = time.perf_counter() - t0
    if args.only:
        _show_only(records, args.pool)
        return 0
    print(table(records))
    ran = [r for r in records if r["outcome"] != "skipped"]
    failing = [r for r in ran if failures(r)]
    print(f"\n{len(ran)} cases in {wall:.0f} s wall ({wall / max(1, len(ran)):.2f} s a case at --jobs {args.jobs}; "
          f"1000 cases: about {wall / max(1, len(ran)) * 1000 / 60:.0f} min); mean command time "
          f"{sum(r['seconds'] for r in ran) / max(1, len(ran)):.2f} s; {len(failing)} failing")
    for rec in failing[:args.show]:
        print("\n" + describe(rec, args.pool))
    if args.out:
        write_json_atomic(args.out, {"seed": args.seed, "pool": args.pool, "wall_seconds": wall, "cases": records})
    return 1 if failing else 0


if __name__ == "__main__":
    sys.exit(main())
