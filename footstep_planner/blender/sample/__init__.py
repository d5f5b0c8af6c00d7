"""The sample content in Blender: the Footstep Mannequin armature and body and its clips
(``mannequin``), and the sample scenes (``sample_scenes``).
"""
