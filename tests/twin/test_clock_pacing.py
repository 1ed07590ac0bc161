"""A paced clock behind a slow simulation: simulated time falls behind the wall instead of
asking the simulation for ever longer spans (the runaway that left a host's bytes unanswered)."""

import pytest

from whiskercal.twin.devices import clock as clock_module
from whiskercal.twin.devices.clock import SimClock


class FakeWall:
    def __init__(self):
        self.now = 100.0

    def monotonic(self):
        return self.now


@pytest.fixture
def wall(monkeypatch):
    fake = FakeWall()
    monkeypatch.setattr(clock_module.time, "monotonic", fake.monotonic)
    monkeypatch.setattr(clock_module.time, "sleep", lambda s: None)
    return fake


def test_a_simulation_ten_times_slower_than_real_time_gets_bounded_spans(wall):
    clock = SimClock(speed=1.0)
    spans = []
    for _ in range(50):
        target = clock.paced_now_s(max_step_s=0.02)
        spans.append(target - clock.now_s)
        wall.now += 10 * spans[-1] + 0.001  # each simulated second costs ten wall seconds
        clock.advance_to(target)
    assert max(spans) <= 0.02 + 1e-12
    # it keeps going at the slow simulation's own pace: no span shrinks to nothing either
    assert min(spans[5:]) > 0.015


def test_a_simulation_that_keeps_up_follows_the_wall_exactly(wall):
    clock = SimClock(speed=2.0)
    clock.paced_now_s(max_step_s=0.02)
    wall.now += 0.005
    assert clock.paced_now_s(max_step_s=0.02) == pytest.approx(0.01)
