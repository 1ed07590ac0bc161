"""The twin's sensor carried on a robot's end effector at its true mount.

A real sensor never sits exactly where its drawing puts it on the flange: the twin carries
``twin.mobile.MobileSensor``'s base frame on an end effector through a mount of its own (the
true one), which a client only knows as well as it knows its robot. What the client sees is
the end effector (its pose, the twists it takes); what the twin solves is the base frame at the
true mount. ``mount`` is ``(x_mm, y_mm, yaw_deg)``: the base frame in the end-effector frame,
as ``whiskercal.mount.Mount`` holds it (the twin keeps its own arithmetic: it is the world's
side of the mount, not the client's).
"""

from __future__ import annotations

import math

import numpy as np


class CarriedSensor:
    """A ``MobileSensor`` whose base frame rides on an end effector at ``mount`` (see the
    module's docstring); it steps and measures as the mobile sensor does."""

    def __init__(self, mobile, mount=(0.0, 0.0, 0.0)) -> None:
        self.mobile = mobile
        x_mm, y_mm, yaw_deg = (float(value) for value in mount)
        self.mount = (x_mm, y_mm, yaw_deg)
        self._offset, self._yaw = np.array([x_mm, y_mm]), math.radians(yaw_deg)

    def effector_pose(self) -> np.ndarray:
        """The end effector's world pose (x mm, y mm, heading rad) for the base's true pose."""
        base = self.mobile.pose()
        heading = base[2] - self._yaw
        c, s = math.cos(heading), math.sin(heading)
        x, y = self._offset
        return np.array([base[0] - c * x + s * y, base[1] - s * x - c * y, heading])

    def command_effector(self, velocity_mm_s, turn_rad_s: float) -> None:
        """Move the end effector at a world-frame velocity (mm/s) and turn rate (rad/s): the base
        moves with it, plus the turn times the lever from the effector to the base."""
        arm = self.mobile.pose()[:2] - self.effector_pose()[:2]
        velocity = np.asarray(velocity_mm_s, float) + turn_rad_s * np.array([-arm[1], arm[0]])
        self.mobile.command(velocity, turn_rad_s)

    def step(self, dt_s: float):
        """One control period of the mobile sensor (its ``MobileSample``)."""
        return self.mobile.step(dt_s)

    def truth(self) -> dict:
        """The true mount (JSON-able), for a run's record."""
        return dict(zip(("x_mm", "y_mm", "yaw_deg"), self.mount))
