"""Keying the FK controls: the spine's FK bones and torso, the neck and head, and each limb's
FK chain (rigid controls carry their DEF bone, aimed ones pivot and aim at the next joint),
the IK/FK switch set to FK; a leg keyed on its IK controls instead goes to ``ik``.
"""

from __future__ import annotations

import bpy
import numpy as np

from .ik import _solve_leg_ik
from .solver import _Solver


def _solve_spine(s: _Solver, sp: dict):
    ob, d, fk, p = s.ob, sp["deform"], sp["fk"], sp["pivot"]
    bones = ob.data.bones
    n = len(d)
    joints = [s.head(x) for x in d] + [s.tail(d[-1])]
    rest_j = [np.array(bones[x].head_local) for x in d] + [np.array(bones[d[-1]].tail_local)]
    # above the pivot: each FK bone carries its DEF bone
    for k in range(p + 1, n):
        s.rigid(fk[k], d[k])
    # at the pivot: pivot at J_p, aimed at J_p+1; torso carries it
    delta = s.aim(fk[p], s.delta_rot(d[p]), rest_j[p], joints[p], rest_j[p + 1], joints[p + 1])
    s.want[sp["torso"]] = delta @ s.rest(sp["torso"])
    # below the pivot: the lowest (hips) FK bone carries DEF-spine; the ones between pivot about
    # their head (the joint above) and aim at the joint below
    for k in range(p - 1, 0, -1):
        s.aim(fk[k], s.delta_rot(d[k]), rest_j[k + 1], joints[k + 1], rest_j[k], joints[k])
    if p > 0:
        s.rigid(fk[0], d[0])
    s.neutral.update([sp["hips"], sp["chest"]])
    s.tweaks_of(d)


def _solve_head(s: _Solver, h: dict):
    ob = s.ob
    dn, dh = h["deform"][0], h["deform"][-1]
    bn = ob.data.bones
    s.aim(h["neck"], s.delta_rot(dn), np.array(bn[dn].head_local), s.head(dn),
          np.array(bn[dh].head_local), s.head(dh))
    s.rigid(h["head"], dh)
    for bone, prop, value in h["follow"]:  # the value that turns the follow constraints off
        s.props[f'pose.bones["{bpy.utils.escape_identifier(bone)}"]["{prop}"]'] = value
    s.tweaks_of(h["deform"])


def _solve_limb(s: _Solver, lb: dict, neutral: bool, leg_ik: bool = False):
    if leg_ik and lb["kind"] == "leg":
        return _solve_leg_ik(s, lb, neutral)
    ob = s.ob
    segs, fk = lb["deform"], lb["fk"]
    if lb["parent_control"]:
        if lb["parent_deform"] in s.t:
            s.rigid(lb["parent_control"], lb["parent_deform"])
        else:
            s.neutral.add(lb["parent_control"])
    # lower bone (shin / forearm) moves with its first DEF segment
    lower = s.rigid(fk[1], segs[1][0])
    # upper bone: pivot at the hip/shoulder, aimed at the knee/elbow, twist from the lower bone
    bn = ob.data.bones
    s.aim(fk[0], lower[:, :3, :3], np.array(bn[segs[0][0]].head_local), s.head(segs[0][0]),
          np.array(bn[segs[1][0]].head_local), s.head(segs[1][0]))
    for k in range(2, len(fk)):
        s.rigid(fk[k], segs[k][0])
    s.props[lb["switch"]["data_path"]] = float(lb["switch"]["fk_value"])
    if neutral and lb["follow"] is not None:
        s.props[lb["follow"]["data_path"]] = float(lb["follow"]["value"])
    s.tweaks_of([x for seg in segs for x in seg])
