"""``workers.run_side_by_side``: jobs in forked processes give what they give one after the
other, in the jobs' order, and a worker's error reaches the caller."""

import os

import numpy as np
import pytest

from whiskercal.errors import UsageError
from whiskercal.mechfit import workers


def _job(seed: int, size: int):
    """Something a worker computes, and which process computed it."""
    return np.random.default_rng(seed).normal(size=size), os.getpid()


def _refused(value: float):
    raise UsageError(f"refused {value:g}.")


def test_jobs_side_by_side_match_one_after_the_other(monkeypatch):
    monkeypatch.setattr(workers, "available_cpus", lambda: 2)
    jobs = [(seed, 5) for seed in (1, 2, 3)]
    side_by_side = workers.run_side_by_side(_job, jobs)
    in_turn = [_job(*job) for job in jobs]
    for (got, pid), (expected, _) in zip(side_by_side, in_turn):
        np.testing.assert_array_equal(got, expected)
        assert pid != os.getpid()  # forked: the jobs did run elsewhere


def test_one_cpu_runs_the_jobs_here_and_errors_come_back(monkeypatch):
    monkeypatch.setattr(workers, "available_cpus", lambda: 1)
    assert all(pid == os.getpid() for _, pid in workers.run_side_by_side(_job, [(1, 2), (2, 2)]))
    monkeypatch.setattr(workers, "available_cpus", lambda: 2)
    with pytest.raises(UsageError, match="refused 2"):
        workers.run_side_by_side(_refused, [(2.0,), (3.0,)])


def test_different_functions_side_by_side_come_back_in_their_order(monkeypatch):
    monkeypatch.setattr(workers, "available_cpus", lambda: 2)
    found = workers.run_calls_side_by_side([(_job, (4, 3)), (divmod, (7, 2)), (_job, (5, 1))])
    np.testing.assert_array_equal(found[0][0], _job(4, 3)[0])
    assert found[1] == (3, 1)
    np.testing.assert_array_equal(found[2][0], _job(5, 1)[0])


@pytest.mark.parametrize("cpus", [1, 2])
def test_a_background_job_gives_its_result_later_forked_or_not(monkeypatch, cpus):
    monkeypatch.setattr(workers, "available_cpus", lambda: cpus)
    background = workers.InBackground(_job, 6, 4)
    values, pid = background.result()
    np.testing.assert_array_equal(values, _job(6, 4)[0])
    assert (pid != os.getpid()) == (cpus > 1)
    with pytest.raises(UsageError, match="refused 1"):
        workers.InBackground(_refused, 1.0).result()


def test_leaving_a_background_job_unasked_ends_it_at_once(monkeypatch):
    # a fit that raises before it asks for its background job's result neither waits for it
    # nor leaves it running
    import time

    monkeypatch.setattr(workers, "available_cpus", lambda: 2)
    started = time.monotonic()
    with pytest.raises(UsageError, match="refused 3"):
        with workers.InBackground(time.sleep, 60.0):
            _refused(3.0)
    assert time.monotonic() - started < 30.0  # not the job's 60 s
