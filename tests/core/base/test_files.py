"""Outputs written as one transaction (core/base/files.py): all files land, or none."""

import os

import pytest

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
    real = os.rename

    def rename(src, dst):
        if str(dst).endswith("b.json") and ".tmp" in str(src):
            raise PermissionError(1, "Operation not permitted", str(dst))
        return real(src, dst)

    monkeypatch.setattr(files.os, "rename", rename)
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
