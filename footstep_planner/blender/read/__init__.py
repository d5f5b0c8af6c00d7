"""Reading the scene: armatures into rigs and clips (``scene``, ``clips``, importing BVH,
FBX and glTF files with Blender's own importers: ``bvh_import``, ``fbx_gltf_import``,
``root_motion``, ``retarget``, ``clip_keys``, ``clip_checks``), a character's analysis and
library (``character``), and the tagged surfaces as a ground the planner queries
(``surfaces``).

Returns plain arrays and core objects. Never writes to the user's data.
"""
