"""The project's own sample content as data: the Footstep Mannequin's skeleton
(``mannequin``) and its clip library made by a parametric gait solved with the project's
own IK (``gait``).

Reads: nothing. Returns: a rig and clips (``ClipMotion``) like any a user brings.
Never: imports bpy (``blender/sample`` builds the armature and actions from this).
"""
