"""Automatic mapping of an armature's bones to locomotion roles.

Pure Python/numpy: this module never imports bpy. The Blender layer reads the armature
(bone names, parent indices, rest heads/tails in armature space) and calls
:func:`map_roles`; everything below works on plain sequences and arrays.

Here: the roles, :class:`RoleMapping`, :func:`map_roles` assembling the layers below, and
the "name" layer's choice of bones (``_name_stage``). The words of a bone's name are read
in ``role_names``; the bone tree and rest geometry (consistency, feet hanging by
geometry, the "hierarchy" layer) are ``role_chains``'.

Roles
-----
``hips``
    The bone from which the spine and both legs branch (the pelvis). In Rigify and the
    Blender human metarig this is the first spine bone (``DEF-spine`` / ``spine``).
``thigh_l, shin_l, foot_l, toe_l`` / ``thigh_r, shin_r, foot_r, toe_r``
    The leg chain of each side. Left means the *character's* left. ``toe_*`` is
    optional: a foot without a toe bone is allowed.
``spine``
    Optional: the first spine bone above the hips (``Spine``, ``spine_01``,
    ``DEF-spine.001``, CMU's ``LowerBack``, DAZ ``abdomenLower``...).
``root``
    Optional: a bone above the hips that is an ancestor (normally the parent) of the
    hips and sits at the ground (Rigify/Unreal ``root``).

Conventions
-----------
* ``names[i]`` is the name of bone ``i``; ``parents[i]`` is the index of its parent or
  ``-1``. ``heads``/``tails`` are optional ``(B, 3)`` rest positions in armature space,
  Blender convention: Z up. The character usually faces -Y, so its left is +X; facing is
  only used when the names do not tell the sides.
* Mapping happens in three layers, each recorded in :attr:`RoleMapping.how`:

  1. ``"manual"``: ``overrides`` (role -> bone name) always win.
  2. ``"name"``: name matching, case-insensitive, tolerant of namespaces
     (``mixamorig:``, ``mixamorig1:``, ``Armature|``), Rigify prefixes (``DEF-`` bones
     preferred, then plain names, then ``ORG-``; ``MCH-``/``VIS-``/``WGT-`` and
     control bones with ``ik``/``fk``/``pole``/``parent``/``tweak``/``target``/
     ``twist``/``roll``/``end``/``nub`` tokens are never mapped), 3ds Max biped
     ``Bip01 ``/``Bip001 `` prefixes, separators ``_ . - space :`` and camelCase, and
     sides written ``Left/Right``, ``L/R``, ``l/r`` as prefix or suffix.
  3. ``"hierarchy"``: when names are missing or inconsistent, the hips are found as the
     bone from which two downward leg chains (thigh, shin, foot[, toe]) branch,
     possibly through one short intermediate bone (CMU ``LHipJoint``). The leg whose
     thigh head has the larger X is the left one unless the chain's names say
     otherwise.

* Every mapping is consistent with the hierarchy: thighs descend from the hips, the shin
  from the thigh, the foot from the shin, the toe from the foot, the spine from the hips
  and the hips from the root. A foot (toe) may instead *hang* from its shin (foot) by
  geometry, as in IK-style game rigs whose feet are parented to the root or to an IK
  control (Quaternius ``Foot.L`` under ``Bone``): its rest head lies at the shin's far end
  (the shin's tail, or its chain child's head) within ``ATTACH_TOLERANCE`` of the shin's
  length, and it points away from the shin like a foot (``FOOT_ANGLES``). A descendant is
  preferred to a bone that only hangs there. Control and mechanism bones (poles, IK
  targets, ``_end`` stubs...) never qualify. The planner treats a hanging foot as a child
  of its shin (``core.clips.rig.Rig``'s planner hierarchy). For Rigify, ``DEF-x``/``ORG-x``/``x``
  count as the same logical bone when checking ancestry (generated rigs parent
  ``DEF-thigh.L`` to ``ORG-spine``, not to ``DEF-spine``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from itertools import product
from typing import Mapping, Sequence

import numpy as np
from .role_chains import (RoleError, _Ctx, _below, _compatible, _feet_tried, _hier_root, _hier_spine,
                          _hierarchy_stage, _lca)
from .role_names import _HIPS, _LEG_PARTS, _LEG_TABLES, _ROOT, _SIDES, _SPINE

__all__ = [
    "REQUIRED_ROLES",
    "OPTIONAL_ROLES",
    "ALL_ROLES",
    "RoleMapping",
    "RoleError",
    "map_roles",
]

REQUIRED_ROLES: tuple[str, ...] = (
    "hips",
    "thigh_l",
    "shin_l",
    "foot_l",
    "thigh_r",
    "shin_r",
    "foot_r",
)
"""Roles a usable mapping must fill: the hips and thigh/shin/foot of both legs."""

OPTIONAL_ROLES: tuple[str, ...] = ("toe_l", "toe_r", "spine", "root")
"""Roles that are filled when the armature has such bones."""

ALL_ROLES: tuple[str, ...] = (
    "hips",
    "thigh_l",
    "shin_l",
    "foot_l",
    "toe_l",
    "thigh_r",
    "shin_r",
    "foot_r",
    "toe_r",
    "spine",
    "root",
)
"""Every role, in a stable order (hips, left leg, right leg, spine, root)."""


@dataclass(frozen=True)
class RoleMapping:
    """Result of :func:`map_roles`.

    ``roles`` maps role -> bone name for every role that could be filled, ``missing``
    lists the *required* roles that could not be filled (in :data:`REQUIRED_ROLES`
    order), ``how`` maps each filled role to ``"name"``, ``"hierarchy"`` or
    ``"manual"``. ``bones`` holds the armature's bone names (for messages).
    """

    roles: dict[str, str]
    missing: tuple[str, ...]
    how: dict[str, str]
    bones: tuple[str, ...] = field(default=(), repr=False)
    #: Where a foot is missing: the shins' ends and the candidate feet tried, with their
    #: distances (one line, for messages); empty otherwise.
    tried: str = field(default="", repr=False)

    @property
    def ok(self) -> bool:
        """True when no required role is missing."""
        return not self.missing

    def bone(self, role: str) -> str:
        """Name of the bone mapped to ``role``; :class:`RoleError` naming it otherwise."""
        if role not in ALL_ROLES:
            raise RoleError(f"unknown role {role!r}; roles are {', '.join(ALL_ROLES)}")
        try:
            return self.roles[role]
        except KeyError:
            raise RoleError(
                f"role {role!r} is not mapped to any bone; set it by hand "
                f"(bones: {_preview(self.bones)})"
            ) from None

    def describe(self) -> str:
        """One-line human summary of the mapping (or of what is missing)."""
        mapped = ", ".join(f"{r}={self.roles[r]}" for r in ALL_ROLES if r in self.roles)
        if not self.ok:
            text = (
                f"could not map roles: {', '.join(self.missing)} "
                f"of armature bones {_preview(self.bones)}"
            )
            if mapped:
                text += f"; mapped: {mapped}"
            if self.tried:
                text += f"; {self.tried}"
            return text
        notes = []
        for kind in ("hierarchy", "manual"):
            rs = [r for r in ALL_ROLES if self.how.get(r) == kind]
            if rs:
                notes.append(f"{kind}: {', '.join(rs)}")
        return f"mapped {len(self.roles)} roles: {mapped}" + (
            f" ({'; '.join(notes)})" if notes else ""
        )


def _preview(bones: Sequence[str], limit: int = 16) -> str:
    """The first ``limit`` bone names, comma separated, and how many more (for messages)."""
    if not bones:
        return "(none)"
    shown = ", ".join(bones[:limit])
    if len(bones) > limit:
        shown += f", ... (+{len(bones) - limit} more)"
    return shown


def _assemble(ctx, fixed, proposal):
    """Overrides first, then ``proposal`` (role -> (idx, how)) where consistent."""
    roles = dict(fixed)
    how = {r: "manual" for r in fixed}
    for role in ALL_ROLES:
        if role in roles or role not in proposal:
            continue
        idx, kind = proposal[role]
        if idx in roles.values() or not _compatible(ctx, role, idx, roles):
            continue
        roles[role] = idx
        how[role] = kind
    return roles, how


# ---------------------------------------------------------------------- name stage


def _name_candidates(ctx: _Ctx):
    """(leg candidates, hips candidates) by name: role -> [(score, bone index)] for each
    leg role, and [(score, bone index)] for the hips, each sorted best (lowest score)
    first. Bones that are never mapped are left out."""
    cands: dict[str, list] = {f"{p}_{s}": [] for p in _LEG_PARTS for s in _SIDES}
    hips: list = []
    for i, p in enumerate(ctx.parsed):
        if p.tier is None:
            continue
        name = ctx.names[i]
        if p.side in _SIDES:
            for part, table in _LEG_TABLES:
                if p.base in table:
                    cands[f"{part}_{p.side}"].append(
                        ((p.tier, table[p.base], p.index or 0, name), i)
                    )
        elif p.side is None:
            if p.base in _HIPS:
                hips.append(((p.tier, 0, p.index or 0, name), i))
            elif p.base == "spine" and not p.index:  # Rigify/metarig: spine == hips
                hips.append(((p.tier, 1, 0, name), i))
            elif p.base in _ROOT and _root_may_be_hips(ctx, i):  # ASF 'root' is the hips
                hips.append(((p.tier + 10, 2, p.index or 0, name), i))  # last resort
    for lst in cands.values():
        lst.sort()
    hips.sort()
    return cands, hips


def _root_may_be_hips(ctx: _Ctx, i: int) -> bool:
    """A bone named root can be the hips only if it is not at the ground."""
    if ctx.heads is None:
        return True
    return ctx.z(i) > ctx.zmin + 0.25 * (ctx.zmax - ctx.zmin)


_FIXED_SCORE = (-1, 0, 0, "")
_NO_SCORE = (9, 9, 9, "")


def _best_leg(ctx, side, hips, cands, fixed):
    """Best consistent (thigh, shin, foot, toe) of one side by names, under ``hips``."""
    opts = []
    for part in ("thigh", "shin", "foot"):
        role = f"{part}_{side}"
        if role in fixed:
            opts.append([(_FIXED_SCORE, fixed[role])])
        else:
            opts.append(cands[role] + [(_NO_SCORE, None)])
    best_key, best = None, None
    for combo in product(*opts):
        chain = [("hips", hips)] + [
            (f"{part}_{side}", c[1]) for part, c in zip(("thigh", "shin", "foot"), combo)
        ]
        chain = [(r, i) for r, i in chain if i is not None]
        total_dist, hanging, ok = 0, 0, True
        for (ra, a), (rb, b) in zip(chain, chain[1:]):
            if ra in fixed and rb in fixed:
                continue
            d = _below(ctx, rb, b, a)
            if d is None:
                ok = False
                break
            hanging += d >= ctx.n
            total_dist += d
        if not ok:
            continue
        scores = [c[0] for c in combo if c[1] is not None]
        key = (
            -len(scores),
            hanging,  # a foot under its shin before one that only hangs from it
            sum(s[0] for s in scores),
            sum(s[1] for s in scores),
            sum(s[2] for s in scores),
            total_dist,
            tuple(s[3] for s in scores),
        )
        if best_key is None or key < best_key:
            best_key, best = key, {r: i for r, i in chain if r != "hips"}
    if best is None:  # only possible when an override contradicts every candidate
        return (0, 0, 0, 0, 0, 0, ()), {}
    # toe: best candidate under the deepest filled role of this side
    toe_role = f"toe_{side}"
    anchor = next(
        (best[f"{p}_{side}"] for p in ("foot", "shin", "thigh") if f"{p}_{side}" in best),
        hips,
    )
    if toe_role in fixed:
        best[toe_role] = fixed[toe_role]
    elif anchor is not None and f"foot_{side}" in best:
        toes = []
        for score, i in cands[toe_role]:
            d = _below(ctx, toe_role, i, anchor)
            if d is not None and i not in best.values():
                toes.append(((d >= ctx.n, score[0], score[1], score[2], d, score[3]), i))
        if toes:
            best[toe_role] = min(toes)[1]
    return best_key, best


def _name_stage(ctx: _Ctx, fixed: dict[str, int]) -> dict[str, int]:
    """Role -> bone index by names: the hips candidate (or override) and the consistent
    legs under it that fill the most roles, then have the best-named hips (the higher
    bone on equal names), then the best-named legs."""
    cands, hips_cands = _name_candidates(ctx)
    if "hips" in fixed:
        hips_opts = [(_FIXED_SCORE, fixed["hips"])]
    else:
        hips_opts = hips_cands + [(_NO_SCORE, None)]
    best_key, best = None, {}
    for hscore, h in hips_opts:
        kl, legs_l = _best_leg(ctx, "l", h, cands, fixed)
        kr, legs_r = _best_leg(ctx, "r", h, cands, fixed)
        filled = (h is not None) + (-kl[0]) + (-kr[0])
        # equal names (DAZ 'hip' above 'pelvis'): the higher bone is the hips
        depth = len(ctx.ancestors[h]) if h is not None else 0
        key = (-filled, hscore[:3], depth, hscore[3], kl[1:], kr[1:])
        if best_key is None or key < best_key:
            best_key = key
            best = {**legs_l, **legs_r}
            if h is not None:
                best["hips"] = h
    return best


def _name_spine(ctx: _Ctx, hips: int, used) -> int | None:
    """The unused, mappable bone named like a spine, without a side, that descends from
    the ``hips`` in the fewest steps (then best tier, lowest index, name); None if
    there is none."""
    opts = []
    for i, p in enumerate(ctx.parsed):
        if p.tier is None or p.side is not None or p.base not in _SPINE or i in used:
            continue
        d = ctx.desc(i, hips)
        if d is not None:
            opts.append(((d, p.tier, p.index or 0, ctx.names[i]), i))
    return min(opts)[1] if opts else None


def _name_root(ctx: _Ctx, hips: int, used) -> int | None:
    """The nearest unused ancestor of the ``hips`` named root, without a side; None if
    there is none."""
    opts = []
    for a_step, a in enumerate(ctx.ancestors[hips], 1):
        p = ctx.parsed[a]
        if p.tier is not None and p.side is None and p.base in _ROOT and a not in used:
            opts.append(((a_step, p.tier, ctx.names[a]), a))
    return min(opts)[1] if opts else None


# ------------------------------------------------------------------------- public


def map_roles(
    names: Sequence[str],
    parents: Sequence[int],
    heads: np.ndarray | None = None,
    tails: np.ndarray | None = None,
    overrides: Mapping[str, str] | None = None,
) -> RoleMapping:
    """Map an armature's bones to locomotion roles.

    ``names[i]`` is bone ``i``'s name and ``parents[i]`` its parent's index (``-1`` for
    none); ``heads``/``tails`` are optional ``(B, 3)`` rest positions in armature space
    (Z up; the character usually faces -Y, so its left is +X). ``overrides`` maps role ->
    bone name chosen by hand; they always win (``how == "manual"``), empty values are
    ignored, and an unknown role or a bone that does not exist raises :class:`RoleError`.

    Names are tried first (``how == "name"``); roles that names cannot fill consistently
    are taken from the bone hierarchy (``how == "hierarchy"``). A foot (toe) need not
    descend from its shin (foot): one parented elsewhere hangs from it by geometry (see the
    module's doc). Everything is read from rest data, so a rest pose written from any
    frame of a clip maps the same. Required roles that stay unfilled are listed in
    :attr:`RoleMapping.missing` (no exception is raised for them); where a foot is
    missing, :attr:`RoleMapping.tried` says which bones were tried at the shin's end.
    """
    ctx = _Ctx(names, parents, heads, tails)
    fixed = _fixed_roles(ctx, overrides)
    proposals = _proposals(ctx, fixed)
    roles, how = _best_assembly(ctx, fixed, proposals)
    _add_spine_and_root(ctx, roles, how)
    return RoleMapping(
        roles={r: ctx.names[roles[r]] for r in ALL_ROLES if r in roles},
        missing=tuple(r for r in REQUIRED_ROLES if r not in roles),
        how={r: how[r] for r in ALL_ROLES if r in roles},
        bones=tuple(ctx.names),
        tried=_feet_tried(ctx, roles),
    )


def _fixed_roles(ctx: _Ctx, overrides: Mapping[str, str] | None) -> dict[str, int]:
    """The overrides as role -> bone index, empty values dropped; RoleError for an
    unknown role or a bone the armature does not have."""
    fixed: dict[str, int] = {}
    for role, bone in (overrides or {}).items():
        if role not in ALL_ROLES:
            raise RoleError(f"unknown role {role!r} in overrides; roles are {', '.join(ALL_ROLES)}")
        if not bone:
            continue
        if bone not in ctx.index:
            raise RoleError(
                f"override for role {role!r} names bone {bone!r}, "
                f"which does not exist in the armature"
            )
        fixed[role] = ctx.index[bone]
    return fixed


def _proposals(ctx: _Ctx, fixed: dict[str, int]) -> list[dict[str, tuple[int, str]]]:
    """Candidate mappings (role -> (bone index, how)), the overrides left out, in order
    of preference: by names; and when names leave a required role unfilled, names
    completed by the hierarchy, then the hierarchy alone."""
    by_name = {r: (i, "name") for r, i in _name_stage(ctx, fixed).items() if r not in fixed}
    base_roles, _ = _assemble(ctx, fixed, by_name)
    if all(r in base_roles for r in REQUIRED_ROLES):
        return [by_name]
    tree = {r: (i, "hierarchy") for r, i in _hierarchy_stage(ctx, fixed).items() if r not in fixed}
    tree = _named_legs_kept(tree, base_roles)
    return [by_name, _mixed_proposal(ctx, by_name, base_roles, tree), tree]


def _named_legs_kept(tree: dict, base_roles: dict[str, int]) -> dict:
    """The hierarchy proposal ``tree`` without the legs that leave out the thigh and shin
    names gave their side (``base_roles``): such a chain is another limb (arms hanging in
    an A pose where a leg's foot was not found), never that side's leg."""
    out = dict(tree)
    for side in _SIDES:
        named = {base_roles[r] for r in (f"thigh_{side}", f"shin_{side}") if r in base_roles}
        leg = [f"{p}_{side}" for p in _LEG_PARTS]
        if named and not named & {tree[r][0] for r in leg if r in tree}:
            for r in leg:
                out.pop(r, None)
    return out


def _mixed_proposal(ctx: _Ctx, by_name: dict, base_roles: dict[str, int], tree: dict) -> dict:
    """The name proposal ``by_name`` with what names could not fill (``base_roles``: the
    name proposal as assembled) taken from the hierarchy proposal ``tree``: the hips (or
    the lowest common ancestor of the named thighs), and each leg whose thigh, shin or
    foot is missing, as a whole."""
    mixed = dict(by_name)
    if "hips" not in base_roles:
        thighs = [base_roles[r] for r in ("thigh_l", "thigh_r") if r in base_roles]
        carries = "hips" in tree and all(ctx.desc(t, tree["hips"][0]) is not None for t in thighs)
        if carries:
            mixed["hips"] = tree["hips"]
        elif len(thighs) == 2 and _lca(ctx, *thighs) is not None:
            # (the tree's hips, found on a rest pose written from a clip's frame, may carry
            # other limbs: a character lying down has its arms reaching lowest)
            mixed["hips"] = (_lca(ctx, *thighs), "hierarchy")
        elif "hips" in tree:
            mixed["hips"] = tree["hips"]
    for side in _SIDES:
        leg = [f"{p}_{side}" for p in _LEG_PARTS]
        if all(r in base_roles for r in leg[:3]):
            continue
        if any(r in tree for r in leg):
            for r in leg:
                mixed.pop(r, None)
                if r in tree:
                    mixed[r] = tree[r]
    return mixed


def _best_assembly(ctx: _Ctx, fixed: dict[str, int], proposals: list[dict]
                   ) -> tuple[dict[str, int], dict[str, str]]:
    """(roles, how) of the proposal that, assembled with the overrides, fills the most
    required roles, then the most roles by name, then the most roles; the earliest on
    a tie."""
    best_key, roles, how = None, {}, {}
    for rank, proposal in enumerate(proposals):
        cand_roles, cand_how = _assemble(ctx, fixed, proposal)
        key = (
            -sum(r in cand_roles for r in REQUIRED_ROLES),
            -sum(v == "name" for v in cand_how.values()),
            -len(cand_roles),
            rank,
        )
        if best_key is None or key < best_key:
            best_key, roles, how = key, cand_roles, cand_how
    return roles, how


def _add_spine_and_root(ctx: _Ctx, roles: dict[str, int], how: dict[str, str]) -> None:
    """Fill the optional spine and root relative to the final hips, names first, then
    hierarchy, where consistent with the rest (``roles`` and ``how`` changed in place)."""
    if "hips" not in roles:
        return
    h = roles["hips"]
    for role, finders in (
        ("spine", ((_name_spine, "name"), (_hier_spine, "hierarchy"))),
        ("root", ((_name_root, "name"), (None, "hierarchy"))),
    ):
        if role in roles:
            continue
        for finder, kind in finders:
            used = set(roles.values())
            if finder is None:
                idx = _hier_root(ctx, h, roles, used)
            else:
                idx = finder(ctx, h, used)
            if idx is not None and _compatible(ctx, role, idx, roles):
                roles[role] = idx
                how[role] = kind
                break
