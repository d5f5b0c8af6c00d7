"""Stage 0, the base every stage stands on: errors, settings, timing, angles and
quaternions, files.

Reads: nothing of the scene, no clip, no plan. Returns: the error base (``FootstepError``,
whose messages name the fault and the fix), ``Settings`` (every tunable, declared once,
with unit and range), ``StageTimer``, the quaternion helpers (scipy's x, y, z, w order)
and ``Outputs`` (files written as one transaction).
Never: imports another stage of the core, or bpy.
"""
