"""The armature as a tree, for mapping bones to locomotion roles (``roles``) where names
cannot.

Here: the bones' hierarchy and rest geometry as mapping reads them (``_Ctx``; a malformed
armature raises ``RoleError``); whether a role's bone keeps to the hierarchy the mapped
roles make (``_compatible``; a foot or toe may instead hang from its shin or foot by
geometry, ``ATTACH_TOLERANCE``, ``FOOT_ANGLES``, ``TOE_ANGLES``); the feet found by
geometry and, where none is, what was tried (``_feet_tried``); and the hips, legs, spine
and root found from the bone tree alone (``roles``' "hierarchy" layer,
``_hierarchy_stage``).

Pure numpy: never imports bpy.
"""

from __future__ import annotations

from itertools import combinations

import numpy as np
from ..base.errors import FootstepError
from .role_names import _CAMEL_RE, _END_MARK, _FOOT, _LEG_PARTS, _SIDES, _SPLIT_RE, _parse_name

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
