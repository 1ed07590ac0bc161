"""Wall time per stage of a fit (``fit --json``'s ``timings_s``): where a refit's seconds go."""

from __future__ import annotations

import time
from contextlib import contextmanager
from typing import Callable, Iterator


class StageTimes:
    """Seconds of wall time per named stage, summed when a stage runs more than once.

    ``progress`` (optional) is told each stage's message as it starts, as ``fit``'s progress
    callback is.
    """

    def __init__(self, progress: Callable[[str], None] | None = None):
        self.seconds: dict[str, float] = {}
        self._progress = progress

    @contextmanager
    def stage(self, name: str, message: str | None = None) -> Iterator[None]:
        """Time the block as stage ``name``; tell ``message`` to the progress callback first."""
        if message is not None and self._progress is not None:
            self._progress(message)
        started = time.perf_counter()
        try:
            yield
        finally:
            self.seconds[name] = self.seconds.get(name, 0.0) + time.perf_counter() - started
