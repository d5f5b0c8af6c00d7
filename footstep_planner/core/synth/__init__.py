"""Stage 3, synthesis: from a footprint path to a body trajectory with blended clips
(thesis 3.3 to 3.7), each pass timed.

Reads: a path (``footprint.PathFootprint`` list), the clip analyses and library, the
ground, ``Settings``. Returns: a ``pipeline.Synthesis``: smoothed and refined footprints,
the body trajectory, the blend-group weights, the schedule of clip playback (``schedule``)
and each pass's time.
Never: searches for a path, solves a leg, writes keys, or imports bpy.
"""
