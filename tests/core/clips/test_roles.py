"""Tests for footstep_planner.core.clips.roles (automatic bone -> locomotion role mapping)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from footstep_planner.core.clips.roles import (
    ALL_ROLES,
    OPTIONAL_ROLES,
    REQUIRED_ROLES,
    RoleError,
    RoleMapping,
    map_roles,
)

LEG_ROLES = ("thigh_l", "shin_l", "foot_l", "thigh_r", "shin_r", "foot_r")

# ------------------------------------------------------------------ skeleton kit
# Rest positions of a ~1.7 m character facing -Y (its left is +X), Z up.
POS = {
    "root": (0.0, 0.0, 0.0),
    "hips": (0.0, 0.0, 1.0),
    "pelvis": (0.0, 0.0, 0.98),  # DAZ-like second hips bone
    "spine": (0.0, 0.0, 1.1),
    "spine1": (0.0, 0.0, 1.25),
    "chest": (0.0, 0.0, 1.4),
    "neck": (0.0, 0.0, 1.55),
    "head": (0.0, 0.0, 1.65),
    "hipjoint": (0.0, 0.0, 1.0),  # CMU LHipJoint: head at the hips
    "thigh": (0.1, 0.0, 0.93),
    "thigh1": (0.1, 0.0, 0.72),  # twist segment half-way down the thigh
    "shin": (0.1, 0.0, 0.5),
    "shin1": (0.1, 0.0, 0.3),
    "foot": (0.1, 0.02, 0.08),
    "toe": (0.1, -0.1, 0.02),
    "toe_end": (0.1, -0.18, 0.02),
    "heel": (0.1, 0.06, 0.0),
    "shoulder": (0.03, 0.0, 1.45),
    "upperarm": (0.18, 0.0, 1.45),
    "forearm": (0.35, 0.0, 1.22),  # A-pose: arms go down too
    "hand": (0.5, 0.0, 1.0),
}


def P(slot: str, sign: int = 1):
    x, y, z = POS[slot]
    return (sign * x, y, z)


def build(rows):
    """rows: (name, parent name or None, head) -> names, parents, heads."""
    names = [r[0] for r in rows]
    idx = {n: i for i, n in enumerate(names)}
    parents = [idx[r[1]] if r[1] is not None else -1 for r in rows]
    heads = np.array([r[2] for r in rows], dtype=float)
    return names, parents, heads


def leg(names, parent, sign, slots=("thigh", "shin", "foot", "toe")):
    """A chain of bones named ``names`` with rest heads at ``slots``."""
    rows, p = [], parent
    for n, s in zip(names, slots):
        rows.append((n, p, P(s, sign)))
        p = n
    return rows


def arm(names, parent, sign):
    return leg(names, parent, sign, ("shoulder", "upperarm", "forearm", "hand"))


# ------------------------------------------------------------------ conventions


def cmu():
    rows = [("Hips", None, P("hips")), ("LowerBack", "Hips", P("spine"))]
    rows += [("Spine", "LowerBack", P("spine1")), ("Spine1", "Spine", P("chest"))]
    rows += [("Neck", "Spine1", P("neck")), ("Head", "Neck", P("head"))]
    for side, s, sign in (("Left", "L", 1), ("Right", "R", -1)):
        rows += leg(
            [f"{s}HipJoint", f"{side}UpLeg", f"{side}Leg", f"{side}Foot", f"{side}ToeBase"],
            "Hips",
            sign,
            ("hipjoint", "thigh", "shin", "foot", "toe"),
        )
        rows += arm([f"{side}Shoulder", f"{side}Arm", f"{side}ForeArm", f"{side}Hand"], "Spine1", sign)
    expected = {
        "hips": "Hips",
        "spine": "LowerBack",
        **{f"{p}_{s}": f"{side}{n}" for s, side in (("l", "Left"), ("r", "Right"))
           for p, n in (("thigh", "UpLeg"), ("shin", "Leg"), ("foot", "Foot"), ("toe", "ToeBase"))},
    }
    return rows, expected


def mixamo(ns="mixamorig:"):
    rows = [(f"{ns}Hips", None, P("hips")), (f"{ns}Spine", f"{ns}Hips", P("spine"))]
    rows += [(f"{ns}Spine1", f"{ns}Spine", P("spine1")), (f"{ns}Spine2", f"{ns}Spine1", P("chest"))]
    for side, sign in (("Left", 1), ("Right", -1)):
        rows += leg(
            [f"{ns}{side}{n}" for n in ("UpLeg", "Leg", "Foot", "ToeBase", "Toe_End")],
            f"{ns}Hips",
            sign,
            ("thigh", "shin", "foot", "toe", "toe_end"),
        )
        rows += arm([f"{ns}{side}{n}" for n in ("Shoulder", "Arm", "ForeArm", "Hand")], f"{ns}Spine2", sign)
    expected = {"hips": f"{ns}Hips", "spine": f"{ns}Spine"}
    for s, side in (("l", "Left"), ("r", "Right")):
        for p, n in (("thigh", "UpLeg"), ("shin", "Leg"), ("foot", "Foot"), ("toe", "ToeBase")):
            expected[f"{p}_{s}"] = f"{ns}{side}{n}"
    return rows, expected


def rigify_deform_only():
    rows = [("root", None, P("root")), ("DEF-spine", "root", P("hips"))]
    rows += [("DEF-spine.001", "DEF-spine", P("spine")), ("DEF-spine.002", "DEF-spine.001", P("spine1"))]
    for s, sign in (("L", 1), ("R", -1)):
        rows += [(f"DEF-pelvis.{s}", "DEF-spine", P("hips", sign))]
        rows += leg(
            [f"DEF-thigh.{s}", f"DEF-thigh.{s}.001", f"DEF-shin.{s}", f"DEF-shin.{s}.001",
             f"DEF-foot.{s}", f"DEF-toe.{s}"],
            "DEF-spine",
            sign,
            ("thigh", "thigh1", "shin", "shin1", "foot", "toe"),
        )
    expected = {"hips": "DEF-spine", "spine": "DEF-spine.001", "root": "root"}
    for s in ("L", "R"):
        for p in ("thigh", "shin", "foot", "toe"):
            expected[f"{p}_{s.lower()}"] = f"DEF-{p}.{s}"
    return rows, expected


def rigify_full(with_def=True):
    """Generated Rigify rig: ORG/MCH/control bones, DEF bones parented to ORG bones."""
    rows = [
        ("root", None, P("root")),
        ("torso", "root", P("hips")),
        ("MCH-torso.parent", "root", P("hips")),
        ("hips", "torso", P("hips")),
        ("chest", "torso", P("chest")),
        ("tweak_spine", "hips", P("hips")),
        ("ORG-spine", "root", P("hips")),
        ("ORG-spine.001", "ORG-spine", P("spine")),
        ("MCH-spine.001", "ORG-spine", P("spine")),
        ("spine_fk", "torso", P("hips")),
        ("spine_fk.001", "spine_fk", P("spine")),
    ]
    if with_def:
        rows += [("DEF-spine", "ORG-spine", P("hips")), ("DEF-spine.001", "DEF-spine", P("spine"))]
    for s, sign in (("L", 1), ("R", -1)):
        rows += leg([f"ORG-thigh.{s}", f"ORG-shin.{s}", f"ORG-foot.{s}", f"ORG-toe.{s}"], "ORG-spine", sign)
        rows += [(f"ORG-heel.02.{s}", f"ORG-foot.{s}", P("heel", sign))]
        rows += [(f"MCH-thigh_parent.{s}", "ORG-spine", P("thigh", sign))]
        rows += [(f"thigh_parent.{s}", f"MCH-thigh_parent.{s}", P("thigh", sign))]
        rows += leg([f"thigh_fk.{s}", f"shin_fk.{s}", f"foot_fk.{s}", f"toe_fk.{s}"], f"thigh_parent.{s}", sign)
        rows += [(f"MCH-thigh_ik.{s}", f"thigh_parent.{s}", P("thigh", sign))]
        rows += [(f"MCH-shin_ik.{s}", f"MCH-thigh_ik.{s}", P("shin", sign))]
        rows += [(f"thigh_ik.{s}", f"thigh_parent.{s}", P("thigh", sign))]
        rows += [(f"foot_ik.{s}", "root", P("foot", sign))]
        rows += [(f"foot_heel_ik.{s}", f"foot_ik.{s}", P("heel", sign))]
        rows += [(f"foot_spin_ik.{s}", f"foot_heel_ik.{s}", P("toe", sign))]
        rows += [(f"thigh_ik_target.{s}", f"foot_spin_ik.{s}", P("foot", sign))]
        rows += [(f"VIS_thigh_ik_pole.{s}", f"thigh_ik.{s}", P("shin", sign))]
        rows += [(f"toe.{s}", f"foot_spin_ik.{s}", P("toe", sign))]  # old-style toe control
        rows += [(f"thigh_tweak.{s}", f"ORG-thigh.{s}", P("thigh", sign))]
        rows += [(f"shin_tweak.{s}", f"ORG-shin.{s}", P("shin", sign))]
        rows += [(f"foot_tweak.{s}", f"ORG-foot.{s}", P("foot", sign))]
        if with_def:
            rows += leg(
                [f"DEF-thigh.{s}", f"DEF-thigh.{s}.001", f"DEF-shin.{s}", f"DEF-shin.{s}.001",
                 f"DEF-foot.{s}", f"DEF-toe.{s}"],
                "ORG-spine",
                sign,
                ("thigh", "thigh1", "shin", "shin1", "foot", "toe"),
            )
    prefix = "DEF-" if with_def else "ORG-"
    expected = {"hips": f"{prefix}spine", "spine": f"{prefix}spine.001", "root": "root"}
    for s in ("L", "R"):
        for p in ("thigh", "shin", "foot", "toe"):
            expected[f"{p}_{s.lower()}"] = f"{prefix}{p}.{s}"
    return rows, expected


def metarig():
    rows = [("spine", None, P("hips")), ("spine.001", "spine", P("spine"))]
    rows += [("spine.002", "spine.001", P("spine1")), ("spine.003", "spine.002", P("chest"))]
    for s, sign in (("L", 1), ("R", -1)):
        rows += [(f"pelvis.{s}", "spine", P("hips", sign))]
        rows += [(f"heel.02.{s}", f"foot.{s}", P("heel", sign))]  # before its parent in order
        rows += leg([f"thigh.{s}", f"shin.{s}", f"foot.{s}", f"toe.{s}"], "spine", sign)
        rows += arm([f"shoulder.{s}", f"upper_arm.{s}", f"forearm.{s}", f"hand.{s}"], "spine.003", sign)
    expected = {"hips": "spine", "spine": "spine.001"}
    for s in ("L", "R"):
        for p in ("thigh", "shin", "foot", "toe"):
            expected[f"{p}_{s.lower()}"] = f"{p}.{s}"
    return rows, expected


def unreal():
    rows = [("root", None, P("root")), ("pelvis", "root", P("hips")), ("spine_01", "pelvis", P("spine"))]
    rows += [("spine_02", "spine_01", P("spine1")), ("ik_foot_root", "root", P("root"))]
    for s, sign in (("l", 1), ("r", -1)):
        rows += leg([f"thigh_{s}", f"calf_{s}", f"foot_{s}", f"ball_{s}"], "pelvis", sign)
        rows += [(f"thigh_twist_01_{s}", f"thigh_{s}", P("thigh1", sign))]
        rows += [(f"calf_twist_01_{s}", f"calf_{s}", P("shin1", sign))]
        rows += [(f"ik_foot_{s}", "ik_foot_root", P("foot", sign))]
    expected = {"hips": "pelvis", "spine": "spine_01", "root": "root"}
    for s in ("l", "r"):
        expected.update({f"thigh_{s}": f"thigh_{s}", f"shin_{s}": f"calf_{s}",
                         f"foot_{s}": f"foot_{s}", f"toe_{s}": f"ball_{s}"})
    return rows, expected


def simple(hips, spine, fmt, words, sides=("L", "R"), toe=True, root=None):
    """Generic convention: leg names from ``fmt.format(side=..., word=...)``."""
    rows = []
    if root:
        rows.append((root, None, P("root")))
    rows += [(hips, root, P("hips"))]
    if spine:
        rows.append((spine, hips, P("spine")))
    expected = {"hips": hips}
    if spine:
        expected["spine"] = spine
    if root:
        expected["root"] = root
    parts = ("thigh", "shin", "foot", "toe") if toe else ("thigh", "shin", "foot")
    for s, side, sign in zip(("l", "r"), sides, (1, -1)):
        leg_names = [fmt.format(side=side, word=w) for w in words[: len(parts)]]
        rows += leg(leg_names, hips, sign, parts)
        expected.update({f"{p}_{s}": n for p, n in zip(parts, leg_names)})
    return rows, expected


def bip01(prefix="Bip01"):
    rows = [(prefix, None, P("hips")), (f"{prefix} Pelvis", prefix, P("hips"))]
    rows += [(f"{prefix} Spine", f"{prefix} Pelvis", P("spine")), (f"{prefix} Spine1", f"{prefix} Spine", P("spine1"))]
    expected = {"hips": f"{prefix} Pelvis", "spine": f"{prefix} Spine"}
    for s, side, sign in (("l", "L", 1), ("r", "R", -1)):
        names = [f"{prefix} {side} {w}" for w in ("Thigh", "Calf", "Foot", "Toe0", "Toe0Nub")]
        rows += leg(names, f"{prefix} Spine", sign, ("thigh", "shin", "foot", "toe", "toe_end"))
        expected.update(zip((f"thigh_{s}", f"shin_{s}", f"foot_{s}", f"toe_{s}"), names))
    return rows, expected


def daz():
    rows = [("hip", None, P("hips")), ("pelvis", "hip", P("pelvis")), ("abdomenLower", "hip", P("spine"))]
    rows += [("abdomenUpper", "abdomenLower", P("spine1"))]
    expected = {"hips": "hip", "spine": "abdomenLower"}
    for s, sign in (("l", 1), ("r", -1)):
        rows += [
            (f"{s}ThighBend", "pelvis", P("thigh", sign)),
            (f"{s}ThighTwist", f"{s}ThighBend", P("thigh1", sign)),
            (f"{s}Shin", f"{s}ThighTwist", P("shin", sign)),
            (f"{s}Foot", f"{s}Shin", P("foot", sign)),
            (f"{s}Metatarsals", f"{s}Foot", P("foot", sign)),
            (f"{s}Toe", f"{s}Metatarsals", P("toe", sign)),
            (f"{s}BigToe", f"{s}Toe", P("toe_end", sign)),
        ]
        expected.update({f"thigh_{s}": f"{s}ThighBend", f"shin_{s}": f"{s}Shin",
                         f"foot_{s}": f"{s}Foot", f"toe_{s}": f"{s}Toe"})
    return rows, expected


def asf():
    """Acclaim ASF (CMU mocap): 'root' is the hips, lfemur/ltibia/lfoot/ltoes."""
    rows = [("root", None, P("hips")), ("lowerback", "root", P("spine")), ("upperback", "lowerback", P("spine1"))]
    expected = {"hips": "root", "spine": "lowerback"}
    for s, sign in (("l", 1), ("r", -1)):
        names = [f"{s}hipjoint", f"{s}femur", f"{s}tibia", f"{s}foot", f"{s}toes"]
        rows += leg(names, "root", sign, ("hipjoint", "thigh", "shin", "foot", "toe"))
        expected.update(zip((f"thigh_{s}", f"shin_{s}", f"foot_{s}", f"toe_{s}"), names[1:]))
    return rows, expected


def old_bvh():
    """Older BVH files: LeftHip is the thigh, then LeftKnee, LeftAnkle; Chest above Hips."""
    rows, expected = simple("Hips", None, "{side}{word}", ("Hip", "Knee", "Ankle"),
                            sides=("Left", "Right"), toe=False)
    rows.append(("Chest", "Hips", P("spine")))
    expected["spine"] = "Chest"  # by hierarchy: the child of the hips going up
    return rows, expected


CONVENTIONS = {
    "cmu": cmu,
    "mixamo": mixamo,
    "mixamo1": lambda: mixamo("mixamorig1:"),
    "armature_pipe": lambda: mixamo("Armature|"),
    "rigify_deform": rigify_deform_only,
    "rigify_full": rigify_full,
    "rigify_org_only": lambda: rigify_full(with_def=False),
    "metarig": metarig,
    "unreal": unreal,
    "bip01": bip01,
    "bip001": lambda: bip01("Bip001"),
    "daz": daz,
    "unity": lambda: simple("Hips", "Spine", "{word}_{side}", ("UpperLeg", "LowerLeg", "Foot", "Toes")),
    "left_thigh_shin": lambda: simple("Pelvis", "Spine", "{side}{word}", ("Thigh", "Shin", "Foot", "Toe"),
                                      sides=("Left", "Right")),
    "left_calf": lambda: simple("Hip", None, "{side}{word}", ("Thigh", "Calf", "Foot", "Toe"),
                                sides=("Left", "Right")),
    "left_knee_no_toe": lambda: simple("Hips", "Spine", "{side}{word}", ("Thigh", "Knee", "Foot"),
                                       sides=("Left", "Right"), toe=False),
    "L_prefix": lambda: simple("Hip", "Spine", "{side}_{word}", ("Thigh", "Calf", "Foot", "Toe")),
    "upperleg_dot_l": lambda: simple("hips", "spine", "{word}.{side}", ("upperleg", "lowerleg", "foot", "toe"),
                                     sides=("l", "r")),
    "underscore_lower": lambda: simple("Pelvis", None, "{word}_{side}", ("Thigh", "Calf", "Foot", "Toe"),
                                       sides=("l", "r"), root="Root"),
    "upper_case": lambda: simple("HIPS", "SPINE", "{side}{word}", ("UPLEG", "LEG", "FOOT", "TOEBASE"),
                                 sides=("LEFT", "RIGHT")),
    "asf": asf,
    "old_bvh": old_bvh,
    "advanced_skeleton": lambda: simple("Root_M", "Spine1_M", "{word}_{side}", ("Hip", "Knee", "Ankle", "Toes")),
    "game_def": lambda: simple("DEF_Pelvis", None, "DEF_{word}_{side}", ("Thigh", "Calf", "Foot", "Toe")),
}


def run(rows, **kw):
    names, parents, heads = build(rows)
    return map_roles(names, parents, heads, **kw)


# ------------------------------------------------------------------ name-based tests


@pytest.mark.parametrize("conv", sorted(CONVENTIONS))
def test_naming_conventions(conv):
    rows, expected = CONVENTIONS[conv]()
    m = run(rows)
    assert m.ok, m.describe()
    assert m.missing == ()
    for role, bone in expected.items():
        assert m.roles.get(role) == bone, (role, m.roles)
    for role in REQUIRED_ROLES:
        assert m.how[role] == "name", (role, m.how)
    # nothing beyond what the convention expects (e.g. no spurious toe/root)
    assert set(m.roles) == set(expected), (set(m.roles) ^ set(expected))


@pytest.mark.parametrize("conv", sorted(CONVENTIONS))
def test_names_work_without_heads(conv):
    rows, expected = CONVENTIONS[conv]()
    names, parents, _ = build(rows)
    m = map_roles(names, parents)
    assert m.ok
    for role in REQUIRED_ROLES + ("toe_l", "toe_r", "spine"):
        assert m.roles.get(role) == expected.get(role), role


def test_full_rigify_never_maps_control_or_mechanism_bones():
    rows, _ = rigify_full()
    m = run(rows)
    for role, bone in m.roles.items():
        if role != "root":
            assert bone.startswith("DEF-"), (role, bone)
    banned = ("MCH-", "VIS", "_fk", "_ik", "tweak", "parent", "pole")
    assert not [b for b in m.roles.values() if any(t in b for t in banned)]


def test_cmu_hipjoint_is_not_the_thigh():
    rows, _ = cmu()
    m = run(rows)
    assert m.bone("thigh_l") == "LeftUpLeg" and m.bone("thigh_r") == "RightUpLeg"
    assert "LHipJoint" not in m.roles.values()


def test_metarig_heel_is_not_a_toe():
    rows, _ = metarig()
    m = run(rows)
    assert m.bone("toe_l") == "toe.L" and m.bone("toe_r") == "toe.R"
    assert not any(b.startswith("heel") for b in m.roles.values())


def test_names_win_over_facing():
    """A character facing +Y has its left leg at -X; names still decide."""
    rows, expected = mixamo()
    rows = [(n, p, (-x, -y, z)) for n, p, (x, y, z) in rows]
    m = run(rows)
    assert m.bone("thigh_l") == expected["thigh_l"]
    assert m.bone("foot_r") == expected["foot_r"]


def test_inconsistent_names_fall_back_to_hierarchy():
    """LeftFoot and LeftLeg swapped in the tree: names can't give a consistent left leg."""
    rows, _ = mixamo("")
    swapped = {"LeftLeg": "LeftFoot", "LeftFoot": "LeftLeg"}
    rows = [(swapped.get(n, n), swapped.get(p, p), h) for n, p, h in rows]
    m = run(rows)
    assert m.ok, m.describe()
    # the geometry (and tree) says: shin slot holds "LeftFoot", foot slot holds "LeftLeg"
    assert m.bone("shin_l") == "LeftFoot" and m.bone("foot_l") == "LeftLeg"
    assert m.how["foot_l"] == "hierarchy" and m.how["thigh_r"] == "name"


# ------------------------------------------------------------------ hierarchy fallback


def anonymous(rows):
    """Rename every bone Bone, Bone.001, ... keeping tree and geometry."""
    rename = {r[0]: ("Bone" if i == 0 else f"Bone.{i:03d}") for i, r in enumerate(rows)}
    new = [(rename[n], rename.get(p) if p else None, h) for n, p, h in rows]
    return new, rename


@pytest.mark.parametrize("conv", ["cmu", "mixamo", "metarig", "unreal"])
def test_hierarchy_fallback_anonymous(conv):
    rows, expected = CONVENTIONS[conv]()
    anon, rename = anonymous(rows)
    m = run(anon)
    assert m.ok, m.describe()
    for role in REQUIRED_ROLES + ("toe_l", "toe_r"):
        assert m.roles[role] == rename[expected[role]], (role, m.roles)
        assert m.how[role] == "hierarchy"
    assert m.roles["spine"] == rename[expected["spine"]]
    if "root" in expected:
        assert m.roles["root"] == rename[expected["root"]]


def test_hierarchy_left_is_plus_x():
    rows, expected = mixamo("")
    anon, rename = anonymous(rows)
    m = run(anon)
    names, parents, heads = build(anon)
    idx = {n: i for i, n in enumerate(names)}
    assert heads[idx[m.bone("thigh_l")], 0] > 0 > heads[idx[m.bone("thigh_r")], 0]


def test_hierarchy_with_tails_prefers_connected_toe():
    rows, expected = metarig()
    anon, rename = anonymous(rows)
    names, parents, heads = build(anon)
    tails = heads.copy()
    inv = {v: k for k, v in rename.items()}
    for i, n in enumerate(names):
        orig = inv[n]
        if orig.startswith("foot."):  # connected toe: its head is the foot's tail
            tails[i] = heads[names.index(rename["toe." + orig[-1]])]
        else:
            tails[i] = heads[i] + np.array([0.0, -0.05, 0.0])
        if orig.startswith("heel"):  # make the heel the farther child by head distance
            heads[i] = heads[i] + np.array([0.0, 0.3, -0.05])
    m = map_roles(names, parents, heads, tails)
    assert m.bone("toe_l") == rename["toe.L"] and m.bone("toe_r") == rename["toe.R"]


def test_named_hips_with_anonymous_legs():
    rows, expected = mixamo("")
    rename = {n: f"Bone.{i:03d}" for i, (n, _, _) in enumerate(rows)
              if any(w in n for w in ("Leg", "Foot", "Toe"))}
    rows = [(rename.get(n, n), rename.get(p, p), h) for n, p, h in rows]
    m = run(rows)
    assert m.ok
    assert m.bone("hips") == "Hips" and m.how["hips"] == "name"
    for role in LEG_ROLES + ("toe_l", "toe_r"):
        assert m.bone(role) == rename[expected[role]] and m.how[role] == "hierarchy"


def test_partial_names_are_completed_by_hierarchy():
    """Named legs but anonymous hips: the hips come from the tree."""
    rows, expected = unreal()
    rename = {"pelvis": "Bone.007", "root": "Bone"}
    rows = [(rename.get(n, n), rename.get(p, p), h) for n, p, h in rows]
    m = run(rows)
    assert m.ok
    assert m.bone("hips") == "Bone.007" and m.how["hips"] == "hierarchy"
    assert m.how["thigh_l"] == "name"
    assert m.roles.get("root") == "Bone" and m.how["root"] == "hierarchy"


# ------------------------------------------------------------------ permutation invariance


FIXTURES = sorted(CONVENTIONS)


def _permute(rows, perm):
    names, parents, heads = build(rows)
    pos = {old: new for new, old in enumerate(perm)}
    p_names = [names[o] for o in perm]
    p_parents = [pos[parents[o]] if parents[o] >= 0 else -1 for o in perm]
    return p_names, p_parents, heads[list(perm)]


@settings(max_examples=40, deadline=None, database=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data(), conv=st.sampled_from(FIXTURES))
def test_name_mapping_invariant_under_bone_order(data, conv):
    rows, expected = CONVENTIONS[conv]()
    perm = data.draw(st.permutations(range(len(rows))))
    names, parents, heads = _permute(rows, perm)
    m = map_roles(names, parents, heads)
    ref = run(rows)
    assert m.roles == ref.roles
    assert m.how == ref.how
    assert m.roles == expected


@settings(max_examples=15, deadline=None, database=None)
@given(data=st.data())
def test_hierarchy_mapping_invariant_under_bone_order(data):
    anon, _ = anonymous(cmu()[0])
    perm = data.draw(st.permutations(range(len(anon))))
    names, parents, heads = _permute(anon, perm)
    assert map_roles(names, parents, heads).roles == run(anon).roles


# ------------------------------------------------------------------ overrides


def test_overrides_win():
    rows, expected = mixamo()
    m = run(rows, overrides={"spine": "mixamorig:Spine1", "toe_l": "mixamorig:LeftToe_End"})
    assert m.bone("spine") == "mixamorig:Spine1" and m.how["spine"] == "manual"
    assert m.bone("toe_l") == "mixamorig:LeftToe_End" and m.how["toe_l"] == "manual"
    assert m.bone("thigh_l") == expected["thigh_l"] and m.how["thigh_l"] == "name"


def test_override_steers_the_rest_of_the_chain():
    """Overriding the thigh to the CMU hip joint keeps the rest consistent below it."""
    rows, _ = cmu()
    m = run(rows, overrides={"thigh_l": "LHipJoint"})
    assert m.bone("thigh_l") == "LHipJoint" and m.how["thigh_l"] == "manual"
    assert m.bone("shin_l") in ("LeftUpLeg", "LeftLeg")
    assert m.ok


def test_override_completes_an_otherwise_unmappable_rig():
    rows = [("Body", None, P("hips"))]
    for s, sign in (("a", 1), ("b", -1)):  # legs that neither names nor geometry reveal
        rows += leg([f"{s}1", f"{s}2", f"{s}3"], "Body", sign, ("thigh", "thigh", "thigh"))
    ov = {"hips": "Body", "thigh_l": "a1", "shin_l": "a2", "foot_l": "a3",
          "thigh_r": "b1", "shin_r": "b2", "foot_r": "b3"}
    m = run(rows, overrides=ov)
    assert m.ok and m.roles == ov
    assert set(m.how.values()) == {"manual"}


def test_override_to_missing_bone_raises():
    rows, _ = mixamo()
    with pytest.raises(RoleError) as err:
        run(rows, overrides={"foot_l": "NoSuchFoot"})
    assert "NoSuchFoot" in str(err.value) and "foot_l" in str(err.value)


def test_override_unknown_role_raises():
    rows, _ = mixamo()
    with pytest.raises(RoleError, match="tail"):
        run(rows, overrides={"tail": "mixamorig:Hips"})


# ------------------------------------------------------------------ failures


def no_legs():
    rows = [("Spine", None, P("hips")), ("Spine1", "Spine", P("spine")), ("Chest", "Spine1", P("chest"))]
    rows += [("Neck", "Chest", P("neck")), ("Head", "Neck", P("head"))]
    for side, sign in (("Left", 1), ("Right", -1)):
        rows += leg([f"{side}Shoulder", f"{side}Arm", f"{side}ForeArm"], "Chest", sign,
                    ("shoulder", "upperarm", "forearm"))
    return rows


def test_no_legs_reports_missing_roles():
    m = run(no_legs())
    assert not m.ok
    assert set(LEG_ROLES) <= set(m.missing)
    text = m.describe()
    assert text.startswith("could not map roles:")
    for role in LEG_ROLES:
        assert role in text
    assert "Chest" in text  # lists the armature's bones
    with pytest.raises(RoleError, match="thigh_l"):
        m.bone("thigh_l")


def test_empty_armature():
    m = map_roles([], [])
    assert not m.ok and m.missing == REQUIRED_ROLES
    assert "could not map roles" in m.describe()


def test_malformed_input_raises():
    with pytest.raises(RoleError):
        map_roles(["a", "b"], [-1])
    with pytest.raises(RoleError):
        map_roles(["a", "b"], [1, 0])  # cycle
    with pytest.raises(RoleError):
        map_roles(["a", "a"], [-1, 0])
    with pytest.raises(RoleError):
        map_roles(["a"], [-1], heads=np.zeros((2, 3)))


# ------------------------------------------------------------------ API surface


def test_role_tuples():
    assert REQUIRED_ROLES == ("hips", "thigh_l", "shin_l", "foot_l", "thigh_r", "shin_r", "foot_r")
    assert set(OPTIONAL_ROLES) == {"toe_l", "toe_r", "spine", "root"}
    assert set(ALL_ROLES) == set(REQUIRED_ROLES) | set(OPTIONAL_ROLES)
    assert len(ALL_ROLES) == len(set(ALL_ROLES))


def test_role_mapping_methods():
    m = RoleMapping(roles={"hips": "Hips"}, missing=("thigh_l",), how={"hips": "name"})
    assert not m.ok and m.bone("hips") == "Hips"
    with pytest.raises(RoleError, match="spine"):
        m.bone("spine")
    with pytest.raises(RoleError):
        m.bone("nonsense")
    ok = run(mixamo()[0])
    assert ok.describe().startswith("mapped") and "hips=mixamorig:Hips" in ok.describe()
    with pytest.raises(Exception):
        ok.roles = {}  # frozen


# ------------------------------------------------------------------ game rigs: feet hung by geometry
# Rest heads and tails (a ~1.7 m character facing -Y, Z up) of an IK-style game rig shaped
# like Quaternius' "HumanArmature": the feet (and the knees' pole targets) parented to the
# root at the ground, not to the shins, whose only child is an FBX end marker.
GAME = {  # bone: (parent, head, tail), left side (the right is its mirror in X)
    "Bone": (None, (0.0, 0.0, 0.0), (0.0, 0.0, 0.4)),
    "Body": ("Bone", (0.0, -0.03, 0.99), (0.0, -0.03, 1.1)),
    "Hips": ("Body", (0.0, 0.0, 0.95), (0.0, 0.0, 1.1)),
    "Abdomen": ("Hips", (0.0, 0.0, 1.1), (0.0, 0.0, 1.3)),
    "Torso": ("Abdomen", (0.0, 0.0, 1.3), (0.0, 0.01, 1.5)),
    "Neck": ("Torso", (0.0, 0.01, 1.5), (0.0, 0.01, 1.58)),
    "Head": ("Neck", (0.0, 0.01, 1.58), (0.0, 0.01, 1.75)),
    "Shoulder.L": ("Torso", (0.03, 0.0, 1.45), (0.16, 0.0, 1.46)),
    "UpperArm.L": ("Shoulder.L", (0.16, 0.0, 1.46), (0.35, 0.0, 1.22)),
    "LowerArm.L": ("UpperArm.L", (0.35, 0.0, 1.22), (0.5, 0.0, 1.0)),
    "Palm.L": ("LowerArm.L", (0.5, 0.0, 1.0), (0.55, 0.0, 0.93)),
    "UpperLeg.L": ("Body", (0.1, 0.0, 0.93), (0.1, -0.02, 0.5)),
    "LowerLeg.L": ("UpperLeg.L", (0.1, -0.02, 0.5), (0.1, 0.02, 0.08)),
    "LowerLeg.L_end": ("LowerLeg.L", (0.1, 0.02, 0.08), (0.1, 0.06, -0.34)),
    "Foot.L": ("Bone", (0.1, 0.02, 0.08), (0.1, -0.1, 0.075)),
    "Foot.L_end": ("Foot.L", (0.1, -0.1, 0.075), (0.1, -0.22, 0.07)),
    "PoleTarget.L": ("Bone", (0.1, -0.6, 0.5), (0.1, -0.6, 0.6)),
    "PoleTarget.L_end": ("PoleTarget.L", (0.1, -0.6, 0.6), (0.1, -0.6, 0.7)),
}
GAME_ROLES = {"hips": "Body", "spine": "Abdomen", "root": "Bone"}
for _s in ("l", "r"):
    GAME_ROLES.update({f"thigh_{_s}": f"UpperLeg.{_s.upper()}", f"shin_{_s}": f"LowerLeg.{_s.upper()}",
                       f"foot_{_s}": f"Foot.{_s.upper()}"})


def game_rig(foot_parent="Bone", rename=None):
    """(names, parents, heads, tails) of the game rig, both sides, its feet parented to
    ``foot_parent``; ``rename`` maps names to others."""
    rows = []
    for name, (parent, head, tail) in GAME.items():
        sides = [("L", 1), ("R", -1)] if ".L" in name else [("", 1)]
        for s, sign in sides:
            nm = name.replace(".L", f".{s}") if s else name
            par = parent.replace(".L", f".{s}") if (s and parent) else parent
            if name == "Foot.L":
                par = foot_parent.replace(".L", f".{s}")
            rows.append((nm, par, (sign * head[0], head[1], head[2]), (sign * tail[0], tail[1], tail[2])))
    rename = rename or {}
    names = [rename.get(r[0], r[0]) for r in rows]
    idx = {r[0]: i for i, r in enumerate(rows)}
    parents = [idx[r[1]] if r[1] else -1 for r in rows]
    return names, parents, np.array([r[2] for r in rows]), np.array([r[3] for r in rows])


@pytest.mark.parametrize("foot_parent", ["Bone", "Body", "PoleTarget.L", "Hips", "UpperLeg.L"])
def test_game_rig_feet_parented_anywhere_hang_from_their_shins(foot_parent):
    """Feet parented to the root (Quaternius), the pelvis, an IK control, the spine or the
    thigh: each is found at its shin's end, the same mapping every time."""
    names, parents, heads, tails = game_rig(foot_parent)
    m = map_roles(names, parents, heads, tails)
    assert m.ok, m.describe()
    assert m.roles == GAME_ROLES, m.describe()
    assert m.how["foot_l"] == m.how["foot_r"] == "name"
    assert "Foot.L_end" not in m.roles.values() and "PoleTarget.L" not in m.roles.values()


def test_game_rig_without_tails_finds_the_shins_end_by_its_end_marker():
    names, parents, heads, _ = game_rig()
    m = map_roles(names, parents, heads)
    assert m.ok and m.roles == GAME_ROLES, m.describe()


def test_game_rig_anonymous_by_hierarchy_and_geometry():
    """Nameless bones: the legs come from the tree, each foot from the shin's end; the
    shin's end marker (a leaf going on the shin's way) is no foot."""
    names, parents, heads, tails = game_rig()
    rename = {n: f"b{i:02d}" for i, n in enumerate(names)}
    anon = [rename[n] for n in names]
    m = map_roles(anon, parents, heads, tails)
    assert m.ok, m.describe()
    for role in REQUIRED_ROLES:
        assert m.roles[role] == rename[GAME_ROLES[role]], (role, m.describe())
        assert m.how[role] == "hierarchy"


def _rot(axis, deg):
    from scipy.spatial.transform import Rotation

    return Rotation.from_rotvec(np.radians(deg) * np.asarray(axis, float)).as_matrix()


def posed_rest(names, parents, heads, tails, turns, carry, lift=(0.0, 0.0, 0.0), gaps=None):
    """Heads and tails of the rig posed as a clip's frame would pose it (a rest pose written
    from that frame): bone ``b`` turned by ``turns[b]`` (3, 3) about its head, each bone
    carried by its parent, a foot in ``carry`` (bone -> bone) by that bone instead (the
    animation keeps it at the ankle), then parted from there by ``gaps[b]`` (3,)."""
    n = len(names)
    pp = [carry.get(i, parents[i]) for i in range(n)]
    G, H = [None] * n, [None] * n
    done = 0
    while done < n:
        for i in range(n):
            if G[i] is not None or (pp[i] >= 0 and G[pp[i]] is None):
                continue
            if pp[i] < 0:
                G[i], H[i] = turns.get(i, np.eye(3)), heads[i] + np.asarray(lift)
            else:
                p = pp[i]
                G[i] = G[p] @ turns.get(i, np.eye(3))
                H[i] = H[p] + G[p] @ (heads[i] - heads[p])
            done += 1
    H = np.array(H) + (np.array([gaps.get(i, np.zeros(3)) for i in range(n)]) if gaps else 0.0)
    T = H + np.einsum("bij,bj->bi", np.array(G), tails - heads)
    return H, T


@settings(max_examples=60, deadline=None, database=None)
@given(yaw=st.floats(-180, 180), tilt=st.floats(-15, 15), hip=st.tuples(*[st.floats(-50, 50)] * 2),
       knee=st.tuples(*[st.floats(0, 110)] * 2), ankle=st.tuples(*[st.floats(-40, 40)] * 2),
       gap=st.floats(0.0, 0.08), lift=st.tuples(st.floats(-1, 1), st.floats(-1, 1), st.floats(0, 0.5)))
def test_game_rig_maps_the_same_whatever_frame_its_rest_pose_was_written_in(yaw, tilt, hip, knee, ankle, gap,
                                                                             lift):
    """An FBX's rest pose is the pose it was written in: the same mapping however the legs
    are posed, the character turned or lifted, an ankle parted from its shin by up to 8%
    of the shin's length."""
    names, parents, heads, tails = game_rig()
    i = {n: k for k, n in enumerate(names)}
    turns = {i["Bone"]: _rot((0, 0, 1), yaw) @ _rot((1, 0, 0), tilt)}
    for k, s in enumerate("LR"):
        turns[i[f"UpperLeg.{s}"]] = _rot((1, 0, 0), -hip[k])
        turns[i[f"LowerLeg.{s}"]] = _rot((1, 0, 0), knee[k])
        turns[i[f"Foot.{s}"]] = _rot((1, 0, 0), ankle[k])
    carry = {i[f"Foot.{s}"]: i[f"LowerLeg.{s}"] for s in "LR"}
    shin = np.linalg.norm(heads[i["LowerLeg.L"]] - tails[i["LowerLeg.L"]])
    gaps = {i["Foot.L"]: np.array([0.0, 0.6, 0.8]) * gap * shin, i["Foot.R"]: np.array([0.6, 0.0, -0.8]) * gap * shin}
    H, T = posed_rest(names, parents, heads, tails, turns, carry, lift, gaps)
    m = map_roles(names, parents, H, T)
    assert {r: m.roles.get(r) for r in REQUIRED_ROLES} == {r: GAME_ROLES[r] for r in REQUIRED_ROLES}, m.describe()


@settings(max_examples=30, deadline=None, database=None)
@given(data=st.data())
def test_game_rig_mapping_invariant_under_bone_order(data):
    names, parents, heads, tails = game_rig()
    perm = data.draw(st.permutations(range(len(names))))
    pos = {old: new for new, old in enumerate(perm)}
    m = map_roles([names[o] for o in perm], [pos[parents[o]] if parents[o] >= 0 else -1 for o in perm],
                  heads[list(perm)], tails[list(perm)])
    assert m.roles == GAME_ROLES


def test_a_foot_under_its_shin_wins_over_one_hanging_there():
    """A rig with both: the foot its shin carries is the foot (an existing rig's mapping
    is never changed by a bone that only hangs at the ankle)."""
    rows, expected = mixamo()
    names, parents, heads = build(rows)
    for s, sign in (("Left", 1), ("Right", -1)):
        names.append(f"Foot{s}Copy")  # a named foot at the ankle, parented to the hips
        parents.append(names.index("mixamorig:Hips"))
        heads = np.vstack([heads, P("foot", sign)])
    m = map_roles(names, parents, heads)
    assert m.roles == expected


FAMILIES = {  # names that map without help: (thigh, shin, foot, toe) of the left leg, hips
    "mixamo": (("mixamorig:LeftUpLeg", "mixamorig:LeftLeg", "mixamorig:LeftFoot", "mixamorig:LeftToeBase"),
               "mixamorig:Hips"),
    "quaternius": (("UpperLeg.L", "LowerLeg.L", "Foot.L", None), "Hips"),
    "rigify_metarig": (("thigh.L", "shin.L", "foot.L", "toe.L"), "spine"),
    "unreal": (("thigh_l", "calf_l", "foot_l", "ball_l"), "pelvis"),
    "unity": (("LeftUpperLeg", "LeftLowerLeg", "LeftFoot", "LeftToes"), "Hips"),
    "cmu_bvh": (("LeftUpLeg", "LeftLeg", "LeftFoot", "LeftToeBase"), "Hips"),
}


def _right(name):
    for a, b in (("Left", "Right"), (".L", ".R"), ("_l", "_r")):
        if a in name:
            return name.replace(a, b)
    raise AssertionError(name)


@pytest.mark.parametrize("family", sorted(FAMILIES))
@pytest.mark.parametrize("feet_on_root", [False, True])
def test_rig_families_map_by_name_feet_under_the_shin_or_on_the_root(family, feet_on_root):
    """Each family's leg names, with twist bones (Unreal), hip joints (CMU), a root at the
    ground, and the feet either under their shins or parented to the root by the rig."""
    leg_names, hips = FAMILIES[family]
    rows = [("root", None, P("root"), None), (hips, "root", P("hips"), None), ("Spine", hips, P("spine"), None)]
    for sign, side in ((1, lambda n: n), (-1, _right)):
        thigh, shin, foot, toe = [side(n) if n else None for n in leg_names]
        up = hips
        if family == "cmu_bvh":
            up = "LHipJoint" if sign > 0 else "RHipJoint"
            rows.append((up, hips, P("hipjoint", sign), P("thigh", sign)))
        rows += [(thigh, up, P("thigh", sign), P("shin", sign)), (shin, thigh, P("shin", sign), P("foot", sign))]
        rows.append((foot, "root" if feet_on_root else shin, P("foot", sign), P("toe", sign)))
        if toe:
            rows.append((toe, foot, P("toe", sign), P("toe_end", sign)))
        if family == "unreal":
            rows += [(f"thigh_twist_01_{'lr'[sign < 0]}", thigh, P("thigh1", sign), P("shin", sign)),
                     (f"calf_twist_01_{'lr'[sign < 0]}", shin, P("shin1", sign), P("foot", sign))]
    names = [r[0] for r in rows]
    parents = [names.index(r[1]) if r[1] else -1 for r in rows]
    heads = np.array([r[2] for r in rows], float)
    tails = np.array([r[3] if r[3] is not None else np.add(r[2], (0, 0, 0.1)) for r in rows], float)
    m = map_roles(names, parents, heads, tails)
    assert m.ok, m.describe()
    for part, n in zip(("thigh", "shin", "foot", "toe"), leg_names):
        assert m.roles.get(f"{part}_l") == n and m.roles.get(f"{part}_r") == (_right(n) if n else None), m.describe()
        if n:
            assert m.how[f"{part}_l"] == "name"
    assert m.roles["hips"] == hips and m.roles.get("root") == "root"
    assert not any("twist" in b or "HipJoint" in b for b in m.roles.values())


def test_unpaired_feet_name_the_shins_ends_and_the_bones_tried():
    """Feet parented to the root that stand nowhere near the shins' ends: the message says
    where each shin ends and which bones were tried, how far each is and why it is not
    the foot."""
    names, parents, heads, tails = game_rig()
    for s in "LR":
        k = names.index(f"Foot.{s}")
        heads[k] += (0.0, -0.25, 0.0)
        tails[k] += (0.0, -0.25, 0.0)
    m = map_roles(names, parents, heads, tails)
    assert not m.ok and set(m.missing) == {"foot_l", "foot_r"}
    text = m.describe()
    assert "\n" not in text and text.startswith("could not map roles: foot_l, foot_r")
    assert "shin 'LowerLeg.L' ends at (0.1, 0.02, 0.08)" in text and "'LowerLeg.R'" in text
    assert "'Foot.L' 0.25 (too far)" in text and "'Foot.R' 0.25 (too far)" in text
    assert "'LowerLeg.L_end' 0 (a control or end bone)" in text
    assert "a foot's head within 0.105" in text
