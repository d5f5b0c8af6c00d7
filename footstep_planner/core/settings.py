"""Every tunable of the planner in one dataclass, with the thesis's defaults.

The panel, the command line and the tests all build this same object. Units: metres,
seconds, radians unless a name says otherwise.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, fields


@dataclass
class Settings:
    # --- clip analysis (Johansen 2008) -----------------------------------------------
    analysis_rate: float = 120.0
    """Hz. Clips are resampled (cubic) to at least this rate before contact events are
    searched, so the figures do not depend on the scene's frame rate."""
    contact_height: float = 0.08
    """m. A foot point lower than this above its lowest level in the clip may be in contact."""
    contact_speed: float = 1.0
    """m/s. A foot point slower than this (horizontally) may be in contact."""
    balance_band: float = 0.04
    """m. Johansen's heel/toe balance moves from heel to toe while the heel rises this much
    more than the toe (a half of it either side of level)."""
    firm_speed: float = 0.35
    """m/s. ... and while it moves (horizontally) slower than this."""
    firm_height: float = 0.03
    """m. During a stance the foot stands firmly while its higher point (heel or toe) is
    within this of its lowest; Johansen's lift and landing searches start from there."""
    lift_fraction: float = 0.1
    """Johansen's rule 1: the lift (or landing) lies before the foot curve reaches this
    fraction of its maximum height above the stance height."""
    derivative_smoothing: float = 0.02
    """s. Gaussian width used when differentiating foot curves (mocap noise)."""
    min_step_height: float = 0.02
    """m. A foot whose heel and toe never rise more than this between stances is not stepping."""
    slip_tolerance: float = 0.5
    """Johansen's horizontal check: the foot has left the ground once its horizontal speed
    differs from its speed at the stance time by more than this fraction of the body speed."""
    slip_min_speed: float = 0.25
    """m/s. Floor of the horizontal check, for a body at (or near) rest."""
    rest_speed: float = 0.15
    """m/s. The body is at rest while slower than this, with both feet down."""
    rest_time: float = 0.25
    """s. A clip starts (ends) at rest if it is at rest for at least this long at its start (end)."""
    jump_min_flight: float = 0.25
    """s. A flight phase at least this long (and well above the clip's running flights) is a jump."""
    run_flight_share: float = 0.5
    """A gait is a run when at least this share of its steps has a flight phase."""

    # --- path search (thesis 3.2) ---------------------------------------------------
    turn_penalty: float = 0.1
    """s per radian of heading change added to a step's cost (cost is time)."""
    jump_penalty: float = 0.5
    """s added to the cost of each jump."""
    run_penalty: float = 1.0
    """s added to the cost of each running step: the path walks, and runs only where a
    clip needs it (a jump is entered running); 0 plans the fastest path."""
    gait_change_penalty: float = 0.2
    """s added where the path changes between walking and running."""
    heuristic_weight: float = 2.0
    """Weighted A*: the path found costs at most this many times the cheapest; larger
    searches less. 1 is plain A*."""
    goal_radius: float = 0.35
    """m. The path ends at the first footprint this close to the goal."""

    # --- smoothing (thesis 3.3) -----------------------------------------------------
    smoothing_iterations: int = 4
    smoothing_keep_arcs: bool = True
    """Smooth positions with the thesis's binomial kernel K made shrink-free
    (p - (I - K)^3 p): kinks and the left/right zig-zag go as before, but planned turns
    keep their radius (K alone makes a 2.5 m turn 17 % tighter in four passes, a 1.25 m
    turn 89 %). Off: the thesis's kernel as printed."""

    # --- refinement (3.5) -----------------------------------------------------------
    refinement_iterations: int = 10
    transition_time: float = 0.3
    """s. Clip transitions are blend-weight ramps of this length."""

    # --- blend groups (3.7) ---------------------------------------------------------
    tau_dt: float = 0.5
    """s. Half-width of the three-point circumradius estimate of the path curvature tau."""
    tau_smoothing: float = 2.5
    """s. Low-pass filter on tau: curvature changes with a period of this many seconds are
    halved, quicker ones removed (the sway of each step, and a plan that alternates
    left and right clips), slower ones kept (the turns of the path). 0 = no filter."""
    speed_sigma: float = 2.0
    """Footsteps taken to change between walk (s = 0) and run (s = 1); thesis sigma."""

    # --- IK (3.8) -------------------------------------------------------------------
    ik_alpha: float = 0.5
    ik_beta: float = 1.0
    ik_iterations: int = 10

    def replace(self, **changes) -> "Settings":
        """A copy with some fields changed; unknown names raise ValueError naming them."""
        names = {f.name for f in fields(self)}
        unknown = sorted(set(changes) - names)
        if unknown:
            raise ValueError(f"unknown setting(s): {', '.join(unknown)}")
        data = asdict(self)
        data.update(changes)
        return Settings(**data)

    def to_dict(self) -> dict:
        return asdict(self)
