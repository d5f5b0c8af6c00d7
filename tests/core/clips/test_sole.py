"""The feet's soles from a skinned mesh (``core.sole``), and the planner's use of them
(``core.clips.clip.clip_motion``'s heel and ball, ``core.solve.ik.toe_tip``): pure numpy, on a rig
and a box-shaped foot mesh made here."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from footstep_planner.core.clips.clip import clip_motion
from footstep_planner.core.solve.ik import toe_tip
from footstep_planner.core.clips.rig import Rig, forward_kinematics
from footstep_planner.core.clips.sole import SOLE_WEIGHT, sole_from_mesh

HEADS = {"Hips": (0, 0, 0.9), "LeftUpLeg": (0.1, 0, 0.88), "LeftLeg": (0.1, 0, 0.46), "LeftFoot": (0.1, 0, 0.08),
         "LeftToeBase": (0.1, -0.14, 0.03), "Spine": (0, 0, 1.0)}
TAILS = {"Hips": (0, 0, 1.0), "LeftUpLeg": (0.1, 0, 0.46), "LeftLeg": (0.1, 0, 0.08), "LeftFoot": (0.1, -0.14, 0.03),
         "LeftToeBase": (0.1, -0.2, 0.03), "Spine": (0, 0, 1.3)}
PARENTS = {"Hips": None, "LeftUpLeg": "Hips", "LeftLeg": "LeftUpLeg", "LeftFoot": "LeftLeg",
           "LeftToeBase": "LeftFoot", "Spine": "Hips"}


def _frame(h, t):
    y = (t - h) / np.linalg.norm(t - h)
    x = np.cross(y, [0, -1.0, 0]) if abs(y[1]) < 0.9 else np.array([1.0, 0, 0])
    x /= np.linalg.norm(x)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = x, y, np.cross(x, y), h
    return m


def rig_and_mesh(move=np.eye(4)):
    """A biped whose feet stand 8 cm above the ground and a box-shaped mesh for each foot
    (heel 6 cm behind the ankle, toe tip 20 cm ahead, sole at z = 0), both carried by
    ``move`` (4, 4): (rig, vertices (V, 3), weights (V, 2, 2))."""
    names, heads, tails = [], [], []
    for n in HEADS:
        for side, sign in ([("Left", 1), ("Right", -1)] if n.startswith("Left") else [("", 1)]):
            names.append(n.replace("Left", side) if side else n)
            heads.append((sign * HEADS[n][0],) + HEADS[n][1:])
            tails.append((sign * TAILS[n][0],) + TAILS[n][1:])
    idx = {n: i for i, n in enumerate(names)}
    parents = []
    for n in names:
        p = PARENTS[n.replace("Right", "Left")]
        parents.append(-1 if p is None else idx[p.replace("Left", "Right") if n.startswith("Right") else p])
    rest = np.array([move @ _frame(np.array(h, float), np.array(t, float)) for h, t in zip(heads, tails)])
    tails = np.array(tails, float) @ move[:3, :3].T + move[:3, 3]
    rig = Rig.build("soles", names, parents, rest, tails)
    g = np.meshgrid(np.linspace(-0.04, 0.04, 5), np.linspace(-0.2, 0.06, 27), np.linspace(0.0, 0.06, 4))
    box = np.stack([a.ravel() for a in g], axis=1)
    pts, wts = [], []
    for k, sign in enumerate((1, -1)):
        p = box + [sign * 0.1, 0.0, 0.0]
        w = np.zeros((len(p), 2, 2))
        toe = p[:, 1] < -0.14
        w[~toe, k, 0], w[toe, k, 1] = 1.0, 1.0
        shin = p + [0.0, 0.0, 0.1]  # the ankle's vertices, mostly the shin's
        ws = np.zeros((len(p), 2, 2))
        ws[:, k, 0] = SOLE_WEIGHT - 0.1
        pts += [p, shin]
        wts += [w, ws]
    pts = np.concatenate(pts) @ move[:3, :3].T + move[:3, 3]
    return rig, pts, np.concatenate(wts)


def _armature(rig, k, p):
    foot = rig.foot_chain("lr"[k])[0]
    return (rig.rest[foot] @ p)[:3]


def test_sole_heel_ball_and_tip_from_the_foots_vertices():
    rig, pts, wts = rig_and_mesh()
    sole = sole_from_mesh(rig, pts, wts)
    for k, x in enumerate((0.1, -0.1)):
        heel, ball, tip = (_armature(rig, k, p) for p in sole.local(k))
        assert np.allclose(heel, [x, 0.06, 0.0], atol=1e-9)
        assert np.allclose(ball, [x, -0.14, 0.0], atol=1e-9)  # beneath where the toe bone starts
        assert np.allclose(tip, [x, -0.2, 0.0], atol=1e-9)  # the front's middle, its lowest


def test_sole_needs_the_foots_own_vertices():
    rig, pts, wts = rig_and_mesh()
    assert sole_from_mesh(rig, pts, wts * 0.4) is None  # every vertex mostly another bone's


@settings(max_examples=25, deadline=None, database=None)
@given(yaw=st.floats(-np.pi, np.pi), shift=st.tuples(*[st.floats(-3, 3)] * 3))
def test_sole_points_are_the_same_in_the_foot_frames_wherever_the_character_stands(yaw, shift):
    move = np.eye(4)
    move[:3, :3] = Rotation.from_rotvec([0.0, 0.0, yaw]).as_matrix()
    move[:3, 3] = shift
    ref = sole_from_mesh(*rig_and_mesh())
    moved = sole_from_mesh(*rig_and_mesh(move))
    for a, b in zip((ref.heel, ref.ball, ref.tip), (moved.heel, moved.ball, moved.tip)):
        assert np.allclose(a, b, atol=1e-9)


def test_clip_takes_the_meshs_heel_and_ball_and_the_ik_its_bent_toe_tip():
    rig, pts, wts = rig_and_mesh()
    rig = rig.with_sole(sole_from_mesh(rig, pts, wts))
    rng = np.random.default_rng(2)
    F = 6
    basis = np.tile(np.eye(4), (F, len(rig.names), 1, 1))
    basis[..., :3, :3] = Rotation.from_rotvec(rng.normal(size=(F * len(rig.names), 3)) * 0.3).as_matrix().reshape(
        F, -1, 3, 3)
    clip = clip_motion(rig, "c", basis, fps=30.0)
    pose = forward_kinematics(rig, basis)
    for k, side in enumerate("lr"):
        foot, toe = rig.foot_chain(side)
        heel, ball, tip = rig.sole.local(k)
        assert np.allclose(clip.heel_local[k], heel) and np.allclose(clip.toe_local[k], ball)
        assert np.allclose(clip.heel[k], (pose[:, foot] @ heel)[:, :3])
        got = toe_tip(rig, side, pose[:, foot], pose[:, toe], heel[:3], ball[:3])
        rigid = np.linalg.inv(pose[:, foot]) @ pose[:, toe] @ np.linalg.inv(rig.rest[toe]) @ rig.rest[foot] @ tip
        assert np.allclose(got, rigid[:, :3], atol=1e-9)  # the tip moves with the toe bone
