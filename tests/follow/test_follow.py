"""The contour-following controller: its predictor, its loop on a straight wall, a short run."""

import math

import numpy as np
import pytest
from tests_follow_artifact import calibration_path

from whiskercal import runtime
from whiskercal.follow import FollowConfig, Follower, predict_next
from whiskercal.twin.mobile import MobileSensor
from whiskercal.twin.outlines import Outline
from whiskercal.twin.params import DEFAULT_SENSOR
from whiskercal.twin.truth import true_tip


@pytest.mark.parametrize("radius_mm, spacing_mm", [(80.0, 2.0), (30.0, 2.0), (40.0, 1.0)])
def test_the_spline_predicts_the_next_point_of_a_circle(radius_mm, spacing_mm):
    step = spacing_mm / radius_mm
    angles = np.arange(7) * step
    points = radius_mm * np.column_stack([np.cos(angles), np.sin(angles)])
    predicted = predict_next(points[:6])
    # a cubic through exact points: the extrapolated step misses the circle by far less than it
    assert np.linalg.norm(predicted - points[6]) < 0.01 * spacing_mm


def test_the_spline_on_a_straight_line_stays_on_it():
    points = np.column_stack([np.arange(6) * 2.0, np.zeros(6)])
    np.testing.assert_allclose(predict_next(points), [12.0, 0.0], atol=1e-9)


@pytest.mark.slow
def test_the_controller_on_a_straight_wall_settles_at_the_target_deflection():
    wall = Outline("wall", np.array([[0.0, 0.0], [800.0, 0.0], [800.0, 800.0], [0.0, 800.0]]) - 400.0,
                   0.001)  # a big square: its bottom face is a straight wall at y = -400
    config = FollowConfig()
    heading = math.pi / 2 - math.radians(config.tilt_deg)
    start = np.array([-200.0, -400.0]) - 83.0 * np.array([math.cos(heading), math.sin(heading)])
    robot = MobileSensor(DEFAULT_SENSOR, wall, [*start, heading], seed=3)
    follower = Follower(runtime.load(calibration_path()).tracker(out_of_range="clip"), -5000.0, config)
    sample, zs = robot.step(0.0), []
    for _ in range(int(40 * config.rate_hz)):
        follower.update(sample.z_uT, robot)
        sample = robot.step(1.0 / config.rate_hz)
        zs.append(sample.z_uT)
    settled = np.array(zs[-int(5 * config.rate_hz):])
    assert abs(settled.mean() - (-5000.0)) < 150.0  # µT: the PID holds the target
    assert robot.pose()[0] > 0.0  # and it moved along the wall (counter-clockwise: +x)
    assert sample.kind == "tip"


def test_the_calibrations_tip_motion_per_uT_is_the_twins():
    calibration = runtime.load(calibration_path())
    target = calibration.target_z_uT
    step = 0.01 * (calibration.z_range_uT[1] - calibration.z_range_uT[0])
    tips = true_tip(DEFAULT_SENSOR, np.array([target - step, target + step]))
    truth = float(np.linalg.norm(tips[1] - tips[0])) / (2 * step)
    assert calibration.tip_motion_mm_per_uT(target) == pytest.approx(truth, rel=0.05)
    assert 0.005 < truth < 0.008  # mm/µT: the default build near its target (the gains' figure)


@pytest.mark.parametrize("tip_mm_per_uT, share", [(None, 1.0), (0.0065, 1.0), (0.026, 4.0)])
def test_the_pid_gains_scale_with_how_far_the_builds_tip_moves_per_uT(tip_mm_per_uT, share):
    # a longer or softer whisker moves its tip farther per µT: the same push changes z less,
    # and gains in µT must grow by as much to hold the deflection as firmly
    config = FollowConfig()
    follower = Follower(None, -1000.0, config, tip_mm_per_uT=tip_mm_per_uT)
    speed = follower._pid(-1000.0 + 100.0)  # 100 µT short of the target: press in
    unscaled = config.kp_mm_s_per_uT * 100.0 + config.ki_mm_s2_per_uT * 100.0 / config.rate_hz
    assert speed == pytest.approx(share * unscaled)
    for _ in range(100 * int(config.rate_hz)):  # the integral alone still asks no more than the limit
        follower._pid(-1000.0 + 1e4)
    assert follower._pid(-1000.0) == pytest.approx(config.normal_speed_max_mm_s)
