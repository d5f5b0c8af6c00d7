"""Re-baking only what changed: a new bake's keys spliced into the old bake's, so that
every frame outside the re-planned span keeps its old value exactly.

Frames are whole scene frames. The old bake's span runs from frame ``fa`` (the stance of
the lock before the change) to ``fb`` (the lock after it); the new bake's same span from
``ga`` to ``gb``. The result keeps the old keys up to ``fa``, plays the new span from
``fa`` on (``ga`` mapped to ``fa``), and the old keys after ``fb`` shifted by
``delta = (gb - ga) - (fb - fa)`` frames; over ``blend`` frames inside each end of the
span the values cross-fade (smoothstep) from the old to the new and back. Pure numpy.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class SpanMap:
    """Where the old and the new bake's span lie (whole frames), and the blend."""

    fa: int
    fb: int
    ga: int
    gb: int
    blend: int

    @property
    def delta(self) -> int:
        return (self.gb - self.ga) - (self.fb - self.fa)

    def frames(self, old_first: int, old_last: int) -> np.ndarray:
        """The spliced bake's frames: the old ones, the span's length changed by delta."""
        return np.arange(old_first, old_last + self.delta + 1)

    def changed(self) -> tuple[int, int]:
        """The first and last frame (of the spliced bake) whose value may differ from the
        old bake's (at the same frame before the span, shifted by delta after it)."""
        return self.fa + 1, self.fa + (self.gb - self.ga) - 1


def _smooth(x: np.ndarray) -> np.ndarray:
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def splice_curve(old_first: int, old_values: np.ndarray, new_first: int, new_values: np.ndarray,
                 span: SpanMap) -> tuple[np.ndarray, np.ndarray]:
    """(frames, values) of one spliced channel: ``old_values`` are its keys at whole frames
    from ``old_first`` in the old bake, ``new_values`` from ``new_first`` in the new one.
    Outside the span the old keys are copied as they are."""
    old_values, new_values = np.asarray(old_values, float), np.asarray(new_values, float)
    out_f = span.frames(old_first, old_first + len(old_values) - 1)
    end = span.fa + (span.gb - span.ga)  # where the span ends in the spliced bake
    # the old value to keep (or to cross-fade from): unshifted in the span's first half,
    # shifted by delta in its second half and after it
    late = (out_f - span.fa) > (end - out_f)
    old_idx = np.clip(np.where(late, out_f - span.delta, out_f) - old_first, 0, len(old_values) - 1)
    new_idx = np.clip(out_f - span.fa + span.ga - new_first, 0, len(new_values) - 1)
    values = old_values[old_idx]
    inside = (out_f > span.fa) & (out_f < end)
    b = max(int(span.blend), 1)
    w = np.minimum(_smooth((out_f - span.fa) / b), _smooth((end - out_f) / b))[inside]
    values[inside] = (1.0 - w) * values[inside] + w * new_values[new_idx[inside]]
    return out_f, values


__all__ = ["SpanMap", "splice_curve"]
