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
