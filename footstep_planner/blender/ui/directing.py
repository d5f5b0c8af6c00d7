"""The animator directs: a plan edited as data (PLAN.json) or in the viewport (handles),
a way through waypoints, and a re-bake that keys only the re-planned span.

Each is a ``route`` for ``planning.run_steps`` (it replaces the search) and, for a
re-bake, an ``after_bake`` that splices the new keys into the old bake's
(``rebake.splice_action``) so that every frame outside the span stays as it was.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from ...core.perform import turn_in_place
from ...core.perform.directed import MAX_STAND
from ...core.base.errors import FootstepError
from ...core.base.settings import Settings
from ...core.footprint import PIVOT
from ...core.jobs import MAX_FRAME
from ...core.plan.plan_edit import Edited, edited_path, first_footprint, in_frame
from ...core.plan.plan_file import PlanFile
from ...core.solve import splice as splicing
from ...core.perform.waypoints import Waypoint, plan_via
from ..write import rebake
from ..write.owned import ROUND_OTHERS_PROP


class DirectingError(FootstepError):
    """An edit that can't be honoured: names the footprint or waypoint and why."""


@dataclass
class EditedRoute:
    """``run_steps``'s route for an edited plan; keeps what the edit made (``edited``).
    ``goal``: (position (3,), Z rotation or None) where the character's Goal object is now,
    ``start``: its Start object; where either moved since the plan, the way from the last
    lock to the goal, or from the start to the first lock, is searched again
    (``core.plan.plan_edit.edited_path``). None: the plan's own."""

    plan: PlanFile
    edited: Edited | None = None
    goal: tuple | None = None
    start: object = None

    def __call__(self, setup, start, heading):
        from ..read.scene import rotation_heading

        goal = heading = None
        if self.goal is not None:
            goal = np.asarray(self.goal[0], float)
            heading = None if self.goal[1] is None else rotation_heading(self.goal[1], setup.forward)
        self.edited = edited_path(setup.planner, self.plan, goal, heading, self._first(setup))
        return self.edited.result

    def goal_of_plan(self) -> tuple:
        """(goal (3,) or None, heading from the plan's forward or None) the re-plan went to:
        the Goal object's where one was given, else the plan's (the handles remade keep it,
        so the next re-plan sees the goal where it is)."""
        from ..read.scene import rotation_heading

        if self.goal is None:
            return self.plan.goal, self.plan.goal_heading
        rot = self.goal[1]
        return np.asarray(self.goal[0], float), None if rot is None else rotation_heading(rot, self.plan.forward)

    def _first(self, setup):
        """The foot of the plan's first footprint standing at the Start object (None
        without one)."""
        from .. import planning

        if self.start is None:
            return None
        foot = self.plan.footprints[0].foot
        return planning.marker_footprints(self.start, setup)[foot]

    def standing(self, setup) -> list:
        """The feet the plan starts standing on: its first footprint (at the Start object
        where that moved) and the other beside it (``core.plan.setup.standing_with``),
        wherever the character's object stands now."""
        from ...core.plan.setup import standing_with

        first = first_footprint(in_frame(self.plan, setup.forward)[0], self._first(setup))
        return standing_with(first, setup, f"the first footprint of {self.plan.character!r}'s plan")


@dataclass
class ViaRoute:
    """``run_steps``'s route through waypoints (their headings a Z rotation, or None), each
    with the seconds to stand there (``pauses``, by name) and the scene frame to arrive on
    (``arrive``, by name; the goal's name too)."""

    waypoints: list  # (name, position (3,), heading or None)
    pauses: dict = field(default_factory=dict)  # name -> s
    arrive: dict = field(default_factory=dict)  # name -> scene frame
    route: object = None  # the core Route (its ``arrivals``: the footprint reaching each), once planned
    stops: set = field(default_factory=set)  # names the path stops at with no pause of its own (to wait)
    hurry: set = field(default_factory=set)  # names the way to which runs where that is quicker

    def __call__(self, setup, start, heading):
        from ..read.scene import rotation_heading

        self.wps = [Waypoint(name, np.asarray(pos, float), None if h is None else rotation_heading(h, setup.forward),
                             pause=float(self.pauses.get(name, 0.0)), stop=name in self.stops,
                             hurry=name in self.hurry)
                    for name, pos, h in self.waypoints]
        from ...core.synth.pipeline import standing_body

        body = standing_body(setup.library, setup.analyses)
        head = turn_in_place.start_turn(setup.planner, start, self.wps[0].position, body)
        self.route = plan_via(setup.planner, [head[-1]] if head else start, self.wps, body)
        if head:  # (the way leaves from the turned feet: the turn's pivot steps come first)
            res = self.route.result
            fps = head[:-1] + [replace(res.footprints[0], label=PIVOT)] + list(res.footprints[1:])
            self.route = replace(self.route, result=replace(res, footprints=fps),
                                 arrivals=[i + len(head) - 1 for i in self.route.arrivals])
        return self.route.result

    def marks(self, fps: float, frame_start: float) -> list:
        """The waypoints on the planned path (``core.perform.directed.Mark``), the goal last; their
        arrival frames in seconds from ``frame_start``."""
        from ...core.perform.directed import Mark

        out = []
        for k, (wp, i) in enumerate(zip(self.wps, self.route.arrivals)):
            last = k + 1 == len(self.wps)
            frame = self.arrive.get(wp.name)
            out.append(Mark(wp.name, i, wp.position, wp.heading, stop=wp.stops or last, pause=wp.pause,
                            arrive=None if frame is None else (float(frame) - frame_start) / fps))
        return out

    def retime(self, ex, can_run: bool) -> bool:
        """Change the route so that the arrival ``ex`` (a ``TimingError``) may be met, if
        there is a way: too soon, run (``can_run``: the library has a run) on the way to
        it since the waypoint before with a frame of its own; early with nowhere to wait,
        stop at that waypoint. Whether it changed (then plan the route again)."""
        names = [w[0] for w in self.waypoints]
        since = names.index(ex.anchor) + 1 if ex.anchor in names else 0
        if ex.kind == "soon" and can_run:
            way = set(names[since:names.index(ex.mark) + 1])
            if not way <= self.hurry:
                self.hurry |= way
                return True
        if ex.kind == "early" and ex.anchor in names[:-1] and ex.anchor not in self.stops:
            self.stops.add(ex.anchor)
            return True
        return False

    def laid(self, marks: list) -> None:
        """The footprint reaching each waypoint, as performed (``core.perform.run.MarkedRoute``)."""
        if self.route is not None:
            self.route = replace(self.route, arrivals=[int(m.index) for m in marks])

    def reached(self, scene) -> dict:
        """{footprint index: the waypoint object} of the planned route's waypoints (not the
        goal) that are objects of ``scene``: the footprints their handles lock and move
        with them (``handles.make_handles``)."""
        if self.route is None:
            return {}
        out = {}
        for (name, _, _), i in zip(self.waypoints[:-1], self.route.arrivals[:-1]):
            ob = scene.objects.get(name)
            if ob is not None:
                out[int(i)] = ob
        return out

    @property
    def directed(self) -> bool:
        """Whether the path stops on the way or has frames to meet."""
        return bool(self.arrive) or any(p > 0 for p in self.pauses.values()) or bool(self.stops)


def waypoints_of(scene, names) -> list:
    """(name, position (3,), heading or None) per waypoint, in order: an object by name
    (an empty you turned: with the way it faces; unturned, it sets no heading and is
    passed facing the next), or each point of a curve object in its order."""
    from .. import planning

    out = []
    for name in names:
        ob = scene.objects.get(name)
        if ob is None:
            raise DirectingError(f"no object named {name!r} for a waypoint")
        if ob.type == "CURVE":
            pts = [ob.matrix_world @ p.co.xyz for sp in ob.data.splines
                   for p in (sp.bezier_points if sp.type == "BEZIER" else sp.points)]
            if not pts:
                raise DirectingError(f"curve {name!r} has no points to pass through")
            out += [(f"{name}[{i}]", np.array(p, float), None) for i, p in enumerate(pts)]
        else:
            position, heading = planning.goal_of(scene, name)
            turned = abs(ob.matrix_world.to_euler().z) > 1e-6
            out.append((name, position, heading if turned else None))
    return out


def via_route(scene, names, goal_name: str, goal, heading, pauses=None, arrive=None) -> "ViaRoute | None":
    """The route through the waypoints ``names`` (``waypoints_of``), then the goal, or None
    without any (and no arrival frame for the goal). ``pauses`` (name -> s) and ``arrive``
    (name -> scene frame) must name waypoints (the goal too, for ``arrive``): DirectingError
    naming the one that isn't, or a pause or frame out of range."""
    wps = waypoints_of(scene, names) if names else []
    pauses, arrive = dict(pauses or {}), dict(arrive or {})
    known = [n for n, _, _ in wps]
    for what, table, allowed in (("--pause", pauses, known), ("--arrive", arrive, known + [goal_name])):
        for n, v in table.items():
            if n not in allowed:
                raise DirectingError(f"{'a pause' if what == '--pause' else 'an arrival frame'} ({what}) names {n!r}, "
                                     "which is not " + (f"a waypoint (--via {','.join(known)})" if known
                                                        else "a waypoint (give --via)")
                                     + (f" nor the goal ({goal_name!r})" if what == "--arrive" else ""))
            if not np.isfinite(v) or v < 0 or (what == "--pause" and v > MAX_STAND) or v > MAX_FRAME:
                raise DirectingError(f"{what} {n}={v:g}: must be " + (
                    f"0 to {MAX_STAND:g} seconds" if what == "--pause" else f"a frame number from 0 to {MAX_FRAME}"))
    if not wps and not arrive:
        return None
    return ViaRoute(wps + [(goal_name, goal, heading)], pauses, arrive)


def plan_document(ob, planned, goal) -> dict:
    """The PLAN.json of a plan (``core.perform.run.Planned``): its footprints, none locked."""
    fps = planned.result.footprints
    fwd = np.asarray(planned.setup.forward, float)
    return PlanFile(ob.name, np.array([fwd[0], fwd[1], 0.0]), fps, np.zeros(len(fps), bool),
                    None if goal is None else np.asarray(goal, float), planned.goal_heading).to_dict()


@dataclass
class Splice:
    """A re-bake's splice for ``run_steps``: the old bake's keys, footprints and frames,
    read before the new bake replaced it. ``before_ik`` pins the new path's footprints
    outside the re-planned region to the old bake's places; ``after_bake`` splices the
    region into the old keys (``rebake.splice_action``)."""

    old_keys: dict
    old_planted: np.ndarray  # (N, 3) frames
    old_footprints: np.ndarray  # (N, 4)
    old_last: int
    route: EditedRoute
    span: object = None
    slid_mm: float = 0.0  # the splice's worst slide, when it was given up for a whole bake

    @classmethod
    def of(cls, ob, route: EditedRoute) -> "Splice | None":
        """The splice for re-baking ``ob``, or None when it has no bake of the planner's
        that recorded its footprints (then the whole path is baked)."""
        from ..write.bake import owned_tracks

        acts = [st.action for tr in owned_tracks(ob) for st in tr.strips if rebake.recorded(st.action)]
        if not acts:
            return None
        planted, footprints = rebake.recorded(acts[0])
        return cls(rebake.channel_keys(acts[0]), planted, footprints, int(acts[0].frame_range[1]), route)

    def _region(self, n_new: int):
        ed = self.route.edited
        if ed is None or not ed.spans or len(self.old_planted) != len(self.route.plan.footprints):
            return None
        return splicing.region(ed.spans, n_new, len(self.old_planted), ed.to_goal)

    def before_ik(self, planned) -> None:
        """Put the footprints outside the region where the old bake put them."""
        refined = planned.synthesis.final.refined
        reg = self._region(len(refined.position))
        if reg is None:
            return
        a, b_new, b_old = reg
        keep = [(i, i) for i in range(a + 1)]
        if b_new is not None:
            keep += [(b_new + j, b_old + j) for j in range(len(self.old_footprints) - b_old)]
        for new_i, old_i in keep:
            refined.position[new_i] = self.old_footprints[old_i, :3]
            refined.heading[new_i] = self.old_footprints[old_i, 3]

    def after_bake(self, act, track, planted, frames, frame_start, fps):
        reg = self._region(len(planted))
        if reg is None:
            return planted, frames
        a, b_new, b_old = reg
        new = frame_start + np.asarray(planted, float) * fps
        self.span = splicing.span_map(self.old_planted, new, a, b_new, b_old, self.old_last, int(act.frame_range[1]))
        rebake.splice_action(act, self.old_keys, self.span)
        rebake.fit_strips(track.id_data, act)
        timed = (splicing.spliced_planted(self.old_planted, new, a, b_new, b_old, self.span) - frame_start) / fps
        return [tuple(row) for row in timed], int(act.frame_range[1]) - int(frame_start) + 1


def rebake_handles(scene, ob, settings=None, name: str | None = None, body_on: str = "OBJECT",
                   frame_range: bool = True) -> tuple[dict, EditedRoute, "Splice | None"]:
    """Re-plan from the character's handles (locked and moved footprints kept, the way
    around what changed searched again) and re-bake: with an earlier bake of the planner's
    whose stances are recorded, only the re-planned span is re-keyed. The handles then show
    the new path (locks kept). Round other characters, those it now meets are re-planned
    round it (``rebake_steps``). Returns (report, route, splice)."""
    from .. import planning

    return planning.run_to_end(rebake_steps(scene, ob, settings, name, body_on, frame_range))


def rebake_steps(scene, ob, settings=None, name: str | None = None, body_on: str = "OBJECT",
                 frame_range: bool = True, others_too: bool = True, baked: list | None = None):
    """``rebake_handles`` one stage at a time: a generator yielding (fraction done, next
    stage) as ``planning.run_steps`` does and returning (report, route, splice). Stopped at
    a yield (closed), it leaves the scene as it was: the bake is taken back before its
    quality is accepted, and the handles are remade only at the end.

    Round other characters (``Settings.avoid_characters``, or a bake of the character
    made round them, as a shot baked together is: ``ROUND_OTHERS_PROP``) the edited
    character leads: it is planned round the others but those with footprint handles of
    their own (they can give way); then each of those it now meets as played (``meets``)
    is re-planned round every other character, its own footprints that meet one in time
    searched again between its nearest locks (``core.plan.plan_edit``: the rest of its path
    and keys stay), and the report's ``others_replanned`` says who, how near they had come
    and how near they now come. Stopped while one of those is re-planned, the edited
    character's bake stays and that one's is taken back: each character whose re-bake
    stands is appended to ``baked`` as it does."""
    from .. import planning
    from ..write.bake import owned_tracks
    from . import handles

    edit = edit_of(scene, ob, settings, others_too)
    plan, settings, yielding, route = edit.plan, edit.settings, edit.yielding, edit.route
    reached = handles.waypoints_reached(ob)
    tracks = owned_tracks(ob)
    splice = Splice.of(ob, route)
    if name is None and tracks:
        from ..write.bake import bake_name

        name = bake_name(tracks[0].strips[0].action)
    doc = yield from planning.run_steps(scene, ob, edit.goal, None, None, settings, name=name,
                                        frame_start=edit.frame_start, body_on=body_on, frame_range=frame_range,
                                        route=route, splice=splice, not_around=tuple(o.name for o in yielding))
    fps = route.edited.result.footprints
    locked = _carried_locks(plan, route.edited, len(fps))
    handles.make_handles(scene, ob, fps, plan.forward, *route.goal_of_plan(), locked,
                         _carried_waypoints(reached, fps))
    show_replanned(scene, route.edited)
    edit_report(doc, route, splice)
    if baked is not None:
        baked.append(ob)
    if yielding:
        doc["others_replanned"] = yield from _give_way(scene, ob, doc, settings, yielding, frame_range, baked)
    return doc, route, splice


@dataclass
class Edit:
    """What a re-plan of a character's handles is made of (``edit_of``): its plan read back,
    the settings (round the others where its bake was), those that may give way to it, the
    route that makes the plan whole, its goal and its bake's first frame (None: unbaked)."""

    plan: PlanFile
    settings: Settings
    yielding: list
    route: EditedRoute
    goal: np.ndarray
    frame_start: int | None


def edit_of(scene, ob, settings=None, others_too: bool = True) -> Edit:
    """The re-plan of ``ob``'s handles as Re-plan makes it (``rebake_steps``) and the live
    update shows it (``live``): DirectingError when it has none."""
    from .. import planning
    from ..write.bake import owned_tracks
    from . import handles

    plan, _ = handles.read_plan(ob)
    if not plan.footprints:
        raise DirectingError(f"{ob.name!r} has no footprint handles: plan first, then edit the footprints")
    settings = settings or Settings()
    tracks = owned_tracks(ob)
    if not settings.avoid_characters and any(st.action.get(ROUND_OTHERS_PROP) for tr in tracks for st in tr.strips):
        settings = settings.replace(avoid_characters=True)  # (baked round the others: re-planned round them)
    yielding = _can_give_way(scene, ob) if settings.avoid_characters and others_too else []
    goal_ob, start_ob = directed_by(scene, ob)
    route = EditedRoute(plan, goal=None if goal_ob is None else planning.object_goal(goal_ob), start=start_ob)
    goal = route.goal[0] if route.goal is not None else plan.goal if plan.goal is not None \
        else plan.footprints[-1].position
    return Edit(plan, settings, yielding, route, np.asarray(goal, float),
                int(tracks[0].strips[0].frame_start) if tracks else None)


def directed_by(scene, ob) -> tuple:
    """(Goal object, Start object) the panel sets for ``ob`` (as its character, or in its
    list of characters), either None where it sets none (the 3D cursor, where it stands)."""
    fs = scene.footstep
    if fs.character == ob:
        return fs.goal, fs.start
    for entry in fs.cast:
        if entry.character == ob:
            return entry.goal, entry.start
    return None, None


def _can_give_way(scene, ob) -> list:
    """The other characters the planner baked in the scene that have footprint handles of
    their own (a re-plan can move them), in ``planning.other_characters``' order."""
    from .. import planning
    from . import handles

    return [o for o, _ in planning.other_characters(scene, ob) if handles.owned_collection(o) is not None]


def meets(fig: dict, clearance: float) -> bool:
    """Whether a pair's figures as played (``core.report.crowd.pair_figures``) say the two
    meet: their bodies nearer than ``clearance`` (m, ``Settings.character_clearance``) or a
    foot of each on one footprint."""
    return fig["least_distance_m"] < clearance or fig["frames_on_one_footprint"] > 0


def _give_way(scene, ob, doc: dict, settings, yielding: list, frame_range: bool, baked: list | None):
    """Each of ``yielding`` that ``ob``'s bake (its report ``doc``) now meets, re-planned
    round every other character (``rebake_steps`` of its handles), one after another; a
    generator of their stages, returning a row per one re-planned: who, how near the two
    had come (and on which frame), the spans re-planned and how near it now comes to
    ``ob``, or why it could not be."""
    from .. import planning
    from ..write.bake import owned_tracks
    from ..write.owned import BODY_PROP

    figures = doc["quality"].get("others") or []
    others = [o for o, _ in planning.other_characters(scene, ob)]
    near = {o.as_pointer(): f for o, f in zip(others, figures)}
    rows = []
    for other in yielding:
        fig = near.get(other.as_pointer())
        if fig is None or not meets(fig, settings.character_clearance):
            continue
        row = {"character": other.name, "was_m": fig["least_distance_m"], "was_frame": fig["least_distance_frame"],
               "was_frames_on_one_footprint": fig["frames_on_one_footprint"]}
        body_on = next((str(st.action.get(BODY_PROP, "OBJECT")) for tr in owned_tracks(other) for st in tr.strips),
                       "OBJECT")
        try:
            sub, _, _ = yield from _labelled(rebake_steps(scene, other, settings, body_on=body_on,
                                                          frame_range=frame_range, others_too=False,
                                                          baked=baked), other.name)
        except FootstepError as ex:
            row["error"] = str(ex)
        else:
            theirs = [o for o, _ in planning.other_characters(scene, other)]  # (its figures, in this order)
            mine = next((f for o, f in zip(theirs, sub["quality"].get("others") or []) if o == ob), None)
            row["replanned"] = sub.get("replanned", [])
            if mine is not None:
                row["now_m"], row["now_frame"] = mine["least_distance_m"], mine["least_distance_frame"]
                row["now_frames_on_one_footprint"] = mine["frames_on_one_footprint"]
        rows.append(row)
    return rows


def _labelled(steps, label: str):
    """A stage generator's stages with ``label`` before each; its return value returned,
    and closed with it (a bake not yet measured is taken back)."""
    try:
        while True:
            try:
                fraction, stage = next(steps)
            except StopIteration as done:
                return done.value
            yield fraction, f"{label}: {stage}"
    finally:
        steps.close()


def edit_report(doc: dict, route: EditedRoute, splice: "Splice | None") -> None:
    """What an edited plan's bake adds to its report: the re-planned spans and either the
    frames re-keyed or why the whole path was."""
    doc["replanned"] = [list(s) for s in route.edited.spans]
    if splice is not None and splice.span is not None:
        doc["rebaked_frames"] = list(splice.span.changed())
    elif splice is not None and splice.slid_mm:
        doc["rebaked_whole"] = (f"the edit turned the walk too far round the kept footprints to re-key only its span "
                                f"(a planted foot slid {splice.slid_mm:.1f} mm there): the whole path was re-baked")


def show_replanned(scene, edited: Edited) -> None:
    """Ring the footprints the re-plan made in the overlay."""
    from . import overlay

    made = [f.position for a, b in edited.spans for f in edited.result.footprints[a + 1:b]]
    overlay.mark(scene, replanned=np.array(made, float).reshape(-1, 3), refused=np.zeros((0, 3)))


def _carried_waypoints(reached: list, fps: list) -> dict:
    """{new index: waypoint} of the footprints that reached a waypoint (``reached``:
    (position, waypoint), as ``handles.waypoints_reached`` read them: locked, so kept
    exactly) in the new path ``fps``."""
    at = {tuple(np.round(f.position, 9)): i for i, f in enumerate(fps)}
    out = {}
    for pos, w in reached:
        i = at.get(tuple(np.round(np.asarray(pos, float), 9)))
        if i is not None:
            out[i] = w
    return out


def _carried_locks(plan: PlanFile, edited: Edited, n: int) -> np.ndarray:
    """The new path's locks: the old locks (and moved footprints) at their new indices."""
    old = np.asarray(plan.locked, bool)
    out = np.zeros(n, bool)
    kept = {tuple(np.round(f.position, 9)) for f, lk in zip(plan.footprints, old) if lk}
    for i, f in enumerate(edited.result.footprints):
        out[i] = tuple(np.round(f.position, 9)) in kept
    return out
