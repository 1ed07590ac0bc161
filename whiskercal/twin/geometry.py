"""Where the whisker frame sits in the stage's machine coordinates, and the turn between them."""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np


@dataclass(frozen=True)
class RigGeometry:
    """Where the whisker frame sits in the stage's machine coordinates (mm, rad).

    The defaults put the calibration grid (whisker x 20..75, y -40..+10) at stage x 60..115,
    y 60..110, with room above it for the rod's approach from +y and around it for the plane's
    slide; see docs/twin.md.
    """

    origin_stage_mm: tuple[float, float] = (40.0, 100.0)
    angle_rad: float = 0.0  # direction of the whisker's +x axis in stage coordinates

    @cached_property
    def _rotation(self) -> np.ndarray:
        # cached: the world converts the carriage position at every sample
        c, s = math.cos(self.angle_rad), math.sin(self.angle_rad)
        return np.array([[c, -s], [s, c]])

    @cached_property
    def _origin(self) -> np.ndarray:
        return np.asarray(self.origin_stage_mm, float)

    def to_whisker(self, stage_mm) -> np.ndarray:
        """Stage (machine) coordinates -> whisker frame, mm; works on (..., 2)."""
        return (np.asarray(stage_mm, float) - self._origin) @ self._rotation

    def to_stage(self, whisker_mm) -> np.ndarray:
        """Whisker frame -> stage (machine) coordinates, mm; works on (..., 2)."""
        return np.asarray(whisker_mm, float) @ self._rotation.T + self._origin
