"""Re-baking only what changed: a new bake's keys spliced into the old bake's, so that
every frame outside the re-planned span keeps its old value exactly.

Frames are whole scene frames. The old bake's span runs from frame ``fa`` (the stance of
the kept footprint before the change) to ``fb`` (the kept one after it); the new bake's
same span from ``ga`` to ``gb``. The spliced bake keeps the old keys up to the fade-in,
plays the new span mapped so that ``ga`` falls on ``fa``, and keeps the old keys after
the fade-out shifted by ``delta = (gb - ga) - (fb - fa)`` frames. The fades (smoothstep)
lie where both bakes agree on the planted foot: while the kept footprint's foot stands
and the other foot swings from a kept footprint to a re-planned one (fade in), or from a
re-planned one to a kept one (fade out). Pure numpy.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class SpanMap:
    """Where the old and the new bake's span lie (whole frames) and the fades (frames of
    the spliced bake: ``fade_in`` at the span's start, ``fade_out`` at its end)."""

    fa: int
    fb: int
    ga: int
    gb: int
    fade_in: tuple[int, int]
    fade_out: tuple[int, int]

    @property
    def delta(self) -> int:
        return (self.gb - self.ga) - (self.fb - self.fa)

    @property
    def end(self) -> int:
        """The span's end in the spliced bake."""
        return self.fa + (self.gb - self.ga)

    def frames(self, old_first: int, old_last: int) -> np.ndarray:
        """The spliced bake's frames: the old ones, the span's length changed by delta."""
        return np.arange(old_first, old_last + self.delta + 1)

    def changed(self) -> tuple[int, int]:
        """The first and last frame (of the spliced bake) whose value may differ from the
        old bake's (at the same frame before the span, shifted by delta after it)."""
        return self.fade_in[0] + 1, self.fade_out[1] - 1

    @classmethod
    def fitted(cls, fa: int, fb: int, ga: int, gb: int, fade_in, fade_out, least: int = 2) -> "SpanMap":
        """A SpanMap with its fades put in order: each at least ``least`` frames, the
        fade-in ending before the fade-out starts."""
        end = fa + (gb - ga)
        i0, i1 = int(min(fade_in[0], fa)), int(max(fade_in[1], fade_in[0] + least))
        o0, o1 = int(fade_out[0]), int(max(fade_out[1], fade_out[0] + least, end))
        o0 = min(o0, end)
        if i1 > o0:  # (a very short span: fade straight from one into the other)
            mid = (i0 + o1) // 2
            i1, o0 = min(i1, mid), max(o0, mid)
        return cls(int(fa), int(fb), int(ga), int(gb), (i0, i1), (o0, o1))


def _smooth(x: np.ndarray) -> np.ndarray:
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def weights(out_f: np.ndarray, span: SpanMap) -> np.ndarray:
    """(F,) the new bake's share at the spliced frames: 0 before the fade-in, rising over
    it, 1 until the fade-out, falling over it, 0 after."""
    (i0, i1), (o0, o1) = span.fade_in, span.fade_out
    rise = _smooth((out_f - i0) / max(i1 - i0, 1))
    fall = _smooth((o1 - out_f) / max(o1 - o0, 1))
    return np.minimum(rise, fall)


def splice_curve(old_first: int, old_values: np.ndarray, new_first: int, new_values: np.ndarray,
                 span: SpanMap) -> tuple[np.ndarray, np.ndarray]:
    """(frames, values) of one spliced channel: ``old_values`` are its keys at whole frames
    from ``old_first`` in the old bake, ``new_values`` from ``new_first`` in the new one.
    Outside the fades the old keys are copied as they are."""
    old_values, new_values = np.asarray(old_values, float), np.asarray(new_values, float)
    out_f = span.frames(old_first, old_first + len(old_values) - 1)
    late = out_f >= span.fade_out[0]  # the old value comes shifted by delta from here on
    old_idx = np.clip(np.where(late, out_f - span.delta, out_f) - old_first, 0, len(old_values) - 1)
    new_idx = np.clip(out_f - span.fa + span.ga - new_first, 0, len(new_values) - 1)
    values = old_values[old_idx]
    w = weights(out_f, span)
    mix = w > 0
    values[mix] = (1.0 - w[mix]) * values[mix] + w[mix] * new_values[new_idx[mix]]
    return out_f, values


def region(spans: list[tuple[int, int]], n_new: int, n_old: int, to_goal: bool) -> tuple[int, int | None, int | None]:
    """(a, b_new, b_old): the re-planned region as footprint indices of the new path (a and
    b_new) and of the old (a, b_old); b is None when the region runs to the goal."""
    a = min(s[0] for s in spans)
    if to_goal:
        return a, None, None
    b_new = max(s[1] for s in spans)
    return a, b_new, b_new - (n_new - n_old)


def span_map(old: np.ndarray, new: np.ndarray, a: int, b_new: int | None, b_old: int | None, old_last: int,
             new_last: int) -> SpanMap:
    """Where the region lies in the old bake's frames and the new's (``old``, ``new``:
    planted frames (N, 3) strike, stance, liftoff), with the fades where both bakes
    agree on the planted foot: the kept footprint's foot stands while the other swings."""
    S, M, L = 0, 1, 2
    fa, ga = int(round(old[a, M])), int(round(new[a, M]))
    to_spliced = lambda x: x - ga + fa  # noqa: E731  (new frames onto the spliced bake's)
    i0 = old[a - 1, L] if a >= 1 else fa
    i1 = min(old[a + 1, S], to_spliced(new[a + 1, S])) if a + 1 < min(len(old), len(new)) else fa + 2
    if b_new is None:
        end = to_spliced(new_last)
        return SpanMap.fitted(fa, int(old_last), ga, int(new_last), (round(i0), round(i1)), (end + 1, end + 3))
    fb, gb = int(round(old[b_old, M])), int(round(new[b_new, M]))
    delta = (gb - ga) - (fb - fa)
    o0 = max(old[b_old - 1, L] + delta, to_spliced(new[b_new - 1, L]))
    has_next = b_old + 1 < len(old) and b_new + 1 < len(new)
    o1 = min(old[b_old + 1, S] + delta, to_spliced(new[b_new + 1, S])) if has_next else to_spliced(gb) + 2
    return SpanMap.fitted(fa, fb, ga, gb, (round(i0), round(i1)), (round(o0), round(o1)))


def spliced_planted(old: np.ndarray, new: np.ndarray, a: int, b_new: int | None, b_old: int | None,
                    span: SpanMap) -> np.ndarray:
    """(M, 3) each footprint's strike, stance and liftoff frames in the spliced bake: the
    old bake's up to the region, the new bake's (shifted onto the old start) inside it,
    the old bake's shifted by delta after it."""
    parts = [old[:a + 1], new[a + 1:b_new] - span.ga + span.fa]
    if b_new is not None:
        parts.append(old[b_old:] + span.delta)
    return np.concatenate(parts)


__all__ = ["SpanMap", "region", "span_map", "splice_curve", "spliced_planted", "weights"]
