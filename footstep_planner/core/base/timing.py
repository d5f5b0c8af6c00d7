"""Stage timing from outside the algorithms: ``with timer("smoothing"): ...``.

A stage's seconds add up when it runs more than once (the synthesis plays, refines and
carries the body twice or three times), so a stage table reports the whole cost."""

from __future__ import annotations

import gc
import time
from contextlib import contextmanager


class StageTimer:
    """Wall-clock seconds per named stage, in ``seconds`` (stage -> s)."""

    def __init__(self):
        self.seconds: dict[str, float] = {}

    @contextmanager
    def __call__(self, stage: str):
        t0 = time.perf_counter()
        try:
            yield
        finally:
            self.seconds[stage] = self.seconds.get(stage, 0.0) + time.perf_counter() - t0


@contextmanager
def collection_paused():
    """No cyclic garbage collection inside (a ``with`` block or a decorated function),
    automatic collection as it was after. A search or a synthesis makes hundreds of
    thousands of short-lived objects (footprints, nodes, arrays), which reference counting
    frees; each full collection they set off walks every live object of the process
    (Blender's and the add-on's too): 50 ms at a time, landing in whichever stage runs
    then (the demo's smoothing took 50 to 70 ms instead of 8). Nests."""
    was = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if was:
            gc.enable()
