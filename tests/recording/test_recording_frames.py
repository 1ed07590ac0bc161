"""Poses at each sample's time: linear in x, y and the unwrapped heading, a gap leaves a sample
without a pose, a latency shifts the poses; quaternions and headings round-trip."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from whiskercal.recording import Poses, poses_at
from whiskercal.recording.frames import heading_of, quaternion_of


def test_interpolation_unwraps_the_heading_across_pi():
    poses = Poses(np.array([0.0, 1.0]), np.array([[0.0, 0.0, 3.1], [10.0, -4.0, 3.1 + 0.2]]), "p")
    pose, far = poses_at(poses, np.array([0.5]), max_gap_s=1.0)
    np.testing.assert_allclose(pose[0], [5.0, -2.0, 3.2], atol=1e-12)
    assert not far.any()
    wrapped = Poses(poses.t_s, np.array([[0.0, 0.0, 3.1], [10.0, -4.0, 3.3 - 2 * np.pi]]), "p")
    np.testing.assert_allclose(poses_at(wrapped, np.array([0.5]), 1.0)[0][0, 2], 3.2, atol=1e-12)


def test_samples_far_from_every_pose_get_none_and_latency_shifts():
    poses = Poses(np.array([0.0, 0.01, 0.02, 0.5, 0.51]), np.tile([1.0, 2.0, 0.0], (5, 1)), "p")
    t = np.array([0.0, 0.015, 0.1, 0.26, 0.45, 0.6, -0.2])
    pose, far = poses_at(poses, t, max_gap_s=0.05)
    np.testing.assert_array_equal(far, [False, False, True, True, False, True, True])
    assert np.all(np.isnan(pose[far])) and np.all(np.isfinite(pose[~far]))
    line = Poses(np.array([0.0, 1.0]), np.array([[0.0, 0.0, 0.0], [100.0, 0.0, 0.0]]), "p")
    # a pose stamped t describes the robot at t - 0.1 s: at 0.4 s the robot was where the
    # pose stamped 0.5 s says
    np.testing.assert_allclose(poses_at(line, np.array([0.4]), 1.0, latency_s=0.1)[0][0, 0], 50.0)


@settings(max_examples=200, deadline=None, derandomize=True)
@given(st.floats(-3.14159, 3.14159))
def test_quaternion_and_heading_round_trip(heading):
    assert abs(heading_of(quaternion_of(heading)) - heading) < 1e-12
