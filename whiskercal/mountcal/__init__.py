"""The sensor's mount on the robot, calibrated by touching a known cylinder (docs/mount-cal.md).

``mount_cal`` presses the whisker on the cylinder at a few poses (``plan``), on the twin in
process or a robot over rosbridge (``touch``), and fits the mount with its uncertainty
(``solve``), or takes the held touches of a replay track (``recorded``); ``write_result``
writes it as the mount file ``replay``, ``contour evaluate`` and
``contour run --robot`` read.
"""

from whiskercal.mountcal.plan import Cylinder, Press, plan_presses, station_angles
from whiskercal.mountcal.run import (TWIN_URL, MountCalResult, Routine, mount_cal,
                                     mount_cal_recorded, parse_cylinder,
                                     parse_twin_url, write_result)
from whiskercal.mountcal.solve import MountFit, solve_mount

__all__ = ["TWIN_URL", "Cylinder", "MountCalResult", "MountFit", "Press", "Routine", "mount_cal",
           "mount_cal_recorded", "parse_cylinder", "parse_twin_url", "plan_presses", "solve_mount",
           "station_angles", "write_result"]
