"""What every clip file's import shares: its error (``ClipImportError``), the outcomes it
reports (``ClipOutcome`` for a file or take, ``ClipImport`` for the whole import), an FBX or
glTF file read by Blender's importers (``_SceneClip``) and a clip while it is imported
(``_Take``); the checks that a file is the library's skeleton (``_check_bvh_fits``,
``_check_fits``) and has legs (``_check_legs``); the tags an imported clip carries
(``_tag_source``).
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field

import numpy as np

from ...core.base.errors import FootstepError
from ...core.clips.roles import map_roles
from .scene import ARMATURE_PROP, SOURCE_FILE_PROP, SOURCE_FPS_PROP


class ClipImportError(FootstepError):
    """An import that cannot be done; names the file, take or bone at fault."""


@dataclass
class _SceneClip:
    """An FBX or glTF file (``kind``) read by Blender's own importer; ``fps`` (its frame
    rate) is known once Blender read it."""

    path: str
    kind: str
    fps: float = 0.0


@dataclass
class ClipOutcome:
    """One file or take of an import: imported as the action named ``clip`` (with
    ``notes`` on what was done to it), or refused with ``error`` (one line naming the file
    and take)."""

    path: str
    take: str | None = None
    clip: str | None = None
    notes: list[str] = field(default_factory=list)
    error: str | None = None

    @property
    def label(self) -> str:
        """The file's name, and the take's when the file holds several."""
        name = os.path.basename(self.path)
        return name if self.take is None else f"{name} take {self.take!r}"


@dataclass
class ClipImport:
    """What an import did: the armature (None when nothing was imported), the actions it
    made (in file and take order) and one outcome per file or take."""

    armature: object = None
    actions: list = field(default_factory=list)
    outcomes: list[ClipOutcome] = field(default_factory=list)

    @property
    def refused(self) -> list[ClipOutcome]:
        return [o for o in self.outcomes if o.error]

    def report(self) -> list[str]:
        """The import's report as a person reads it: the clips imported, a line for each
        note (a name taken, root motion moved onto the hips), the files and takes refused
        (their reasons are the outcomes' errors)."""
        lines = [f"imported {len(self.actions)} clip(s) into armature {self.armature.name!r}: "
                 + ", ".join(a.name for a in self.actions) if self.actions else "imported no clip"]
        lines += [f"  {note}" for o in self.outcomes for note in o.notes]
        if self.refused:
            lines.append(f"refused {len(self.refused)}: " + ", ".join(o.label for o in self.refused))
        return lines


@dataclass
class _Take:
    """One clip of a file while it is imported: its action, the name it is to have, its
    take's name in a file of several (else None), why it was refused, and the armature
    object's channels moved onto bones ``onto``."""

    action: object
    want: str
    take: str | None = None
    error: str | None = None
    moved: list[str] = field(default_factory=list)
    onto: str = "the hips"

    def where(self, path: str) -> str:
        return path if self.take is None else f"{path}: take {self.take!r}"


def _tree(names, parents) -> dict:
    return {n: (names[p] if p >= 0 else None) for n, p in zip(names, parents)}


def _bone_tree(ob) -> dict:
    return {b.name: (b.parent.name if b.parent else None) for b in ob.data.bones}


def _check_bvh_fits(sk, target, users: bool, first_path: str) -> None:
    """Before a BVH file is imported onto armature ``target``: ClipImportError unless
    every joint is a bone of the user's ``target`` (``users``), or the joints and their
    parents are the bones of the first file's armature ``target``."""
    if users:
        have = {b.name for b in target.data.bones}
        missing = [n for n in sk.names if n not in have]
        if missing:
            raise ClipImportError(
                f"{sk.path}: joints {', '.join(missing[:6])} are not bones of armature "
                f"{target.name!r}; clips of one library must share one skeleton")
    elif _tree(sk.names, sk.parents) != _bone_tree(target):
        raise ClipImportError(f"{sk.path}: its skeleton differs from {first_path}'s; "
                              "clips of one library must share one skeleton")


def _check_fits(ob, path: str, target, users: bool, first_path: str) -> None:
    """The check above for a file already imported as armature ``ob`` (an FBX or glTF):
    its bones are bones of the user's ``target`` (``users``), or the same bones with the
    same parents as the first file's armature ``target``."""
    if users:
        have = {b.name for b in target.data.bones}
        missing = [b.name for b in ob.data.bones if b.name not in have]
        if missing:
            raise ClipImportError(
                f"{path}: joints {', '.join(missing[:6])} are not bones of armature "
                f"{target.name!r}; clips of one library must share one skeleton")
    elif _bone_tree(ob) != _bone_tree(target):
        raise ClipImportError(f"{path}: its skeleton differs from {first_path}'s; "
                              "clips of one library must share one skeleton")


def _check_legs(ob, path):
    """The roles of armature ``ob``'s bones; ClipImportError naming the file when its legs
    cannot be mapped."""
    bones = ob.data.bones
    names = [b.name for b in bones]
    parents = [names.index(b.parent.name) if b.parent else -1 for b in bones]
    heads = np.array([b.head_local for b in bones], float).reshape(-1, 3)
    tails = np.array([b.tail_local for b in bones], float).reshape(-1, 3)
    roles = map_roles(names, parents, heads, tails)
    if not roles.ok:
        raise ClipImportError(f"{path}: skeleton has no usable legs: {roles.describe()}")
    return roles


def _tag_source(act, src, target):
    """Mark a clip as imported for ``target``; a fake user keeps it in the file while no
    object plays it."""
    act[SOURCE_FPS_PROP] = src.fps
    act[SOURCE_FILE_PROP] = os.path.basename(src.path)
    act[ARMATURE_PROP] = target.data.name
    act.use_fake_user = True
