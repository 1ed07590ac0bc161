"""What stops a run on a robot: each a ``DeviceError`` (one line, non-zero exit), raised after
the robot has been sent a zero twist."""

from whiskercal.errors import DeviceError


class RobotError(DeviceError):
    """The robot or its link ended the run."""


class ConnectionLostError(RobotError):
    """The rosbridge connection closed during the run."""


class WatchdogError(RobotError):
    """No pose or no sample arrived within the watchdog's time."""


class WorkspaceError(RobotError):
    """The end effector is outside the workspace box."""
