"""Nothing on the stage: the whisker stays free (the sensor's noise and drift alone)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from whiskercal.twin.scenes.base import SceneBase


@dataclass
class NoFixture(SceneBase):
    """An empty end effector."""

    name: ClassVar[str] = "none"

    def touches(self, points_mm: np.ndarray, tool_mm: np.ndarray) -> bool:
        """Nothing touches."""
        return False

    def solve(self, physics, tool_mm: np.ndarray, previous):
        """The free whisker (never asked: nothing touches)."""
        return physics.free()
