"""The animator's interface: properties (``props``), operators (``operators``), the sidebar
panel (``panel``), the viewport overlay (``overlay``), the footprint handles
(``handles``) and directing (waypoints, pauses, arrivals: ``directing``).
"""
