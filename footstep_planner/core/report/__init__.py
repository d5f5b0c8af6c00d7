"""Stage 6, report: what the user is shown. Quality figures of a bake measured on plain
arrays (``metrics``), the plan's and bake's report document (``document``), the command
line's tables (``tables``), the viewport overlay's geometry (``overlay``) and pictures of
an analysis (``plots``, matplotlib imported lazily).

Reads: results of the stages below and arrays the Blender layer evaluated. Returns:
dicts, text, arrays.
Never: changes a plan or a synthesis, or imports bpy.
"""
