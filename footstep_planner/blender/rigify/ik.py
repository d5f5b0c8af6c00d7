"""Keying a leg on its IK controls (``_solve_leg_ik``): foot_ik and toe_ik carry the DEF foot
and toe, the knee placed by the pole control where Blender's IK solver puts it on its target
(``_pole_matrix``), the parent switches keyed to the root, the IK constraints' stretch off.
"""

from __future__ import annotations

import re

import bpy
import numpy as np

from .skeleton import _driver_prop, _drivers, _is_control
from .solver import _Solver, _current_delta, _rest, _rot


def _unit(v):
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-12)


def _perp(v, axis):
    """The part of ``v`` perpendicular to the unit vector(s) ``axis``."""
    return v - np.sum(v * axis, axis=-1, keepdims=True) * axis


def _switch_value(fc, want: float) -> float:
    """The value (0 or 1) of the property driving ``fc`` at which the driven value is ``want``."""
    return 0.0 if abs(fc.evaluate(0.0) - want) <= abs(fc.evaluate(1.0) - want) else 1.0


def _parent_switch(ob, bone: str):
    """``bone``'s parent switch: when its parent bone follows an Armature constraint whose
    target weights are driven by one property (``IK_parent``, ``pole_parent``: ``var == k``),
    the property's data path, the value that picks the rig's root bone, and that bone."""
    par = ob.data.bones[bone].parent
    arm = None if par is None else next((c for c in ob.pose.bones[par.name].constraints
                                         if c.type == "ARMATURE"), None)
    if arm is None:
        return None
    esc, drv = bpy.utils.escape_identifier, _drivers(ob)
    for i, t in enumerate(arm.targets):
        if t.target != ob or t.subtarget not in ob.data.bones or ob.data.bones[t.subtarget].parent is not None:
            continue
        fc = drv.get(f'pose.bones["{esc(par.name)}"].constraints["{esc(arm.name)}"].targets[{i}].weight')
        prop = _driver_prop(fc)
        m = re.fullmatch(r"\s*\w+\s*==\s*(-?\d+)\s*", fc.driver.expression) if prop is not None else None
        if m is not None:
            return {"data_path": f'pose.bones["{esc(prop[0])}"]["{esc(prop[1])}"]',
                    "value": float(m.group(1)), "bone": t.subtarget}
    return None


def _leg_ik_controls(ob, lb: dict) -> dict:
    """The IK side of a Rigify leg (``lb`` from ``_limbs``): the IK chain's top control
    (thigh_ik), its IK tip (MCH-shin_ik), the IK target (MCH-thigh_ik_target) and the toe
    control (toe_ik), as the ORG bones' IK Copy Transforms name them; the foot control
    (foot_ik: the top of the run of controls above the IK target), the controls between
    (foot_spin_ik, and foot_heel_ik which the roll bones copy), the pole control and its
    switch (``pole_vector``), the IK constraints' stretch, the parent switches."""
    root, tip, target, toe = lb["ik"]
    esc, drv = bpy.utils.escape_identifier, _drivers(ob)
    iks = [c for c in ob.pose.bones[tip].constraints if c.type == "IK"]
    pole = next((c for c in iks if c.pole_target == ob and c.pole_subtarget), None)
    mute = None if pole is None else drv.get(
        f'pose.bones["{esc(tip)}"].constraints["{esc(pole.name)}"].mute')
    prop = _driver_prop(mute)
    run, path, b = [], [], ob.data.bones[target]
    while b is not None and not (run and not _is_control(b.name)):
        (run if _is_control(b.name) else path).append(b.name)
        b = b.parent
    if prop is None or not run or not (_is_control(root) and _is_control(toe)):
        raise ValueError(f"leg {lb['org'][0][4:]}: no Rigify IK foot, toe and pole controls to key")
    between = {c.subtarget for n in path for c in ob.pose.bones[n].constraints
               if getattr(c, "subtarget", "") and _is_control(c.subtarget)
               and ob.data.bones[c.subtarget].parent is not None}
    return {"root": root, "tip": tip, "toe": toe, "foot": run[-1], "pole": pole.pole_subtarget,
            "pole_angle": float(pole.pole_angle), "neutral": sorted(set(run[:-1]) | between | {root}),
            "pole_switch": (f'pose.bones["{esc(prop[0])}"]["{esc(prop[1])}"]', _switch_value(mute, 0.0)),
            "stretch": [f'pose.bones["{esc(tip)}"].constraints["{esc(c.name)}"].use_stretch' for c in iks],
            "parents": {c: _parent_switch(ob, c) for c in (run[-1], pole.pole_subtarget)}}


def _solve_leg_ik(s: _Solver, lb: dict, neutral: bool):
    """A leg on its IK controls: foot_ik and toe_ik carry the DEF foot and toe; the knee is
    placed by the pole control (``pole_vector`` on), put where Blender's IK pole turns the
    chain so the knee lands on its target (``_pole_matrix``); thigh_ik and the controls
    between foot_ik and the IK target at rest; IK_FK at IK. Blender's (legacy) IK solver
    stretches or shrinks a leg whose bones allow it (Rigify's ``ik_stretch`` 0.1) while it
    bends the knee away from its rest angle, so the IK constraints' ``use_stretch`` is keyed
    off; the parent switches (IK_parent, pole_parent) are keyed to the root."""
    k = _leg_ik_controls(s.ob, lb)
    segs = lb["deform"]
    foot = s.rigid(k["foot"], segs[2][0])
    s.rigid(k["toe"], segs[3][0])
    for ctrl, sw in k["parents"].items():
        if sw is not None:
            s.props[sw["data_path"]] = sw["value"]
            s.via[ctrl] = sw["bone"]
    s.want[k["pole"]] = _pole_matrix(s, lb, k, foot)
    s.props[k["pole_switch"][0]] = k["pole_switch"][1]
    s.props[lb["switch"]["data_path"]] = 1.0 - float(lb["switch"]["fk_value"])
    s.props.update({path: 0.0 for path in k["stretch"]})
    s.neutral.update(k["neutral"])
    if neutral and lb["follow"] is not None:
        s.props[lb["follow"]["data_path"]] = float(lb["follow"]["value"])
    s.tweaks_of([x for seg in segs for x in seg])


def _pole_matrix(s: _Solver, lb: dict, k: dict, foot_delta):
    """(F, 4, 4) the pole control's wanted matrix. Blender's IK pole turns the chain about
    the hip-to-goal line until its top bone's axis ``X cos(a) + Z sin(a)`` (a: the pole
    angle) points, across that line, at the pole; then it bends the knee in that plane.
    The knee's own direction across the line makes a fixed angle (psi) with that axis,
    read from the rest chain, so the pole goes at the wanted knee's direction turned by
    psi. A straight leg (no knee direction) takes the knee's rest direction turned with
    the foot; it moves the knee by at most 1e-6 m elsewhere."""
    ob, segs = s.ob, lb["deform"]
    hip, knee, goal = (s.head(seg[0]) for seg in segs[:3])
    line = _unit(goal - hip)
    bn = ob.data.bones
    h0, k0, e0 = (np.array(v) for v in (bn[k["root"]].head_local, bn[k["tip"]].head_local, bn[k["tip"]].tail_local))
    d0 = _unit(e0 - h0)
    up0 = _rot(_rest(ob, k["root"])) @ np.array([np.cos(k["pole_angle"]), 0.0, np.sin(k["pole_angle"])])
    knee0, upp0 = _unit(_perp(k0 - h0, d0)), _unit(_perp(up0, d0))
    psi = np.arctan2(np.cross(knee0, upp0) @ d0, knee0 @ upp0) if np.linalg.norm(_perp(k0 - h0, d0)) > 1e-9 else 0.0
    rest_dir = _unit(_perp(foot_delta[:, :3, :3] @ knee0, line))
    want = _unit(_perp(knee - hip, line) + 1e-6 * rest_dir)
    pole = want * np.cos(psi) + np.cross(line, want) * np.sin(psi)
    sw = k["parents"][k["pole"]]
    w = (_current_delta(ob, sw["bone"]) if sw is not None else np.eye(4)) @ _rest(ob, k["pole"])
    out = np.repeat(w[None], s.n, axis=0)
    out[:, :3, 3] = (hip + goal) / 2 + pole * np.linalg.norm(goal - hip, axis=-1, keepdims=True)
    return out
