"""Stage 2, plan: where the feet go. The ground and its queries (``surface``), the A*
search over footprints (``navgraph.Planner``), edits of a planned path (``plan_edit``)
and plan files (``plan_file``).

Reads: a ``Ground`` (surfaces, obstacles), a ``StepSet`` (the clips' steps), a start, a
goal and ``Settings``. Returns: a ``PlanResult`` (``footprint.PathFootprint`` list, search
counts and times) or a ``PlanError`` that says why and where the nearest reachable point
is.
Never: plays a clip, poses a bone, or imports bpy.
"""
