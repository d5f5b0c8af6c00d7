"""A clip's mirror image: the same motion reflected across the character's sagittal
plane, its left and right swapped, so a jump that takes off from one foot gives a second
jump that takes off from the other (pure numpy/scipy; never imports bpy).

Conventions: armature space, Z up, metres; the character's rest forward ``f`` (the rig's
``forward_axis``, horizontal) and up ``u`` (+Z) span the sagittal plane, whose normal is
``n = f x u`` (the character's right). The reflection is ``M = I - 2 n n^T`` about the
plane through the rest hips head (only the plane's offset along ``n`` matters, and it
only moves the mirrored clip sideways as a whole: everything the planner reads of a clip
is relative to its root).

The bone rotations. With ``R_b`` a bone's rest orientation (armature space) and ``B_b``
its pose basis rotation, the bone's armature orientation is ``G_b = G_p R_p^T R_b B_b``
(``rig.forward_kinematics``), so ``D_b = G_b R_b^T``, the rotation carrying the bone from
rest to pose, composes as ``D_b = D_p A_b`` with ``A_b = R_b B_b R_b^T``: the basis seen
in armature axes. The mirror image of the pose turns each bone by the reflected rotation
``M D M`` (a proper rotation: ``M`` twice), and since ``M M = I`` that holds down the chain
exactly when every ``A`` is reflected alike: ``A'_b' = M A_b M``, where ``b' = mirror(b)``
(left and right swapped; a bone on the centre line is its own mirror). Back in the
mirrored bone's own frame::

    B'_b' = R_b'^T A'_b' R_b' = C^T B_b C,    C = R_b^T M R_b'

``C`` is orthogonal with determinant -1, so ``C^T B C = Q^T B Q`` with the proper rotation
``Q = -C``: the quaternion reflection is a conjugation by ``Q``, done with scipy's
``Rotation``. For a pair whose rest frames are Blender's mirror images (X mirrored, the
bone's Y along it and Z mirrored: ``R_b' = M R_b diag(-1, 1, 1)``), ``C = diag(-1, 1, 1)``,
``Q`` is a half turn about X, and the conjugation negates the quaternion's y and z
components: the usual trick. The formula needs no such symmetry of the rest frames (a
BVH import's rolls need not be mirror images): the bones' armature-space rotations are
the exact reflections whatever their rolls. Their positions are the exact reflections
when the rest skeleton is symmetric (a measured skeleton's bone lengths differ between
sides by millimetres; the feet's heel and toe points, which the analysis and the IK
read, are reflected exactly).

The mirrored bones' armature matrices are ``G'_b' = M G_b C``, so a point fixed in bone
``b``'s frame (a heel or toe point) is ``C^T`` of it in the mirrored bone's frame.
Mirroring twice gives the clip back (``C`` of the way back is ``C^T``).
"""

from __future__ import annotations

import re
from dataclasses import replace

import numpy as np
from scipy.spatial.transform import Rotation

from .analysis import ClipAnalysis
from .stances import Footprint
from .clip import ClipMotion
from ..base.errors import FootstepError
from .rig import Rig
from ..base.quat import rotations
from ..base.angles import wrap

#: The suffix of a mirrored clip's name ("run_jump" -> "run_jump~mirror").
SUFFIX = "~mirror"


class MirrorError(FootstepError):
    """A rig whose left and right bones cannot be paired; the message names the bones."""


def mirrored_name(name: str) -> str:
    """The mirror image's name: ``SUFFIX`` added, or taken off a mirror's name (so that
    mirroring twice gives the name back)."""
    return name[:-len(SUFFIX)] if name.endswith(SUFFIX) else name + SUFFIX


def is_mirror(name: str) -> bool:
    """True for the name of a mirror image (``mirrored_name``)."""
    return name.endswith(SUFFIX)


def _normal(forward, up=(0.0, 0.0, 1.0)) -> np.ndarray:
    """(3,) the unit normal ``forward x up`` of the sagittal plane (the character's right);
    ``forward`` (2,) or (3,)."""
    f = np.zeros(3)
    f[:len(forward)] = np.asarray(forward, float)[:3]
    n = np.cross(f, np.asarray(up, float))
    norm = np.linalg.norm(n)
    if norm < 1e-9:
        raise MirrorError("the rest forward is parallel to up: the sagittal plane is undefined")
    return n / norm


def reflection(forward, up=(0.0, 0.0, 1.0)) -> np.ndarray:
    """(3, 3) the reflection ``I - 2 n n^T`` across the plane spanned by ``forward``
    ((2,) or (3,), the rest forward) and ``up`` (3,): ``n`` is their unit cross
    product (the character's right)."""
    n = _normal(forward, up)
    return np.eye(3) - 2.0 * np.outer(n, n)


# ----------------------------------------------------------------------------- the rig

_WORD = {"left": "right", "right": "left", "Left": "Right", "Right": "Left",
         "LEFT": "RIGHT", "RIGHT": "LEFT"}
_LETTER = {"L": "R", "R": "L", "l": "r", "r": "l"}
# side words anywhere; single side letters between separators (or the ends); a capital
# side letter glued to a capitalised word at the start of a name or after a namespace
# ("LHipJoint", "mixamorig:LeftArm", "RThumb"); a small one glued the same way ("lThigh")
_RULES = (
    re.compile(r"(Left|Right|left|right|LEFT|RIGHT)"),
    re.compile(r"(?:^|(?<=[._\-: |]))([LlRr])(?=$|[._\-: |])"),
    re.compile(r"(?:^|(?<=[:|]))([LRlr])(?=[A-Z][a-z])"),
)


def _swapped_names(name: str) -> list[str]:
    """Candidate names of ``name``'s other side: each rule's side tokens swapped."""
    out = []
    for rule in _RULES:
        other = rule.sub(lambda m: _WORD.get(m.group(1)) or _LETTER[m.group(1)], name)
        if other != name:
            out.append(other)
    return out


def bone_mirror(rig: Rig, tolerance: float = 0.05) -> np.ndarray:
    """(B,) int: the index of each bone's mirror image (its own index on the centre line):
    the leg roles' pairs, then names with their side swapped (``thigh.L``/``thigh.R``,
    ``LeftArm``/``RightArm``, ``LHipJoint``/``RHipJoint``), then, for bones the names do
    not pair, the bone whose rest head and tail are the reflection of this one's within
    ``tolerance`` of the rig's height. MirrorError naming the bones when the pairing is
    not a symmetric one-to-one map that keeps the hierarchy (a bone's mirror's parent is
    its parent's mirror)."""
    names = list(rig.names)
    index = {nm: i for i, nm in enumerate(names)}
    nb = len(names)
    perm = np.full(nb, -1, np.int64)

    def pair(a: int, b: int) -> None:
        if perm[a] in (-1, b) and perm[b] in (-1, a):
            perm[a], perm[b] = b, a

    roles = rig.roles.roles
    for part in ("thigh", "shin", "foot", "toe"):
        if f"{part}_l" in roles and f"{part}_r" in roles:
            pair(index[roles[f"{part}_l"]], index[roles[f"{part}_r"]])
    for role in ("hips", "spine", "root"):
        if role in roles:
            pair(index[roles[role]], index[roles[role]])
    for i, nm in enumerate(names):
        if perm[i] >= 0:
            continue
        for other in _swapped_names(nm):
            j = index.get(other)
            if j is not None and perm[j] < 0:
                pair(i, j)
                break
    # the rest by geometry: reflected head and tail (a bone alone on the centre line
    # is its own mirror)
    M = reflection(rig.forward_axis())
    o = rig.rest[rig.role_index("hips"), :3, 3]
    heads, tails = rig.rest[:, :3, 3], rig.tails
    size = max(float(np.ptp(np.concatenate([heads, tails])[:, 2])), 1e-6)
    refl = lambda p: (p - o) @ M.T + o  # noqa: E731
    for i in np.flatnonzero(perm < 0):
        if perm[i] >= 0:
            continue
        free = np.flatnonzero(perm < 0)
        d = (np.linalg.norm(heads[free] - refl(heads[i]), axis=1)
             + np.linalg.norm(tails[free] - refl(tails[i]), axis=1))
        j = int(free[np.argmin(d)])
        if d.min() <= 2 * tolerance * size:
            pair(int(i), j)
    bad = [names[i] for i in np.flatnonzero(perm < 0)]
    if bad:
        raise MirrorError(f"armature {rig.name!r}: no mirror image found for bone(s) {', '.join(bad)} "
                          "(neither a name with its side swapped nor a bone at the reflected place)")
    par = rig.parents
    wrong = [names[b] for b in range(nb)
             if (par[b] < 0) != (par[perm[b]] < 0) or (par[b] >= 0 and perm[par[b]] != par[perm[b]])]
    if wrong:
        raise MirrorError(f"armature {rig.name!r}: the left/right pairing of bone(s) {', '.join(wrong)} "
                          "does not keep the hierarchy (a bone's mirror image must hang from its "
                          "parent's mirror image)")
    return perm


def rest_reflections(rig: Rig, perm: np.ndarray, M: np.ndarray) -> np.ndarray:
    """(B, 3, 3) ``C`` per mirrored bone ``b'``: ``R_b^T M R_b'`` with ``b = perm[b']``,
    the rest orientations ``R`` taken as the nearest rotations of the rest matrices."""
    R = Rotation.from_matrix(rig.rest[:, :3, :3]).as_matrix()
    return np.einsum("bji,jk,bkl->bil", R[perm], M, R)


class Mirror:
    """A rig's mirror: the bone pairing, the reflection and the rest frames' ``C``;
    ``motion`` and ``analysis`` mirror a clip of that rig."""

    def __init__(self, rig: Rig, up=(0.0, 0.0, 1.0)):
        self.rig = rig
        self.perm = bone_mirror(rig)
        self.M = reflection(rig.forward_axis(), up)
        self.n = _normal(rig.forward_axis(), up)
        self.origin = rig.rest[rig.role_index("hips"), :3, 3].copy()
        self.C = rest_reflections(rig, self.perm, self.M)
        # Q = -C: the proper rotation that conjugates a basis into its mirror image
        self.Q = Rotation.from_matrix(-self.C)
        self.feet = [rig.foot_chain(side)[0] for side in ("l", "r")]

    # points and directions
    def point(self, p: np.ndarray) -> np.ndarray:
        """Points (..., 3) reflected across the sagittal plane through the rest hips:
        ``p - 2 ((p - o) . n) n``, which leaves the components along the plane exactly
        as they are where ``n`` is an axis (heights, and forward for a rig facing -Y)."""
        p = np.asarray(p, float)
        return p - 2.0 * ((p - self.origin) @ self.n)[..., None] * self.n

    def rotations(self, rot: np.ndarray) -> np.ndarray:
        """Pose basis rotations (N, B, 3, 3) of the rig -> those of the mirror image:
        bone ``b'`` turns by ``Q^T B_b Q`` (``b = perm[b']``), vectorised over frames."""
        rot = np.asarray(rot)
        n, nb = rot.shape[:2]
        src = rotations(rot[:, self.perm].reshape(-1, 3, 3))
        q = Rotation.from_quat(np.broadcast_to(self.Q.as_quat()[None], (n, nb, 4)).reshape(-1, 4))
        out = (q.inv() * src * q).as_matrix().reshape(n, nb, 3, 3)
        return out.astype(rot.dtype, copy=False)

    def hips_in_root(self, h: np.ndarray) -> np.ndarray:
        """(N, 4, 4) the hips' matrices in the root frame -> the mirror image's:
        ``diag(M, 1) H diag(C_hips, 1)`` (the root frame's own axes are the rest ones)."""
        hips = self.rig.role_index("hips")
        L = np.eye(4)
        L[:3, :3] = self.M
        R = np.eye(4)
        R[:3, :3] = self.C[hips]
        return L @ np.asarray(h, float) @ R

    def motion(self, m: ClipMotion, name: str | None = None) -> ClipMotion:
        """The mirror image of clip ``m`` (a clip of this rig), named ``name`` (default
        ``mirrored_name``): root and feet reflected, headings negated, the feet's points
        and the bones' rotations taken from the other side."""
        if m.local_rot is not None and m.local_rot.shape[1] != len(self.perm):
            raise MirrorError(f"clip {m.name!r} has {m.local_rot.shape[1]} bones, "
                              f"the rig {self.rig.name!r} {len(self.perm)}")
        fl, fr = self.feet
        c_feet = np.stack([self.C[fl], self.C[fr]])  # C of the mirrored left / right foot
        local = lambda p: np.concatenate(  # noqa: E731  (points in the other foot's frame)
            [np.einsum("kji,kj->ki", c_feet, p[::-1, :3]), p[::-1, 3:]], axis=1)
        return replace(
            m, name=name or mirrored_name(m.name),
            root_pos=self.point(m.root_pos), root_heading=-np.asarray(m.root_heading, float),
            hips_in_root=self.hips_in_root(m.hips_in_root),
            local_rot=None if m.local_rot is None else self.rotations(m.local_rot),
            heel=self.point(m.heel[::-1]), toe=self.point(m.toe[::-1]),
            heel_local=local(np.asarray(m.heel_local, float)),
            toe_local=local(np.asarray(m.toe_local, float)),
        )

    def footprint(self, f: Footprint) -> Footprint:
        """A footprint's mirror image: the other foot, reflected, its heading negated."""
        return Footprint(1 - f.foot, f.time, self.point(f.position), float(wrap(-f.heading)),
                         self.point(f.heel), self.point(f.toe), f.strike_part)

    def analysis(self, a: ClipAnalysis, name: str | None = None) -> ClipAnalysis:
        """The analysis of clip ``a``'s mirror image, from ``a``'s own (no clip is read
        again and nothing is made in Blender): the same events at the same times, each
        on the other foot; footprints and the root reflected; curvature negated. Named
        ``name`` (default ``mirrored_name``)."""
        name = name or mirrored_name(a.name)
        stances = [replace(st, foot=1 - st.foot, footprint=self.footprint(st.footprint))
                   for st in a.stances]
        # as the analysis orders them: by stance time, the left foot first at equal times
        stances.sort(key=lambda st: (st.stance, st.foot))
        return replace(
            a, name=name, tau=-a.tau, stances=stances, flights=list(a.flights),
            jump_flights=list(a.jump_flights), balance=a.balance[::-1].copy(),
            contact=a.contact[::-1].copy(),
            motion=None if a.motion is None else self.motion(a.motion, name))


def mirror_motion(m: ClipMotion, rig: Rig, name: str | None = None) -> ClipMotion:
    """``Mirror(rig).motion(m, name)``: clip ``m`` of ``rig`` mirrored."""
    return Mirror(rig).motion(m, name)


def mirror_analysis(a: ClipAnalysis, rig: Rig, name: str | None = None) -> ClipAnalysis:
    """``Mirror(rig).analysis(a, name)``: the analysis of clip ``a``'s mirror image."""
    return Mirror(rig).analysis(a, name)


def take_off_foot(a: ClipAnalysis) -> int | None:
    """The foot a jump clip takes off from (0 left, 1 right): that of its last footprint
    before its first jump's flight (the step ``core.steps`` gives the planner); None for
    a clip without a jump or without a footprint before it."""
    if not a.jump_flights:
        return None
    t0 = a.jump_flights[0][0]
    before = [f for f in a.footprints() if f.time < t0]
    return before[-1].foot if before else None


#: The special clips' kinds whose mirror images the planner may need: a jump takes off
#: from one foot, a start clip sets off with one, a stop clip arrives with one.
MIRRORED_KINDS = ("jump", "start", "stop")


def lead_foot(a: ClipAnalysis) -> int | None:
    """The foot a special clip leads with (0 left, 1 right): a jump's take-off foot
    (``take_off_foot``), a start clip's first to move (the foot whose stance from the
    clip's start lifts first), a stop clip's last to arrive (the foot whose stance to the
    clip's end lands last); None for any other clip or one without such stances."""
    if a.kind == "jump":
        return take_off_foot(a)
    if a.kind == "start":
        st = [x for x in a.stances if x.open_start]
        return min(st, key=lambda x: x.liftoff).foot if st else None
    if a.kind == "stop":
        st = [x for x in a.stances if x.open_end]
        return max(st, key=lambda x: x.strike).foot if st else None
    return None


def mirrored_jumps(analyses: list[ClipAnalysis], rig: Rig, kinds=("jump",)) -> list[ClipAnalysis]:
    """The mirror images the planner needs to jump from either foot (with ``kinds``
    MIRRORED_KINDS: also to set off and to arrive with either foot): of every clip of
    those kinds in ``analyses`` that leads with a foot (``lead_foot``) from which no clip
    of the same kind, entry and exit gaits leads the other way (a library that already
    jumps from both feet gets none). Mirrors of mirrors and clips whose mirror name is
    taken are left out."""
    jumps = [a for a in analyses if a.kind in kinds and lead_foot(a) is not None]
    feet: dict[tuple[str, str, str], set[int]] = {}
    for a in jumps:
        feet.setdefault((a.kind, a.entry_gait, a.exit_gait), set()).add(lead_foot(a))
    names = {a.name for a in analyses}
    todo = [a for a in jumps if len(feet[(a.kind, a.entry_gait, a.exit_gait)]) == 1
            and not is_mirror(a.name) and mirrored_name(a.name) not in names]
    if not todo:
        return []
    mirror = Mirror(rig)
    return [mirror.analysis(a) for a in todo]
