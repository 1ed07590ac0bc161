"""Pressing the whisker on the cylinder, the same on the twin and on a robot.

A driver gives one sample per call (the time s, z and the chip's Z axis µT from rest, and the
twin's truth where there is one) and carries a ``robot``: ``pose()`` (the base frame through the
nominal mount), ``effector_pose()``, ``command(velocity, turn)`` (the base frame's motion) and
``stop()``. Every motion is a command per sample, so the twin in process and a robot over
rosbridge run the same code.

A press goes from its standoff along the whisker at the approach speed until contact, then at
the press speed until each deflection in turn, holding still at each: the held samples' mean z
gives the tip (the artifact's lookup, in the base frame), the effector's mean pose where it was.
Then the whisker backs out along itself.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from whiskercal.errors import DeviceError

CONTACT_UT = 150.0        # |z| past this (µT): the whisker touches
APPROACH_MM_S = 5.0       # toward the object before contact
PRESS_MM_S = 2.0          # after contact, to each deflection
TRANSIT_MM_S = 20.0
TURN_RAD_S = 0.5
MAX_PRESS_MM = 45.0       # past the standoff: further than this finds no object where it should be
SETTLE_S, HOLD_S = 0.1, 0.2


@dataclass(frozen=True)
class Touch:
    """One held deflection: the end effector's pose (x mm, y mm, heading rad), the mean z and
    the chip's Z (µT), the tip in the base frame (mm), and the twin's true contact kind (None
    on a robot)."""

    effector_pose: np.ndarray
    z_uT: float
    axial_uT: float
    tip_mm: np.ndarray
    kind: str | None = None
    true_tip_mm: np.ndarray | None = None  # the twin's, in the true base frame
    geometry: str = ""  # the press's tilt and depth: touches of one geometry share a tip error


class TwinDriver:
    """The twin in process (``contour.mounted.MountedTwin``), stepped one period per sample."""

    def __init__(self, twin, rate_hz: float = 300.0) -> None:
        self.robot, self.dt, self.t_s = twin, 1.0 / rate_hz, 0.0
        self.rate_hz = rate_hz

    def sample(self):
        """(t s, z µT, axial µT, the twin's contact kind) after one period."""
        sample = self.robot.step(self.dt)
        self.t_s, self.last = self.t_s + self.dt, sample
        return self.t_s, sample.z_uT, sample.axial_uT, sample.kind

    def true_tip(self) -> np.ndarray:
        """The last sample's true tip in the twin's true base frame (mm)."""
        base = self.robot.carried.mobile.pose()
        c, s = math.cos(base[2]), math.sin(base[2])
        offset = self.last.tip_mm - base[:2]
        return np.array([c * offset[0] + s * offset[1], -s * offset[0] + c * offset[1]])


class RobotDriver:
    """A robot over rosbridge (``robot.RosbridgeRobot``) and its field samples, z from the rest
    reading taken before the first press (``contour.robot_run.rest_reading``)."""

    def __init__(self, robot, samples, rest_uT, rate_hz: float, watchdog_s: float) -> None:
        self.robot, self.samples, self.rest = robot, samples, rest_uT
        self.rate_hz, self.watchdog_s = rate_hz, watchdog_s

    def sample(self):
        from whiskercal.contour.robot_run import next_sample

        sample = next_sample(self.samples, self.robot, self.watchdog_s)
        return sample.stamp_s, sample.field_uT[1] - self.rest[0], sample.field_uT[2] - self.rest[1], None


def go_to(driver, target, speed_mm_s: float = TRANSIT_MM_S, tolerance_mm: float = 0.1) -> None:
    """Drive the base frame (as the nominal mount places it) to ``target`` (x, y, heading)."""
    target = np.asarray(target, float)
    limit = 10 * int(driver.rate_hz * (10.0 + np.hypot(*(target[:2] - driver.robot.pose()[:2])) / speed_mm_s))
    for _ in range(limit):
        pose = driver.robot.pose()
        gap, turn = target[:2] - pose[:2], math.remainder(target[2] - pose[2], 2 * math.pi)
        distance = float(np.hypot(*gap))
        if distance < tolerance_mm and abs(turn) < 1e-3:
            driver.robot.stop()
            driver.sample()
            return
        velocity = gap / max(distance, 1e-9) * min(speed_mm_s, 3.0 * distance)
        driver.robot.command(velocity, float(np.clip(3.0 * turn, -TURN_RAD_S, TURN_RAD_S)))
        driver.sample()
    driver.robot.stop()
    raise DeviceError(f"the robot did not reach the pose {target[:2].round(1).tolist()} mm: stopped")


def press(driver, heading: float, levels_uT, tip_of) -> list[Touch]:
    """From the standoff, along ``heading``, to each deflection of ``levels_uT`` (module
    docstring); ``tip_of(z, axial)`` is the artifact's tip in the base frame."""
    along = np.array([math.cos(heading), math.sin(heading)])
    start = driver.robot.pose()[:2]
    touches, touched = [], False
    for level in levels_uT:
        while True:
            _, z, _, _ = driver.sample()
            if z > CONTACT_UT:
                raise DeviceError(f"z {z:.0f} µT: the object pushes the whisker from the other "
                                  "side (is it where --object-pose says?)")
            touched = touched or z < -CONTACT_UT
            if z <= level:
                break
            if float(np.dot(driver.robot.pose()[:2] - start, along)) > MAX_PRESS_MM:
                driver.robot.stop()
                raise DeviceError(f"no deflection of {level:.0f} µT within {MAX_PRESS_MM:g} mm of "
                                  "the standoff: is the object where --object-pose says?")
            driver.robot.command(along * (PRESS_MM_S if touched else APPROACH_MM_S), 0.0)
        touches.append(hold(driver, tip_of))
    return touches


def hold(driver, tip_of) -> Touch:
    """Stand still, let the whisker settle, and average the held samples."""
    driver.robot.stop()
    rows, poses, kinds = [], [], []
    settle = int(math.ceil(SETTLE_S * driver.rate_hz))
    for index in range(settle + int(math.ceil(HOLD_S * driver.rate_hz))):
        _, z, axial, kind = driver.sample()
        if index >= settle:
            rows.append((z, axial))
            poses.append(driver.robot.effector_pose())
            kinds.append(kind)
    z, axial = np.mean(rows, axis=0)
    pose = mean_pose(poses)
    kind = None if kinds[0] is None else max(set(kinds), key=kinds.count)
    truth = driver.true_tip() if hasattr(driver, "true_tip") else None
    return Touch(pose, float(z), float(axial), np.asarray(tip_of(float(z), float(axial)), float),
                 kind, truth)


def mean_pose(poses) -> np.ndarray:
    """The mean of poses (n, 3) held still: the positions' mean, the headings' circular mean."""
    poses = np.asarray(poses, float)
    return np.array([*poses[:, :2].mean(axis=0),
                     math.atan2(np.sin(poses[:, 2]).mean(), np.cos(poses[:, 2]).mean())])


def retreat(driver, heading: float, back_mm: float) -> None:
    """Back the whisker out along itself by ``back_mm``."""
    pose = driver.robot.pose()
    target = np.array([*(pose[:2] - back_mm * np.array([math.cos(heading), math.sin(heading)])),
                       heading])
    go_to(driver, target, APPROACH_MM_S * 2)
