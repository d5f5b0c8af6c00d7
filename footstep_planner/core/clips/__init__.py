"""Stage 1, clips: a character's skeleton and animation clips, read into what the planner
uses.

Reads: a rig (bone table, rest poses) and clips as plain arrays (``ClipMotion``, from the
Blender layer or a BVH file). Returns: the legs' roles (``roles``, ``rig``), each clip's
analysis (gait, stances, footprints, root motion, one-cycle loops, in-place clips:
``analysis``), mirrored clips, the clip library of blend groups and special clips
(``library``), and the steps the search expands (``steps.StepSet``). ``body`` gives the
character's size as a scale of a human's.
Never: plans a path, plays or blends clips, or imports bpy.
"""
