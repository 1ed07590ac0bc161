"""A robot that carries the sensor, driven over rosbridge (the rosbridge v2 protocol: ROS
messages as JSON over a WebSocket), with no ROS installed where whiskercal runs.

``RosbridgeRobot`` is the follower's ``Robot`` (``follow.controller``) on a real arm (or the
twin's served base): the end effector's pose in, a Cartesian twist out, through the sensor's
mount, within :class:`Safety`'s limits; ``FieldTopic`` and ``SerialSamples`` are the sensor's
stream (docs/robot.md).
"""

from whiskercal.robot.errors import ConnectionLostError, RobotError, WatchdogError, WorkspaceError
from whiskercal.robot.rosbridge import RobotTopics, RosbridgeLink, RosbridgeRobot, parse_url
from whiskercal.robot.safety import Safety
from whiskercal.robot.samples import FieldSample, FieldTopic, SerialSamples

__all__ = ["ConnectionLostError", "FieldSample", "FieldTopic", "RobotError", "RobotTopics",
           "RosbridgeLink", "RosbridgeRobot", "Safety", "SerialSamples", "WatchdogError",
           "WorkspaceError", "parse_url"]
