"""Stage 4, solve: the pose of every frame. Clips' bone rotations blended by their
weights (``pose``), body offsets (``offsets``), the feet pinned to the footprints by IK
(``ik``), and a re-bake's keys spliced into the old ones (``splice``).

Reads: a ``Synthesis``, the rig, the ground. Returns: per-frame arrays of bone bases and
the body's transform, ready for the Blender layer to key.
Never: plans, changes the path's footprints or timing, or imports bpy.
"""
