"""Every tunable of the planner in one dataclass, with the thesis's defaults.

Each setting declares, once, its type (the annotation), its unit, its valid range and
what it does (``setting(...)``): the panel builds its properties from that, the command
line's ``--set NAME=VALUE`` and the job file convert and check through ``Settings.parse``
and ``Settings.check``, and the tests build the same object. Units: metres, seconds,
radians unless the unit says otherwise.

Sizes are a human's. Every length (m) and speed (m/s) here, and every length a stage
names beside its code, is for a human of the size the defaults were tuned on (legs of
``REFERENCE_LEG``); a character of another size is planned with them scaled by its
``body_scale`` (``Settings.for_body``: its leg length over REFERENCE_LEG, read from its
rig), curvatures (1/m) the other way, so a 4.85 m giant or a 1 m child is planned as a
human is on a scene scaled to it. ``Settings.length`` scales a stage's own constants.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, fields

from .errors import FootstepError


class SettingsError(FootstepError):
    """A setting's name, type or value is not valid; the message names the setting."""


def setting(default, unit: str, lo: float | None = None, hi: float | None = None, doc: str = "",
            lo_open: bool = False, derived: bool = False):
    """A Settings field: its default, unit (``"m"``, ``"s"``, ``"1"`` for a plain number...),
    valid range ``[lo, hi]`` (``(lo, hi]`` with ``lo_open``; None: unbounded) and what it
    does; ``derived``: set by the planner, not a user's tunable (no panel property, no
    ``--set``)."""
    return field(default=default, metadata={"unit": unit, "min": lo, "max": hi, "min_open": lo_open,
                                            "doc": " ".join(doc.split()), "derived": derived})


#: m: the leg length (thigh head to ankle, the longer leg) of the human the defaults are
#: for: CMU subject 16 and the sample character (0.84 m; hips about 0.95 m high).
REFERENCE_LEG = 0.84

#: How each unit scales with the body: a length or a speed by ``body_scale`` (times
#: unchanged), a curvature by its inverse, a cost per curvature (s m) by it.
_SIZE_POWER = {"m": 1, "m/s": 1, "m/s^2": 1, "s m": 1, "1/m": -1, "1/m^2": -2}

_TRUE = ("1", "true", "yes", "on")
_FALSE = ("0", "false", "no", "off")


@dataclass(frozen=True)
class Settings:
    # --- clip analysis (Johansen 2008) -----------------------------------------------
    analysis_rate: float = setting(120.0, "Hz", 1.0, 10000.0, """Clips are resampled (cubic) to at
        least this rate before contact events are searched, so the figures do not depend on the
        scene's frame rate.""")
    contact_height: float = setting(0.08, "m", 0.0, 1.0, """A foot point lower than this above its
        lowest level in the clip may be in contact.""", lo_open=True)
    contact_speed: float = setting(1.0, "m/s", 0.0, 20.0, """A foot point slower than this
        (horizontally) may be in contact.""", lo_open=True)
    balance_band: float = setting(0.04, "m", 0.0, 0.5, """Johansen's heel/toe balance moves from heel
        to toe while the heel rises this much more than the toe (a half of it either side of
        level).""", lo_open=True)
    firm_speed: float = setting(0.35, "m/s", 0.0, 10.0, """During a stance the foot stands firmly
        while it moves (horizontally) slower than this.""", lo_open=True)
    firm_height: float = setting(0.03, "m", 0.0, 0.5, """During a stance the foot stands firmly while
        its higher point (heel or toe) is within this of its lowest; Johansen's lift and landing
        searches start from there.""", lo_open=True)
    lift_fraction: float = setting(0.1, "1", 0.0, 1.0, """Johansen's rule 1: the lift (or landing)
        lies before the foot curve reaches this fraction of its maximum height above the stance
        height.""", lo_open=True)
    derivative_smoothing: float = setting(0.02, "s", 0.0, 1.0, """Gaussian width used when
        differentiating foot curves (mocap noise).""")
    min_step_height: float = setting(0.02, "m", 0.0, 1.0, """A foot whose heel and toe never rise
        more than this between stances is not stepping.""")
    slip_tolerance: float = setting(0.5, "1", 0.0, 10.0, """Johansen's horizontal check: the foot has
        left the ground once its horizontal speed differs from its speed at the stance time by more
        than this fraction of the body speed.""", lo_open=True)
    slip_min_speed: float = setting(0.25, "m/s", 0.0, 10.0, """Floor of the horizontal check, for a
        body at (or near) rest.""")
    rest_speed: float = setting(0.15, "m/s", 0.0, 10.0, """The body is at rest while slower than this,
        with both feet down.""", lo_open=True)
    rest_time: float = setting(0.25, "s", 0.0, 60.0, """A clip starts (ends) at rest if it is at rest
        for at least this long at its start (end).""", lo_open=True)
    jump_min_flight: float = setting(0.25, "s", 0.0, 10.0, """A flight phase at least this long (and
        well above the clip's running flights) is a jump.""", lo_open=True)
    run_flight_share: float = setting(0.5, "1", 0.0, 1.0, """A gait is a run when at least this share
        of its steps has a flight phase.""", lo_open=True)

    # --- path search (thesis 3.2) ---------------------------------------------------
    turn_penalty: float = setting(0.1, "s/rad", 0.0, 100.0, """Seconds per radian of heading change
        added to a step's cost (cost is time): the change of the way walked (the step's turn
        less the straight walk's turning of each foot out and back).""")
    curvature_penalty: float = setting(0.0, "s m", 0.0, 100.0, """Seconds added to a step's cost
        per 1/m of its curvature (its heading change beyond the straight walk's, and its
        sideways crab, over its clip's step length), and above 0 the standing feet turned
        out as the walk turns them: a straight way is walked with straight steps rather
        than left and right turning steps in turn, and the library's straightest walk is
        offered straightened (a captured walk's steps need not cancel over a stride). The
        weave penalty already walks a straight way straight; this one also makes every turn
        dearer the sharper it is (wide turns rather than sharp ones), so it is off by
        default.""")
    weave_penalty: float = setting(2.0, "s/rad", 0.0, 100.0, """Seconds per radian of a step's
        veer (its heading change of the way walked) that undoes the step before it: a left
        turn right after a right turn (or the reverse) pays for the smaller of the two veers.
        A straight way is then walked in straight steps, not in left and right turning
        steps in turn (a turning step's outer foot reaches further, and alternating them
        weaves the body at more than the walk's speed); a turn, held or not, pays
        nothing more, and an S-bend only once. Above 0 the library's straightest walk is
        also offered straightened, and the standing feet turn out as the walk turns them.""")
    jump_penalty: float = setting(0.5, "s", 0.0, 100.0, """Seconds added to the cost of each jump.""")
    cross_gaps: bool = setting(True, "", doc="""Let a walking or running step cross a gap its swing
        clears when both its footprints stand (stepping stones, the gap between two slabs, a
        gutter), a jump then only a gap no step spans. Only from one piece of ground to
        another (the traversable triangles joined where they share or touch a vertex, within
        a step's height): a floor's corner or notch is walked round on the floor, never cut
        over. Off: a step walks on ground that continues under it, and any gap is jumped.""")
    square_on_stairs: bool = setting(True, "", doc="""Set a footprint that lands on a stair's tread (a
        narrow level patch with a riser up on one side and down on the other) square to the
        tread and wholly on it, moved the least that does (a tread shorter than the foot: the
        toe to the riser going up, the heel going down), before its support is checked: flights
        are climbed with square feet, and the search finds the way up without trying thousands
        of steps that miss the treads. Off: the library's steps as they land.""")
    run_penalty: float = setting(1.0, "s", 0.0, 100.0, """Seconds added to the cost of each running
        step: the path walks, and runs only where a clip needs it (a jump is entered running); 0
        plans the fastest path.""")
    gait_change_penalty: float = setting(0.2, "s", 0.0, 100.0, """Seconds added where the path
        changes between walking and running.""")
    heuristic_weight: float = setting(2.0, "1", 1.0, 100.0, """Weighted A*: the path found costs at
        most this many times the cheapest; larger searches less. 1 is plain A*.""")
    goal_radius: float = setting(0.35, "m", 0.0, 100.0, """The path ends at the first footprint this
        close to the goal.""", lo_open=True)
    goal_heading_tolerance: float = setting(math.radians(30), "rad", 0.0, math.pi, """With a goal
        heading, the path ends at a footprint turned at most this far from it.""", lo_open=True)
    bend_curvature: float = setting(0.8, "1/m", 0.0, 5.0, """A cyclic clip's steps may also be
        bent into arcs of up to this curvature (1/radius) either way, beyond the turns the
        library's own clips make, so a library of one straight walk still turns; the IK puts
        the feet on the bent footprints. 0: only the clips' own steps.""")
    stride_min: float = setting(0.4, "1", 0.05, 1.0, """Walking steps may be shortened down to
        this share of their clip's stride (the same clip, its footprints scaled and the feet put
        there by IK), so stair treads, kerbs and tight places are stepped on: 0.4 of a 0.7 m
        step fits one 28 cm tread per step. 1: the clips' own strides only.""")
    stride_max: float = setting(1.0, "1", 1.0, 3.0, """Walking steps may be lengthened up to this
        share of their clip's stride (1: never).""")
    stride_penalty: float = setting(2.0, "1", 0.0, 100.0, """An adapted stride costs its time times
        1 + this times |ln(share of the clip's stride)|: above about 1.2 a longer stride covers
        ground dearer than the clip's own, so open ground keeps the clip's stride.""")
    max_expansions: int = setting(20000, "footprints", 1, 10_000_000, """The search gives up after
        expanding this many footprints (a bound on work, the same on every machine).""")
    clearance: float = setting(0.25, "m", 0.0, 10.0, """The body keeps this far from obstacles
        (at the ankle, knee, hips, chest and head of a standing footprint, and at the hips
        along a step's way).""", lo_open=True)
    max_step_height: float = setting(0.3, "m", 0.0, 10.0, """A step goes up or down at most this
        much from one footprint to the next.""", lo_open=True)
    avoid_characters: bool = setting(False, "", doc="""Plan around the other characters the planner
        baked in the scene, and the obstacles that move, in time: no step brings the body within
        the two bodies' radii and character_clearance of another's (or of a moving obstacle) at
        the same moment, or sets a foot on a footprint another foot stands on then, so the
        character side-steps, goes round, or stands to let them pass (the command line's bake
        --together turns it on for a job list, each job around the ones before it).""")
    character_clearance: float = setting(0.15, "m", 0.0, 10.0, """With avoid_characters, two bodies
        (capsules from the hips to the head, a human's half shoulder width round) keep at least this
        far apart.""")
    wait_penalty: float = setting(1.0, "s", 0.0, 60.0, """With avoid_characters, the cost of stopping to
        let another character pass, beyond the time stood: a way round or a change of pace that
        costs less than the stand and this is taken instead.""")

    # --- smoothing (thesis 3.3) -----------------------------------------------------
    smoothing_iterations: int = setting(4, "passes", 0, 100, """Passes of the binomial kernel over
        the footprints.""")
    smoothing_keep_arcs: bool = setting(True, "", doc="""Smooth positions with the thesis's binomial
        kernel K made shrink-free (p - (I - K)^3 p): kinks and the left/right zig-zag go as before,
        but planned turns keep their radius (K alone makes a 2.5 m turn 17 % tighter in four passes,
        a 1.25 m turn 89 %). Off: the thesis's kernel as printed.""")

    # --- refinement (3.5) -----------------------------------------------------------
    refinement_iterations: int = setting(10, "passes", 0, 1000, """Sweeps pulling the footprints
        towards what the clips do locally.""")
    transition_time: float = setting(0.3, "s", 0.0, 10.0, """Clip transitions are blend-weight ramps
        of this length.""")
    stand_hold: float = setting(1.0, "s", 0.0, 60.0, """The character stands still at the goal this
        long after it stops, both feet planted (it also stands this long, at most half a second,
        before its first step).""")
    climb_time: float = setting(2.0, "1/m", 0.0, 10.0, """A walking step up or down takes longer: its
        clips' time times 1 + this times the height (m) its swinging foot climbs or descends
        (2: a 17 cm stair step lasts 1.34 times as long), as people climb stairs slower than they
        walk, lifting the foot over the nosing before it goes on. 0: every step at its clips'
        pace.""")
    pace_min: float = setting(0.8, "1", 0.5, 1.0, """To arrive at a waypoint on its frame, the walk
        may be played this much slower than its clips (0.8: a step lasts 1.25 times as long); when
        that is still early the character waits, standing, at the last stop before.""")
    pace_max: float = setting(1.25, "1", 1.0, 2.0, """To arrive at a waypoint on its frame, the walk
        may be played this much faster than its clips (1.25: a step lasts 0.8 times as long); a
        frame even this pace can't meet is met jogging (``jog_to_arrive``), then running, or
        refused, naming the earliest frame it can.""")
    jog_to_arrive: bool = setting(True, "", doc="""Meet an arrival frame too soon for the walk's
        fastest pace by a jog, before running: the walk and the run blended at the speed the
        frame needs, the way's walking footprints laid again at the stride the clips take at
        that speed (fewer, longer steps; a stretch that climbs, jumps, crosses a gap or turns in
        place is kept as planned). Needs a walk and a quicker run in the library. Off: the way
        is planned again, running where that is quicker.""")

    # --- blend groups (3.7) ---------------------------------------------------------
    tau_dt: float = setting(0.5, "s", 0.0, 10.0, """Half-width of the three-point circumradius
        estimate of the path curvature tau.""", lo_open=True)
    tau_smoothing: float = setting(2.5, "s", 0.0, 100.0, """Low-pass filter on tau: curvature changes
        with a period of this many seconds are halved, quicker ones removed (the sway of each step,
        and a plan that alternates left and right clips), slower ones kept (the turns of the path).
        0 = no filter.""")
    speed_sigma: float = setting(3.0, "footsteps", 0.0, 100.0, """Footsteps taken to change between
        walk (s = 0) and run (s = 1); thesis sigma.""", lo_open=True)

    # --- IK (3.8) -------------------------------------------------------------------
    ik_alpha: float = setting(0.5, "1", 0.0, 2.0, """Body-offset IK: share of the feet's pull that
        moves the body (thesis alpha).""")
    ik_beta: float = setting(1.0, "1/m^2", 0.0, 2.0, """Body-offset IK: scale of the torque that turns
        the body (thesis beta).""")
    ik_iterations: int = setting(10, "passes", 0, 1000, """Body-offset IK iterations.""")

    # --- bake -----------------------------------------------------------------------
    rigify_ik_feet: bool = setting(False, "", doc="""On a Rigify rig, key the legs on their IK
        controls (foot_ik, toe_ik and the knee's pole, IK/FK switch at IK) instead of the FK
        controls; the arms stay FK and the torso and spine are keyed as without it.""")

    # --- turning in place -----------------------------------------------------------
    turn_in_place_angle: float = setting(math.radians(75), "rad", 0.0, math.pi, """When the way
        ahead at the start lies further than this from the way the character faces (behind it,
        beside it), or the goal's heading further than this from the way the walk arrives, the
        character turns on the spot in pivot steps there instead of walking a loop. 0 switches
        turning in place off.""")
    turn_step_angle: float = setting(math.radians(60), "rad", math.radians(10), math.radians(75), """A
        pivot step of a turn in place turns a foot at most this far, and opens the feet at most
        this far apart.""")

    # --- the character's size ------------------------------------------------------
    body_scale: float = setting(1.0, "1", 1e-4, 1e4, """The character's size over the human's the
        other settings are for (its leg length over 0.84 m): set from the rig by the planner
        (``Settings.for_body``), so every length and speed above is a human's, scaled by it.""",
        lo_open=True, derived=True)

    def __post_init__(self):
        self.check()

    # ------------------------------------------------------------------ the table
    @classmethod
    def names(cls) -> list[str]:
        """The user's tunables (not the derived ``body_scale``)."""
        return [f.name for f in fields(cls) if not f.metadata.get("derived")]

    @classmethod
    def spec(cls, name: str) -> dict:
        """``{"type", "default", "unit", "min", "max", "min_open", "doc"}`` of a setting;
        SettingsError for an unknown name (or a derived one, which no one sets)."""
        for f in fields(cls):
            if f.name == name:
                return {"type": _TYPES[f.type], "default": f.default, **f.metadata}
        raise SettingsError(f"unknown setting {name!r}")

    # ------------------------------------------------------------------ values
    @classmethod
    def coerce(cls, name: str, value):
        """``value`` (a JSON or Python value) as the setting's type, range-checked."""
        spec = cls.spec(name)
        kind = spec["type"]
        if kind is bool:
            if not isinstance(value, (bool, int)) or value not in (0, 1):
                raise SettingsError(f"setting {name!r} wants true or false, got {value!r}")
            return bool(value)
        if isinstance(value, bool) or not isinstance(value, (int, float)) or (
                kind is int and not float(value).is_integer()):
            raise SettingsError(f"setting {name!r} wants {'an integer' if kind is int else 'a number'}"
                                f"{_unit(spec)}, got {value!r}")
        value = kind(value)
        _check_range(name, value, spec)
        return value

    @classmethod
    def parse(cls, name: str, text: str):
        """The string ``text`` (from ``--set NAME=VALUE``) as the setting's value."""
        spec = cls.spec(name.strip())
        if spec["derived"]:
            raise SettingsError(f"setting {name.strip()!r} is set by the planner from the character's rig")
        low = text.strip().lower()
        if spec["type"] is bool:
            if low not in _TRUE + _FALSE:
                raise SettingsError(f"setting {name.strip()!r} wants true or false, got {text!r}")
            return low in _TRUE
        try:
            value = spec["type"](low) if spec["type"] is float else int(float(low)) if float(low).is_integer() \
                else float(low)
        except ValueError:
            raise SettingsError(f"setting {name.strip()!r} wants {'an integer' if spec['type'] is int else 'a number'}"
                                f"{_unit(spec)}, got {text!r}") from None
        return cls.coerce(name.strip(), value)

    @classmethod
    def from_pairs(cls, pairs) -> "Settings":
        """Settings from ``NAME=VALUE`` strings (the CLI's ``--set``)."""
        changes = {}
        for pair in pairs:
            if "=" not in pair:
                raise SettingsError(f"--set wants NAME=VALUE, got {pair!r}")
            k, v = pair.split("=", 1)
            changes[k.strip()] = cls.parse(k, v)
        return cls().replace(**changes)

    def check(self) -> None:
        """SettingsError naming the first setting of the wrong type or out of its range (a
        length's or speed's range is a human's: checked at ``body_scale`` 1)."""
        self.coerce("body_scale", self.body_scale)
        for f in fields(self):
            v = getattr(self, f.name)
            if _TYPES[f.type] is float and isinstance(v, int) and not isinstance(v, bool):
                object.__setattr__(self, f.name, float(v))
            power = _SIZE_POWER.get(f.metadata["unit"], 0) if f.name != "body_scale" else 0
            value = getattr(self, f.name)
            self.coerce(f.name, value / self.body_scale ** power if power else value)

    def for_body(self, scale: float) -> "Settings":
        """These settings for a character ``scale`` times the human's size (``body_scale``;
        a rig's own: ``core.clips.body.body_scale``): every length and speed scaled by ``scale``
        over the present body scale, curvatures the other way (idempotent: the human's
        values are kept underneath)."""
        scale = float(scale)
        ratio = scale / self.body_scale
        if abs(ratio - 1.0) < 1e-12:
            return self
        data = asdict(self)
        for f in fields(self):
            power = _SIZE_POWER.get(f.metadata["unit"], 0)
            if power and f.name != "body_scale":
                data[f.name] = getattr(self, f.name) * ratio ** power
        data["body_scale"] = scale
        return Settings(**data)

    def length(self, metres: float) -> float:
        """``metres`` of a human (a stage's own constant) for this character: times
        ``body_scale``."""
        return metres * self.body_scale

    @property
    def straightens(self) -> bool:
        """Whether the search prices a way that is not straight (``weave_penalty`` or
        ``curvature_penalty`` above 0): then the library's straightest walk is offered
        straightened, and the standing feet stand as that walk puts them."""
        return self.weave_penalty > 0 or self.curvature_penalty > 0

    def replace(self, **changes) -> "Settings":
        """A copy with some fields changed; unknown names raise SettingsError naming them."""
        unknown = sorted(set(changes) - set(self.names()))
        if unknown:
            raise SettingsError(f"unknown setting(s): {', '.join(unknown)}")
        data = asdict(self)
        data.update(changes)
        return Settings(**data)

    def to_dict(self) -> dict:
        return asdict(self)


_TYPES = {"float": float, "int": int, "bool": bool, float: float, int: int, bool: bool}


def _unit(spec) -> str:
    return f" ({spec['unit']})" if spec["unit"] and spec["unit"] != "1" else ""


def _check_range(name: str, value, spec) -> None:
    lo, hi = spec["min"], spec["max"]
    if not math.isfinite(value) or (lo is not None and (value < lo or (spec["min_open"] and value == lo))) \
            or (hi is not None and value > hi):
        low = "" if lo is None else f"{'above' if spec['min_open'] else 'at least'} {lo:g}"
        high = "" if hi is None else f"at most {hi:g}"
        rng = " and ".join(x for x in (low, high) if x)
        raise SettingsError(f"setting {name!r} must be {rng}{_unit(spec)}, got {value!r}")
