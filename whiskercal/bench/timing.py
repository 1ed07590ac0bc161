"""Timing helpers shared by the comparisons: per-call time and the machine it was measured on.

Absolute times depend on the machine; every comparison therefore reports times measured in the
same process and run, so their ratios are meaningful, and records the machine as context.
"""

from __future__ import annotations

import os
import platform
import statistics
import time
from typing import Callable

import numpy as np


def per_call_s(call: Callable[[], object], repeats: int = 5, min_batch_s: float = 0.02,
               max_calls: int = 100_000) -> float:
    """Median time of one call (s) over ``repeats`` batches.

    A batch repeats the call until it has lasted ``min_batch_s`` (so a microsecond call is not
    dominated by the timer's own cost); the median of the batches resists a busy machine.
    """
    call()  # warm-up: caches and lazy imports stay out of the timing
    started = time.perf_counter()
    call()
    single = max(time.perf_counter() - started, 1e-9)
    calls = int(min(max_calls, max(1, min_batch_s / single)))
    batches = []
    for _ in range(max(1, repeats)):
        started = time.perf_counter()
        for _ in range(calls):
            call()
        batches.append((time.perf_counter() - started) / calls)
    return float(statistics.median(batches))


def machine_info() -> dict:
    """Where the times were measured: Python, numpy, processor, cores."""
    return {"python": platform.python_version(), "numpy": np.__version__,
            "machine": platform.machine(), "processor": platform.processor() or platform.machine(),
            "system": platform.system(), "cpu_count": os.cpu_count()}
