"""Files a command writes, as one transaction: nothing lost, ever.

Every output is first written to a temporary file beside its destination and renamed
over it in one step (``os.replace``) only when the command has succeeded
(``Outputs.commit``): at every instant the destination is the old file or the whole new
one, even when the process is killed. A failed or interrupted command discards the
temporary files (``Outputs.discard``) and leaves every existing file as it was. What a
killed run leaves (hidden temporary and backup files named by this module's own pattern,
``litter``) is removed by the next run that writes there. An output that is one of the command's inputs (the same file,
also through a symbolic or hard link), or two outputs at one path, are refused before
any work (``Outputs.claim``).

Pure Python: the Blender layer passes a writer (``save_as_mainfile``) for .blend files.
"""

from __future__ import annotations

import contextlib
import errno
import json
import os
import re
import shutil
import signal
import tempfile
from typing import Callable, Iterable

from .errors import FootstepError


class OutputError(FootstepError):
    """An output that can't be written: it names the path and why."""


def same_file(a: str, b: str) -> bool:
    """Whether two paths name one file: the same real path, or (both existing) the same
    inode, as a hard link is."""
    if os.path.realpath(a) == os.path.realpath(b):
        return True
    try:
        return os.path.samefile(a, b)
    except OSError:
        return False


def describe_os_error(ex: OSError, path: str | None = None) -> str:
    """One line for an OSError: the path and the system's reason (permission denied, no
    space left on device, ...)."""
    where = path or ex.filename or "a file"
    reason = ex.strerror or str(ex)
    if ex.errno == errno.ENOSPC:
        reason = "no space left on the device"
    return f"{where}: {reason[:1].lower()}{reason[1:]}"


def _probe_dir(directory: str) -> None:
    """Raise OutputError unless a file can be created in ``directory`` (tried for real:
    permission bits say nothing to root, a read-only mount or a file in the way does)."""
    try:
        fd, probe = tempfile.mkstemp(prefix=".footstep-probe-", dir=directory)
    except OSError as ex:
        raise OutputError(f"cannot write into {directory}: {describe_os_error(ex, directory).split(': ', 1)[1]}") from None
    os.close(fd)
    os.unlink(probe)


def _name_max(directory: str) -> int:
    """The longest file name (bytes) ``directory`` allows."""
    try:
        return int(os.pathconf(directory, "PC_NAME_MAX"))
    except (OSError, ValueError):
        return 255


def _existing_parent(path: str) -> str:
    parent = os.path.dirname(os.path.abspath(path))
    while not os.path.exists(parent):
        parent = os.path.dirname(parent)
    return parent


class Outputs:
    """The outputs of one command. ``claim`` each before any work, ``stage`` (or
    ``write_json``/``write_text``) each when ready, ``commit`` at the end. Used as a context
    manager, anything staged and not committed is discarded on the way out."""

    def __init__(self, inputs: Iterable[str] = ()):
        self.inputs = [os.path.abspath(p) for p in inputs if p]
        self.claimed: dict[str, str] = {}
        self._staged: list[tuple[str, str]] = []
        self._made_dirs: list[str] = []
        self._scratch: list[str] = []
        self.committed: list[str] = []

    def __enter__(self) -> "Outputs":
        return self

    def __exit__(self, *exc) -> None:
        self.discard()

    # -- before any work ----------------------------------------------------------
    def claim(self, path: str, what: str) -> str:
        """Refuse ``path`` (one message naming it and what it would have held) when it is
        an input, already another output, a folder, or not writable; return its absolute
        path."""
        if not path or path.endswith(("/", os.sep)):
            raise OutputError(f"the {what} {path!r} is not a file name" + (": give one" if not path else
                              " (it ends in a folder separator): add the file's name"))
        full = os.path.abspath(path)
        for inp in self.inputs:
            if same_file(full, inp):
                raise OutputError(f"the {what} {path!r} is one of the inputs ({inp}); refusing to "
                                  "write over it: choose another path")
        for other, other_what in self.claimed.items():
            # (outputs replace the path itself, never write through a link: two links to
            # one file are two outputs)
            if os.path.normpath(full) == os.path.normpath(other):
                raise OutputError(f"the {what} and the {other_what} are both {path!r}: give each its own path")
        if os.path.isdir(full):
            raise OutputError(f"the {what} {path!r} is a folder, not a file")
        if os.path.exists(full) and not os.path.isfile(full):
            raise OutputError(f"the {what} {path!r} is not a regular file (a pipe or a device?): "
                              "refusing to replace it")
        parent = _existing_parent(full)
        if not os.path.isdir(parent):
            raise OutputError(f"cannot write the {what} {path!r}: {parent} is a file, not a folder")
        _probe_dir(parent)
        longest = _name_max(parent)
        name = os.fsencode(os.path.basename(full))
        if len(name) > longest:
            raise OutputError(f"the {what}'s file name is {len(name)} bytes long; its folder {parent} allows "
                              f"{longest}: give it a shorter name")
        self.claimed[full] = what
        return full

    # -- while working ------------------------------------------------------------
    def _make_dirs(self, directory: str) -> None:
        missing = []
        while not os.path.isdir(directory):
            missing.append(directory)
            directory = os.path.dirname(directory)
        for d in reversed(missing):
            os.mkdir(d)
            self._made_dirs.append(d)

    def stage(self, path: str, write: Callable[[str], None]) -> str:
        """Write ``path``'s content with ``write(temporary_path)`` into a temporary file
        beside it; it takes ``path``'s place at ``commit``. Returns the temporary path."""
        full = os.path.abspath(path)
        self._make_dirs(os.path.dirname(full))
        base, ext = os.path.splitext(os.path.basename(full))
        fd, tmp = tempfile.mkstemp(prefix=f".{base[:100]}.fp{os.getpid()}.", suffix=f".tmp{ext[:20]}",
                                   dir=os.path.dirname(full))
        os.close(fd)
        os.unlink(tmp)  # (a random name kept free: a writer that finds a file there may back it up)
        self._staged.append((tmp, full))
        try:
            write(tmp)
        except BaseException:
            self.unstage(tmp)
            raise
        return tmp

    def write_text(self, path: str, text: str) -> str:
        def write(tmp):
            with open(tmp, "w", encoding="utf-8") as fh:
                fh.write(text)
                fh.flush()
                os.fsync(fh.fileno())
        return self.stage(path, write)

    def write_json(self, path: str, doc) -> str:
        return self.write_text(path, json.dumps(doc))

    def adopt(self, produced: str, path: str) -> str:
        """Stage a file made elsewhere (in a ``scratch`` folder) to take ``path``'s place."""
        return self.stage(path, lambda tmp: os.replace(produced, tmp))

    def scratch(self, directory: str) -> str:
        """A private temporary folder in ``directory`` (made if missing) for files that are
        made under names of their own, then ``adopt``-ed; removed at the end."""
        self._make_dirs(os.path.abspath(directory))
        path = tempfile.mkdtemp(prefix=".footstep-", dir=directory)
        self._scratch.append(path)
        return path

    def unstage(self, tmp: str) -> None:
        """Drop one staged file (its job failed after all)."""
        self._staged = [(t, f) for t, f in self._staged if t != tmp]
        with contextlib.suppress(OSError):
            os.unlink(tmp)

    # -- at the end -----------------------------------------------------------------
    def commit(self) -> list[str]:
        """Rename every staged file into place (Ctrl-C held off meanwhile); returns the
        destinations."""
        with _signals_held():
            _swap_in(self._staged)
            self.committed += [final for _, final in self._staged]
            self._staged = []
            self._made_dirs = []
        self._remove_scratch()
        return list(self.committed)

    def _remove_scratch(self) -> None:
        for d in self._scratch:
            shutil.rmtree(d, ignore_errors=True)
        self._scratch = []

    def discard(self) -> None:
        """Remove every staged temporary file and any folder made for it."""
        for tmp, _ in self._staged:
            with contextlib.suppress(OSError):
                os.unlink(tmp)
        self._staged = []
        self._remove_scratch()
        for d in reversed(self._made_dirs):
            with contextlib.suppress(OSError):
                os.rmdir(d)
        self._made_dirs = []


def _aside(final: str) -> str:
    """A free name beside ``final`` for a backup of the file it replaces, kept until all
    the command's files are in place."""
    fd, bak = tempfile.mkstemp(prefix=f".{os.path.basename(final)[:100]}.fp{os.getpid()}.", suffix=".old",
                               dir=os.path.dirname(final))
    os.close(fd)
    os.unlink(bak)
    return bak


def _backup(final: str) -> str:
    """A backup of ``final`` beside it (a hard link, else a copy; a symbolic link: one
    to the same target); ``final`` stays in place."""
    bak = _aside(final)
    if os.path.islink(final):
        os.symlink(os.readlink(final), bak)
        return bak
    try:
        os.link(final, bak)
    except OSError:
        shutil.copy2(final, bak)
    return bak


def _swap_in(staged: list[tuple[str, str]]) -> None:
    """Put every staged file in place, all or none: each replaces its destination in one
    step (``os.replace``: the destination is never missing); a backup of each file
    replaced is kept until all are in place, and if any replace fails (a file the system
    won't let go of), the files already replaced are put back from their backups and the
    error raised."""
    backups, placed = {}, []
    try:
        for tmp, final in staged:
            if os.path.lexists(final):
                backups[final] = _backup(final)
        for tmp, final in staged:
            if os.path.exists(tmp):
                os.chmod(tmp, 0o644 & ~_umask())
            os.replace(tmp, final)
            placed.append(final)
    except BaseException:
        for final in placed:
            with contextlib.suppress(OSError):
                if final in backups:
                    os.replace(backups.pop(final), final)
                else:
                    os.unlink(final)
        for bak in backups.values():
            with contextlib.suppress(OSError):
                os.unlink(bak)
        raise
    for bak in backups.values():
        with contextlib.suppress(OSError):
            os.unlink(bak)
    for final in dict.fromkeys(final for _, final in staged):
        remove_litter(final)


def _litter_pattern(final: str) -> re.Pattern:
    """The names of the hidden files this module makes beside ``final``: its temporary
    files (``.<base>.fp<pid>.<random>.tmp<ext>``) and backups
    (``.<name>.fp<pid>.<random>.old``), and the same without the process id (this module's
    earlier versions)."""
    name = os.path.basename(final)
    base, ext = os.path.splitext(name)
    rnd = r"[a-z0-9_]{8}"
    return re.compile(rf"^(?:\.{re.escape(base[:100])}\.(?:fp(\d+)\.)?{rnd}\.tmp{re.escape(ext[:20])}"
                      rf"|\.{re.escape(name[:100])}\.(?:fp(\d+)\.)?{rnd}\.old)$")


def _alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:
        return True
    return True


#: s: a temporary file of this module without a process id in its name (an earlier
#: version's) is litter once this old
LITTER_AGE = 60.0


def litter(final: str) -> list[str]:
    """The hidden temporary and backup files an interrupted run writing ``final`` left
    beside it: named by this module's pattern, and made by a process no longer running
    (or, without a process id in the name, not touched for ``LITTER_AGE`` seconds)."""
    import time

    folder = os.path.dirname(os.path.abspath(final))
    pat = _litter_pattern(final)
    out = []
    with contextlib.suppress(OSError):
        for entry in os.scandir(folder):
            m = pat.match(entry.name)
            if m is None or entry.is_dir(follow_symlinks=False):
                continue
            pid = m.group(1) or m.group(2)
            if pid is not None and _alive(int(pid)):
                continue
            if pid is None and time.time() - entry.stat(follow_symlinks=False).st_mtime < LITTER_AGE:
                continue
            out.append(entry.path)
    return sorted(out)


def remove_litter(final: str) -> list[str]:
    """Remove ``litter(final)``; returns what went."""
    gone = []
    for path in litter(final):
        with contextlib.suppress(OSError):
            os.unlink(path)
            gone.append(path)
    return gone


@contextlib.contextmanager
def _signals_held():
    """Ctrl-C and SIGTERM held off while files are renamed into place; a Ctrl-C that came
    meanwhile is dropped (the command has done its work: its files are in place)."""
    old = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT, signal.SIGTERM})
    handler = None
    try:
        yield
    finally:
        with contextlib.suppress(ValueError):  # (only the main thread may set handlers)
            handler = signal.signal(signal.SIGINT, signal.SIG_IGN)
        signal.pthread_sigmask(signal.SIG_SETMASK, old)
        if handler is not None:
            signal.signal(signal.SIGINT, handler)


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


__all__ = ["OutputError", "Outputs", "describe_os_error", "litter", "remove_litter", "same_file"]
