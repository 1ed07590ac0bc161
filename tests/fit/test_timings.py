"""``fit.timings.StageTimes``: the wall time per stage that ``fit --json`` reports as timings_s."""

import time

import pytest

from whiskercal.fit.timings import StageTimes


def test_each_stage_is_timed_summed_over_repeats_and_announced_before_it_runs():
    told = []
    times = StageTimes(told.append)
    with times.stage("joint_fit", "the joint fit"):
        assert told == ["the joint fit"]  # told before the stage's work starts
        time.sleep(0.02)
    with times.stage("joint_fit"):
        time.sleep(0.02)
    with times.stage("table"):
        pass
    assert list(times.seconds) == ["joint_fit", "table"] and told == ["the joint fit"]
    assert 0.04 <= times.seconds["joint_fit"] < 5.0 and 0.0 <= times.seconds["table"] < 1.0


def test_a_stage_that_raises_is_still_timed():
    times = StageTimes()
    with pytest.raises(ValueError):
        with times.stage("mechanics"):
            raise ValueError("refused")
    assert times.seconds["mechanics"] >= 0.0


def test_the_fit_runs_on_one_blas_thread_and_gives_the_rest_back(monkeypatch):
    from threadpoolctl import threadpool_info

    from whiskercal.fit import run

    def blas_threads():
        return [pool["num_threads"] for pool in threadpool_info() if pool["user_api"] == "blas"]

    seen = []

    def first_stage(raw):  # the fit's first step: record the threads and stop there
        seen.append(blas_threads())
        raise RuntimeError("stopped")
    monkeypatch.setattr(run, "refuse_z_against_truth", first_stage)
    before = blas_threads()
    with pytest.raises(RuntimeError, match="stopped"):
        run.fit(None)
    assert seen and seen[0] and all(n == 1 for n in seen[0]) and blas_threads() == before
