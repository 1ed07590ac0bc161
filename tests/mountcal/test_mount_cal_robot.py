"""mount-cal over rosbridge against the twin's server, its sensor off the nominal mount: the
same presses as in process, through the robot's link, and a zero twist at the end."""

import tempfile
import time
from pathlib import Path

import numpy as np
import pytest
from goals import MARGIN

from whiskercal.contour.on_robot import RobotSetup
from whiskercal.mount import Mount
from whiskercal.mountcal import Routine, mount_cal
from whiskercal.mountcal.plan import RETREAT_MM, plan_presses, station_angles
from whiskercal.robot import Safety
from whiskercal.twin.devices.rosbridge_robot import RobotTwinServer, ServedInThread
from whiskercal.twin.mobile import MobileSensor
from whiskercal.twin.outlines import outline
from whiskercal.twin.params import DEFAULT_SENSOR

pytestmark = [pytest.mark.slow, pytest.mark.timeout(900)]
NOMINAL = Mount(0.0, 30.0, 90.0)
ERROR = (1.0, -0.8, 1.5)


def test_a_robot_is_pressed_and_stopped_as_the_twin_in_process_is():
    from whiskercal.bench.contour_target import calibrations_with_target

    artifact = calibrations_with_target(Path(tempfile.mkdtemp(prefix="whiskercal-mcr-")))["yz-table"]
    routine = Routine(nominal=NOMINAL, stations=2, arc_deg=60.0)
    first = plan_presses(-1000.0, station_angles(routine.side_deg, routine.arc_deg, 2))[0]
    start = first.standoff(routine.cylinder, DEFAULT_SENSOR.whisker.reach_mm, RETREAT_MM)
    mobile = MobileSensor(DEFAULT_SENSOR, outline("cylinder"), start, seed=5)
    server = RobotTwinServer(mobile, 100.0, mount=NOMINAL.offset_by(ERROR))
    with ServedInThread(server, duration_s=800.0):
        setup = RobotSetup(server.url, mount=NOMINAL, safety=Safety(watchdog_s=1.0))
        result = mount_cal(artifact, routine, setup=setup, echo=lambda line: None)
        (vx, vy), turn = server.last_twist
        before = server.mobile.pose()
        time.sleep(0.1)
        assert vx == vy == turn == 0.0 and np.allclose(server.mobile.pose(), before)
    true = NOMINAL.offset_by(ERROR)
    fit, std = result.fit.mount, result.fit.std
    assert len(result.touches) == 18 and result.true_mount is None  # a robot has no truth
    for key, sigma in zip(("x_mm", "y_mm", "yaw_deg"), std):
        assert abs(getattr(fit, key) - getattr(true, key)) <= MARGIN * sigma, key
    assert abs(fit.yaw_deg - true.yaw_deg) < 0.5 * abs(ERROR[2])
