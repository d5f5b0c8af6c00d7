"""The Footstep Mannequin: the project's own sample character, built by code.

A humanoid armature of adult proportions (1.75 m) with the bone names of Blender's
human metarig, facing -Y in its rest pose, and a low-poly body of capsules (one per
bone, rigidly skinned through vertex groups named after the bones, with an Armature
modifier) so renders read as a person. Nothing of the user's is touched: the armature,
its mesh and its body are new data blocks linked into the given collection.

Proportions (metres): hip joints at 0.92, knees at 0.49, ankles at 0.08, feet 0.25 long,
shoulders at 1.45, the top of the head at 1.75; hips 0.18 apart.
"""

from __future__ import annotations

import math

import bpy
import numpy as np

from scipy.spatial.transform import Rotation

from ...core.sample.mannequin import HEIGHT, NAME, bone_table  # noqa: F401 (HEIGHT re-exported)
from ..read.clip_keys import _curve, _write_rotation
from ..ui.operators import _Stepped

#: Custom property on the clips the generator wrote: the armature (data) they were made
#: for. Only actions carrying it are ever replaced by a new generation.
GENERATED_PROP = "footstep_generated"


def _capsule(head, tail, radius, sides=8, rings=2):
    """Vertices and quads of a closed, rounded tube from head to tail (local frame)."""
    head, tail = np.asarray(head, float), np.asarray(tail, float)
    axis = tail - head
    length = np.linalg.norm(axis)
    z = axis / length
    x = np.cross(z, [0.0, 0.0, 1.0] if abs(z[2]) < 0.9 else [1.0, 0.0, 0.0])
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    verts, faces = [], []
    # rings along the axis, narrowing at the ends (rounded caps)
    profile = [(0.0, 0.35), (0.12, 0.85), (0.3, 1.0), (0.7, 1.0), (0.88, 0.85), (1.0, 0.35)]
    for s, w in profile:
        for k in range(sides):
            a = 2 * math.pi * k / sides
            verts.append(head + s * axis + radius * w * (math.cos(a) * x + math.sin(a) * y))
    n = len(profile)
    for i in range(n - 1):
        for k in range(sides):
            a, b = i * sides + k, i * sides + (k + 1) % sides
            faces.append((a, b, b + sides, a + sides))
    faces.append(tuple(range(sides))[::-1])
    faces.append(tuple(range((n - 1) * sides, n * sides)))
    return verts, faces


def build(collection=None, name: str = NAME, location=(0.0, 0.0, 0.0)):
    """Make the mannequin: (armature object, body mesh object), linked into
    ``collection`` (default: the active scene's collection)."""
    coll = collection or bpy.context.scene.collection
    arm = bpy.data.armatures.new(name)
    ob = bpy.data.objects.new(name, arm)
    ob.location = location
    coll.objects.link(ob)
    view = bpy.context.view_layer
    prev = view.objects.active
    view.objects.active = ob
    table = bone_table()
    bpy.ops.object.mode_set(mode="EDIT")
    try:
        for bname, head, tail, parent, conn, _ in table:
            eb = arm.edit_bones.new(bname)
            eb.head, eb.tail = head, tail
            eb.roll = 0.0
            if parent:
                eb.parent = arm.edit_bones[parent]
                eb.use_connect = conn and tuple(arm.edit_bones[parent].tail) == tuple(eb.head)
            eb.use_deform = not bname.startswith("heel")
    finally:
        bpy.ops.object.mode_set(mode="OBJECT")
        view.objects.active = prev
    for pb in ob.pose.bones:
        pb.rotation_mode = "QUATERNION"

    verts, faces, groups = [], [], []
    for bname, head, tail, _, _, radius in table:
        if radius <= 0:
            continue
        v, f = _capsule(head, tail, radius)
        base = len(verts)
        verts += [tuple(p) for p in v]
        faces += [tuple(base + i for i in face) for face in f]
        groups.append((bname, range(base, base + len(v))))
    me = bpy.data.meshes.new(f"{name} Body")
    me.from_pydata(verts, [], faces)
    me.validate()
    mat = bpy.data.materials.new(f"{name} Skin")
    mat.diffuse_color = (0.78, 0.72, 0.64, 1.0)
    me.materials.append(mat)
    body = bpy.data.objects.new(f"{name} Body", me)
    coll.objects.link(body)
    body.parent = ob
    for bname, idx in groups:
        body.vertex_groups.new(name=bname).add(list(idx), 1.0, "REPLACE")
    mod = body.modifiers.new("Armature", "ARMATURE")
    mod.object = ob
    return ob, body


def generate_clips(ob, names=None, fps: float | None = None) -> list:
    """Synthesize the sample clip library (``core.gait``) for armature ``ob`` and write each
    clip as an Action of its own (hips location and every bone's rotation, keyed on every
    frame from frame 1, at the scene's frame rate). Nothing but the generator's own clips
    for this armature is touched. ``names`` picks clips of
    ``gait.library_specs()``. Clips generated earlier are rewritten in place (strips that
    play them keep playing them; keys edited by hand in them are replaced). Returns the
    actions, in library order.

    Raises RigError or GaitError (naming the armature and bones) for a rig without legs
    or without the human metarig's leg bones."""
    from ...core.sample import gait
    from .. import rigify
    from ..read.scene import rig_from_armature, scene_fps

    if rigify.is_rigify(ob):
        return _generate_on_rigify(ob, names, fps)
    rig = rig_from_armature(ob, world=False)  # (its clips are keyed in the armature's units)
    rig.require_legs()
    gait.require_metarig(rig)
    fps = float(fps or scene_fps())
    specs = _chosen_specs(gait.library_specs(), names)
    earlier = _earlier_clips(ob)
    hips = rig.roles.bone("hips")
    out = []
    for spec in specs:
        clip = gait.generate(rig, spec, fps)
        frames = 1.0 + np.arange(len(clip.basis)) * scene_fps() / fps
        act, slot = _clip_action(ob, spec.name, earlier.get(spec.name), fps)
        _write_clip(act, slot, ob, rig.names, hips, clip.basis, frames)
        out.append(act)
    return out


def _generate_on_rigify(ob, names, fps) -> list:
    """``generate_clips`` for a rig generated by Rigify: the gait is made for its ORG
    bones (the metarig's own skeleton, by the metarig's names) and keyed on its controls
    (``rigify.key_controls``) so that its DEF bones move as the metarig's would."""
    from ...core.sample import gait
    from ...core.clips.rig import forward_kinematics
    from .. import rigify
    from ..read.scene import rig_from_armature, scene_fps

    meta = _org_rig(ob)
    meta.require_legs()
    gait.require_metarig(meta)
    deform = rig_from_armature(ob, world=False)
    org_of = _org_of_deform(ob, deform.names)
    relation = {d: np.linalg.inv(meta.rest[meta.index(o)]) @ deform.rest[deform.index(d)] for d, o in org_of.items()}
    fps = float(fps or scene_fps())
    earlier = _earlier_clips(ob)
    out = []
    for spec in _chosen_specs(gait.library_specs(), names):
        clip = gait.generate(meta, spec, fps)
        pose = forward_kinematics(meta, clip.basis)
        frames = 1.0 + np.arange(len(clip.basis)) * scene_fps() / fps
        act, slot = _clip_action(ob, spec.name, earlier.get(spec.name), fps)
        if not len(act.layers):
            act.layers.new("Layer").strips.new(type="KEYFRAME")
        targets = {d: pose[:, meta.index(o)] @ relation[d] for d, o in org_of.items()}
        rigify.key_controls(ob, (act, slot), frames, targets)
        out.append(act)
    return out


def _org_rig(ob):
    """The metarig a Rigify rig was generated from, as a Rig: its ORG bones, named as in
    the metarig (without "ORG-"), each under its metarig parent. The ORG bones hang from
    mechanism bones in the generated rig (ORG-spine.001 under tweak_spine.001), so the
    body's chain comes from Rigify's deform chain (a DEF bone's parent's ORG bone) and
    other bones take their nearest ORG ancestor."""
    from ...core.clips.rig import Rig
    from .. import rigify

    bones = [b for b in ob.data.bones if b.name.startswith("ORG-")]
    index = {b.name: i for i, b in enumerate(bones)}
    skeleton = rigify.deform_chain(ob)["skeleton"]
    org_of = _org_of_deform(ob, list(skeleton))
    chained = {}
    for d, parent in skeleton.items():
        if parent is not None and d in org_of and parent in org_of and org_of[d] != org_of[parent]:
            chained.setdefault("ORG-" + org_of[d], "ORG-" + org_of[parent])

    def org_parent(b):
        if b.name in chained:
            return index[chained[b.name]]
        p = b.parent
        while p is not None and p.name not in index:
            p = p.parent
        return index[p.name] if p is not None else -1

    rest = np.array([np.array(b.matrix_local) for b in bones], dtype=np.float64)
    tails = np.array([b.tail_local for b in bones], dtype=np.float64).reshape(-1, 3)
    return Rig.build(ob.name, [b.name[4:] for b in bones], [org_parent(b) for b in bones], rest, tails)


def _org_of_deform(ob, deform_names) -> dict:
    """DEF bone -> the metarig bone (ORG bone without "ORG-") it is part of: Rigify's
    deform chains pair their ORG and DEF segments; other DEF bones share the ORG name."""
    from .. import rigify

    chain = rigify.deform_chain(ob)
    pairs = {}
    groups = [(lb["org"], lb["deform"]) for lb in chain["limbs"].values()]
    spine = chain.get("spine")
    if spine:
        groups.append((spine["org"], [[d] for d in spine["deform"]]))
        if spine.get("head"):
            groups.append((spine["head"]["org"], [[d] for d in spine["head"]["deform"]]))
    for orgs, deforms in groups:
        for org, segs in zip(orgs, deforms):
            for d in (segs if isinstance(segs, list) else [segs]):
                pairs[d] = org[4:]
    for d in deform_names:
        if d not in pairs and ob.data.bones.get("ORG-" + d[4:]) is not None:
            pairs[d] = d[4:]
    return {d: pairs[d] for d in deform_names if d in pairs}


def _chosen_specs(specs: list, names) -> list:
    """The specs named in ``names`` (all when empty), in library order; ValueError
    naming the names that are not in the library."""
    if not names:
        return specs
    unknown = sorted(set(names) - {spec.name for spec in specs})
    if unknown:
        raise ValueError(f"no generated clip named {', '.join(unknown)}; the library has "
                         f"{', '.join(spec.name for spec in specs)}")
    return [spec for spec in specs if spec.name in names]


def _earlier_clips(ob) -> dict:
    """Clip name -> action of the clips generated earlier for ``ob``'s armature data:
    they are rewritten in place, so NLA strips and assignments that play them keep
    playing them."""
    return {a.get("footstep_clip"): a for a in bpy.data.actions
            if a.get(GENERATED_PROP) == ob.data.name}


def _clip_action(ob, clip_name: str, act, fps: float):
    """(action, slot) for generated clip ``clip_name`` of ``ob``: ``act`` emptied of its
    layers (keeping its first slot), or a new action when ``act`` is None; tagged as
    generated for ``ob``'s armature at ``fps`` frames per second, with a fake user."""
    from ..read.scene import ARMATURE_PROP, SOURCE_FPS_PROP

    if act is None:
        act = bpy.data.actions.new(clip_name)
        slot = act.slots.new(id_type="OBJECT", name=ob.name)
    else:
        for layer in list(act.layers):
            act.layers.remove(layer)
        slot = act.slots[0] if len(act.slots) else act.slots.new(id_type="OBJECT", name=ob.name)
    act[GENERATED_PROP] = ob.data.name
    act["footstep_clip"] = clip_name
    act[ARMATURE_PROP] = ob.data.name
    act[SOURCE_FPS_PROP] = fps
    act.use_fake_user = True
    return act, slot


def _write_clip(act, slot, ob, bone_names, hips: str, basis: np.ndarray, frames: np.ndarray
                ) -> None:
    """Key a new layer of ``act`` for ``slot``: the rotation of each of ``ob``'s bones
    from ``basis`` (F, B, 4, 4) pose-basis matrices in ``bone_names`` order, at scene
    ``frames`` (F,), in the pose bone's rotation mode; bones that never turn are
    skipped, and bone ``hips`` also gets its location (metres, its rest axes)."""
    cbag = act.layers.new("Layer").strips.new(type="KEYFRAME").channelbag(slot, ensure=True)
    rot = basis[:, :, :3, :3]
    turns = [b for b, bname in enumerate(bone_names)
             if bname == hips or not np.allclose(rot[:, b], np.eye(3), atol=1e-7)]
    # (every turning bone's rotations read in one call)
    quats = Rotation.from_matrix(rot[:, turns].transpose(1, 0, 2, 3).reshape(-1, 3, 3)).as_quat()
    quats = quats.reshape(len(turns), -1, 4)
    for k, b in enumerate(turns):
        bname = bone_names[b]
        pb = ob.pose.bones[bname]
        base = f'pose.bones["{bpy.utils.escape_identifier(bname)}"]'
        _write_rotation(cbag, base, bname, pb.rotation_mode, Rotation.from_quat(quats[k]), frames)
        if bname == hips:
            for i in range(3):
                _curve(cbag, f"{base}.location", i, bname, frames, basis[:, b, i, 3])


class FOOTSTEP_OT_add_mannequin(bpy.types.Operator):
    """Add the Footstep Mannequin: a 1.75 m humanoid armature (human metarig bone names)
    with a simple skinned body, to try the planner on"""

    bl_idname = "footstep.add_mannequin"
    bl_label = "Footstep Mannequin"
    bl_options = {"REGISTER", "UNDO"}

    clips: bpy.props.BoolProperty(
        name="Clips", default=True,
        description="Also generate its clip library (walk, turns, run, jump, start, stop, idle)")

    def execute(self, context):
        ob, _ = build(context.collection, location=tuple(context.scene.cursor.location))
        if self.clips:
            acts = generate_clips(ob)
            _analyze(context, ob)
            self.report({"INFO"}, f"{ob.name}: {len(acts)} clips generated")
        if context.scene.footstep.character is None:
            context.scene.footstep.character = ob
        for o in context.selected_objects:
            o.select_set(False)
        ob.select_set(True)
        context.view_layer.objects.active = ob
        return {"FINISHED"}


def add_to_scene(scene, marker: str = "Start", clips: bool = True, settings=None):
    """The mannequin standing on ``scene``'s object ``marker`` (its location and Z
    rotation; the scene's origin when there is no such object), with its generated clips
    analysed and its library proposed, as the planner's character. Returns (armature,
    CharacterClips or None)."""
    from ..read.character import analyze_and_propose

    at = scene.objects.get(marker)
    ob, _ = build(scene.collection, location=tuple(at.location) if at else (0.0, 0.0, 0.0))
    if at is not None:
        ob.rotation_euler.z = at.rotation_euler.z
    result = None
    if clips:
        generate_clips(ob)
        result = analyze_and_propose(ob, settings)
    scene.footstep.character = ob
    return ob, result


def _analyze(context, ob):
    """Analyse the character's clips and store the proposed library (unless edited)."""
    from ..read.character import analyze_and_propose
    from ..ui.props import settings_from_props

    return analyze_and_propose(ob, settings_from_props(context.scene.footstep.settings))


class FOOTSTEP_OT_generate_clips(_Stepped, bpy.types.Operator):
    """Generate the sample clip library (walk, turns, run, jump, start, stop, idle) for the
    planner's character, a rig with the human metarig's bone names (the Footstep
    Mannequin, Rigify's metarig): the mannequin's gait scaled to its legs. Replaces only
    clips generated earlier"""

    bl_idname = "footstep.generate_clips"
    bl_label = "Generate Sample Clips"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        from ..ui.operators import NO_CHARACTER, character

        ob = character(context)
        if ob is None or ob.type != "ARMATURE":
            cls.poll_message_set(NO_CHARACTER if ob is None else f"the character {ob.name!r} is not an armature")
            return False
        return True

    _names: list = []
    _done: list = []

    def execute(self, context):
        from ...core.base.errors import FootstepError
        from ..ui.operators import character

        ob = character(context)
        try:
            acts = generate_clips(ob)
            result = _analyze(context, ob)
        except FootstepError as ex:
            self.report({"ERROR"}, str(ex))
            return {"CANCELLED"}
        self.report({"INFO"}, f"{ob.name}: {len(acts)} clips generated")
        for msg in result.errors.values():
            self.report({"WARNING"}, msg)
        return {"FINISHED"}

    # From the UI: one clip at a time, with progress; Esc stops between two clips (each
    # clip written is whole, the library is analysed for what is there, one undo step).

    def invoke(self, context, event):
        from ...core.sample import gait

        self._names, self._done = [spec.name for spec in gait.library_specs()], []
        return self._begin(context, len(self._names))

    def modal(self, context, event):
        from ...core.base.errors import FootstepError
        from ..ui.operators import _status, character

        if event.type == "ESC":
            self._end(context)
            return self._stopped(context)
        if event.type != "TIMER":
            return {"PASS_THROUGH"}
        ob, name = character(context), self._names[len(self._done)]
        try:
            generate_clips(ob, names=[name])
        except FootstepError as ex:
            self._end(context)
            self.report({"ERROR"}, str(ex))
            return self._stopped(context) if self._done else {"CANCELLED"}
        self._done.append(name)
        context.window_manager.progress_update(len(self._done))
        if len(self._done) < len(self._names):
            _status(context, f"Footstep: generated {name} ({len(self._done)} of {len(self._names)} clips)... "
                             "(Esc to stop)")
            return {"RUNNING_MODAL"}
        self._end(context)
        return self._analysed(context, f"{ob.name}: {len(self._done)} clips generated", {"INFO"})

    def _stopped(self, context):
        if not self._done:
            self.report({"INFO"}, "clip generation cancelled: nothing was changed")
            return {"CANCELLED"}
        left = [n for n in self._names if n not in self._done]
        return self._analysed(context, f"clip generation stopped: kept the {len(self._done)} clip(s) written "
                                       f"({', '.join(self._done)}); not generated: {', '.join(left)} "
                                       "(Undo removes the kept ones)", {"WARNING"})

    def _analysed(self, context, msg: str, level: set):
        from ...core.base.errors import FootstepError
        from ..ui.operators import character

        self.report(level, msg)
        try:
            result = _analyze(context, character(context))
        except FootstepError as ex:
            self.report({"ERROR"}, str(ex))
            return {"FINISHED"}  # (the clips are written: one undo step)
        for err in result.errors.values():
            self.report({"WARNING"}, err)
        return {"FINISHED"}


def _menu(self, context):
    self.layout.operator(FOOTSTEP_OT_add_mannequin.bl_idname, icon="OUTLINER_OB_ARMATURE")


def register():
    bpy.utils.register_class(FOOTSTEP_OT_add_mannequin)
    bpy.utils.register_class(FOOTSTEP_OT_generate_clips)
    bpy.types.VIEW3D_MT_armature_add.append(_menu)


def unregister():
    bpy.types.VIEW3D_MT_armature_add.remove(_menu)
    bpy.utils.unregister_class(FOOTSTEP_OT_generate_clips)
    bpy.utils.unregister_class(FOOTSTEP_OT_add_mannequin)
