"""How long work reports where it is: a plain record, passed to a callback the caller chooses.

Library functions that take long (collect, the study, bench, regress) call
``on_progress(Progress(...))``; they draw nothing. The command line draws it
(``whiskercal.cli.progress``), only on a terminal.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable


@dataclass
class Progress:
    """Where the run is: items done (in total, including resumed ones), items planned, items
    done in this session and the wall time this session has taken (s)."""

    done: int
    total: int
    taken_now: int
    elapsed_s: float

    @property
    def rate_per_s(self) -> float:
        """Items per second of wall time in this session."""
        return self.taken_now / self.elapsed_s if self.elapsed_s > 0 else 0.0

    @property
    def remaining_s(self) -> float:
        """Estimated wall time to finish, s (inf before the first item)."""
        rate = self.rate_per_s
        return (self.total - self.done) / rate if rate > 0 else float("inf")


ProgressCallback = Callable[[Progress], None]
