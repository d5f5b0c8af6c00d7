"""Characters baked together in one space and time (``bake --job JOBS.json --together``):
a ``Shot`` that the jobs of one run share.

- Each job is planned round those baked before it in the shot as their IK solved them
  (``core.solve.frames.solved_world``: what their bakes key and Blender plays, as each
  job's own measure confirms), so no pass of the scene is played between two jobs.
- The characters baked before the shot and the obstacles that move are read as Blender
  plays them, once for the shot (one pass of ``scene.frame_set`` from a first frame), and
  kept: nothing the shot bakes moves them.
- Every job's bake is measured at the end, in one pass of the scene as Blender plays it with
  every character of the shot in it (``Shot.close``, then ``played_matrices``): each job
  against every other character, those after it too.

A pass costs a depsgraph evaluation per frame of everything animated in the scene, so a
pass per job costs the square of the characters; the shot's cost grows with their number.
Members are told apart by identity (the object), never by name.
"""

from __future__ import annotations

from ..core.report import crowd
from ..core.solve.frames import Solved, solved_world
from .read.surfaces import tagged_objects
from .write import bake as baking


class Shot:
    """The jobs of one run planned together in ``scene``: the bodies their IK solved, the
    passes played for them, and (once ``close``d) the one pass they are all measured in."""

    def __init__(self, scene):
        self.scene = scene
        self._solved: dict[int, tuple] = {}  # object pointer -> (object, body, first frame, frames)
        self._obstacles: dict = {}  # the obstacles the jobs named (names, in order)
        self._passes: dict[tuple, tuple] = {}  # (first frame, characters, objects) -> (frames, matrices)
        self._final = None
        self._worlds: dict[int, object] = {}  # object pointer -> its bones' world matrices over the one pass
        #: (lead s, rate): the search's clock the shot's last synthesis kept (``others.fit_clock``),
        #: which the next job's search starts on (a job's own re-plans then fit its own)
        self.clock: tuple | None = None

    def add(self, ob, rig, solved: Solved, frame_start: int, fps: float, obstacles=()) -> None:
        """``ob``'s bake in the shot: its body as ``solved`` (played from ``frame_start``),
        which the later jobs go round; ``obstacles`` the objects its job named as such."""
        body = crowd.body_of(ob.name, rig, solved_world(rig, solved), fps)
        self._solved[ob.as_pointer()] = (ob, body, int(frame_start), solved.ik.frames)
        self._obstacles.update(dict.fromkeys(obstacles))

    def drop(self, ob) -> None:
        """``ob``'s bake taken back: no later job goes round it."""
        self._solved.pop(ob.as_pointer(), None)

    def bodies(self, characters, first: int, frames: int) -> dict[int, crowd.PlayedBody]:
        """The bodies of those of ``characters`` ((object, Rig)) baked in the shot, over
        ``frames`` frames from scene frame ``first`` (``crowd.held``), by object pointer."""
        out = {}
        for ob, _ in characters:
            got = self._solved.get(ob.as_pointer())
            if got is not None and got[0] == ob:
                out[ob.as_pointer()] = crowd.held(got[1], got[2], first, frames)
        return out

    def last_frame(self) -> int:
        """The last frame a bake of the shot plays (0 when it has none)."""
        return max((f + n - 1 for _, _, f, n in self._solved.values()), default=0)

    def close(self, characters) -> None:
        """Every job baked: the measures from now on read the one pass of ``characters``
        ((object, Rig): every character the planner baked in the scene) and the obstacles
        (the tagged ones and those the jobs named, as each measure reads them) over the
        shot's frames."""
        if not self._solved:
            return
        first = min(f for _, _, f, _ in self._solved.values())
        frames = self.last_frame() - first + 1
        objects = tagged_objects(self.scene, (), tuple(self._obstacles))[1]
        played, moved = baking.played_matrices(self.scene, characters, first, frames, objects)
        self._worlds.clear()
        self._final = (first, frames, {ob.as_pointer(): m for (ob, _), m in zip(characters, played)},
                       {ob.as_pointer(): m for ob, m in zip(objects, moved)})

    def _in_final(self, frame_start: int, frames: int) -> int | None:
        """Where ``frames`` frames from ``frame_start`` begin in the one pass (closed), or
        None where the pass does not hold them."""
        if self._final is None:
            return None
        a = int(frame_start) - self._final[0]
        return a if 0 <= a and a + int(frames) <= self._final[1] else None

    def played_world(self, ob, frame_start: int, m):
        """``bake.played_world`` of ``ob``'s ``m`` (its ``played_matrices`` from
        ``frame_start``): once closed, of the one pass, made once for every job measured
        against ``ob`` and given over each job's frames."""
        frames, a = len(m[0]), self._in_final(frame_start, len(m[0]))
        if a is None or ob.as_pointer() not in self._final[2]:
            return baking.played_world(*m)
        world = self._worlds.get(ob.as_pointer())
        if world is None:
            world = self._worlds[ob.as_pointer()] = baking.played_world(*self._final[2][ob.as_pointer()])
        return world[a:a + frames]

    def played_matrices(self, scene, characters, frame_start: int, frames: int, objects=()) -> tuple[list, list]:
        """``bake.played_matrices`` of these in ``scene`` (the shot's), from the shot's one pass where it holds them all
        over those frames (once ``close``d), else from a pass of their own, kept for the shot
        (the characters before it and the obstacles that move, read once)."""
        frame_start, frames = int(frame_start), int(frames)
        a = self._in_final(frame_start, frames)
        if a is not None:
            chars, objs = self._final[2], self._final[3]
            if all(ob.as_pointer() in chars for ob, _ in characters) and all(ob.as_pointer() in objs for ob in objects):
                return ([tuple(m[a:a + frames] for m in chars[ob.as_pointer()]) for ob, _ in characters],
                        [objs[ob.as_pointer()][a:a + frames] for ob in objects])
        key = (frame_start, tuple(ob.as_pointer() for ob, _ in characters), tuple(ob.as_pointer() for ob in objects))
        kept = self._passes.get(key)
        if kept is None or kept[0] < frames:  # (a longer pass replaces a shorter one)
            kept = self._passes[key] = (frames, baking.played_matrices(self.scene, characters, frame_start, frames,
                                                                         objects))
        played, moved = kept[1]
        return [tuple(m[:frames] for m in p) for p in played], [m[:frames] for m in moved]


__all__ = ["Shot"]
