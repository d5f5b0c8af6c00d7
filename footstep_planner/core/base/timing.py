"""Stage timing from outside the algorithms: ``with timer("smoothing"): ...``.

A stage's seconds add up when it runs more than once (the synthesis plays, refines and
carries the body twice or three times), so a stage table reports the whole cost."""

from __future__ import annotations

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
