"""A slip the follower detects resets the tracker's filter (``FollowConfig.slip_resets_filter``)."""

import numpy as np

from follow_script import TARGET_UT, KinematicRobot
from whiskercal.follow import FollowConfig, Follower
from whiskercal.runtime import TrackerState


class CountingTracker:
    """A tracker in contact whose tip is fixed; it counts the resets of its filter."""

    def __init__(self):
        self.resets = 0

    def update(self, z_uT, axial_uT=None):
        tip = np.array([70.0, -20.0])
        return TrackerState(True, tip, tip)

    def reset_filter(self):
        self.resets += 1


def _slip_run(config: FollowConfig) -> tuple[int, int]:
    """At the target for 0.5 s, then |z| snaps to a third of it: (resets, slips seen)."""
    tracker, robot = CountingTracker(), KinematicRobot([0.0, 0.0, 0.0])
    follower = Follower(tracker, TARGET_UT, config)
    z = [TARGET_UT] * 150 + [TARGET_UT / 3] * 5
    slips = sum(follower.update(value, robot).slip for value in z)
    return tracker.resets, slips


def test_a_slip_resets_the_filter_once_and_the_flag_turns_it_off():
    resets, slips = _slip_run(FollowConfig())
    assert slips == 1 and resets == 1
    resets, slips = _slip_run(FollowConfig(slip_resets_filter=False))
    assert slips == 1 and resets == 0
