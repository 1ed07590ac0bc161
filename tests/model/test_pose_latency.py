"""The pose latency estimated from the data (``model.pose_latency``) recovers an injected one."""

import numpy as np
import pytest

from whiskercal.contour.latency import base_to_world, shifted_poses, world_to_base
from whiskercal.model.errors import ModelError
from whiskercal.model.pose_latency import estimate_pose_latency, roughness_mm2


def _wall_run(latency_s: float, rate_hz: float, seed: int = 0):
    """A base sliding along the wall y = 0 at 8 mm/s, its distance and heading wandering (a
    controller's corrections), the tip on the wall; the poses reported ``latency_s`` late.
    Returns the sample times, the reported poses and the tips (base frame, with 0.02 mm noise)."""
    rng = np.random.default_rng(seed)
    t = np.arange(0, 20, 1 / rate_hz)
    wander = np.cumsum(rng.normal(0, 1, (t.size, 2)), axis=0) / np.sqrt(rate_hz)
    true_pose = np.column_stack([8.0 * t - 40.0, -60.0 + 1.5 * np.sin(wander[:, 0]),
                                 np.pi / 2 - 0.35 + 0.05 * np.sin(wander[:, 1])])
    contact = np.column_stack([8.0 * t, np.zeros_like(t)])
    tips = world_to_base(true_pose, contact) + rng.normal(0, 0.02, (t.size, 2))
    # the pose stamped t is the true pose at t - latency
    reported = np.column_stack([np.interp(t - latency_s, t, true_pose[:, k]) for k in range(3)])
    return t, reported, tips


@pytest.mark.parametrize("latency_s, rate_hz", [(0.033, 300.0), (0.1, 300.0), (0.033, 30.0),
                                                (0.0, 100.0)])
def test_the_estimate_recovers_an_injected_latency(latency_s, rate_hz):
    t, pose, tips = _wall_run(latency_s, rate_hz)
    estimate = estimate_pose_latency(lambda lag: base_to_world(shifted_poses(t, pose, lag), tips),
                                     1.0 / rate_hz, max_latency_s=0.25)
    assert estimate.latency_s == pytest.approx(latency_s, abs=0.25 / rate_hz)
    assert len(estimate.tried_s) == len(estimate.cost_mm2)


def test_the_contacts_placed_with_the_estimate_lie_on_the_wall():
    t, pose, tips = _wall_run(0.06, 300.0, seed=3)
    late = base_to_world(shifted_poses(t, pose, 0.0), tips)
    placed = base_to_world(shifted_poses(t, pose, 0.06), tips)
    inner = slice(100, -100)  # away from the ends, where the shifted poses are held
    assert np.mean(np.abs(placed[inner, 1])) < 0.5 * np.mean(np.abs(late[inner, 1]))


def test_no_run_of_contacts_long_enough_is_an_error_and_gaps_are_not_smoothed_over():
    points = np.full((40, 2), np.nan)
    with pytest.raises(ModelError, match="no run of"):
        estimate_pose_latency(lambda lag: points, 1 / 300)
    points[:10] = 0.0
    points[20:30] = 5.0  # two runs apart: the jump between them is no roughness
    assert roughness_mm2(points, 5) == 0.0
