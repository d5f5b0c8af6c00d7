"""A fixed sample of the fuzz campaign (``benchmarks/fuzz.py``, issue 13): a dozen cases of
seed 1 across the kinds, each run as ``python -m footstep_planner ...`` in a folder of its
own, held to the campaign's target: no traceback, no file changed that the command did
not own, and nothing left behind by a command that failed (nor temporary files). Any case
reruns alone with ``python benchmarks/fuzz.py --only CASE_ID``.

The sample needs only the Turns sample scene, its plan report and a BVH file (built once,
in a subprocess, in a few seconds); the cases are quick ones (no long plans), two at a
time, each given at most 50 s.
"""

import pytest

from benchmarks import fuzz
from conftest import HANG_SECONDS

fc = fuzz.fc

#: (case id, what it tries): one case of each failure the campaign found (the first six
#: were tracebacks or overwritten files on the tree of 2026-11-29 05:00, since fixed; the
#: next two leave files behind), and a few that have always passed
SAMPLE = [
    ("jobs-1-3", "a job list naming a character with a lone UTF-16 surrogate"),
    ("plot-1-11", "a plan report whose synthesis is null"),
    ("plot-1-20", "a plan report nested 100000 deep"),
    ("plot-1-25", "a plan report whose lists are all empty"),
    ("output_is_input-1-2", "plot reading plots/r_tau.png and writing r's curves into plots/"),
    ("unwritable-1-13", "bake --out at a FIFO (a named pipe must not be replaced by a file)"),
    ("unwritable-1-61", "bake --report new --out over an immutable file: fails, and leaves the report"),
    ("plot-1-90", "plot --name ../escape: pictures written beside the --out folder"),
    ("output_is_input-1-3", "plan --report through two symbolic links to the scene"),
    ("failed_bake-1-0", "a plan that fails late, with --report at a previous good file"),
    ("bad_scene-1-1", "plan of a text file named scene.blend, a previous report beside it"),
    ("import_clips-1-16", "BVH files with NaN, a 1e-300 s frame time, 99999 channels; --out immutable"),
    ("analyze-1-14", "a BVH file with two joints of one name"),
    ("jobs-1-13", "a job list with one good job and one with an empty start: one bakes"),
    ("sacred-1-5", "issue 26: the character's NLA in tweak mode (was a traceback): refused in one line"),
    ("sacred-1-3", "issue 26: a driver on the character's location (baked wrong, exit 0): an error"),
]


@pytest.fixture(scope="module")
def records(tmp_path_factory):
    work = str(tmp_path_factory.mktemp("fuzz"))
    ctx = fc.Ctx(seed=1, pool=20, immutable=fc.immutable_works(work))
    cases = [fc.make_case(*fc.parse_id(cid), ctx) for cid, _ in SAMPLE]
    # (the timeout only catches a hang: a slow or loaded machine must not fail a case)
    return {rec["id"]: rec for rec in fuzz.run_cases(cases, work, jobs=2, timeout=HANG_SECONDS)}


def test_the_sample_spans_the_kinds_on_the_sample_scene_and_is_fixed():
    cases = [fc.make_case(*fc.parse_id(cid)) for cid, _ in SAMPLE]
    assert len({c.kind for c in cases}) >= 7
    assert not any(need.startswith("@scene:") for c in cases for need in c.needs())  # (the sample scene only)
    assert [c.to_dict() for c in cases] == [fc.make_case(*fc.parse_id(cid)).to_dict() for cid, _ in SAMPLE]


@pytest.mark.parametrize("cid,what", SAMPLE, ids=[cid for cid, _ in SAMPLE])
def test_no_traceback_and_nothing_changed_it_did_not_own(records, cid, what):
    rec = records[cid]
    assert rec["outcome"] != "skipped", rec.get("why")
    shown = f"{what}:\n{fuzz.describe(rec, 20, lines=8)}"
    assert not rec["traceback"], shown
    assert not rec["changed"], shown


@pytest.mark.parametrize("cid,what", SAMPLE, ids=[cid for cid, _ in SAMPLE])
def test_nothing_left_behind(records, cid, what):
    rec = records[cid]
    assert not rec.get("litter"), f"{what}:\n{fuzz.describe(rec, 20, lines=8)}"


@pytest.mark.parametrize("cid,what", [c for c in SAMPLE if c[0].startswith("sacred")],
                         ids=[cid for cid, _ in SAMPLE if cid.startswith("sacred")])
def test_a_wrong_bake_never_exits_0(records, cid, what):
    rec = records[cid]
    assert not rec["unexpected"] and rec["status"] != 0, f"{what}:\n{fuzz.describe(rec, 20, lines=8)}"
