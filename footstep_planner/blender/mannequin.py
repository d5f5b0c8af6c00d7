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

HEIGHT = 1.75

#: name: (head, tail, parent, connected, capsule radius or 0 for no capsule)
_SIDE = {
    "thigh": ((0.09, 0.0, 0.92), (0.09, 0.0, 0.49), "spine", False, 0.075),
    "shin": ((0.09, 0.0, 0.49), (0.09, 0.01, 0.08), "thigh", True, 0.055),
    "foot": ((0.09, 0.01, 0.08), (0.09, -0.13, 0.02), "shin", True, 0.045),
    "toe": ((0.09, -0.13, 0.02), (0.09, -0.2, 0.02), "foot", True, 0.035),
    "heel.02": ((0.06, 0.05, 0.0), (0.12, 0.05, 0.0), "foot", False, 0.0),
    "shoulder": ((0.02, 0.0, 1.44), (0.17, 0.02, 1.44), "spine.003", False, 0.045),
    "upper_arm": ((0.19, 0.02, 1.43), (0.21, 0.04, 1.14), "shoulder", False, 0.05),
    "forearm": ((0.21, 0.04, 1.14), (0.22, 0.0, 0.88), "upper_arm", True, 0.04),
    "hand": ((0.22, 0.0, 0.88), (0.22, -0.01, 0.7), "forearm", True, 0.045),
}
_SPINE = [
    ("spine", (0.0, 0.02, 0.95), (0.0, 0.01, 1.07), None, 0.13),
    ("spine.001", (0.0, 0.01, 1.07), (0.0, 0.01, 1.19), "spine", 0.12),
    ("spine.002", (0.0, 0.01, 1.19), (0.0, 0.02, 1.31), "spine.001", 0.13),
    ("spine.003", (0.0, 0.02, 1.31), (0.0, 0.03, 1.47), "spine.002", 0.14),
    ("spine.004", (0.0, 0.03, 1.47), (0.0, 0.02, 1.53), "spine.003", 0.05),
    ("spine.005", (0.0, 0.02, 1.53), (0.0, 0.01, 1.58), "spine.004", 0.05),
    ("spine.006", (0.0, 0.01, 1.58), (0.0, 0.0, 1.75), "spine.005", 0.1),
]


def bone_table() -> list[tuple]:
    """(name, head, tail, parent, connected, radius) of every bone, parents first."""
    out = [(n, h, t, p, p is not None, r) for n, h, t, p, r in _SPINE]
    for side, sx in (("L", 1.0), ("R", -1.0)):
        for base, (h, t, parent, conn, r) in _SIDE.items():
            par = parent if parent.startswith("spine") else f"{parent}.{side}"
            out.append((f"{base}.{side}", (sx * h[0], h[1], h[2]), (sx * t[0], t[1], t[2]), par, conn, r))
    return out


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


def build(collection=None, name: str = "Footstep Mannequin", location=(0.0, 0.0, 0.0)):
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


class FOOTSTEP_OT_add_mannequin(bpy.types.Operator):
    """Add the Footstep Mannequin: a 1.75 m humanoid armature (human metarig bone names)
    with a simple skinned body, to try the planner on"""

    bl_idname = "footstep.add_mannequin"
    bl_label = "Footstep Mannequin"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        ob, _ = build(context.collection, location=tuple(context.scene.cursor.location))
        for o in context.selected_objects:
            o.select_set(False)
        ob.select_set(True)
        context.view_layer.objects.active = ob
        return {"FINISHED"}


def _menu(self, context):
    self.layout.operator(FOOTSTEP_OT_add_mannequin.bl_idname, icon="OUTLINER_OB_ARMATURE")


def register():
    bpy.utils.register_class(FOOTSTEP_OT_add_mannequin)
    bpy.types.VIEW3D_MT_armature_add.append(_menu)


def unregister():
    bpy.types.VIEW3D_MT_armature_add.remove(_menu)
    bpy.utils.unregister_class(FOOTSTEP_OT_add_mannequin)
