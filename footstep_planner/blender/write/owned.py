"""What the planner owns, and the character as it was: the tags a bake writes on its
action (``OWNED_PROP``, ``BAKE_NAME_PROP`` and the records ``CARRIED`` from bake to bake),
finding the planner's tracks by them (``owned_tracks``), and the character's transform
values and pose channels as the user typed them (``character_state``). Never by name.
"""

from __future__ import annotations


import numpy as np

from ...core.base.errors import FootstepError


OWNED_PROP = "footstep_bake"
#: The character's own object transform before the first bake (row-major 4x4), put back
#: by ``clear``: the bake animates the object, and Blender leaves the last evaluated
#: transform in it when the animation goes.
REST_PROP = "footstep_rest_matrix"
#: Where the bake put the body: "OBJECT" or "ROOT".
BODY_PROP = "footstep_body_on"
TRACK_PREFIX = "Footstep: "
MARKER_PREFIX = "FP "
#: Whether the bake was planned round the other characters baked in the scene
#: (``Settings.avoid_characters``, as every bake of a shot baked together): a re-plan of
#: it keeps them apart too.
ROUND_OTHERS_PROP = "footstep_round_others"
#: The bake's name (on its action): a bake replaces only the planner's bake of its name.
BAKE_NAME_PROP = "footstep_bake_name"
#: The timeline markers the bake made, as JSON [[name, frame], ...]: the only markers
#: the planner ever removes.
MARKERS_PROP = "footstep_markers"
#: The character as it was before the planner's first bake of it (JSON: the object's
#: transform values as typed, every pose bone's channels and rotation mode, whether it
#: had animation data), given back when the planner's last bake of it goes.
BEFORE_PROP = "footstep_before"
#: The user's active action the bake stashed: its name, its slot's identifier, the name
#: of the stash track the bake made.
STASH_PROP = "footstep_stashed_action"
STASH_SLOT_PROP = "footstep_stashed_slot"
STASH_TRACK_PROP = "footstep_stash_track"
#: The scene's frame range before the bake grew it, and the range it grew it to.
RANGE_PROP = "footstep_frame_range"
STASH_TRACK = "[Action Stash]"
#: What every bake of a character carries of the character's state before its first
#: bake (copied from bake to bake, so that whichever goes last gives it back).
CARRIED = (REST_PROP, BEFORE_PROP, STASH_PROP, STASH_SLOT_PROP, STASH_TRACK_PROP, RANGE_PROP)


class BakeError(FootstepError):
    pass


def is_owned(act) -> bool:
    """Whether ``act`` is one of the planner's bakes (its owner tag)."""
    return act is not None and act.get(OWNED_PROP) is not None


def bake_name(act) -> str:
    """The name of the bake ``act`` holds (its tag; a bake made before names were
    tagged: its action's name without the planner's prefix)."""
    name = act.get(BAKE_NAME_PROP)
    if name is not None:
        return str(name)
    return act.name[len("Footstep "):] if act.name.startswith("Footstep ") else act.name


def owned_tracks(ob, name: str | None = None) -> list:
    """The planner's own NLA tracks on ``ob`` (found by their actions' owner tag, whatever
    the tracks are called), or only those of the bake ``name``."""
    ad = ob.animation_data
    if ad is None:
        return []
    out = [tr for tr in ad.nla_tracks if tr.strips and all(is_owned(st.action) for st in tr.strips)]
    if name is not None:
        out = [tr for tr in out if any(bake_name(st.action) == name for st in tr.strips)]
    return out


def track_frames(tr) -> tuple[float, float]:
    return min(st.frame_start for st in tr.strips), max(st.frame_end for st in tr.strips)


def unscaled(m: np.ndarray) -> np.ndarray:
    """(..., 4, 4) ``m`` with its even scale taken out of its rotation (translation kept)."""
    m = np.array(m, float, copy=True)
    s = np.cbrt(np.abs(np.linalg.det(m[..., :3, :3])))
    m[..., :3, :3] /= np.asarray(s)[..., None, None]
    return m


def own_frame(ob) -> np.ndarray:
    """(4, 4) the object's own world frame (``own_matrix_world``) without its even scale:
    where the planner's world-unit rig stands."""
    return unscaled(own_matrix_world(ob))


def own_matrix_world(ob) -> np.ndarray:
    """(4, 4) the object's world matrix with its own transform, not the one the
    planner's bake animates it to."""
    m = np.array(ob.matrix_world)
    for tr in owned_tracks(ob):
        for st in tr.strips:
            rest = st.action.get(REST_PROP)
            if rest is not None and len(rest) == 16:
                basis = np.array([float(v) for v in rest]).reshape(4, 4)
                return m @ np.linalg.inv(np.array(ob.matrix_basis)) @ basis
    return m


BODY_ON = ("OBJECT", "ROOT")


# -- the character as it was --------------------------------------------------------

_OBJECT_CHANNELS = ("location", "rotation_euler", "rotation_quaternion", "rotation_axis_angle", "scale")


def character_state(ob) -> dict:
    """What a bake changes on the character and Clear gives back: the object's transform
    values as they are typed (an Euler beyond 360 degrees too) and rotation mode, every
    pose bone's channels and rotation mode (``scene.pose_channels``), whether it had
    animation data. Plain values (JSON)."""
    from ..read.scene import pose_channels

    state = {"object": {k: [float(v) for v in getattr(ob, k)] for k in _OBJECT_CHANNELS},
             "rotation_mode": ob.rotation_mode, "anim_data": ob.animation_data is not None}
    if ob.pose is not None:
        pose = pose_channels(ob)
        state["pose"] = {k: v.tolist() if hasattr(v, "tolist") else v for k, v in pose.items()}
    return state


def give_back_state(ob, state: dict) -> None:
    """Put the character's channels back as ``character_state`` read them."""
    from ..read.scene import set_pose_channels

    if ob.rotation_mode != state.get("rotation_mode", ob.rotation_mode):
        ob.rotation_mode = state["rotation_mode"]
    for k, v in state.get("object", {}).items():
        setattr(ob, k, v)
    if state.get("pose") is not None and ob.pose is not None:
        set_pose_channels(ob, state["pose"])
