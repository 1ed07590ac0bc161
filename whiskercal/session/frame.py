"""The whisker frame and the stage frame, and the rig geometry that maps one onto the other.

The whisker frame has its origin at the suspension's centre of rotation, x along the undeflected
whisker, y to its left (docs/architecture.md, "Frames"). The stage frame is the stage's machine
coordinates. The whisker frame is the stage frame rotated by ``angle_rad`` (counter-clockwise)
about, and shifted to, ``origin_stage_mm``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def rotation(angle_rad: float) -> np.ndarray:
    """2x2 counter-clockwise rotation matrix."""
    c, s = np.cos(angle_rad), np.sin(angle_rad)
    return np.array([[c, -s], [s, c]])


@dataclass(frozen=True)
class RigFrame:
    """Where the whisker frame sits in stage coordinates: origin (mm) and angle (rad)."""

    origin_stage_mm: tuple[float, float]
    angle_rad: float

    @classmethod
    def from_degrees(cls, origin_stage_mm, angle_deg: float) -> "RigFrame":
        """The frame from an origin (mm) and an angle in degrees, as the configs state them."""
        x, y = (float(v) for v in origin_stage_mm)
        return cls((x, y), float(np.radians(angle_deg)))

    @property
    def origin(self) -> np.ndarray:
        """The whisker frame's origin in stage coordinates (2,), mm."""
        return np.asarray(self.origin_stage_mm, float)

    def to_stage(self, points_mm) -> np.ndarray:
        """Whisker-frame points (..., 2) mm to stage coordinates (..., 2) mm."""
        return np.asarray(points_mm, float) @ rotation(self.angle_rad).T + self.origin

    def to_whisker(self, points_mm) -> np.ndarray:
        """Stage coordinates (..., 2) mm to whisker-frame points (..., 2) mm."""
        return (np.asarray(points_mm, float) - self.origin) @ rotation(self.angle_rad)

    def vector_to_stage(self, vectors) -> np.ndarray:
        """Directions or displacements (..., 2) from the whisker frame to the stage frame."""
        return np.asarray(vectors, float) @ rotation(self.angle_rad).T

    def vector_to_whisker(self, vectors) -> np.ndarray:
        """Directions or displacements (..., 2) from the stage frame to the whisker frame."""
        return np.asarray(vectors, float) @ rotation(self.angle_rad)


def outside_travel(points_stage_mm, travel_mm, margin_mm: float) -> np.ndarray:
    """Mask of stage positions (..., 2) mm outside ``margin_mm``..travel-``margin_mm`` (soft limits)."""
    points = np.asarray(points_stage_mm, float)
    high = np.asarray(travel_mm, float) - margin_mm
    return np.any((points < margin_mm) | (points > high), axis=-1)
