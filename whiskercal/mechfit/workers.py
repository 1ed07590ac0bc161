"""Independent fits run side by side on the machine's CPUs.

The joint fit refines a start group's suspensions one after the other, each with its own
objective and nothing shared, so each may as well run in its own process: the results, and
which one is kept, are the same as one after the other. So do the Y fit's scouting starts and
its profile points, and the table's families of tip loads. Processes are forked (the compiled
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


def _may_fork(workers: int) -> bool:
    """Are ``workers`` processes worth forking here: two or more, from a process that is not
    itself a worker, where fork exists?"""
    return (workers >= 2 and multiprocessing.parent_process() is None
            and "fork" in multiprocessing.get_all_start_methods())


def run_side_by_side(function: Callable, jobs: Sequence[tuple]) -> list:
    """``[function(*job) for job in jobs]``, in forked processes where more than one CPU is
    free for it (one per job, at most ``MAX_WORKERS``); in this process otherwise."""
    workers = min(len(jobs), available_cpus(), MAX_WORKERS)
    if not _may_fork(workers):
        return [function(*job) for job in jobs]
    with ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("fork")) as pool:
        futures = [pool.submit(function, *job) for job in jobs]
        return [future.result() for future in futures]


def _call(function: Callable, *args):
    return function(*args)


def run_calls_side_by_side(calls: Sequence[tuple[Callable, tuple]]) -> list:
    """``[function(*args) for function, args in calls]``, side by side as
    :func:`run_side_by_side` runs them: different functions, each its own job."""
    return run_side_by_side(_call, [(function, *args) for function, args in calls])


class InBackground:
    """``function(*args)`` started in a forked process, where :func:`run_side_by_side` would
    fork, for a result wanted later (:meth:`result`); computed then, in this process,
    otherwise. As a context manager it ends the process on leaving, so a caller that raises
    before it asks for the result neither waits for the job nor leaves it running."""

    def __init__(self, function: Callable, *args):
        self._call, self._pool, self._pending = (function, args), None, None
        if _may_fork(min(2, available_cpus())):
            self._pool = multiprocessing.get_context("fork").Pool(1)
            self._pending = self._pool.apply_async(function, args)

    def result(self):
        """What ``function(*args)`` returned (its exception raised here)."""
        if self._pending is None:
            function, args = self._call
            return function(*args)
        try:
            return self._pending.get()
        finally:
            self._end()

    def _end(self) -> None:
        if self._pool is not None:
            self._pool.terminate()
            self._pool.join()
            self._pool = None

    def __enter__(self) -> InBackground:
        return self

    def __exit__(self, *exc) -> None:
        self._end()
