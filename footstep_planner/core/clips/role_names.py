"""The words of a bone's name, for mapping bones to locomotion roles (``roles``).

A name is read as ``roles`` describes (its "name" layer): namespaces (``mixamorig:``,
``Armature|``), Rigify prefixes (``DEF-`` preferred, then plain, then ``ORG-``; ``MCH-``,
``VIS-``, ``WGT-`` never mapped), 3ds Max biped prefixes, separators and camelCase split
off; its side, trailing index and base word read; control and helper bones (``ik``,
``pole``, ``twist``, ``_end``...) marked never to map. Here: that parsing
(``_parse_name``) and the tables of words each role goes by (thigh, shin, foot, toe,
hips, spine, root).

Pure Python: never imports bpy.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

_SIDES = ("l", "r")
_LEG_PARTS = ("thigh", "shin", "foot", "toe")

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
