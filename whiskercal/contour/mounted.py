"""The twin in process as a robot drives it: the end effector is what is known, the sensor's base
frame only through the mount the user gives.

``MountedTwin`` is the follower's ``Robot`` over ``twin.carried.CarriedSensor``, as
``robot.RosbridgeRobot`` is over a real arm: ``pose()`` is the end effector's pose composed with
the nominal mount, and each command (the base frame's motion) becomes the end effector's through
that mount. The twin carries the sensor at its true mount, so a nominal mount off the true one
moves what the loop believes, not what the whisker touches: its world-frame error is the mount's.
"""

from __future__ import annotations

import numpy as np

from whiskercal.mount import Mount
from whiskercal.twin.carried import CarriedSensor


class MountedTwin:
    """The follower's ``Robot`` on the twin through a nominal mount (the module's docstring)."""

    def __init__(self, mobile, nominal: Mount = Mount(), true: Mount | None = None) -> None:
        true = nominal if true is None else true
        self.carried = CarriedSensor(mobile, (true.x_mm, true.y_mm, true.yaw_deg))
        self.nominal, self.true = nominal, true

    @classmethod
    def placed(cls, mobile, nominal: Mount, error=(0.0, 0.0, 0.0)) -> "MountedTwin":
        """The twin at the nominal mount moved by ``error`` (dx mm, dy mm, dyaw deg)."""
        return cls(mobile, nominal, nominal.offset_by(error))

    def effector_pose(self) -> np.ndarray:
        """The end effector's world pose (x mm, y mm, heading rad), as the robot reports it."""
        return self.carried.effector_pose()

    def pose(self) -> np.ndarray:
        """The sensor's base frame as the nominal mount places it."""
        return self.nominal.base_pose(self.effector_pose())

    def command(self, velocity_mm_s, turn_rad_s: float) -> None:
        """The base frame's velocity (world, mm/s) and turn (rad/s), sent as the end effector's."""
        turn = float(turn_rad_s)
        effector = self.effector_pose()
        self.carried.command_effector(self.nominal.effector_velocity(effector, velocity_mm_s, turn),
                                      turn)

    def stop(self) -> None:
        """A zero twist."""
        self.carried.command_effector(np.zeros(2), 0.0)

    def step(self, dt_s: float):
        """One control period of the twin (its ``MobileSample``, truth in the world frame)."""
        return self.carried.step(dt_s)

    def truth(self) -> dict:
        """The nominal and the true mount (JSON-able), for a run's record."""
        return {"nominal": self.nominal.as_dict(), "true": self.true.as_dict()}
