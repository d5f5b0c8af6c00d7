"""Outputs written as one transaction (core/base/files.py): all files land, or none; a
destination is never missing, even when the process is killed; a killed run's litter is
removed by the next run writing there."""

import os
import subprocess
import sys

import pytest

from conftest import HANG_SECONDS
from footstep_planner.core.base import files
from footstep_planner.core.base.files import OutputError, Outputs


def test_all_outputs_land_together(tmp_path):
    (tmp_path / "b.json").write_text("old b")
    with Outputs() as outs:
        for name in ("a.json", "b.json"):
            outs.write_text(str(tmp_path / name), f"new {name}")
        outs.commit()
    assert (tmp_path / "a.json").read_text() == "new a.json" and (tmp_path / "b.json").read_text() == "new b.json"
    assert sorted(os.listdir(tmp_path)) == ["a.json", "b.json"]


def test_a_failing_rename_puts_everything_back(tmp_path, monkeypatch):
    """The second file can't be put in place (as an immutable file can't): the first,
    already in place, is taken back and the old files stand as they were, no litter."""
    (tmp_path / "a.json").write_text("old a")
    (tmp_path / "b.json").write_text("old b")
    real = os.replace

    def replace(src, dst):
        if str(dst).endswith("b.json") and ".tmp" in str(src):
            raise PermissionError(1, "Operation not permitted", str(dst))
        return real(src, dst)

    monkeypatch.setattr(files.os, "replace", replace)
    with Outputs() as outs:
        outs.write_text(str(tmp_path / "a.json"), "new a")
        outs.write_text(str(tmp_path / "b.json"), "new b")
        with pytest.raises(PermissionError):
            outs.commit()
    assert (tmp_path / "a.json").read_text() == "old a" and (tmp_path / "b.json").read_text() == "old b"
    assert sorted(os.listdir(tmp_path)) == ["a.json", "b.json"]


@pytest.mark.parametrize("path, words", [("", "give one"), ("newdir/", "folder separator")])
def test_empty_and_folder_style_paths_are_refused(tmp_path, path, words):
    with pytest.raises(OutputError, match=words):
        Outputs().claim(path, "--report")


def test_a_pipe_is_never_replaced(tmp_path):
    fifo = tmp_path / "pipe.json"
    os.mkfifo(fifo)
    with pytest.raises(OutputError, match="not a regular file"):
        Outputs().claim(str(fifo), "--report")


def test_a_long_name_still_gets_a_temporary_file(tmp_path):
    name = "x" * 245 + ".json"
    with Outputs() as outs:
        outs.write_text(str(tmp_path / name), "ok")
        outs.commit()
    assert (tmp_path / name).read_text() == "ok"


_KILLED_AT = """
import os, sys
sys.path.insert(0, sys.argv[1])
from footstep_planner.core.base import files
calls = [0]
def killer(real):
    def call(*a, **k):
        calls[0] += 1
        if calls[0] == int(sys.argv[3]):
            os._exit(9)  # (killed: no handler, no clean-up runs)
        return real(*a, **k)
    return call
files.os.rename, files.os.replace = killer(os.rename), killer(os.replace)
out = files.Outputs()
out.write_text(os.path.join(sys.argv[2], "out.json"), "new")
out.write_text(os.path.join(sys.argv[2], "report.json"), "new report")
out.commit()
"""


def _run_killed(tmp_path, at: int) -> int:
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    return subprocess.run([sys.executable, "-c", _KILLED_AT, root, str(tmp_path), str(at)], timeout=HANG_SECONDS).returncode


def test_a_kill_at_any_point_leaves_the_old_file_or_the_whole_new_one(tmp_path):
    """Killed at each rename of a commit in turn (issue 26): ``out.json`` is always there,
    old or new, never missing; the next run writing there removes the hidden litter."""
    for at in range(1, 6):
        (tmp_path / "out.json").write_text("old")
        (tmp_path / "report.json").write_text("old report")
        status = _run_killed(tmp_path, at)
        assert (tmp_path / "out.json").read_text() in ("old", "new"), f"killed at rename {at}"
        assert (tmp_path / "report.json").read_text() in ("old report", "new report")
        if status == 0:
            break
    assert _run_killed(tmp_path, 99) == 0  # (a run that is not killed)
    assert sorted(os.listdir(tmp_path)) == ["out.json", "report.json"]
    assert (tmp_path / "out.json").read_text() == "new"


def test_only_this_codes_own_litter_is_removed(tmp_path):
    """Hidden files of the user's beside the output, even alike, stay; this module's own
    temporary and backup files of a dead process go; a live process's are left alone."""
    dead = 2 ** 22 + 12345  # (beyond pid_max's default: no such process)
    theirs = [".out.notes", ".out.json.swp", ".out.12345678.tmp.txt", ".other.fp1.abcd1234.tmp.json"]
    ours = [f".out.fp{dead}.abcd1234.tmp.json", f".out.json.fp{dead}.x1y2z3w4.old"]
    live = [f".out.fp{os.getpid()}.abcd1234.tmp.json"]
    for name in theirs + ours + live:
        (tmp_path / name).write_text("x")
    with Outputs() as outs:
        outs.write_text(str(tmp_path / "out.json"), "new")
        outs.commit()
    assert sorted(os.listdir(tmp_path)) == sorted(theirs + live + ["out.json"])


def test_a_file_name_too_long_for_its_folder_is_refused_before_any_work(tmp_path):
    with pytest.raises(OutputError, match="file name is 300 bytes long; its folder .* allows 255"):
        Outputs().claim(str(tmp_path / ("x" * 295 + ".json")), "report of job 1")
