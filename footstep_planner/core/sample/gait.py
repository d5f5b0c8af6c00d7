"""A parametric gait: the sample character's clip library, synthesized and solved with the
project's own IK.

Each clip is built the way a person moves, from the feet up:

1. **Path and timing.** The body travels along a straight line or an arc of curvature
   ``tau`` (1/m, positive turning left) at a speed that may ramp up from standing or down
   to it. Footfalls alternate at the gait's cadence; each foot is down for the gait's duty
   factor of the cycle (walking: both feet down in between; running: flight phases).
2. **Footprints** lie beside the path where the hips are at mid-stance, a step width
   apart, heading along the path (toes a little out).
3. **Feet.** A planted foot rolls: heel strike with the toes up, pivoting on the heel to
   flat, flat, then the heel rises and the foot pivots on its ball until toe off. The
   pivots are exact, so nothing slides. In between, the foot swings on a smooth
   path (smoothstep) with clearance, turning smoothly from its toe-off pose to its heel-strike pose.
4. **Body.** The hips bob (highest at mid-stance when walking, lowest when running), sway
   over the standing foot, rotate with the legs (the chest against them), lean forward
   with speed and into turns (the angle whose tangent is v^2 tau / g), and fly ballistic
   arcs in a jump. Where a leg could not reach its foot the hips are lowered, smoothly.
5. **Legs** are solved with ``legs.two_bone`` (closed form, knee forward), the feet take
   their planned rotations, and the arms swing against the legs.

The result is pose bases (F, B, 4, 4) for ``clip.clip_motion``: the same analysis and
planner then read it as they read motion capture. Conventions: armature space of the
mannequin (Z up, metres, rest forward -Y); heading 0 faces -Y; foot 0 is the left.

Here: the rig check (``require_metarig``), the library (``library_specs``) and
``generate``, which runs the steps in order: the gaits and specs are in ``specs``, path,
timing and footprints (1, 2) in ``course``, the feet (3) in ``feet``, the body and legs
(4, 5) in ``body``.
"""

from __future__ import annotations

import hashlib
from dataclasses import replace

import numpy as np

from ..base.errors import FootstepError
from ..base.memo import Memo
from ..solve.legs import leg_lengths
from ..clips.rig import Rig
from .body import (_body_frame, _hips_bases, _hips_height, _idle_sway, _jump_flight, _leg_forward, _legs,
                   _sway_signal, _toes, _upper_body)
from .course import _course, _place_footprints
from .feet import _feet
from .specs import RUN, WALK, ClipSpec, GaitClip


class GaitError(FootstepError):
    """A rig the gait cannot be made for; the message names the armature and bones."""


#: The bones the gait poses by name (Blender's human metarig, Rigify's metarig): legs
#: and hips are required, spine and arms optional.
LEG_BONES = ("spine", "thigh.L", "shin.L", "foot.L", "toe.L", "thigh.R", "shin.R", "foot.R", "toe.R")


def require_metarig(rig: Rig) -> None:
    """Raise GaitError unless ``rig`` has the human metarig's hips and leg bones in those
    roles, with the feet flat on the ground in the rest pose (the gait's feet roll from
    there)."""
    missing = [b for b in LEG_BONES if b not in rig.names]
    roles = {"hips": "spine", "thigh_l": "thigh.L", "shin_l": "shin.L", "foot_l": "foot.L",
             "thigh_r": "thigh.R", "shin_r": "shin.R", "foot_r": "foot.R"}
    wrong = [f"{r} is {rig.roles.roles.get(r)!r}" for r, b in roles.items()
             if b in rig.names and rig.roles.roles.get(r) != b]
    if missing or wrong:
        raise GaitError(
            f"armature {rig.name!r}: the sample clips are made for rigs with the human metarig's "
            f"bone names (the Footstep Mannequin, Rigify's metarig); "
            + (f"it has no {', '.join(missing)}" if missing else f"its roles differ: {', '.join(wrong)}"))
    leg = sum(leg_lengths(rig, "l"))
    for side in "LR":
        foot, toe = rig.rest[rig.index(f"foot.{side}")], rig.rest[rig.index(f"toe.{side}")]
        ankle, ball = foot[2, 3], toe[2, 3]
        if not (abs(ball) < 0.07 * leg and ball < ankle) or abs(toe[2, 1]) > 0.5:
            raise GaitError(f"armature {rig.name!r}: foot.{side} does not stand flat in the rest pose "
                            f"(ankle at {ankle:.3f} m, ball at {ball:.3f} m, toe pointing "
                            f"{np.degrees(np.arcsin(np.clip(toe[2, 1], -1, 1))):+.0f} deg): the "
                            "sample clips need the feet on the ground at z = 0")

#: Hips-head height standing (m): the knees a little soft.
STAND_HEIGHT = 0.935


def library_specs() -> list[ClipSpec]:
    """The sample character's library: walk forward and turning left and right at radii of
    0.8 m and 2.5 m, run forward and turning at 4 m, a running jump over 1.2 m, start from
    standing, stop to standing, idle. A right turn is the left turn's mirror image: it
    leads with the right foot."""
    out = [ClipSpec("walk", WALK)]
    for r, tag in ((2.5, "wide"), (0.8, "sharp")):
        for sign, side in ((1, "left"), (-1, "right")):
            # a sharp turn is walked a little slower
            out.append(ClipSpec(f"walk_turn_{side}_{tag}", WALK, tau=sign / r,
                                speed=WALK.speed * (0.93 if r < 1 else 1.0), lead=int(sign < 0)))
    out.append(ClipSpec("run", RUN, cycles=3))
    for sign, side in ((1, "left"), (-1, "right")):
        out.append(ClipSpec(f"run_turn_{side}", RUN, tau=sign / 4.0, cycles=3, speed=3.0, lead=int(sign < 0)))
    out += [ClipSpec("run_jump", RUN, kind="jump"), ClipSpec("walk_start", WALK, kind="start"),
            ClipSpec("walk_stop", WALK, kind="stop"), ClipSpec("idle", WALK, kind="idle")]
    return out


#: The mannequin's leg (hip joint to knee to ankle, 0.84) and hips-head height, m: the
#: gaits' lengths and heights are the mannequin's, and scale with a rig's legs.
REF_LEG = 0.43 + float(np.hypot(0.41, 0.01))
REF_HIPS = 0.95
#: A rig within this of the mannequin's leg length (ratio) and hips height (m) gets the
#: gaits unscaled.
SAME_SIZE = 1e-4


#: The clips generated in this process by what they were made from (``_made_from``):
#: the sample character is made again for each scene, file and test, the same each time.
#: At most 64, the latest (the sample library is 15 clips, a few hundred kB each).
_GENERATED = Memo(kept=64)


def generate(rig: Rig, spec: ClipSpec, fps: float = 30.0) -> GaitClip:
    """Generate one clip for ``rig`` at ``fps``: the mannequin, or a rig with the human
    metarig's hips and leg bones (``require_metarig``; spine and arm bones are posed
    where they have the metarig's names too). A rig of other proportions gets the gait
    scaled to its legs: lengths by the ratio of leg lengths (``size``), speeds and times
    by its square root (equal Froude numbers), heights measured down from its hips' rest
    height. The passes follow the module docstring's steps.

    A clip made before from the same rig, spec and rate is given again (its arrays read
    only): the generation is a function of those alone."""
    key = _made_from(rig, spec, fps)
    clip = _GENERATED.get(key)
    return clip if clip is not None else _GENERATED.put(key, _generate(rig, spec, fps))


def _made_from(rig: Rig, spec: ClipSpec, fps: float) -> tuple:
    """What ``generate`` makes a clip from: the rig's bones, hierarchy, rests, tails and
    roles, the spec and the rate."""
    h = hashlib.sha1(repr((rig.names, rig.roles)).encode())
    for a in (rig.parents, rig.rest, rig.tails):
        h.update(np.ascontiguousarray(a, np.float64).tobytes())
    return h.hexdigest(), spec, float(fps)


def _generate(rig: Rig, spec: ClipSpec, fps: float) -> GaitClip:
    """``generate``'s work (its passes numbered as in the module docstring)."""
    require_metarig(rig)
    spec, size, stand_height = _fit_to_legs(rig, spec)
    course = _course(spec, fps, size)  # 1. path and timing
    _place_footprints(course, spec, size)  # 2. footprints
    foot_m, toe_bend = _feet(rig, course, spec.gait, size)  # 3. feet: roll and swing
    # 4. body: sway over the standing foot, rotation with the legs, height, lean, reach
    sigma = _idle_sway(course.t) if spec.kind == "idle" else _sway_signal(course.t, course.stances)
    lift = _leg_forward(foot_m, course.root, course.heading, spec.gait, spec)
    height = _hips_height(course, sigma, spec, stand_height, size)
    if spec.kind == "jump":
        height = _jump_flight(course, height, foot_m, size)
    pos, R_body = _body_frame(course, sigma, lift, height, spec, size, fps)
    basis, drop = _hips_bases(rig, pos, R_body, foot_m, spec.kind == "cycle", fps)
    _upper_body(rig, basis, lift, sigma, course.ramp, spec.gait, spec, course.t)
    # 5. legs, then the toes
    _legs(rig, basis, foot_m, course.heading)
    _toes(rig, basis, toe_bend)
    return GaitClip(spec, float(fps), basis, course.stances, drop)


def _fit_to_legs(rig: Rig, spec: ClipSpec) -> tuple[ClipSpec, float, float]:
    """(``spec`` scaled to the rig, size: the rig's leg length over the mannequin's
    (REF_LEG), the hips' standing height m): lengths by size, speeds and times by its
    square root, heights measured down from the rig's hips' rest height; unchanged for
    a rig of the mannequin's size (within SAME_SIZE)."""
    size = sum(leg_lengths(rig, "l")) / REF_LEG
    hips0 = float(rig.rest[rig.role_index("hips"), 2, 3])
    stand_height = hips0 - (REF_HIPS - STAND_HEIGHT) * size
    if abs(size - 1.0) > SAME_SIZE or abs(hips0 - REF_HIPS) > SAME_SIZE:
        r, k = np.sqrt(size), size
        g0 = spec.gait
        g = replace(g0, speed=g0.speed * r, cycle=g0.cycle * r, width=g0.width * k, clearance=g0.clearance * k,
                    height=hips0 - (REF_HIPS - g0.height) * k, bob=g0.bob * k, sway=g0.sway * k)
        spec = replace(spec, gait=g, speed=None if spec.speed is None else spec.speed * r, tau=spec.tau / k)
    return spec, size, stand_height
