"""Automatic mapping of an armature's bones to locomotion roles.

Pure Python/numpy: this module never imports bpy. The Blender layer reads the armature
(bone names, parent indices, rest heads/tails in armature space) and calls
:func:`map_roles`; everything below works on plain sequences and arrays.

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

import re
from dataclasses import dataclass, field
from itertools import combinations, product
from typing import Mapping, Sequence

import numpy as np
from ..base.errors import FootstepError

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

_SIDES = ("l", "r")
_LEG_PARTS = ("thigh", "shin", "foot", "toe")

#: A foot (toe) hangs from a shin (foot) it does not descend from when its rest head lies
#: within this share of the shin's (foot's) length of the shin's far end. Generous, so
#: that a rest pose written from a clip's frame (an FBX's rest is the pose it was written
#: in), where the animation parts the ankle from the shin a little, maps the same; the
#: nearest such bone is the one taken.
ATTACH_TOLERANCE = 0.25
#: (min, max) degrees between a shin's direction (head to tail) and a foot hanging from
#: it: a foot points away from the shin, forward, or down when pointed (seen from 25 to
#: 132 degrees in a game rig's clips), never along it (a stub continuing the shin) nor back
#: up it (a pole or an IK target standing up).
FOOT_ANGLES = (15.0, 160.0)
#: (min, max) degrees between a foot's direction and a toe hanging from it: about its way.
TOE_ANGLES = (0.0, 100.0)


class RoleError(FootstepError):
    """A role cannot be resolved (unmapped role, bad override, malformed armature)."""


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


# --------------------------------------------------------------------------- names

_NAMESPACE_RE = re.compile(r"^.*[:|]")
# Rigify-style prefixes: DEF (deform, preferred), ORG (original, last resort) and
# mechanism/visual/widget/control prefixes that must never be mapped.
_PREFIX_RE = re.compile(r"^(DEF|ORG|MCH|VIS|WGT|CTRL|CTL|TGT|HLP)[-_.]", re.IGNORECASE)
_BIPED_RE = re.compile(r"^bip\d+(?:[ _]+|$)", re.IGNORECASE)
_SPLIT_RE = re.compile(r"[\s_.\-:|]+")
_CAMEL_RE = re.compile(r"[A-Z]+(?=[A-Z][a-z])|[A-Z]?[a-z]+|[A-Z]+|\d+")

# A bone with any of these tokens is a helper/control/mechanism bone: never mapped.
_EXCLUDE = frozenset(
    """mch ik fk ikfk pole parent tweak target tgt ctrl ctl control controller twist roll
    end nub site tip null helper hlp socket vis wgt widget pivot spin corrective offset
    aux jiggle stretch track aim lock driver drv proxy mech""".split()
)
# The words of an end marker's name: FBX ``LowerLeg.L_end``, Mixamo ``LeftToe_End``, 3ds
# Max ``Toe0Nub``, BVH ``End Site``.
_END_MARK = frozenset("end nub site".split())
# Tokens that carry no meaning for matching.
_NOISE = frozenset("jnt jt bn bone bind skin deform def bend".split())
# Centre markers (AdvancedSkeleton ``Root_M``, ``C_Hips``) dropped at either end.
_CENTER = frozenset("m c mid middle center centre".split())
_SIDE_TOKENS = {"l": "l", "left": "l", "r": "r", "right": "r"}

# base word -> priority (lower is better)
_THIGH = {"thigh": 0, "upleg": 0, "upperleg": 0, "legupper": 0, "femur": 1, "hip": 2}
_SHIN = {
    "shin": 0,
    "calf": 0,
    "lowerleg": 0,
    "leglower": 0,
    "lowleg": 0,
    "tibia": 1,
    "knee": 1,
    "leg": 1,
}
_FOOT = {"foot": 0, "ankle": 1}
_TOE = {"toe": 0, "toes": 0, "toebase": 0, "ball": 0}
_LEG_TABLES = (("thigh", _THIGH), ("shin", _SHIN), ("foot", _FOOT), ("toe", _TOE))
_LEG_WORDS = frozenset(w for _, t in _LEG_TABLES for w in t)
_HIPS = {"hips": 0, "hip": 0, "pelvis": 0}
_SPINE = frozenset(
    "spine lowerback abdomen abdomenlower waist torso back lowerspine spinelower".split()
)
_ROOT = frozenset({"root"})


@dataclass(frozen=True)
class _Parsed:
    tier: int | None  # 0 DEF-, 1 plain, 2 ORG-; None: never map this bone
    side: str | None  # "l", "r", None (no side) or "?" (contradictory sides)
    base: str  # remaining words, lowercase, joined ("upleg", "toebase", ...)
    index: int | None  # trailing number: thigh.L.001 -> 1, Spine1 -> 1, Toe0 -> 0
    key: str  # logical identity: name without DEF-/ORG- prefix, lowercase


def _parse_name(name: str) -> _Parsed:
    """Split a bone name into (tier, side, base word, index, logical key)."""
    s = name.strip()
    ns_match = _NAMESPACE_RE.match(s)
    namespace = ns_match.group(0) if ns_match else ""
    s = s[len(namespace) :]
    tier: int | None = 1
    m = _PREFIX_RE.match(s)
    if m:
        prefix = m.group(1).upper()
        tier = 0 if prefix == "DEF" else 2 if prefix == "ORG" else None
        s = s[m.end() :]
    key = (namespace + s).lower()
    s = _BIPED_RE.sub("", s)
    tokens = [t.lower() for part in _SPLIT_RE.split(s) for t in _CAMEL_RE.findall(part)]
    if any(t in _EXCLUDE for t in tokens):
        tier = None
    nums = [t for t in tokens if t.isdigit()]
    index = int(nums[-1]) if nums else None
    words = [t for t in tokens if not t.isdigit() and t not in _NOISE]
    if len(words) > 1 and words[-1] in _CENTER:
        words.pop()
    if len(words) > 1 and words[0] in _CENTER:
        words.pop(0)
    sides = {_SIDE_TOKENS[t] for t in words if t in _SIDE_TOKENS}
    words = [t for t in words if t not in _SIDE_TOKENS]
    base = "".join(words)
    side: str | None = None
    if len(sides) > 1:
        side = "?"
    elif sides:
        side = sides.pop()
    else:  # sides glued to the word: LEFTUPLEG, upperlegleft, lfemur, rThigh (lowercase)
        for word, sd in (("left", "l"), ("right", "r")):
            if base.startswith(word) and len(base) > len(word):
                base, side = base[len(word) :], sd
                break
            if base.endswith(word) and len(base) > len(word):
                base, side = base[: -len(word)], sd
                break
        else:
            if len(base) > 1 and base[0] in "lr" and base[1:] in _LEG_WORDS:
                base, side = base[1:], base[0]
    return _Parsed(tier, side, base, index, key)


# ------------------------------------------------------------------------- context


class _Ctx:
    """Pre-computed hierarchy/geometry of one armature."""

    def __init__(self, names, parents, heads, tails):
        self.names = list(names)
        n = len(self.names)
        self.n = n
        if len(parents) != n:
            raise RoleError(f"got {n} bone names but {len(parents)} parent indices")
        self.parents = [int(p) for p in parents]
        for i, p in enumerate(self.parents):
            if p < -1 or p >= n or p == i:
                raise RoleError(f"bone {self.names[i]!r} has invalid parent index {p}")
        seen: dict[str, int] = {}
        for i, nm in enumerate(self.names):
            if nm in seen:
                raise RoleError(f"duplicate bone name {nm!r}")
            seen[nm] = i
        self.index = seen
        self.heads = _as_points(heads, n, "heads")
        self.tails = _as_points(tails, n, "tails")
        self.children: list[list[int]] = [[] for _ in range(n)]
        for i, p in enumerate(self.parents):
            if p >= 0:
                self.children[p].append(i)
        for kids in self.children:
            kids.sort(key=lambda k: self.names[k])
        self.ancestors: list[list[int]] = []
        for i in range(n):
            chain, p = [], self.parents[i]
            while p >= 0:
                if len(chain) > n:
                    raise RoleError(f"parent cycle through bone {self.names[i]!r}")
                chain.append(p)
                p = self.parents[p]
            self.ancestors.append(chain)
        self.parsed = [_parse_name(nm) for nm in self.names]
        # subtree height (over mappable bones) and size, children before parents
        self._height = [1] * n
        self._size = [1] * n
        for i in sorted(range(n), key=lambda k: -len(self.ancestors[k])):
            p = self.parents[i]
            if p >= 0:
                self._size[p] += self._size[i]
                if self.parsed[i].tier is not None:
                    self._height[p] = max(self._height[p], self._height[i] + 1)
        self.hang_cache: dict = {}
        self.eps, self.zmin, self.zmax = 1e-9, 0.0, 0.0
        if self.heads is not None and n:
            z = self.heads[:, 2]
            extent = float(np.ptp(self.heads, axis=0).max()) if n else 0.0
            self.eps = max(extent, 1e-9) * 1e-4
            self.zmin, self.zmax = float(z.min()), float(z.max())

    def desc(self, a: int, b: int) -> int | None:
        """Steps from ``a`` up to ancestor ``b`` (or a logical twin of it), else None."""
        kb = self.parsed[b].key
        for step, x in enumerate(self.ancestors[a], 1):
            if x == b or self.parsed[x].key == kb:
                return step
        return None

    def height(self, i: int) -> int:
        """Bones in the longest mappable chain starting at ``i`` (itself included)."""
        return self._height[i]

    def size(self, i: int) -> int:
        """Number of bones in the subtree of ``i`` (itself included)."""
        return self._size[i]

    def z(self, i: int) -> float:
        """Height of bone ``i``'s rest head (needs heads)."""
        return float(self.heads[i, 2])

    def dist(self, a: int, b: int) -> float:
        """Distance between the rest heads of bones ``a`` and ``b`` (needs heads)."""
        return float(np.linalg.norm(self.heads[a] - self.heads[b]))


def _as_points(arr, n, what):
    """``arr`` as an (n, 3) float array (None stays None); RoleError naming ``what``
    for another shape."""
    if arr is None:
        return None
    pts = np.asarray(arr, dtype=float)
    if pts.shape != (n, 3):
        raise RoleError(f"{what} must have shape ({n}, 3), got {pts.shape}")
    return pts


# --------------------------------------------------------------------- consistency


def _leg_chain(side: str) -> tuple[str, ...]:
    """The roles from the hips down one leg: hips, thigh, shin, foot, toe of ``side``."""
    return ("hips",) + tuple(f"{p}_{side}" for p in _LEG_PARTS)


def _compatible(ctx: _Ctx, role: str, idx: int, roles: dict[str, int]) -> bool:
    """Whether ``role -> idx`` respects the hierarchy rules w.r.t. ``roles``."""
    if role == "root":
        return "hips" not in roles or ctx.desc(roles["hips"], idx) is not None
    if role == "spine":
        return "hips" not in roles or ctx.desc(idx, roles["hips"]) is not None
    if role == "hips":
        if "root" in roles and ctx.desc(idx, roles["root"]) is None:
            return False
        if "spine" in roles and ctx.desc(roles["spine"], idx) is None:
            return False
    chains = [_leg_chain(s) for s in _SIDES] if role == "hips" else [_leg_chain(role[-1])]
    for chain in chains:
        pos = chain.index(role)
        above = next((roles[r] for r in reversed(chain[:pos]) if r in roles), None)
        below = next(((r, roles[r]) for r in chain[pos + 1 :] if r in roles), None)
        if above is not None and _below(ctx, role, idx, above) is None:
            return False
        if below is not None and _below(ctx, below[0], below[1], idx) is None:
            return False
    return True


def _below(ctx: _Ctx, role: str, lo: int, hi: int) -> int | None:
    """Steps from bone ``lo`` (mapped to ``role``) up to bone ``hi`` as a mapping links
    them: its ancestry, or, for a foot or toe that hangs from ``hi`` by geometry
    (``_hangs``), ``ctx.n`` (after any real chain); None when ``lo`` is not below ``hi``."""
    d = ctx.desc(lo, hi)
    if d is None and role.startswith(("foot_", "toe_")) and _hangs(ctx, lo, hi, role[:-2]):
        return ctx.n
    return d


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


# ------------------------------------------------------------- feet by geometry


def _far_ends(ctx: _Ctx, a: int) -> list:
    """The far end of bone ``a`` (rest, armature space): its tail, when tails are known,
    and its chain child's head (``_main_child``), when it has one; failing both, the head
    of an end marker hanging from it (a leaf named ``_end``, ``Nub``...: FBX and 3ds Max
    put one at a chain's last tail)."""
    ends = [ctx.tails[a]] if ctx.tails is not None else []
    c = _main_child(ctx, a)
    if c is not None:
        ends.append(ctx.heads[c])
    if not ends:
        ends = [ctx.heads[k] for k in ctx.children[a] if not ctx.children[k] and _end_mark(ctx.names[k])]
    return ends


def _end_mark(name: str) -> bool:
    """Whether a bone's ``name`` is an end marker's (a word of ``_END_MARK``)."""
    return any(t.lower() in _END_MARK for part in _SPLIT_RE.split(name) for t in _CAMEL_RE.findall(part))


def _end_and_reach(ctx: _Ctx, a: int):
    """(far ends (K, 3), the distance within which a bone's head hangs from them: the
    ``ATTACH_TOLERANCE`` share of ``a``'s length) of bone ``a``; None without rest heads or
    a far end, or for a bone of no length."""
    if ctx.heads is None:
        return None
    ends = _far_ends(ctx, a)
    if not ends:
        return None
    ends = np.asarray(ends)
    length = float(np.linalg.norm(ends - ctx.heads[a], axis=1).max())
    return (ends, ATTACH_TOLERANCE * length) if length > ctx.eps else None


def _angle(ctx: _Ctx, a: int, b: int) -> float | None:
    """Degrees between the rest directions (head to tail) of bones ``a`` and ``b``; None
    without tails or for a bone of no length."""
    if ctx.tails is None:
        return None
    u, v = ctx.tails[a] - ctx.heads[a], ctx.tails[b] - ctx.heads[b]
    nu, nv = float(np.linalg.norm(u)), float(np.linalg.norm(v))
    if nu <= ctx.eps or nv <= ctx.eps:
        return None
    return float(np.degrees(np.arccos(np.clip(u @ v / (nu * nv), -1.0, 1.0))))


def _hang_fault(ctx: _Ctx, b: int, a: int, part: str) -> str | None:
    """Why bone ``b`` does not hang from bone ``a`` as its ``part`` ("foot" from a shin,
    "toe" from a foot) by geometry, in a few words; None when it does: ``b`` is no control bone,
    no ancestor of ``a``, its rest head lies within reach of ``a``'s far end
    (``_end_and_reach``) and it points as a foot (``FOOT_ANGLES``) or toe (``TOE_ANGLES``)
    does from ``a``."""
    if b == a or ctx.desc(a, b) is not None:
        return "above it"
    if ctx.parsed[b].tier is None:
        return "a control or end bone"
    er = _end_and_reach(ctx, a)
    if er is None:
        return "no rest geometry"
    ends, reach = er
    if float(np.linalg.norm(ends - ctx.heads[b], axis=1).min()) > reach:
        return "too far"
    ang = _angle(ctx, a, b)
    lo, hi = FOOT_ANGLES if part == "foot" else TOE_ANGLES
    if ang is not None and not lo <= ang <= hi:
        return f"at {ang:.0f} degrees to it"
    return None


def _hangs(ctx: _Ctx, b: int, a: int, part: str) -> bool:
    """Whether bone ``b`` hangs from bone ``a`` as its ``part`` by geometry
    (``_hang_fault``; cached)."""
    key = (b, a, part)
    if key not in ctx.hang_cache:
        ctx.hang_cache[key] = ctx.heads is not None and _hang_fault(ctx, b, a, part) is None
    return ctx.hang_cache[key]


def _hanging_bone(ctx: _Ctx, a: int, part: str) -> int | None:
    """The bone that hangs from bone ``a`` as its ``part`` by geometry and does not descend
    from it: of those that hang (none below another that does), the nearest to ``a``'s far
    end, then by name; None if there is none."""
    er = _end_and_reach(ctx, a)
    if er is None:
        return None
    ends, reach = er
    dist = np.linalg.norm(ctx.heads[:, None] - ends[None], axis=2).min(axis=1)
    near = [int(b) for b in np.flatnonzero(dist <= reach)
            if ctx.desc(int(b), a) is None and _hangs(ctx, int(b), a, part)]
    top = [b for b in near if not any(ctx.desc(b, c) is not None for c in near)]
    return min(top, key=lambda b: (dist[b], ctx.names[b])) if top else None


def _feet_tried(ctx: _Ctx, roles: dict[str, int]) -> str:
    """One line on each leg whose shin is mapped and whose foot is not: where the shin
    ends, how far a foot may be from there, and the bones nearest it (and those named as
    that side's foot), each with its distance and why it is not the foot."""
    parts = []
    for side in _SIDES:
        shin = roles.get(f"shin_{side}")
        if shin is None or f"foot_{side}" in roles:
            continue
        er = _end_and_reach(ctx, shin)
        if er is None:
            parts.append(f"shin {ctx.names[shin]!r} has no rest tail or child to find its foot by")
            continue
        ends, reach = er
        dist = np.linalg.norm(ctx.heads[:, None] - ends[None], axis=2).min(axis=1)
        named = [i for i, p in enumerate(ctx.parsed) if p.side == side and p.base in _FOOT]
        others = [i for i in np.argsort(dist, kind="stable") if i != shin and ctx.desc(shin, int(i)) is None]
        tried = list(dict.fromkeys(named + [int(i) for i in others[:4]]))
        used = set(roles.values())
        words = []
        for b in sorted(tried, key=lambda b: (dist[b], ctx.names[b])):
            why = "mapped as another role" if b in used else (_hang_fault(ctx, b, shin, "foot")
                                                               or "not consistent with the rest")
            words.append(f"{ctx.names[b]!r} {dist[b]:.3g} ({why})")
        x, y, z = ends[0]
        parts.append(f"shin {ctx.names[shin]!r} ends at ({x:.3g}, {y:.3g}, {z:.3g}), a foot's head within "
                     f"{reach:.3g}: tried {', '.join(words) or 'no other bone'}")
    return ("feet tried: " + "; ".join(parts)) if parts else ""


# ----------------------------------------------------------------- hierarchy stage


def _main_child(ctx: _Ctx, i: int) -> int | None:
    """The child continuing a limb: deepest subtree, then nearest to the parent's tail."""
    kids = [k for k in ctx.children[i] if ctx.parsed[k].tier is not None]
    if not kids:
        return None

    def key(k):
        near_tail = 0.0
        far_head = 0.0
        if ctx.tails is not None and ctx.heads is not None:
            near_tail = float(np.linalg.norm(ctx.heads[k] - ctx.tails[i]))
        elif ctx.heads is not None:
            far_head = -ctx.dist(k, i)
        return (-ctx.height(k), near_tail, far_head, ctx.names[k])

    return min(kids, key=key)


def _seg_len(ctx: _Ctx, chain: list[int], j: int) -> float:
    """Length of bone ``chain[j]``: to the next bone's head, else to its own tail (0
    without tails)."""
    if j + 1 < len(chain):
        return ctx.dist(chain[j + 1], chain[j])
    if ctx.tails is not None:
        return float(np.linalg.norm(ctx.tails[chain[j]] - ctx.heads[chain[j]]))
    return 0.0


def _leg_from(ctx: _Ctx, start: int):
    """Interpret the limb starting at ``start`` as a leg: (bones, intermediate) or None.

    ``bones`` is [thigh, shin, foot] or [thigh, shin, foot, toe]. The limb follows the
    main children (``_main_child``); where that makes no leg, or one whose foot is a stub
    continuing the shin (``_stub``), it goes on from the shin to the foot that hangs from
    it by geometry (``_hanging_bone``: a game rig's foot parented to the root), and that
    foot's main child or hanging toe.
    """
    chain, x = [start], _main_child(ctx, start)
    while x is not None and len(chain) < 8:
        chain.append(x)
        x = _main_child(ctx, x)
    leg = _leg_of(ctx, chain)
    if leg is not None and not _stub(ctx, leg[0][2]):
        return leg
    head = chain[: chain.index(leg[0][2])] if leg is not None else chain
    foot = _hanging_bone(ctx, head[-1], "foot") if len(head) >= 2 else None
    if foot is None:
        return leg
    toe = _main_child(ctx, foot)
    toe = _hanging_bone(ctx, foot, "toe") if toe is None else toe
    return _leg_of(ctx, head + [foot] + ([toe] if toe is not None else [])) or leg


def _stub(ctx: _Ctx, b: int) -> bool:
    """Whether bone ``b`` is a leaf that goes on its parent's way (within
    ``FOOT_ANGLES[0]``): an exporter's end marker (FBX ``_end`` bones, nameless here), no
    foot."""
    p = ctx.parents[b]
    if p < 0 or ctx.children[b]:
        return False
    ang = _angle(ctx, p, b)
    return ang is not None and ang < FOOT_ANGLES[0]


def _leg_of(ctx: _Ctx, chain: list[int]):
    """The leg (bones, intermediate) a limb's ``chain`` of bones makes, or None: its
    first three or four bones going down (or those after one short intermediate bone)."""
    offsets = [0]
    if ctx.heads is not None and len(chain) >= 4:
        # one short intermediate bone (CMU LHipJoint) before the thigh
        if _seg_len(ctx, chain, 0) < 0.5 * _seg_len(ctx, chain, 1):
            offsets = [1, 0]
    for k in offsets:
        bones = chain[k : k + 4]
        if len(bones) < 3:
            continue
        if ctx.heads is not None:
            z = [ctx.z(b) for b in bones]
            if not (z[0] - ctx.eps > z[1] and z[1] - ctx.eps > z[2]):
                continue
            if len(bones) == 4 and z[3] > z[2] + ctx.eps:
                bones = bones[:3]
        return bones, (chain[0] if k == 1 else None)
    return None


def _chain_side(ctx: _Ctx, bones) -> str | None:
    """"l" or "r" by majority of the sides the ``bones``' names carry; None on a tie or
    with no sided name."""
    votes = [ctx.parsed[b].side for b in bones if ctx.parsed[b].side in _SIDES]
    if not votes:
        return None
    nl = votes.count("l")
    nr = len(votes) - nl
    return "l" if nl > nr else "r" if nr > nl else None


def _hierarchy_stage(ctx: _Ctx, fixed: dict[str, int]) -> dict[str, int]:
    """Find hips + two legs from the bone tree (and rest heads when available)."""
    hips_opts = [fixed["hips"]] if "hips" in fixed else range(ctx.n)
    best_key, best = None, {}
    for h in hips_opts:
        if ctx.parsed[h].tier is None:
            continue
        legs = []
        for c in ctx.children[h]:
            if ctx.parsed[c].tier is None:
                continue
            leg = _leg_from(ctx, c)
            if leg is not None:
                legs.append(leg)
        if len(legs) < 2:
            continue
        if ctx.heads is not None:  # the two chains reaching lowest are the legs
            legs.sort(key=lambda lg: (ctx.z(lg[0][2]), ctx.names[lg[0][0]]))
            legs = legs[:2]
        else:  # no geometry: legs are the most symmetric pair of chains
            legs = list(min(combinations(legs, 2), key=lambda pair: _pair_key(ctx, pair)))
        feet_z = max(ctx.z(lg[0][2]) for lg in legs) if ctx.heads is not None else 0.0
        key = (feet_z, len(ctx.ancestors[h]), ctx.names[h])
        if best_key is not None and key >= best_key:
            continue
        # sides: names in the chain first, then X of the thigh heads, then bone order
        sides = [_chain_side(ctx, lg[0] + ([lg[1]] if lg[1] is not None else [])) for lg in legs]
        if not (sides[0] and sides[1] and sides[0] != sides[1]):
            if ctx.heads is not None and ctx.heads[legs[0][0][0], 0] != ctx.heads[legs[1][0][0], 0]:
                left_first = ctx.heads[legs[0][0][0], 0] > ctx.heads[legs[1][0][0], 0]
            else:
                left_first = ctx.names[legs[0][0][0]] <= ctx.names[legs[1][0][0]]
            sides = ["l", "r"] if left_first else ["r", "l"]
        result = {"hips": h}
        for (bones, _inter), side in zip(legs, sides):
            for part, b in zip(_LEG_PARTS, bones):
                result[f"{part}_{side}"] = b
        best_key, best = key, result
    return best


def _pair_key(ctx: _Ctx, pair):
    """Sort key of two candidate legs, lower for the more symmetric pair: chain heights
    and subtree sizes alike (from the intermediate bone, if any), then shorter, then
    by name."""
    (ba, ia), (bb, ib) = pair
    sa = ia if ia is not None else ba[0]
    sb = ib if ib is not None else bb[0]
    ha, hb = ctx.height(sa), ctx.height(sb)
    return (abs(ha - hb), abs(ctx.size(sa) - ctx.size(sb)), max(ha, hb), ctx.names[sa], ctx.names[sb])


def _hier_spine(ctx: _Ctx, hips: int, used) -> int | None:
    """The child of the hips that goes upward (not part of a leg)."""
    used_set = set(used)
    opts = []
    for c in ctx.children[hips]:
        if ctx.parsed[c].tier is None or c in used_set:
            continue
        if any(ctx.desc(u, c) is not None for u in used_set):  # leads to a leg bone
            continue
        if ctx.heads is not None:
            if ctx.tails is not None:
                up = float(ctx.tails[c, 2] - ctx.heads[c, 2])
            else:
                sub = [c] + [i for i in range(ctx.n) if c in ctx.ancestors[i]]
                up = max(ctx.z(i) for i in sub) - ctx.z(hips)
            if up <= ctx.eps:
                continue
            opts.append(((-up, ctx.names[c]), c))
        else:
            opts.append(((-ctx.height(c), ctx.names[c]), c))
    return min(opts)[1] if opts else None


def _hier_root(ctx: _Ctx, hips: int, roles: dict[str, int], used) -> int | None:
    """The parent of the hips when it sits at the ground (needs rest heads)."""
    p = ctx.parents[hips]
    if p < 0 or ctx.heads is None or ctx.parsed[p].tier is None or p in used:
        return None
    low = [roles[r] for r in roles if r.startswith(("foot_", "toe_"))]
    zs = [ctx.z(i) for i in low]
    if ctx.tails is not None:
        zs += [float(ctx.tails[i, 2]) for i in low]
    if not zs:
        return None
    ground = min(zs)
    if ctx.z(p) <= ground + 0.1 * max(ctx.z(hips) - ground, 0.0):
        return p
    return None


def _lca(ctx: _Ctx, a: int, b: int) -> int | None:
    """The nearest common proper ancestor of bones ``a`` and ``b``, or None."""
    anc_b = set(ctx.ancestors[b])
    return next((x for x in ctx.ancestors[a] if x in anc_b), None)


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
