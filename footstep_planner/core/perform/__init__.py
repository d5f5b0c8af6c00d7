"""Stage 5, perform: a whole performance from standing to standing, built from the stages
below. Routes through waypoints (``waypoints``), turning on the spot at the start, at a
hairpin and at the goal (``turn_in_place``), and directed legs with pauses and arrival
frames met by pace (``directed``).

Reads: a ``Planner`` (stage 2), the synthesis (stage 3), the request's waypoints, pauses
and arrivals. Returns: a path and one joined ``Synthesis`` that the solve stage takes as
it takes any other.
Never: solves legs, writes keys, or imports bpy.
"""
