"""A contour scene's shape (a disc or a convex polygon) carried rigidly by the stage."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from whiskercal.twin.scenes.base import SceneBase


@dataclass
class ShapeFixture(SceneBase):
    """``shape``: a ``Circle`` or convex ``Polygon`` (``physics.obstacles``) given around the end
    effector's point (whisker frame, mm); frictionless. No URL names it: make it in code and
    pass it to ``create_world(fixture=...)``."""

    shape: object

    def obstacle(self, tool_mm: np.ndarray):
        """The shape moved to the tool's position."""
        return self.shape.moved(tool_mm)

    def touches(self, points_mm: np.ndarray, tool_mm: np.ndarray) -> bool:
        """True when the shape reaches any of the points (mm)."""
        return self.obstacle(tool_mm).reaches(points_mm)

    def solve(self, physics, tool_mm: np.ndarray, previous):
        """The whisker against the shape, warm-started from ``previous``."""
        return physics.solve_shape(self.obstacle(tool_mm), previous)
