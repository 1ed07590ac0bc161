"""Pressing and holding on a toy robot: a point base moving as commanded, a wall ahead whose
push bends the whisker linearly (no twin): the press's stages, its holds and its refusals."""

import math

import numpy as np
import pytest

from whiskercal.errors import DeviceError
from whiskercal.mountcal import touch

UT_PER_MM = -100.0  # the toy whisker's z per mm pressed past the wall (µT)


class ToyRobot:
    def __init__(self, pose=(0.0, 0.0, 0.0), moves=True):
        self._pose, self.moves = np.array(pose, float), moves
        self.velocity, self.turn, self.commands = np.zeros(2), 0.0, []

    def pose(self):
        return self._pose.copy()

    def effector_pose(self):
        return self._pose + [0.0, 5.0, 0.0]  # the effector a fixed 5 mm off the base

    def command(self, velocity, turn):
        self.velocity, self.turn = np.asarray(velocity, float), float(turn)
        self.commands.append((float(np.hypot(*self.velocity)), self.turn))

    def stop(self):
        self.velocity, self.turn = np.zeros(2), 0.0

    def advance(self, dt):
        if self.moves:
            self._pose[:2] += self.velocity * dt
            self._pose[2] += self.turn * dt


class ToyDriver:
    """A wall across +x at ``wall_mm``; ``sign`` -1 bends the whisker the expected way."""

    def __init__(self, robot, wall_mm=20.0, sign=1.0, rate_hz=100.0):
        self.robot, self.wall_mm, self.sign = robot, wall_mm, sign
        self.rate_hz, self.t_s = rate_hz, 0.0

    def sample(self):
        self.robot.advance(1.0 / self.rate_hz)
        self.t_s += 1.0 / self.rate_hz
        pressed = max(0.0, self.robot.pose()[0] - self.wall_mm)
        z = self.sign * UT_PER_MM * pressed
        return self.t_s, z, 0.5 * z, "tip" if pressed else None


def _tip_of(z, axial):
    return np.array([z / UT_PER_MM, axial])


def test_a_press_holds_at_each_deflection_in_turn():
    robot = ToyRobot()
    driver = ToyDriver(robot)
    touches = touch.press(driver, 0.0, (-300.0, -600.0), _tip_of)
    assert len(touches) == 2
    for held, level in zip(touches, (-300.0, -600.0)):
        # held still: every held sample reads the same; past the level by at most one step
        assert level - abs(UT_PER_MM) * touch.PRESS_MM_S / driver.rate_hz <= held.z_uT <= level
        assert held.axial_uT == pytest.approx(0.5 * held.z_uT)
        np.testing.assert_allclose(held.tip_mm, _tip_of(held.z_uT, held.axial_uT))
        assert held.effector_pose[1] == pytest.approx(5.0) and held.kind == "tip"
        assert held.true_tip_mm is None  # a driver without truth
    speeds = {speed for speed, _ in robot.commands}
    assert speeds == {touch.APPROACH_MM_S, touch.PRESS_MM_S}  # slower once touching
    assert robot.commands[0][0] == touch.APPROACH_MM_S


def test_a_press_refuses_an_object_on_the_wrong_side_or_missing():
    with pytest.raises(DeviceError, match="other side"):
        touch.press(ToyDriver(ToyRobot(), sign=-1.0), 0.0, (-300.0,), _tip_of)
    robot = ToyRobot()
    with pytest.raises(DeviceError, match="no deflection of -300 µT within 45 mm"):
        touch.press(ToyDriver(robot, wall_mm=100.0), 0.0, (-300.0,), _tip_of)
    assert touch.MAX_PRESS_MM < robot.pose()[0] < touch.MAX_PRESS_MM + 1.0
    assert not robot.velocity.any()  # stopped


def test_go_to_reaches_the_pose_and_a_stuck_robot_is_an_error():
    robot = ToyRobot()
    touch.go_to(ToyDriver(robot), (10.0, -4.0, 0.3))
    assert np.hypot(*(robot.pose()[:2] - [10.0, -4.0])) < 0.1
    assert abs(robot.pose()[2] - 0.3) < 1e-3 and not robot.velocity.any()
    with pytest.raises(DeviceError, match="did not reach the pose"):
        touch.go_to(ToyDriver(ToyRobot(moves=False), rate_hz=10.0), (1.0, 0.0, 0.0))


def test_retreat_backs_out_along_the_heading():
    robot = ToyRobot(pose=(30.0, 10.0, math.pi / 2))
    touch.retreat(ToyDriver(robot), math.pi / 2, 8.0)
    np.testing.assert_allclose(robot.pose()[:2], [30.0, 2.0], atol=0.1)


def test_the_mean_heading_is_circular():
    poses = [[1.0, 2.0, math.pi - 0.1], [3.0, 4.0, -math.pi + 0.1]]
    mean = touch.mean_pose(poses)
    np.testing.assert_allclose(mean[:2], [2.0, 3.0])
    assert abs(math.remainder(mean[2] - math.pi, 2 * math.pi)) < 1e-9
