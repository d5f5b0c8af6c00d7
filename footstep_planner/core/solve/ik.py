"""Feet on the footprints (thesis 3.8): body offset, then each leg solved in closed form.

1. **Targets.** Every footprint is planted from its strike to its liftoff (from the
   synthesis). While planted, the foot keeps the clip's own roll (heel strike,
   flat, toe off) turned by one rotation per footprint that lays the clip's stance
   onto the footprint: its heading and the surface's normal (slopes). The pinned point
   is the heel or the toe, whichever is nearer the ground (Johansen), blended over
   ``balance_band`` so the switch is smooth; the other end follows the roll.
2. **Body offset** (3.8.1, ``offsets.py``): the body is pulled and turned so the pinned
   points reach their targets, and the offsets are spread over time by a multilevel
   B-spline, so the body anticipates each step.
3. **Reach.** Where a target is out of the leg's reach the hips are lowered (smoothly,
   ahead of time) instead of popping the knee straight, but on level ground at most
   ``HIPS_DROP_MAX`` (3 cm) below the clip's height with the body offset's own lowering
   counted (more where the ground under a planted foot lies below the clip's floor).
   Beyond that the planted foot rolls about its pinned point, the free end rising (the
   heel behind the body, the toe ahead), up to ``MAX_ROLL``; only what the roll cannot
   reach lowers the hips further (a foot that missed its footprint would slide).
4. **Swing.** Between two stances of a foot, the correction that put the foot on the
   first footprint (the ankle's offset and the foot's turn from the clip's own) eases
   into the one the next footprint needs (smoothstep): the foot leaves and lands on its
   footprints with the clip's own swing, never released or caught in a hurry. Over
   uneven ground its heel, ball and toe tip (``sole_points``) keep the clearance they
   have over the footprints' planes (the flat-ground swing laid on the slopes): where
   the ground rises above those planes (a hill between footprints, a slope steepening
   ahead, a step's edge) the ankle is lifted, ahead of time, never through the surface.
5. **Legs** (3.8.2): with the body fixed, the ankle goes to its target and the knee
   stays in the plane of the clip's own knee (the swivel closest to the clip: the only
   free variable, solved in closed form); the thigh and the shin turn by the least
   rotation, so their twist is the clip's; the knee bends only the clip's way and never
   past straight. The foot takes its target rotation.

Conventions: world Z up, metres, seconds; quaternions (x, y, z, w) (scipy); headings
are yaws about +Z relative to the world forward; ``spin`` is the world yaw of heading 0
minus the rig's rest forward's yaw, so the armature object's yaw is ``spin + heading``.
Arrays are per frame (F) and vectorized over frames.
"""

from __future__ import annotations

import time
from contextlib import contextmanager
from dataclasses import dataclass, field

import numpy as np
from scipy.ndimage import gaussian_filter1d, maximum_filter1d
from scipy.spatial.transform import Rotation

from ..clips.body import scaled_bases, scaled_points, scaled_rig
from .offsets import body_offsets, smooth_offsets
from ..clips.rig import Rig, forward_kinematics
from ..base.settings import Settings
from ..plan.surface import EDGE_STEP, largest_step_along

#: s: the finest level of the body's height offset (3.8.1) where the feet stand at
#: different heights (``_on_steps``): it changes between stances over about this long.
BODY_RISE_FINE = 0.25
#: m of height between a swing's footprints from which it is retimed as a stair step
#: (``_stair_swing``; a step's edge, ``surface.EDGE_STEP``), fully from STAIR_RISE.
CLIMB_MIN = EDGE_STEP
STAIR_RISE = 0.12
#: How far ahead (behind) of the swing's time its early (late) motion runs, at most 1
#: (monotone): see ``_stair_swing``.
STAIR_LEAD = 1.0
#: m a swinging foot keeps above the surface.
GROUND_MARGIN = 0.002
#: The leg is never stretched past this share of its length (a straight knee pops).
MAX_REACH = 0.995
#: A planted foot rolls (``MAX_ROLL``) to keep its leg within this share of its length:
#: a little short of ``MAX_REACH``, where the knee turns fastest for the reach it gives.
ROLL_REACH = 0.99
#: s either side of a frame whose planted ankle is out of reach over which the hips come
#: down (and go back up) smoothly.
REACH_EASE = 0.15
#: frames either side over which a swinging foot's lift over the surface comes and goes
#: (``lower_smoothly``), so it rises ahead of a step's edge ...
LIFT_EASE = 3
#: m per frame: ... but a foot leaving or reaching its footprint is lifted no faster.
LIFT_RATE = 0.02
#: s after a liftoff (and before a strike) over which every point of a swinging foot comes
#: to keep ``GROUND_MARGIN`` over the ground (near a footprint: its clearance over its plane).
LIFT_RAMP = 0.15
#: m the most a pivot step (a turn in place) lifts the foot over the way between its
#: footprints (``_low_swing``).
PIVOT_LIFT = 0.04
#: Shares of the way to its footprint a swinging foot is drawn where the ground would
#: lift it too fast next to one (``_kept_over_footprints``), tried in turn ...
HOME_SHARES = (0.25, 0.5, 0.75, 1.0)
#: ... and the share per frame that draw comes and goes at.
HOME_RATE = 0.34
#: Passes of that draw, each checking the eased draw of the one before.
HOME_PASSES = 3
#: m a swinging foot's heel, ball or toe tip may come nearer the surface than the
#: clearance it keeps before the foot is lifted (rounding, not a dip).
CLEARANCE_TOL = 0.001
#: m the hips may come down for reach on level ground (more only where the ground under a
#: planted foot lies below the clip's foot, and only when rolling the foot cannot reach).
HIPS_DROP_MAX = 0.03
#: rad, the most a planted foot rolls about its pinned heel or toe (the other end rising)
#: to reach a footprint the capped hips cannot.
MAX_ROLL = np.radians(25.0)
#: rad/s at most a planted foot's roll for reach comes and goes (a foot that flips onto its
#: ball in a frame pops).
ROLL_RATE = np.radians(180.0)
#: rad, the most a planted foot's toe is bent up beyond its clip's bend to keep its tip
#: out of the footprint.
MAX_TOE_BEND = np.radians(30.0)
#: rad/s at most that extra bend comes and goes (a toe that flicks pops).
TOE_BEND_RATE = np.radians(60.0)
#: The ankle target blends the heel- and the toe-pinned solutions while the heel and toe
#: heights differ by less than this share of ``Settings.balance_band``.
PIN_BAND_SHARE = 0.25
#: frames: a strike or liftoff this close to a frame counts as on it.
FRAME_EPS = 1e-6
#: Frames per second assumed for a single frame (no spacing to measure).
DEFAULT_FPS = 30.0

SIDES = ("l", "r")


@dataclass
class FootTargets:
    """Per foot and frame: IK weight, pinned point, ankle target and foot rotation."""

    weight: np.ndarray  # (2, F) 0 free .. 1 planted
    footprint: np.ndarray  # (2, F) int index of the footprint, -1 when free
    pin: np.ndarray  # (2, F, 3) world target of the pinned point (heel or toe)
    pin_local: np.ndarray  # (2, F, 3) the pinned point in the foot bone's frame
    foot_rot: np.ndarray  # (2, F, 3, 3) world target rotation of the foot bone
    ankle: np.ndarray  # (2, F, 3) world target of the foot bone's head


@dataclass
class IKResult:
    body_pos: np.ndarray  # (F, 3)
    body_heading: np.ndarray  # (F,)
    basis: np.ndarray  # (F, B, 4, 4) pose bases after IK
    targets: FootTargets
    hips_drop: np.ndarray  # (F,) m the hips were lowered to keep the legs in reach
    body_offset: tuple[np.ndarray, np.ndarray]  # (dp (F, 3), dpsi (F,)) from 3.8.1
    seconds: dict = field(default_factory=dict)

    @property
    def frames(self) -> int:
        return len(self.body_heading)


def body_frames(pos: np.ndarray, yaw: np.ndarray) -> np.ndarray:
    """(F, 4, 4) world matrices of the armature object: rotation about Z, translation."""
    c, s = np.cos(yaw), np.sin(yaw)
    m = np.tile(np.eye(4), (len(yaw), 1, 1))
    m[:, 0, 0], m[:, 0, 1], m[:, 1, 0], m[:, 1, 1] = c, -s, s, c
    m[:, :3, 3] = pos
    return m


def min_rotation(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(F, 3, 3) least rotations taking directions a (F, 3) onto b (F, 3)."""
    a = a / np.linalg.norm(a, axis=1, keepdims=True)
    b = b / np.linalg.norm(b, axis=1, keepdims=True)
    v = np.cross(a, b)
    c = np.einsum("fi,fi->f", a, b)
    k = np.zeros((len(a), 3, 3))
    k[:, 0, 1], k[:, 0, 2], k[:, 1, 0] = -v[:, 2], v[:, 1], v[:, 2]
    k[:, 1, 2], k[:, 2, 0], k[:, 2, 1] = -v[:, 0], -v[:, 1], v[:, 0]
    s2 = np.einsum("fi,fi->f", v, v)
    with np.errstate(invalid="ignore", divide="ignore"):
        f = np.where(s2 > 1e-18, (1 - c) / np.where(s2 > 1e-18, s2, 1.0), 0.5)
    r = np.eye(3)[None] + k + f[:, None, None] * (k @ k)
    # (nearly) opposite directions: half a turn about an axis perpendicular to a, then
    # the small rest of the way from -a to b
    opp = c < -1 + 1e-6
    if opp.any():
        axis = np.cross(a[opp], np.where(np.abs(a[opp, :1]) < 0.9, [[1.0, 0, 0]], [[0, 1.0, 0]]))
        half = Rotation.from_rotvec(np.pi * axis / np.linalg.norm(axis, axis=1, keepdims=True)).as_matrix()
        r[opp] = min_rotation(-a[opp], b[opp]) @ half
    return r


def _tilt(normal: np.ndarray) -> np.ndarray:
    """(N, 3, 3) least rotations taking +Z onto each surface normal."""
    up = np.tile([0.0, 0.0, 1.0], (len(normal), 1))
    return min_rotation(up, np.asarray(normal, float))


def smoothstep(u: np.ndarray) -> np.ndarray:
    u = np.clip(u, 0.0, 1.0)
    return u * u * (3.0 - 2.0 * u)


def planted_either_side(planted: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(prev, nxt) (F,) each frame's last planted frame at or before it (-1 before the
    first) and first at or after it (F after the last), of a foot ``planted`` (F,)."""
    F = len(planted)
    f = np.arange(F)
    return (np.maximum.accumulate(np.where(planted, f, -1)),
            np.minimum.accumulate(np.where(planted, f, F)[::-1])[::-1])


def swing_targets(planted: np.ndarray, A0: np.ndarray, R0: np.ndarray, ankle: np.ndarray,
                  rot: np.ndarray, ground_z=None) -> tuple[np.ndarray, np.ndarray]:
    """Ankle positions (F, 3) and foot rotations (F, 3, 3) for every frame of one foot:
    ``ankle``/``rot`` where ``planted``; elsewhere the clip's own (``A0``, ``R0``) plus a
    correction eased (smoothstep) from the last planted frame's to the next one's, held
    before the first and after the last planted frame."""
    F = len(planted)
    idx = np.flatnonzero(planted)
    if not len(idx):
        return A0.copy(), R0.copy()
    off = np.zeros((F, 3))
    turn = np.zeros((F, 3))
    off[idx] = ankle[idx] - A0[idx]
    # (rotations of rigid bones: no orthogonalisation, which costs an SVD a frame)
    turn[idx] = Rotation.from_matrix(rot[idx] @ np.transpose(R0[idx], (0, 2, 1)), assume_valid=True).as_rotvec()
    f = np.arange(F)
    prev, nxt = planted_either_side(planted)
    prev_c = np.where(prev < 0, nxt, prev)
    nxt_c = np.where(nxt >= F, prev, nxt)
    span = np.maximum(nxt_c - prev_c, 1)
    x = (f - prev_c) / span
    u = smoothstep(x)[:, None]
    o = (1 - u) * off[prev_c] + u * off[nxt_c]
    tv = (1 - u) * turn[prev_c] + u * turn[nxt_c]
    A = A0 + o
    R = Rotation.from_rotvec(tv).as_matrix() @ R0
    # (Easing the foot onto its footprint in world space over the last frames before a
    # strike, and off it after a liftoff, was tried: it holds the foot back while the
    # clip's foot rushes on, then lets it go faster than any clip: more pops, not fewer.)
    A[idx], R[idx] = ankle[idx], rot[idx]
    swing = ~planted & (prev >= 0) & (nxt < F)
    if swing.any() and ground_z is not None:
        # (only a swing between footprints more than CLIMB_MIN apart in height is retimed:
        # the others' ground is never asked)
        edge = np.zeros(F, bool)
        ask = swing & (np.abs(A[nxt_c, 2] - A[prev_c, 2]) > CLIMB_MIN)
        if ask.any():
            edge[ask] = _over_edge(A, prev_c[ask], nxt_c[ask], ground_z)
        A = _stair_swing(A, edge, prev_c, nxt_c, x)
    return A, R


def _over_edge(A: np.ndarray, a: np.ndarray, b: np.ndarray, ground_z) -> np.ndarray:
    """(n,) whether the ground from ankle target ``A[a]`` to ``A[b]`` (``a``, ``b`` (n,):
    a swinging frame's last and next planted frames) has a step's edge
    (``surface.largest_step_along``: a stair's nosing, a kerb; not a slope, nor a gap), by
    ``ground_z`` (points -> heights). Each swing's way is sampled once, however many
    frames it lasts, by its own length (``surface.largest_step_along``: a jump's long
    way does not make every step's dense)."""
    pairs, inv = np.unique(np.c_[a, b], axis=0, return_inverse=True)
    pa, pb = A[pairs[:, 0]], A[pairs[:, 1]]
    # (``ground_z`` looks 0.3 m up and down; no ground under a sample is no edge)
    edge = largest_step_along(ground_z, pa, pb, 0.5 * (pa[:, 2] + pb[:, 2]), missing=0.0) > CLIMB_MIN
    return edge[np.ravel(inv)]


def _stair_swing(A: np.ndarray, swing: np.ndarray, a: np.ndarray, b: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Ankle targets ``A`` (F, 3) retimed on swings between footprints at different
    heights (``swing`` (F,), from planted frame ``a`` to ``b``, ``x`` the share of the
    swing done): up a step the foot rises early and goes forward late, down one it goes
    forward early and comes down late, each along the path it had (the clip's swing):
    it clears the nosing it passes over instead of sweeping into the riser, or dropping
    off the edge, in the last frames. Fully so from STAIR_RISE m of height change,
    not at all under CLIMB_MIN."""
    F = len(A)
    dz = A[b, 2] - A[a, 2]
    w = np.clip((np.abs(dz) - CLIMB_MIN) / (STAIR_RISE - CLIMB_MIN), 0.0, 1.0) * swing
    if not w.any():
        return A
    # the shares of the swing done by the horizontal and the vertical motion: up, the
    # rise ahead (at the liftoff's own pace) and the way forward behind; down, the way
    # forward ahead and the drop behind (at the strike's own pace). Each leaves or
    # arrives at the clip's own pace: the way forward lagging to the strike (1.6 times
    # the clip's speed there) snapped CMU's knee straight stepping up onto a platform.
    up = dz > 0
    k, mid = STAIR_LEAD, x * (1.0 - x)
    h = np.where(up, x - k * (1.0 - x) * mid, x + k * x * mid)  # (at the strike's (up) or liftoff's (down) own pace)
    v = np.where(up, x + k * x * mid, x - k * (1.0 - x) * mid)
    span = b - a

    def at(share):  # A at the fractional frames a + share * span (linear between frames)
        f = np.clip(a + share * span, 0, F - 1)
        i = np.minimum(np.floor(f).astype(int), F - 2)
        t = (f - i)[:, None]
        return (1 - t) * A[i] + t * A[i + 1]

    h, v = at(h), at(v)
    # never past the footprint it goes to, nor back behind the one it leaves (a clip's
    # foot reaches out and settles back at the strike: on a stair, onto the next riser)
    d = A[b, :2] - A[a, :2]
    p = np.einsum("fi,fi->f", h[:, :2] - A[a, :2], d) / np.maximum(np.einsum("fi,fi->f", d, d), 1e-12)
    h[:, :2] -= (p - np.clip(p, 0.0, 1.0))[:, None] * d
    out = A.copy()
    out[:, :2] += w[:, None] * (h[:, :2] - A[:, :2])
    out[:, 2] += w * (v[:, 2] - A[:, 2])
    return out


def _frame_rate(t: np.ndarray) -> float:
    """Frames per second of the evenly spaced frame times ``t`` (F,) s; ``DEFAULT_FPS``
    for a single frame."""
    return 1.0 / (t[1] - t[0]) if len(t) > 1 else DEFAULT_FPS


def foot_targets(rig: Rig, heel_local: np.ndarray, toe_local: np.ndarray, world: np.ndarray,
                 t: np.ndarray, feet: np.ndarray, planted: list, pos: np.ndarray, heading: np.ndarray,
                 normal: np.ndarray, forward: np.ndarray, band: float) -> FootTargets:
    """The targets of both feet (see the module docstring). ``world`` (F, B, 4, 4) is the
    unadjusted pose in the world; ``heel_local``, ``toe_local`` (2, 4) each foot's heel and
    toe in its foot bone's frame (homogeneous); ``t`` (F,) the frame times, s; ``feet``
    (N,) the foot of each footprint; ``planted`` per footprint (strike, stance, liftoff) s;
    ``pos``, ``heading``, ``normal`` the footprints (N, 3) m, (N,) rad, (N, 3) unit;
    ``forward`` (2,) the world direction of heading 0; ``band`` m, the heel/toe balance
    band (``Settings.balance_band``)."""
    F = len(t)
    fps = _frame_rate(t)
    weight = np.zeros((2, F))
    index = np.full((2, F), -1)
    pin = np.zeros((2, F, 3))
    pin_local = np.zeros((2, F, 3))
    rot = np.zeros((2, F, 3, 3))
    ankle = np.zeros((2, F, 3))
    yaw_fp = np.asarray(heading) + np.arctan2(forward[1], forward[0])  # (N,) world yaw of each footprint
    tilt = _tilt(normal)
    for k, side in enumerate(SIDES):
        Wf = world[:, rig.foot_chain(side)[0]]
        rot[k] = Wf[:, :3, :3]
        heel_w = (Wf @ heel_local[k])[:, :3]  # the clip's heel and toe, world
        toe_w = (Wf @ toe_local[k])[:, :3]
        weight[k], index[k] = _planted_frames(np.asarray(feet) == k, planted, fps, F)
        on = np.flatnonzero(index[k] >= 0)
        if not len(on):
            continue
        j = index[k, on]  # the footprint of each planted frame
        heel_l, toe_l = heel_local[k, :3], toe_local[k, :3]
        rot[k, on] = _laid_on_footprints(rot[k, on], toe_w[on] - heel_w[on], j, yaw_fp, tilt)
        heel_t, toe_t = _footprint_ends(j, pos, yaw_fp, tilt, heel_l, toe_l)
        ankle[k, on], pin[k, on], pin_local[k, on] = _pinned(heel_w[on, 2] - toe_w[on, 2], band, rot[k, on],
                                                             heel_t[j], toe_t[j], heel_l, toe_l)
    return FootTargets(weight, index, pin, pin_local, rot, ankle)


def _planted_frames(mine: np.ndarray, planted: list, fps: float, F: int) -> tuple[np.ndarray, np.ndarray]:
    """Whose footprint each frame of one foot belongs to: ((F,) weight, 1.0 from strike to
    liftoff of one of its footprints, else 0.0; (F,) int index of that footprint, -1 when
    none). ``mine`` (N,) bool marks the foot's footprints; ``planted`` per footprint
    (strike, stance, liftoff) s; frames at ``fps``, the strike's frame rounded up and the
    liftoff's down (within ``FRAME_EPS`` of a frame counts as on it). A later footprint
    overrides an earlier one where their ranges meet."""
    weight = np.zeros(F)
    index = np.full(F, -1)
    for j in np.flatnonzero(mine):
        strike, _, liftoff = planted[j]
        fr = np.arange(max(0, int(np.ceil(strike * fps - FRAME_EPS))),
                       min(F, int(np.floor(liftoff * fps + FRAME_EPS)) + 1))
        weight[fr] = 1.0
        index[fr] = j
    return weight, index


def _laid_on_footprints(rot: np.ndarray, heel_to_toe: np.ndarray, j: np.ndarray, yaw_fp: np.ndarray,
                        tilt: np.ndarray) -> np.ndarray:
    """(n, 3, 3) world rotations of a planted foot at n frames: the clip's own ``rot``
    (n, 3, 3) keeps its pitch and roll (heel strike, flat, toe off), but its heading is
    footprint ``j``'s (n,) for the whole stance (a planted foot does not turn with the
    body) and it is tilted onto the surface: tilt_j Rz(yaw_fp_j - yaw(f)) R0(f), where
    yaw(f) is the world yaw (rad) of the clip's heel-to-toe vector ``heel_to_toe`` (n, 3),
    ``yaw_fp`` (N,) the footprints' world yaws and ``tilt`` (N, 3, 3) +Z onto their normals."""
    yaw_now = np.arctan2(heel_to_toe[:, 1], heel_to_toe[:, 0])
    turn = Rotation.from_euler("z", (yaw_fp[j] - yaw_now)[:, None]).as_matrix()
    return tilt[j] @ turn @ rot


def _footprint_ends(j: np.ndarray, pos: np.ndarray, yaw_fp: np.ndarray, tilt: np.ndarray,
                    heel_local: np.ndarray, toe_local: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """World heel and toe targets (N, 3) of the footprints among ``j`` (rows of the
    others are zero): half the foot's length (heel to toe, from ``heel_local``,
    ``toe_local`` (3,) in the foot bone's frame) behind and ahead of each footprint's
    centre ``pos`` (N, 3) m, along its world yaw ``yaw_fp`` (N,) rad, tilted by ``tilt``
    (N, 3, 3) onto the surface."""
    length = float(np.linalg.norm(toe_local - heel_local))
    js = np.unique(j)
    yaw = yaw_fp[js]
    u = tilt[js] @ np.c_[np.cos(yaw), np.sin(yaw), np.zeros(len(js))][..., None]
    heel_t = np.zeros((len(pos), 3))
    toe_t = np.zeros((len(pos), 3))
    heel_t[js] = pos[js] - 0.5 * length * u[..., 0]
    toe_t[js] = pos[js] + 0.5 * length * u[..., 0]
    return heel_t, toe_t


def _pinned(heel_above_toe: np.ndarray, band: float, rot: np.ndarray, heel_t: np.ndarray,
            toe_t: np.ndarray, heel_local: np.ndarray, toe_local: np.ndarray
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Johansen: the pinned point is the heel or the toe, whichever is lower. At n planted
    frames, from the clip's heel height over its toe ``heel_above_toe`` (n,) m, the foot's
    target rotation ``rot`` (n, 3, 3) and the footprint's heel and toe ``heel_t``, ``toe_t``
    (n, 3): the ankle target (n, 3), the pinned point's target (n, 3) and the pinned
    point in the foot bone's frame (n, 3) (of ``heel_local``, ``toe_local`` (3,)).

    The ankle target blends the heel-pinned and the toe-pinned solutions while their
    heights differ by less than a quarter of ``band`` (m): the two agree while the foot
    lies flat, and a blend over a wider band slides the pinned end (a 10 degree roll puts
    the two solutions 3 cm apart)."""
    bal = np.clip(heel_above_toe / max(PIN_BAND_SHARE * band, 1e-6) + 0.5, 0.0, 1.0)[:, None]
    a_heel = heel_t - np.einsum("fij,j->fi", rot, heel_local)
    a_toe = toe_t - np.einsum("fij,j->fi", rot, toe_local)
    toe_down = bal[:, 0] > 0.5
    return ((1 - bal) * a_heel + bal * a_toe, np.where(toe_down[:, None], toe_t, heel_t),
            np.where(toe_down[:, None], toe_local, heel_local))


@dataclass(frozen=True)
class _Legs:
    """The leg bones of a rig, per side (0 left, 1 right): indices and rest lengths (m)."""

    thigh: tuple[int, int]
    shin: tuple[int, int]
    foot: tuple[int, int]
    thigh_len: tuple[float, float]  # hip to knee
    shin_len: tuple[float, float]  # knee to ankle
    chain: list  # every leg bone's index, sorted
    toe_bones: tuple = ()  # the toe bones the rig has

    @classmethod
    def of(cls, rig: Rig) -> "_Legs":
        thigh = tuple(rig.role_index(f"thigh_{x}") for x in SIDES)
        shin = tuple(rig.role_index(f"shin_{x}") for x in SIDES)
        foot = tuple(rig.foot_chain(x)[0] for x in SIDES)
        toes = tuple(b for b in (rig.foot_chain(x)[1] for x in SIDES) if b is not None)
        L1, L2 = zip(*(leg_lengths(rig, x) for x in SIDES))
        return cls(thigh, shin, foot, L1, L2, sorted(set(thigh) | set(shin) | set(foot)), toes)


@contextmanager
def _timed(seconds: dict, stage: str):
    """Add the wall-clock seconds the block takes to ``seconds[stage]``."""
    t0 = time.perf_counter()
    yield
    seconds[stage] = seconds.get(stage, 0.0) + time.perf_counter() - t0


def solve_ik(rig: Rig, basis: np.ndarray, t: np.ndarray, body_pos: np.ndarray, body_heading: np.ndarray,
             spin: float, heel_local: np.ndarray, toe_local: np.ndarray, feet: np.ndarray, planted: list,
             fp_pos: np.ndarray, fp_heading: np.ndarray, fp_normal: np.ndarray, forward: np.ndarray,
             settings: Settings | None = None, ground_z=None, still: np.ndarray | None = None) -> IKResult:
    """Thesis 3.8 on a synthesized motion. ``basis`` (F, B, 4, 4) the blended pose
    (``pose.pose_bases``), the body on (body_pos, body_heading); the footprints and their
    planted ranges from the synthesis. ``ground_z(points (M, 3)) -> heights (M,)`` (NaN
    where there is no surface) lets a swinging foot clear the ground: where the heel or
    the toe would pass under the surface, the ankle is lifted by that much. ``still``
    (F,) 0..1: how far the body keeps its place over the ground where the synthesis put
    it, the body offset moving it only up and down there (a turn in place: the legs
    reach the pivot steps, the body stays over its spot).
    Returns the adjusted body and pose bases.

    A character of another size than a human's (``Settings.body_scale``) is solved at a
    human's size (every length it is given divided by its scale, this module's own
    lengths as they are) and the result scaled back."""
    settings = settings or Settings()
    k = settings.body_scale
    if abs(k - 1.0) > 1e-12:
        return _solved_at_human_size(k, rig, basis, t, body_pos, body_heading, spin, heel_local, toe_local, feet,
                                     planted, fp_pos, fp_heading, fp_normal, forward, settings, ground_z, still)
    sec = {}
    t0 = time.perf_counter()
    with _timed(sec, "targets"):
        legs = _Legs.of(rig)
        pose = forward_kinematics(rig, basis, bones=list(legs.foot) + list(legs.toe_bones))
        yaw = spin + np.asarray(body_heading, float)
        tg = foot_targets(rig, heel_local, toe_local, _legs_in_world(pose, legs, body_pos, yaw), t,
                          np.asarray(feet), planted, fp_pos, np.asarray(fp_heading, float), fp_normal, forward,
                          settings.balance_band)
        sole = [sole_points(rig, pose, SIDES[k], heel_local[k, :3], toe_local[k, :3]) for k in range(2)]
    with _timed(sec, "body_offset"):  # 3.8.1
        body_pos, yaw, offset = _offset_body(pose, legs, tg, t, body_pos, yaw, settings, still)
        world = _legs_in_world(pose, legs, body_pos, yaw)
    with _timed(sec, "reach"):
        budget = _drop_budget(np.asarray(body_pos, float)[:, 2] - offset[0][:, 2], tg, offset[0][:, 2],
                              _frame_rate(t))
        drop = _reach_drop(world, legs, tg, _frame_rate(t), budget, heel_local[:, :3], toe_local[:, :3])
        body_pos = body_pos - drop[:, None] * [0.0, 0.0, 1.0]
        world[:, legs.chain, 2, 3] -= drop[:, None]
    with _timed(sec, "legs"):  # 3.8.2
        planes = [_swing_planes(tg.footprint[k], np.asarray(fp_pos, float), np.asarray(fp_normal, float))
                  for k in range(2)]
        ankle_t, rot_t = _all_frame_targets(world, legs, tg, ground_z)
        if still is not None:
            ankle_t = np.stack([_low_swing(ankle_t[k], tg.weight[k] >= 1.0, still) for k in range(2)])
        need = [None, None]
        for k in range(2):
            ankle_t[k], rot_t[k], need[k] = _kept_over_footprints_need(
                ankle_t[k], rot_t[k], tg.weight[k] >= 1.0, sole[k], planes[k], ground_z, _frame_rate(t),
                world[:, legs.thigh[k], :3, 3], MAX_REACH * (legs.thigh_len[k] + legs.shin_len[k]))
        lift = [_ground_lift(ankle_t[k], rot_t[k], tg.weight[k] >= 1.0, sole[k], planes[k], ground_z, _frame_rate(t),
                             need[k]) for k in range(2)]
        for k in range(2):
            ankle_t[k] = _swing_within_reach(ankle_t[k], lift[k], tg.weight[k] < 1.0, world[:, legs.thigh[k], :3, 3],
                                             legs.thigh_len[k] + legs.shin_len[k], _frame_rate(t))
        bend = [toe_bend(ankle_t[k] + lift[k][:, None] * [0.0, 0.0, 1.0], rot_t[k], tg.weight[k] >= 1.0,
                         sole[k][2], toe_local[k, :3], planes[k], _frame_rate(t)) for k in range(2)]
        for k in range(2):  # (a foot without a toe bone stands on its tip: lifted, not bent)
            if rig.foot_chain(SIDES[k])[1] is None:
                lift[k] = _tip_lift(ankle_t[k], lift[k], rot_t[k], tg.weight[k] >= 1.0, sole[k][2], planes[k],
                                    _frame_rate(t))
        basis = _solve_legs(rig, basis, pose, world, legs, ankle_t, rot_t, lift, yaw,
                            (bend, toe_local[:, :3] - heel_local[:, :3]))
    sec["total"] = time.perf_counter() - t0
    return IKResult(body_pos, yaw - spin, basis, tg, drop, offset, sec)


def _solved_at_human_size(k: float, rig: Rig, basis, t, body_pos, body_heading, spin, heel_local, toe_local, feet,
                          planted, fp_pos, fp_heading, fp_normal, forward, settings: Settings, ground_z,
                          still) -> IKResult:
    """``solve_ik`` of a character ``k`` times a human's size: solved on everything divided
    by ``k`` (the settings at a human's size), its lengths multiplied back."""
    inv = 1.0 / k
    gz = None if ground_z is None else (lambda p: np.asarray(ground_z(np.asarray(p, float) * k), float) * inv)
    r = solve_ik(scaled_rig(rig, inv), scaled_bases(basis, inv), t, np.asarray(body_pos, float) * inv, body_heading,
                 spin, scaled_points(heel_local, inv), scaled_points(toe_local, inv), feet, planted,
                 np.asarray(fp_pos, float) * inv, fp_heading, fp_normal, forward, settings.for_body(1.0), gz, still)
    tg = r.targets
    targets = FootTargets(tg.weight, tg.footprint, tg.pin * k, tg.pin_local * k, tg.foot_rot, tg.ankle * k)
    dp, dpsi = r.body_offset
    return IKResult(r.body_pos * k, r.body_heading, scaled_bases(r.basis, k), targets, r.hips_drop * k,
                    (dp * k, dpsi), r.seconds)


#: A swinging foot's ankle is kept within this share of its leg's length of the hip: a
#: target further out (a foot reaching up a flight ahead of the body, a long leg's lift
#: over a riser) is drawn in towards the hip, eased over REACH_EASE s, so the knee bends
#: on as the clip bends it instead of locking straight and snapping when the target comes
#: back in reach.
SWING_REACH = 0.99


def _swing_within_reach(ankle: np.ndarray, lift: np.ndarray, free: np.ndarray, hip: np.ndarray, length: float,
                        fps: float) -> np.ndarray:
    """``ankle`` (F, 3) targets (raised by ``lift`` (F,) when solved) with the ``free``
    (F,) bool (swinging) frames' drawn in towards ``hip`` (F, 3) as far as they lie beyond
    SWING_REACH of the leg's ``length``, that pull eased over REACH_EASE s (never on a
    planted frame)."""
    a = ankle + lift[:, None] * [0.0, 0.0, 1.0]
    v = a - hip
    d = np.linalg.norm(v, axis=1)
    need = np.where(free, d - SWING_REACH * length, 0.0)
    if not (need > 0).any():
        return ankle
    pull = np.where(free, lower_smoothly(np.maximum(need, 0.0), max(1, int(round(REACH_EASE * fps)))), 0.0)
    pull = np.minimum(pull, np.maximum(d - 0.5 * length, 0.0))
    return ankle - (pull / np.maximum(d, 1e-9))[:, None] * v


def _legs_in_world(pose: np.ndarray, legs: _Legs, pos: np.ndarray, yaw: np.ndarray) -> np.ndarray:
    """World matrices (F, b, 4, 4) of the leg bones (``legs.chain``; the other entries are
    not set; b: up to the last leg bone, not every bone, so a long path's world is no
    larger than it needs) from their armature-space matrices ``pose`` (F, B, 4, 4), the
    armature object at ``pos`` (F, 3) m turned by ``yaw`` (F,) rad about +Z."""
    w = np.empty((len(pose), max(legs.chain) + 1, 4, 4))
    w[:, legs.chain] = body_frames(pos, yaw)[:, None] @ pose[:, legs.chain]
    return w


def _offset_body(pose: np.ndarray, legs: _Legs, tg: FootTargets, t: np.ndarray, body_pos: np.ndarray,
                 yaw: np.ndarray, settings: Settings, still: np.ndarray | None = None):
    """Thesis 3.8.1: the body (object position ``body_pos`` (F, 3) m, world yaw ``yaw``
    (F,) rad) pulled and turned so the pinned points (where fully planted) reach their
    targets, the offsets spread over time (``offsets.smooth_offsets``; zero when no frame
    is planted; held over its place as far as ``still`` (F,)). ``pose`` (F, B, 4, 4)
    armature space, ``t`` (F,) s. Returns (body
    position (F, 3), yaw (F,), (dp (F, 3), dpsi (F,)))."""
    F = len(t)
    # the pinned points in armature space: that is the body frame turned by the object's
    # yaw, so it is p_loc in a frame turned by the body heading's world yaw
    p_loc = np.zeros((2, F, 3))
    for k in range(2):
        p_loc[k] = (pose[:, legs.foot[k]] @ np.c_[tg.pin_local[k], np.ones(F)][..., None])[:, :3, 0]
    planted_mask = tg.weight >= 1.0 - 1e-9
    dp, dpsi = body_offsets(np.asarray(body_pos, float), yaw, p_loc, tg.pin, planted_mask,
                            alpha=settings.ik_alpha, beta=settings.ik_beta, iterations=settings.ik_iterations)
    if np.isfinite(dpsi).any():
        raw = dp
        dp, dpsi = smooth_offsets(t, dp, dpsi)
        # where the feet stand at different heights (stairs, a kerb) the height offset on
        # a coarser finest level: the stances' offsets differ by centimetres, fitted two
        # frames apart the body jolts (elsewhere, a take-off's push needs the fine fit)
        w = _on_steps(tg, _frame_rate(t))
        if w.any():
            coarse = smooth_offsets(t, raw, np.where(np.isfinite(raw).all(axis=1), 0.0, np.nan),
                                    fine=BODY_RISE_FINE)[0][:, 2]
            dp[:, 2] += w * (coarse - dp[:, 2])
    else:
        dp, dpsi = np.zeros((F, 3)), np.zeros(F)
    if still is not None:  # (held over its place as far as ``still``: up and down only)
        dp[:, :2] *= 1.0 - np.clip(np.asarray(still, float), 0.0, 1.0)[:, None]
    return np.asarray(body_pos, float) + dp, yaw + dpsi, (dp, dpsi)


def _on_steps(tg: FootTargets, fps: float) -> np.ndarray:
    """(F,) 0..1: how far each frame lies where the two feet's last footprints differ in
    height by more than CLIMB_MIN (on stairs, at a kerb), eased over BODY_RISE_FINE."""
    F = tg.weight.shape[1]
    z = np.zeros((2, F))
    for k in range(2):
        on = tg.weight[k] >= 1.0 - 1e-9
        if not on.any():
            return np.zeros(F)
        last = planted_either_side(on)[0]
        last = np.where(last < 0, np.flatnonzero(on)[0], last)
        z[k] = tg.pin[k, last, 2]
    win = max(1, int(round(BODY_RISE_FINE * fps)))
    step = (np.abs(z[0] - z[1]) > CLIMB_MIN).astype(float)
    return np.clip(gaussian_filter1d(maximum_filter1d(step, 2 * win + 1), win / 2.0), 0.0, 1.0)


def _drop_budget(floor_z: np.ndarray, tg: FootTargets, dp_z: np.ndarray, fps: float) -> np.ndarray:
    """(F,) m the hips may still come down for reach: ``HIPS_DROP_MAX`` below the clip's
    height, plus how far a planted foot's pinned point lies below the clip's floor
    ``floor_z`` (F,) m (the body's height before the offset: the ground drops there), less
    what the body offset ``dp_z`` (F,) m already lowered; eased like the drop."""
    low = np.zeros(len(floor_z))
    for k in range(2):
        low = np.maximum(low, np.where(tg.weight[k] >= 1.0, np.maximum(floor_z - tg.pin[k, :, 2], 0.0), 0.0))
    low = lower_smoothly(low, max(1, int(round(REACH_EASE * fps))))
    return np.maximum(HIPS_DROP_MAX + low + np.asarray(dp_z, float), 0.0)


def _reach_needs(world: np.ndarray, legs: _Legs, tg: FootTargets, drop: np.ndarray) -> np.ndarray:
    """(2, F) m the hips (in ``world``, then lowered by ``drop`` (F,)) must still come down
    for each planted ankle target to lie within ``MAX_REACH`` of its leg; 0 where free."""
    need = np.zeros((2, len(world)))
    for k in range(2):
        hip = world[:, legs.thigh[k], :3, 3] - drop[:, None] * [0.0, 0.0, 1.0]
        n = reach_need(hip, tg.ankle[k], MAX_REACH * (legs.thigh_len[k] + legs.shin_len[k]))
        need[k] = np.where(tg.weight[k] >= 1.0, np.maximum(n, 0.0), 0.0)
    return need


def _reach_drop(world: np.ndarray, legs: _Legs, tg: FootTargets, fps: float, budget: np.ndarray | None = None,
                heel_local: np.ndarray | None = None, toe_local: np.ndarray | None = None) -> np.ndarray:
    """(F,) m to lower the hips (smoothly, over ``REACH_EASE`` s either side, ahead of
    time) where a planted ankle target is beyond ``MAX_REACH`` of its leg's length from
    the hip joint in ``world`` (F, B, 4, 4). With a ``budget`` (F,) m the hips come down
    at most that far; a planted foot then rolls about its pinned heel or toe to keep its
    leg within ``ROLL_REACH`` (``roll_to_reach``, with ``heel_local``/``toe_local`` (2, 3):
    ``tg``'s ankle targets and foot rotations change in place) and the hips come down
    further only for what the roll cannot reach."""
    win = max(1, int(round(REACH_EASE * fps)))
    drop = lower_smoothly(_reach_needs(world, legs, tg, np.zeros(len(world))).max(axis=0), win)
    if budget is None:
        return drop
    drop = np.minimum(drop, budget)
    for k in range(2):
        hip = world[:, legs.thigh[k], :3, 3] - drop[:, None] * [0.0, 0.0, 1.0]
        toe_pinned = np.all(np.isclose(tg.pin_local[k], toe_local[k]), axis=1)
        tg.ankle[k], tg.foot_rot[k] = roll_to_reach(hip, tg.ankle[k], tg.foot_rot[k], tg.pin[k], toe_pinned,
                                                    tg.weight[k] >= 1.0, toe_local[k] - heel_local[k],
                                                    ROLL_REACH * (legs.thigh_len[k] + legs.shin_len[k]),
                                                    ROLL_RATE / fps)
    rest = _reach_needs(world, legs, tg, drop).max(axis=0)
    return drop + (lower_smoothly(rest, win) if rest.max() > 1e-6 else 0.0)


def roll_to_reach(hip: np.ndarray, ankle: np.ndarray, rot: np.ndarray, pin: np.ndarray, toe_pinned: np.ndarray,
                  planted: np.ndarray, heel_to_toe: np.ndarray, reach: float, rate: float | None = None
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Copies of one foot's ankle targets ``ankle`` (F, 3) and rotations ``rot`` (F, 3, 3),
    rolled where ``planted`` (F,) and the ankle is beyond ``reach`` (m) of ``hip`` (F, 3):
    about the pinned point ``pin`` (F, 3) and the foot's lateral axis, the free end rising
    (the heel when ``toe_pinned`` (F,), else the toe), by the least angle that brings the
    ankle within reach, at most ``MAX_ROLL`` (the pinned point stays put, so the foot does
    not slide). ``heel_to_toe`` (3,) in the foot bone's frame is the foot's length axis.
    Closed form: with the lever a = ankle - pin, d = pin - hip and Rodrigues' rotation
    about k, |d + R a|^2 = |d|^2 + |a|^2 + 2 (A cos phi + B sin phi + C).
    With ``rate`` (rad per frame) the roll comes and goes no faster (``ease_peaks``, over
    the planted frames about those that need it: the free end starts rising early)."""
    ankle, rot = ankle.copy(), rot.copy()
    idx = np.flatnonzero(planted & (np.linalg.norm(ankle - hip, axis=1) > reach + 1e-9))
    if not len(idx):
        return ankle, rot
    phi, better = _roll_angles(hip, ankle, rot, pin, toe_pinned, heel_to_toe, reach, idx)
    if rate is not None:
        roll = np.zeros(len(ankle))
        roll[idx[better]] = phi[better]
        roll = ease_peaks(np.maximum(roll, 0.0), rate) - ease_peaks(np.maximum(-roll, 0.0), rate)
        idx = np.flatnonzero(planted & (roll != 0.0))
        phi, better = roll[idx], np.ones(len(idx), bool)
    k = _roll_axis(rot[idx], heel_to_toe)
    R = Rotation.from_rotvec(k * phi[:, None]).as_matrix()
    new = pin[idx] + np.einsum("fij,fj->fi", R, ankle[idx] - pin[idx])
    ankle[idx] = np.where(better[:, None], new, ankle[idx])
    rot[idx] = np.where(better[:, None, None], R @ rot[idx], rot[idx])
    return ankle, rot


def _roll_axis(rot: np.ndarray, heel_to_toe: np.ndarray) -> np.ndarray:
    """(n, 3) the level axis across each foot (rotations ``rot`` (n, 3, 3), length axis
    ``heel_to_toe`` (3,) in the foot bone's frame) that a roll turns it about."""
    k = np.cross(np.einsum("fij,j->fi", rot, heel_to_toe), [0.0, 0.0, 1.0])
    return k / np.maximum(np.linalg.norm(k, axis=1, keepdims=True), 1e-12)


def _roll_angles(hip, ankle, rot, pin, toe_pinned, heel_to_toe, reach, idx) -> tuple[np.ndarray, np.ndarray]:
    """(phi (n,) rad, better (n,) bool) at the frames ``idx``: the least roll (signed about
    ``_roll_axis``, at most MAX_ROLL) that brings the ankle within ``reach`` of the hip
    (``roll_to_reach``), and whether it brings it nearer at all."""
    pivot = pin[idx]
    a, d = ankle[idx] - pivot, pivot - hip[idx]
    k = _roll_axis(rot[idx], heel_to_toe)
    ka = np.einsum("fi,fi->f", k, a)
    A = np.einsum("fi,fi->f", d, a - k * ka[:, None])
    B = np.einsum("fi,fi->f", d, np.cross(k, a))
    dot = lambda x, y: np.einsum("fi,fi->f", x, y)  # noqa: E731
    D = 0.5 * (reach ** 2 - dot(d, d) - dot(a, a)) - dot(d, k) * ka
    c = np.arccos(np.clip(D / np.maximum(np.hypot(A, B), 1e-12), -1.0, 1.0))
    cand = np.angle(np.exp(1j * (np.arctan2(B, A)[None] + np.array([[1.0], [-1.0]]) * c[None])))
    sign = np.where(toe_pinned[idx], -1.0, 1.0)
    mag = np.where(sign[None] * cand >= 0, np.abs(cand), np.inf).min(axis=0)
    phi = sign * np.minimum(mag, MAX_ROLL)
    new = pivot + np.einsum("fij,fj->fi", Rotation.from_rotvec(k * phi[:, None]).as_matrix(), a)
    return phi, np.linalg.norm(new - hip[idx], axis=1) < np.linalg.norm(ankle[idx] - hip[idx], axis=1)


def _all_frame_targets(world: np.ndarray, legs: _Legs, tg: FootTargets, ground_z=None
                       ) -> tuple[np.ndarray, np.ndarray]:
    """Every frame's ankle targets (2, F, 3) and foot rotations (2, F, 3, 3), world: on the
    footprint while planted, the clip's own swing (the foot bones in ``world``) plus a
    correction easing from one footprint's to the next's in between (``swing_targets``;
    ``ground_z`` finds the swings up or down a step)."""
    F = len(world)
    ankle_t = np.zeros((2, F, 3))
    rot_t = np.zeros((2, F, 3, 3))
    for k in range(2):
        Wf = world[:, legs.foot[k]]
        ankle_t[k], rot_t[k] = swing_targets(tg.weight[k] >= 1.0, Wf[:, :3, 3], Wf[:, :3, :3], tg.ankle[k],
                                             tg.foot_rot[k], ground_z)
    return ankle_t, rot_t


def sole_points(rig: Rig, pose: np.ndarray, side: str, heel_local: np.ndarray, toe_local: np.ndarray) -> list:
    """The points of one foot that must clear the ground while it swings, each as ((F, 3)
    in the foot bone's frame, (F,) m its height over the floor in the clip: its clearance
    on flat ground): its heel and ball (``heel_local``/``toe_local`` (3,), on the sole)
    and its toe tip (``toe_tip``), in ``pose`` (F, B, 4, 4, armature space, the clip's
    floor at z = 0)."""
    foot, toe = rig.foot_chain(side)
    F = len(pose)
    locs = [np.broadcast_to(heel_local, (F, 3)), np.broadcast_to(toe_local, (F, 3)),
            toe_tip(rig, side, pose[:, foot], pose[:, toe] if toe is not None else None, heel_local, toe_local)]
    return [(loc, np.einsum("fj,fj->f", pose[:, foot, 2, :3], loc) + pose[:, foot, 2, 3]) for loc in locs]


def toe_tip(rig: Rig, side: str, foot_m: np.ndarray, toe_m: np.ndarray | None, heel_local: np.ndarray,
            toe_local: np.ndarray) -> np.ndarray:
    """(F, 3) the toe tip of one foot in its foot bone's frame: ahead of the ball on the
    sole (``toe_local`` (3,)) by the toe bone's length, along the sole (from
    ``heel_local``), bent as the toe bone is bent from its rest in ``foot_m``/``toe_m``
    (F, 4, 4) (the foot's and the toe's matrices in any one space; without a toe bone
    (None) the foot's tail stands for the tip, unbent, on the sole). A rig with the soles
    of its skinned mesh (``Rig.sole``) has the mesh's tip, bent about the toe bone's head."""
    foot, toe = rig.foot_chain(side)
    if rig.sole is not None:
        tip = rig.sole.tip[SIDES.index(side)]
        if toe is None or toe_m is None:
            return np.tile(tip, (len(foot_m), 1))
        rel = np.linalg.inv(rig.rest[foot]) @ rig.rest[toe]
        bend = np.swapaxes(foot_m[:, :3, :3], 1, 2) @ toe_m[:, :3, :3] @ rel[:3, :3].T
        return rel[:3, 3] + bend @ (tip - rel[:3, 3])
    ahead = toe_local - heel_local
    ahead = ahead / max(float(np.linalg.norm(ahead)), 1e-9)
    if toe is None or toe_m is None:
        tail = (np.linalg.inv(rig.rest[foot]) @ np.append(rig.tails[foot], 1.0))[:3]
        length = max(float((tail - rig.ball_local(side)[:3]) @ ahead), 0.0)
        return np.tile(toe_local + length * ahead, (len(foot_m), 1))
    length = float(np.linalg.norm(rig.tails[toe] - rig.rest[toe, :3, 3]))
    rest = (np.linalg.inv(rig.rest[foot]) @ rig.rest[toe])[:3, :3]
    # (the pose's matrices are rigid: the rotation between them needs no general inverse,
    # which costs a LAPACK call per frame)
    bend = np.swapaxes(foot_m[:, :3, :3], 1, 2) @ toe_m[:, :3, :3] @ rest.T
    return toe_local + length * (bend @ ahead)


def _swing_planes(index: np.ndarray, fp_pos: np.ndarray, fp_normal: np.ndarray):
    """The surface one foot's swing is laid over, per frame: the planes of the footprint
    it left and of the one it lands on (``index`` (F,) its footprint while planted, -1 in
    the air; ``fp_pos`` (N, 3) points on them, ``fp_normal`` (N, 3)) and the smoothstep
    share ``u`` (F,) of the second, as ``swing_targets`` eases the foot. Returns (points
    (2, F, 3), normals (2, F, 3), u (F,), frames to the nearest planted frame (F,)), or
    None without a planted frame."""
    F = len(index)
    on = index >= 0
    if not on.any():
        return None
    f = np.arange(F)
    prev, nxt = planted_either_side(on)
    gap = np.minimum(np.where(prev < 0, F, f - prev), np.where(nxt >= F, F, nxt - f))
    prev, nxt = np.where(prev < 0, nxt, prev), np.where(nxt >= F, prev, nxt)
    j = index[np.stack([prev, nxt])]
    return fp_pos[j], fp_normal[j], smoothstep((f - prev) / np.maximum(nxt - prev, 1)), gap


def _plane_z(point: np.ndarray, normal: np.ndarray, xy: np.ndarray) -> np.ndarray:
    """(...,) heights at ``xy`` (..., 2) of the planes through ``point`` (..., 3) with
    ``normal`` (..., 3) (taken no steeper than about 70 degrees)."""
    nz = np.maximum(normal[..., 2], 0.3)
    return point[..., 2] - (normal[..., 0] * (xy[..., 0] - point[..., 0])
                            + normal[..., 1] * (xy[..., 1] - point[..., 1])) / nz


def _low_swing(ankle: np.ndarray, planted: np.ndarray, still: np.ndarray) -> np.ndarray:
    """One foot's ankle targets (F, 3) with each swing's rise over the straight way
    between its footprints' heights scaled down so that it rises at most PIVOT_LIFT, as
    far as ``still`` (F,) 0..1 (a turn in place: a pivot step barely lifts the foot; the
    walk's swing, played on the spot, marches). Unchanged where ``still`` is 0."""
    F = len(planted)
    f = np.arange(F)
    prev, nxt = planted_either_side(planted)
    swing = ~planted & (prev >= 0) & (nxt < F)
    w = np.clip(np.asarray(still, float), 0.0, 1.0) * swing
    if not w.any():
        return ankle
    a, b = np.where(swing, prev, 0), np.where(swing, nxt, 0)
    x = (f - a) / np.maximum(b - a, 1)
    rise = ankle[:, 2] - ((1 - x) * ankle[a, 2] + x * ankle[b, 2])
    top = np.zeros(F)
    np.maximum.at(top, a, np.where(swing, rise, 0.0))  # each swing's highest rise, at its liftoff frame
    scale = np.minimum(1.0, PIVOT_LIFT / np.maximum(top[a], 1e-9))
    out = ankle.copy()
    out[:, 2] -= np.where(swing, w * (1.0 - scale) * np.maximum(rise, 0.0), 0.0)
    return out


def _lift_need(ankle: np.ndarray, rot: np.ndarray, free: np.ndarray, sole: list, planes, ground_z,
               fps: float) -> np.ndarray:
    """(n,) m each ``free`` frame's foot (targets ``ankle`` (F, 3), ``rot`` (F, 3, 3)) must
    rise for its ``sole`` points to keep their clearance (see ``_ground_lift``), not eased."""
    pts = np.stack([ankle[free] + np.einsum("fij,fj->fi", rot[free], loc[free]) for loc, _ in sole])  # (P, n, 3)
    (pa, pb), (na, nb), u, gap = (x[..., free, :] if x.ndim > 1 else x[free] for x in planes)
    base = (1 - u) * _plane_z(pa, na, pts[..., :2]) + u * _plane_z(pb, nb, pts[..., :2])  # (P, n)
    w = smoothstep(gap / max(LIFT_RAMP * fps, 1.0))
    # the clearance over the planes, never under GROUND_MARGIN (the heel and ball) or, away
    # from the footprints, under the clip's own if that is less (a toe tip a clip sinks, by
    # TIP_SINK at most)
    clip = np.minimum(np.stack([h[free] for _, h in sole]), GROUND_MARGIN)
    above = pts[..., 2] - base
    want = above + w * np.maximum(clip - above, 0.0)
    want = np.maximum(want, np.array([GROUND_MARGIN, GROUND_MARGIN] + [-TIP_SINK] * (len(sole) - 2))[:, None])
    gz = np.asarray(ground_z(pts.reshape(-1, 3)), float).reshape(want.shape)
    depth = gz + want - pts[..., 2] - CLEARANCE_TOL
    return np.maximum(np.where(np.isfinite(depth), depth, 0.0).max(axis=0), 0.0)


def _lift_cone(planted: np.ndarray) -> np.ndarray:
    """(F,) m the most a swinging foot may be lifted at each frame: ``LIFT_RATE`` per
    frame from its last liftoff and to its next strike."""
    F = len(planted)
    f = np.arange(F)
    last, first = planted_either_side(planted)
    last, first = np.where(last < 0, -F, last), np.where(first >= F, 2 * F, first)  # (none: far)
    return LIFT_RATE * np.minimum(f - last, first - f)


def _ground_lift(ankle: np.ndarray, rot: np.ndarray, planted: np.ndarray, sole: list, planes, ground_z,
                 fps: float = DEFAULT_FPS, need: np.ndarray | None = None) -> np.ndarray:
    """(F,) m to lift one swinging foot's ankle (targets ``ankle`` (F, 3), ``rot`` (F, 3, 3))
    so that each of its ``sole`` points (``sole_points``: heel, ball, toe tip) keeps over
    the surface ``ground_z`` (points (M, 3) -> heights (M,), NaN for none; None: no lift)
    the clearance it has over the footprints' planes it swings between (``planes``, from
    ``_swing_planes``: its flat-ground clearance, laid on the slopes), the heel and ball
    ``GROUND_MARGIN`` at least, and from ``LIFT_RAMP`` s after liftoff to as long before
    the strike every point that much (or its clip's own clearance, if less): over a hill
    or a slope steepening ahead the foot rises with the ground. Eased over ``LIFT_EASE``
    frames (``LIFT_RATE`` off a footprint); 0 where ``planted`` (F,). ``need``: the free
    frames' ``_lift_need`` of these targets, when measured already."""
    lift = np.zeros(len(ankle))
    free = np.flatnonzero(~planted)
    if ground_z is None or planes is None or not len(free):
        return lift
    lift[free] = _lift_need(ankle, rot, free, sole, planes, ground_z, fps) if need is None else need
    if lift.any():  # rising ahead of time (a step's edge), never faster than LIFT_RATE off a footprint
        lift = np.maximum(lift, np.minimum(lower_smoothly(lift, LIFT_EASE), _lift_cone(planted)))
        lift[planted] = 0.0
    return lift


def _kept_over_footprints(ankle: np.ndarray, rot: np.ndarray, planted: np.ndarray, sole: list, planes,
                          ground_z, fps: float = DEFAULT_FPS, hip: np.ndarray | None = None,
                          reach: float = np.inf) -> tuple[np.ndarray, np.ndarray]:
    """One foot's swing targets (``ankle`` (F, 3), ``rot`` (F, 3, 3)) kept over the
    footprint it leaves (reaches) where, just after the liftoff (before the strike), the
    ground would need it lifted faster than ``LIFT_RATE`` off a footprint
    (``_lift_cone``): a toe swept into the next riser as the foot leaves a tread, a heel
    still over the landing as it steps down, a clip's foot reaching past its footprint
    and settling back. There the foot's place over the ground and its turn are drawn
    towards the nearer planted frame's, by the least share of ``HOME_SHARES`` that lets
    the lift keep to the cone and keeps the ankle (so lifted) within ``reach`` of the
    ``hip`` (F, 3) (else the largest that keeps it in reach: a foot held back while the
    body climbs on would straighten its knee); the draw eases out at ``HOME_RATE`` per
    frame and is gone by the swing's middle (where the footprint it is drawn to
    changes). The foot rises off (comes down onto) its footprint before it goes on. Its
    height is kept (the lift does the rest). Unchanged elsewhere, and without
    ``ground_z``."""
    return _kept_over_footprints_need(ankle, rot, planted, sole, planes, ground_z, fps, hip, reach)[:2]


def _kept_over_footprints_need(ankle: np.ndarray, rot: np.ndarray, planted: np.ndarray, sole: list, planes,
                               ground_z, fps: float = DEFAULT_FPS, hip: np.ndarray | None = None,
                               reach: float = np.inf):
    """``_kept_over_footprints``, and the lift its targets need at the free frames
    (``_lift_need``) when it measured that of the targets it returns (None else): the
    ground then is not asked twice (``_ground_lift``'s ``need``)."""
    free = np.flatnonzero(~planted)
    if ground_z is None or planes is None or not len(free) or not planted.any():
        return ankle, rot, None
    F = len(planted)
    f = np.arange(F)
    prev, nxt = planted_either_side(planted)
    x = (f - prev) / np.maximum(nxt - prev, 1)
    home = np.where((prev >= 0) & ((x <= 0.5) | (nxt >= F)), prev, nxt)
    # the draw is gone by the middle of a swing between two footprints
    cap = np.where((prev >= 0) & (nxt < F), np.clip(4.0 * np.abs(x - 0.5), 0.0, 1.0), 1.0)
    key = Rotation.from_matrix(rot[home], assume_valid=True)  # (rigid: see swing_targets)
    cone = _lift_cone(planted)
    pull = np.zeros(F)
    out_a, out_r = ankle, rot
    for _ in range(HOME_PASSES):  # each pass checks the eased draw of the one before
        need = _lift_need(out_a, out_r, free, sole, planes, ground_z, fps)
        over = free[need > cone[free] + CLEARANCE_TOL]
        if not len(over):
            return out_a, out_r, need
        want = pull[over].copy()
        done = np.zeros(len(over), bool)
        for s in HOME_SHARES:  # a handful of trial shares, each over every flagged frame at once
            share = np.maximum(pull[over], s)
            trial_a, trial_r = ankle.copy(), rot.copy()
            trial_a[over], trial_r[over] = _towards(ankle[over], rot[over], ankle[home[over]], key[over], share)
            near = np.ones(len(over), bool) if hip is None else \
                np.linalg.norm(trial_a[over] + cone[over, None] * [0.0, 0.0, 1.0] - hip[over], axis=1) <= reach
            ok = (_lift_need(trial_a, trial_r, over, sole, planes, ground_z, fps) <= cone[over] + CLEARANCE_TOL)
            want[~done & near] = share[~done & near]
            done |= ok & near
        grown = pull.copy()
        grown[over] = np.maximum(pull[over], want)
        grown = np.minimum(ease_peaks(grown, HOME_RATE), cap)
        grown[planted] = 0.0
        if np.allclose(grown, pull):  # (the targets the need was measured on)
            return out_a, out_r, need
        pull = grown
        moved = np.flatnonzero(pull > 0)
        out_a, out_r = ankle.copy(), rot.copy()
        out_a[moved], out_r[moved] = _towards(ankle[moved], rot[moved], ankle[home[moved]], key[moved], pull[moved])
    return out_a, out_r, None


def _towards(ankle: np.ndarray, rot: np.ndarray, to_a: np.ndarray, to_r: Rotation, share
             ) -> tuple[np.ndarray, np.ndarray]:
    """Ankle targets (n, 3) and foot rotations (n, 3, 3) drawn by ``share`` (scalar or
    (n,)) towards ``to_a`` (n, 3), ``to_r`` (n rotations) over the ground: the ankle's x
    and y, the rotation (slerp); the height kept."""
    s = np.broadcast_to(np.asarray(share, float), (len(ankle),))
    a = ankle.copy()
    a[:, :2] += s[:, None] * (to_a[:, :2] - a[:, :2])
    delta = (to_r * Rotation.from_matrix(rot, assume_valid=True).inv()).as_rotvec()
    return a, Rotation.from_rotvec(s[:, None] * delta).as_matrix() @ rot


def ease_peaks(v: np.ndarray, rate: float) -> np.ndarray:
    """(F,) the least envelope over ``v`` (F,) (>= 0) that changes by at most ``rate`` per
    frame: each peak comes and goes along a cone (a loop over the cone's half width, not
    over frames)."""
    out = np.array(v, float)
    if not out.any() or rate <= 0:
        return out
    for d in range(1, int(np.ceil(out.max() / rate)) + 1):
        out[d:] = np.maximum(out[d:], v[:-d] - rate * d)
        out[:-d] = np.maximum(out[:-d], v[d:] - rate * d)
    return out


def _tip_lift(ankle: np.ndarray, lift: np.ndarray, rot: np.ndarray, planted: np.ndarray, tip: tuple, planes,
              fps: float) -> np.ndarray:
    """(F,) ``lift`` raised, while ``planted`` (F,), by as much as a foot that has no toe
    bone (its toes are its own, rigid) would sink its toe tip (``tip`` from
    ``sole_points``) more than TIP_SINK into the footprint it stands on: such a foot at its
    clip's toe-off stands on its tip, not its ball. Eased in and out at LIFT_RATE."""
    on = np.flatnonzero(planted)
    if planes is None or not len(on):
        return lift
    pt = ankle[on] + lift[on, None] * [0.0, 0.0, 1.0] + np.einsum("fij,fj->fi", rot[on], tip[0][on])
    (pa, _), (na, _), _, _ = planes
    need = np.zeros(len(ankle))
    need[on] = np.maximum(_plane_z(pa[on], na[on], pt[:, :2]) - pt[:, 2] - TIP_SINK, 0.0)
    if not need.any():
        return lift
    return lift + ease_peaks(need, LIFT_RATE)


#: m: a planted foot's toe tip may sink this far into its footprint (rounding, a soft
#: floor), never further, whatever its clip does (a clip whose toes go through its own
#: floor at toe-off, played on a footprint, would sink them there).
TIP_SINK = 0.008


def toe_bend(ankle: np.ndarray, rot: np.ndarray, planted: np.ndarray, tip: tuple, toe_local: np.ndarray,
             planes, fps: float = DEFAULT_FPS) -> np.ndarray:
    """(F,) rad to bend one foot's toe up, beyond its clip's bend (at most ``MAX_TOE_BEND``),
    so that its toe tip (``tip``: ((F, 3) in the foot bone's frame, (F,) m its height over
    the clip's floor), from ``sole_points``) goes no deeper into the footprint it stands on
    while ``planted`` (F,) than it goes into the clip's floor (at most TIP_SINK): a foot rolled up on its ball
    (the clip's toe-off held on a footprint, a roll for reach, a slope) would sink its
    toes. The foot at ``ankle`` (F, 3) turned by ``rot`` (F, 3, 3); the toe bends about the
    ball (``toe_local`` (3,)); ``planes`` from ``_swing_planes``. Eased in and out at
    ``TOE_BEND_RATE`` (``ease_peaks``; frames at ``fps``)."""
    bend = np.zeros(len(ankle))
    on = np.flatnonzero(planted)
    if planes is None or not len(on):
        return bend
    pt = ankle[on] + np.einsum("fij,fj->fi", rot[on], tip[0][on])
    ball = ankle[on] + rot[on] @ toe_local
    (pa, _), (na, _), _, _ = planes
    depth = _plane_z(pa[on], na[on], pt[:, :2]) - pt[:, 2] - np.clip(-tip[1][on], 0.0, TIP_SINK)
    length = np.maximum(np.linalg.norm(pt - ball, axis=1), 1e-6)
    bend[on] = np.minimum(np.arcsin(np.clip(depth / length, 0.0, 1.0)), MAX_TOE_BEND)
    return ease_peaks(bend, TOE_BEND_RATE / fps)


def _lateral(rot: np.ndarray, heel_to_toe: np.ndarray, where: np.ndarray) -> np.ndarray:
    """(3,) a foot's lateral axis (to its right, unit) in its bone's frame: across the
    sole's length ``heel_to_toe`` (3,) and the world's up, averaged over the frames
    ``where`` (F,) of its world rotations ``rot`` (F, 3, 3) (a foot rolled steeply in
    the air has a poor one of its own)."""
    f = np.einsum("fij,j->fi", rot[where], heel_to_toe)
    side = np.cross(f, [0.0, 0.0, 1.0])
    side /= np.maximum(np.linalg.norm(side, axis=1, keepdims=True), 1e-12)
    lat = np.einsum("fji,fj->i", rot[where], side)
    return lat / max(float(np.linalg.norm(lat)), 1e-12)


def _solve_legs(rig: Rig, basis: np.ndarray, pose: np.ndarray, world: np.ndarray, legs: _Legs,
                ankle_t: np.ndarray, rot_t: np.ndarray, lift: list, yaw: np.ndarray, toes=None) -> np.ndarray:
    """Thesis 3.8.2: a copy of ``basis`` (F, B, 4, 4) with both legs solved in closed form
    (``two_bone``, the knee towards the rig's forward) so each ankle reaches its target
    ``ankle_t`` (2, F, 3) raised by ``lift`` (2 x (F,)) m and each foot takes ``rot_t``
    (2, F, 3, 3); ``world`` holds the legs' current world matrices, ``pose`` the
    armature-space ones (the toes' too), the object turned by ``yaw`` (F,) rad. ``toes``
    (bends (2 x (F,)) rad, heel-to-ball (2, 3) in the foot bones' frames): each toe bone
    bent up by that much more than its clip bends it, about the foot's lateral axis."""
    F = len(yaw)
    basis = basis.copy()
    inv_yaw = body_frames(np.zeros((F, 3)), -yaw)[:, :3, :3]
    fwd = np.einsum("fij,j->fi", body_frames(np.zeros((F, 3)), yaw)[:, :3, :3], rig.forward_axis())
    for k in range(2):
        thigh, shin, foot = legs.thigh[k], legs.shin[k], legs.foot[k]
        Wt, Ws, Wf = world[:, thigh], world[:, shin], world[:, foot]
        A = ankle_t[k].copy()
        A[:, 2] += lift[k]
        r1, r2 = two_bone(Wt[:, :3, 3], Ws[:, :3, 3], Wf[:, :3, 3], A, legs.thigh_len[k], legs.shin_len[k], fwd)
        arm = {thigh: inv_yaw @ r1 @ Wt[:, :3, :3], shin: inv_yaw @ r2 @ r1 @ Ws[:, :3, :3],
               foot: inv_yaw @ rot_t[k]}
        chain = [thigh, shin, foot]
        toe = rig.foot_chain(SIDES[k])[1]
        if toes is not None and toe is not None and toes[0][k].max() > 0.0:
            axis = rot_t[k] @ _lateral(rot_t[k], toes[1][k], toes[0][k] > 0)  # the foot's, as it bends
            rel = np.swapaxes(pose[:, foot, :3, :3], 1, 2) @ pose[:, toe, :3, :3]  # the clip's toe on its foot (rigid)
            arm[toe] = inv_yaw @ Rotation.from_rotvec(axis * toes[0][k][:, None]).as_matrix() @ rot_t[k] @ rel
            chain.append(toe)
        p = rig.parents[thigh]
        parent_rot = pose[:, p, :3, :3] if p >= 0 else np.eye(3)[None]
        chain_bases(rig, chain, parent_rot, arm, basis)
    return basis


def reach_need(hip: np.ndarray, ankle: np.ndarray, reach: float) -> np.ndarray:
    """(F,) m the hip (F, 3) must come down for the ankle (F, 3) to lie within ``reach``
    of it (negative: it could rise that much)."""
    v = ankle - hip
    horiz = np.hypot(v[:, 0], v[:, 1])
    return -v[:, 2] - np.sqrt(np.maximum(reach * reach - horiz * horiz, 0.0))


def lower_smoothly(need: np.ndarray, win: int, mode: str = "reflect", edge: str = "reflect") -> np.ndarray:
    """(F,) a drop of the hips that covers ``need`` (F,) (m, >= 0) and comes and goes
    smoothly: the largest need within ``win`` frames either side, Gaussian-smoothed
    (sigma win / 2), never under the need itself. ``mode`` and ``edge`` are the maximum
    and the Gaussian filters' boundary modes ("wrap" for a loop)."""
    drop = gaussian_filter1d(maximum_filter1d(need, 2 * win + 1, mode=mode), max(win / 2.0, 0.5), mode=edge)
    return np.maximum(drop, need)


def leg_lengths(rig: Rig, side: str) -> tuple[float, float]:
    """(thigh, shin) rest lengths of one leg: hip to knee and knee to ankle, m."""
    thigh, shin, foot = rig.role_index(f"thigh_{side}"), rig.role_index(f"shin_{side}"), rig.foot_chain(side)[0]
    return (float(np.linalg.norm(rig.rest[shin, :3, 3] - rig.rest[thigh, :3, 3])),
            float(np.linalg.norm(rig.rest[foot, :3, 3] - rig.rest[shin, :3, 3])))


def two_bone(H: np.ndarray, K0: np.ndarray, A0: np.ndarray, A: np.ndarray, L1: float, L2: float,
             forward: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A leg in closed form (thesis 3.8.2), vectorized over frames.

    ``H``, ``K0``, ``A0`` (F, 3): hip, knee and ankle of the leg as posed now; ``A`` (F, 3)
    the ankle's target (kept within ``MAX_REACH`` of the leg's length); ``forward`` (F, 3)
    the character's forward. The knee stays in the plane of the posed knee (the swivel
    closest to it), or bends forward as the posed leg straightens (a straight knee gives no
    side). Returns (r1, r2) (F, 3, 3): the least world rotation of the thigh, and the one
    that then takes the shin onto the target (the shin's world rotation is r2 @ r1 @ old).
    """
    v = A - H
    d = np.linalg.norm(v, axis=1)
    d_c = np.clip(d, abs(L1 - L2) + 1e-4, MAX_REACH * (L1 + L2))
    u = v / np.maximum(d, 1e-9)[:, None]
    A = H + u * d_c[:, None]
    u0 = (A0 - H) / np.maximum(np.linalg.norm(A0 - H, axis=1, keepdims=True), 1e-9)
    pole = K0 - H  # the posed knee, off the posed hip-ankle line ...
    pole -= np.einsum("fi,fi->f", pole, u0)[:, None] * u0
    m = np.linalg.norm(pole, axis=1)
    pole -= np.einsum("fi,fi->f", pole, u)[:, None] * u  # ... carried to the new line
    fb = forward - np.einsum("fi,fi->f", forward, u)[:, None] * u
    fb /= np.maximum(np.linalg.norm(fb, axis=1, keepdims=True), 1e-9)
    firm = 0.15 * L1
    pole += (firm * np.clip(1.0 - m / firm, 0.0, 1.0))[:, None] * fb
    pole /= np.maximum(np.linalg.norm(pole, axis=1, keepdims=True), 1e-12)
    a = (L1 ** 2 - L2 ** 2 + d_c ** 2) / (2 * d_c)
    h = np.sqrt(np.maximum(L1 ** 2 - a * a, 0.0))
    K = H + a[:, None] * u + h[:, None] * pole
    r1 = min_rotation(K0 - H, K - H)
    r2 = min_rotation(np.einsum("fij,fj->fi", r1, A0 - K0), A - K)
    return r1, r2


def chain_bases(rig: Rig, chain: list, parent_rot: np.ndarray, arm: dict, basis: np.ndarray) -> None:
    """Set the rotations of pose bases ``basis`` (F, B, 4, 4), in place, from armature-space
    rotations: ``arm`` maps each bone of ``chain`` (parents first, each an ancestor of the
    next) to its wanted armature-space rotation (F, 3, 3); ``parent_rot`` (F or 1, 3, 3)
    is the first bone's parent's. Bones between two of the chain (a Rigify leg's split
    halves, thigh.001 between thigh and shin) keep their bases and turn with the chain."""
    known = {int(rig.parents[chain[0]]): parent_rot}
    for b in chain:
        p, between = int(rig.parents[b]), []
        while p not in known and p >= 0:
            between.append(p)
            p = int(rig.parents[p])
        rot = known.get(p, parent_rot)
        for q in reversed(between):  # their armature rotation, following the chain
            rot = np.einsum("fij,jk,fkl->fil", rot, rig.rest_rel[q, :3, :3], basis[:, q, :3, :3])
        rr = rig.rest_rel[b, :3, :3]
        basis[:, b, :3, :3] = np.einsum("ji,fjk->fik", rr, np.einsum("fji,fjk->fik", rot, arm[b]))
        known[b] = arm[b]
