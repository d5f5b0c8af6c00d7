"""docs/troubleshooting.md lists every message the planner means a user to meet.

Every ``raise`` of a ``FootstepError`` subclass (the expected problems the command line
and the operators show without a traceback) is found in the package's source, and its
message's literal text must appear in the troubleshooting page: at least one run of four
consecutive words of it (the page paraphrases names and numbers as ``<file>``, ``<n>``).
A few messages are raised only for a caller's inconsistent arrays, which the readers of
scenes and files never build; they are listed below with where they are raised, and the
list must not go stale.
"""

from __future__ import annotations

import ast
import pathlib
import re

import footstep_planner

PACKAGE = pathlib.Path(footstep_planner.__file__).parent
DOC = PACKAGE.parent / "docs" / "troubleshooting.md"

# (module, a phrase of the message): raised only when code calls the API with
# inconsistent arguments; no file, scene or setting a user gives reaches them.
API_ONLY = {
    ("core/clips/rig.py", "inconsistent bone arrays"),
    ("core/clips/rig.py", "the bone hierarchy has a cycle"),
    ("core/clips/role_chains.py", "bone names but"),
    ("core/clips/role_chains.py", "has invalid parent index"),
    ("core/clips/role_chains.py", "duplicate bone name"),
    ("core/clips/role_chains.py", "parent cycle through bone"),
    ("core/clips/role_chains.py", "must have shape"),
    ("core/clips/mirror.py", "bones, the rig"),
    ("core/synth/schedule.py", "non-negative numbers summing to 1"),
    ("core/synth/labels.py", "the pace must be one positive number per step"),
}


def _words(text: str) -> list[str]:
    return re.findall(r"[a-z0-9_]+", text.lower())


def _windows(text: str, k: int = 4) -> list[str]:
    w = _words(text)
    if len(w) < 3:
        return []
    return [" ".join(w[i:i + k]) for i in range(max(1, len(w) - k + 1))]


def _literal_parts(node) -> list[str]:
    if isinstance(node, ast.Constant) and isinstance(node.value, str):
        return [node.value]
    if isinstance(node, ast.JoinedStr):
        return [v.value for v in node.values if isinstance(v, ast.Constant)]
    if isinstance(node, ast.BinOp):
        return _literal_parts(node.left) + _literal_parts(node.right)
    return []


def _error_classes(trees) -> set[str]:
    names, grown = {"FootstepError"}, True
    while grown:
        grown = False
        for tree in trees.values():
            for n in ast.walk(tree):
                if isinstance(n, ast.ClassDef) and n.name not in names and any(
                        getattr(b, "id", getattr(b, "attr", None)) in names for b in n.bases):
                    names.add(n.name)
                    grown = True
    return names


def _messages():
    """(module, line, literal parts) of every FootstepError raise with a message."""
    trees = {p.relative_to(PACKAGE).as_posix(): ast.parse(p.read_text())
             for p in PACKAGE.rglob("*.py")}
    errors = _error_classes(trees)
    for module, tree in trees.items():
        for n in ast.walk(tree):
            if not (isinstance(n, ast.Raise) and isinstance(n.exc, ast.Call) and n.exc.args):
                continue
            f = n.exc.func
            if getattr(f, "id", getattr(f, "attr", None)) in errors:
                yield module, n.lineno, _literal_parts(n.exc.args[0])


def test_every_expected_message_is_in_the_troubleshooting_page():
    doc = " " + " ".join(_words(DOC.read_text())) + " "
    missing, seen, used = [], 0, set()
    for module, line, parts in _messages():
        text = " ".join(parts)
        windows = [w for p in parts for w in _windows(p)]
        if not windows:
            continue
        seen += 1
        exempt = {(m, phrase) for m, phrase in API_ONLY if m == module and phrase in text}
        if exempt:
            used |= exempt
            continue
        if not any(f" {w} " in doc for w in windows):
            missing.append(f"{module}:{line}: {text.strip()[:100]}")
    assert seen > 150, f"the scan found only {seen} messages: is it still reading the raises?"
    assert not missing, ("messages missing from docs/troubleshooting.md (add a row):\n"
                         + "\n".join(missing))
    assert used == API_ONLY, f"stale API_ONLY entries: {sorted(API_ONLY - used)}"
