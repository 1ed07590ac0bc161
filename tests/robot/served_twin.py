"""The twin's mobile base served on a loopback rosbridge WebSocket for the robot tests."""

from pathlib import Path

import numpy as np

from whiskercal.contour.run import start_pose
from whiskercal.follow import FollowConfig
from whiskercal.twin.devices.rosbridge_robot import RobotTwinServer, ServedInThread
from whiskercal.twin.mobile import MobileSensor
from whiskercal.twin.outlines import outline
from whiskercal.twin.params import DEFAULT_SENSOR

# a calibration of the default sensor that loads at once: enough for every test that only
# needs the loop to run (its table starts past the first touch's deflection, so it does not follow)
CALIBRATION = Path(__file__).resolve().parents[1] / "fixtures" / "calibration-1.3.0-target.h5"


def following_calibration() -> Path:
    """The recorded default grid fitted, with its study's target (the follow tests'; about a
    minute, once per process)."""
    from tests_follow_artifact import calibration_path

    return calibration_path()


def twin_server(shape: str = "octagon", rate_hz: float = 300.0, seed: int = 1, mount=None,
                pose=None) -> RobotTwinServer:
    """A server (not started) of the default sensor in front of ``shape``, at the contour
    run's start pose for ``seed``."""
    shape_outline = outline(shape)
    if pose is None:
        pose = start_pose(shape_outline, FollowConfig().tilt_deg, 5.0, np.random.default_rng(seed),
                          DEFAULT_SENSOR.whisker.reach_mm)
    return RobotTwinServer(MobileSensor(DEFAULT_SENSOR, shape_outline, pose, seed=seed), rate_hz,
                           mount=mount)


def serve(server: RobotTwinServer, duration_s: float | None = 60.0) -> ServedInThread:
    """``server`` running on its own thread (stopped by ``with`` or after ``duration_s``)."""
    return ServedInThread(server, duration_s)
