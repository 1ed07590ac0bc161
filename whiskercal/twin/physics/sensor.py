"""One sensor build's physics as a rig uses it: the whisker's statics against an obstacle, and
the magnet's field at the magnetometer for the resulting suspension pose.

Scenes choose the contact solve (``solve_shape`` or ``solve_plane``); the world asks for the
field. Tests inject a stand-in with the same methods.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np


class SensorPhysics(Protocol):
    """What a rig needs from a sensor's physics (whisker frame, mm; field in µT)."""

    def free(self):
        """The undeflected whisker's equilibrium."""

    def solve_shape(self, shape, previous):
        """The equilibrium against a ``Circle`` or ``Polygon``, warm-started from ``previous``."""

    def solve_shape_sticking(self, shape, friction, previous, stick):
        """Against a ``Circle`` or ``Polygon`` with stick-slip at the tip: (equilibrium, stick)."""

    def solve_plane(self, plane, previous):
        """The equilibrium against a sliding ``Plane``, continuing ``previous``'s stick-slip."""

    def field_uT(self, equilibrium) -> np.ndarray:
        """Field at the magnetometer for an equilibrium, sensor axes, µT (3,)."""


class TwinPhysics:
    """The twin's physics for one sensor (a ``SensorParams``): whisker mechanics and magnet."""

    def __init__(self, sensor) -> None:
        from whiskercal.twin.physics import mechanics

        self.sensor = sensor
        self._mechanics = mechanics

    def free(self):
        """The undeflected whisker."""
        return self._mechanics.free(self.sensor.whisker)

    def solve_shape(self, shape, previous):
        """Equilibrium against a ``Circle`` or convex ``Polygon``, warm-started from ``previous``."""
        return self._mechanics.solve_shape(self.sensor.whisker, shape, previous)

    def solve_shape_sticking(self, shape, friction, previous, stick):
        """Against a ``Circle`` or convex ``Polygon`` with the ``Coulomb`` ``friction``'s
        stick-slip at the tip, from ``previous`` stuck at ``stick``: (equilibrium, stick now)."""
        from whiskercal.twin.physics.shape_friction import solve_shape_sticking

        return solve_shape_sticking(self.sensor.whisker, shape, friction, previous, stick)

    def solve_plane(self, plane, previous):
        """Equilibrium against a sliding ``Plane``, from ``previous`` along the path."""
        return self._mechanics.solve_plane(self.sensor.whisker, plane, previous)

    def field_uT(self, equilibrium) -> np.ndarray:
        """Field of the magnet at the suspension's pose, sensor axes, µT (3,)."""
        from whiskercal.twin.physics.magnet import field_uT

        return np.asarray(field_uT(self.sensor.magnet, equilibrium.root_rotation_rad,
                                   equilibrium.root_shift_mm), dtype=float)
