"""The command line's streams: stdout carries the command's results and nothing else
(one JSON document with ``--json``); Blender's own log lines ("Read blend: ...") and
progress go to stderr. Progress is a bar on a terminal, plain lines otherwise.
"""

from __future__ import annotations

import contextlib
import ctypes
import io
import os
import sys
import time

_RESULTS = None


def results():
    """The stream the command's results go to (stdout as the caller gave it)."""
    return _RESULTS if _RESULTS is not None else sys.stdout


def say(*parts, **kw) -> None:
    """Print a result (a table, a path saved, the JSON document) on the results stream."""
    print(*parts, file=results(), **kw)
    results().flush()


def _flush_c_stdio() -> None:
    with contextlib.suppress(Exception):
        ctypes.CDLL(None).fflush(None)


@contextlib.contextmanager
def results_on_stdout():
    """While it lasts, file descriptor 1 goes to stderr (so whatever Blender or a library
    prints lands there) and ``say`` writes to the real stdout. Where stdout is not a real
    file (a test's capture), nothing is redirected."""
    global _RESULTS
    try:
        fd, err = sys.stdout.fileno(), sys.stderr.fileno()
    except (AttributeError, OSError, ValueError, io.UnsupportedOperation):
        yield sys.stdout
        return
    sys.stdout.flush()
    _flush_c_stdio()
    saved = os.dup(fd)
    out = os.fdopen(os.dup(saved), "w", encoding="utf-8", errors="replace")
    os.dup2(err, fd)
    _RESULTS = out
    try:
        yield out
    finally:
        _RESULTS = None
        with contextlib.suppress(OSError, ValueError):
            out.flush()
            out.close()
        with contextlib.suppress(OSError, ValueError):
            sys.stdout.flush()
        _flush_c_stdio()
        os.dup2(saved, fd)
        os.close(saved)


class Progress:
    """Progress of a long run on stderr: ``step(done, label)`` draws a bar on a terminal,
    and prints a plain line per step otherwise."""

    def __init__(self, total: int, what: str, stream=None):
        self.total, self.what = max(1, total), what
        self.stream = stream or sys.stderr
        self.tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self.t0 = time.perf_counter()

    def step(self, done: int, label: str) -> None:
        elapsed = time.perf_counter() - self.t0
        if self.tty:
            width = 24
            filled = int(width * done / self.total)
            self.stream.write(f"\r[{'#' * filled}{'.' * (width - filled)}] {done}/{self.total} {self.what} "
                              f"{elapsed:6.1f} s  {label[:60]:<60s}")
            if done >= self.total:
                self.stream.write("\n")
        else:
            self.stream.write(f"footstep: {self.what} {done}/{self.total} ({elapsed:.1f} s): {label}\n")
        self.stream.flush()


__all__ = ["Progress", "results", "results_on_stdout", "say"]
