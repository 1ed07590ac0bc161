"""The vertical touch rod of the calibration grid; its axis is the end effector's point."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar, Mapping

import numpy as np

from whiskercal.twin.physics.obstacles import Circle, finite_number
from whiskercal.twin.scenes.base import SceneBase

DEFAULT_ROD_RADIUS_MM = 1.5


@dataclass
class RodFixture(SceneBase):
    """The touch rod, ``radius_mm`` (mm), frictionless.

    It pushes the whisker away from the side it arrives from: the side is taken when it first
    touches the free whisker and kept while in contact (+1: from +y, pushing toward -y).
    """

    name: ClassVar[str] = "rod"
    radius_mm: float = DEFAULT_ROD_RADIUS_MM
    _side: int = field(default=1, init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        # checked here, not at the first solve: the world turns solver errors into "failed"
        # samples, and a negative radius would never touch at all
        finite_number("rod radius (mm)", self.radius_mm, 0.0)

    @classmethod
    def from_options(cls, options: Mapping[str, float]) -> "RodFixture":
        """The rod of radius ``options["rod_radius_mm"]`` (default 1.5 mm)."""
        return cls(options.get("rod_radius_mm", DEFAULT_ROD_RADIUS_MM))

    def obstacle(self, tool_mm: np.ndarray, side: int = 1) -> Circle:
        """The rod as a ``Circle`` in the whisker frame, on ``side`` of the whisker."""
        return Circle(tool_mm, self.radius_mm, side=side)

    def touches(self, points_mm: np.ndarray, tool_mm: np.ndarray) -> bool:
        """True when the rod reaches any of the points (mm)."""
        return self.obstacle(tool_mm).reaches(points_mm)

    def solve(self, physics, tool_mm: np.ndarray, previous):
        """The whisker against the rod, the side chosen on arrival."""
        if not previous.in_contact:
            self._side = 1 if tool_mm[1] >= 0 else -1
        return physics.solve_shape(self.obstacle(tool_mm, self._side), previous)
