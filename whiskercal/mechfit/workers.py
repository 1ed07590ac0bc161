"""Independent fits run side by side on the machine's CPUs.

The joint fit refines a start group's suspensions one after the other, each with its own
objective and nothing shared, so each may as well run in its own process: the results, and
which one is kept, are the same as one after the other. Processes are forked (the compiled
solvers and the caches come along, nothing is compiled or read again) and only from a process
that is not itself a worker: ``bench`` already runs its sessions one per CPU, and a pool in
each would only make them take turns.
"""

from __future__ import annotations

import multiprocessing
import os
from concurrent.futures import ProcessPoolExecutor
from typing import Callable, Sequence

# more than this many processes for one fit gains little on the refinements' groups (2-4 starts)
MAX_WORKERS = 4


def available_cpus() -> int:
    """CPUs this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def run_side_by_side(function: Callable, jobs: Sequence[tuple]) -> list:
    """``[function(*job) for job in jobs]``, in forked processes where more than one CPU is
    free for it (one per job, at most ``MAX_WORKERS``); in this process otherwise."""
    workers = min(len(jobs), available_cpus(), MAX_WORKERS)
    if (workers < 2 or multiprocessing.parent_process() is not None
            or "fork" not in multiprocessing.get_all_start_methods()):
        return [function(*job) for job in jobs]
    with ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("fork")) as pool:
        futures = [pool.submit(function, *job) for job in jobs]
        return [future.result() for future in futures]
