"""A tiny stand-in physics for world tests (no tests here): a rigid whisker turning about its root.

Test-only. It makes the world's plumbing (geometry, time order, truth record, counts) testable
without depending on the real mechanics' numbers.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

REACH_MM = 78.0
STATIC_FIELD_UT = np.array([0.0, 1200.0, -500.0])
FIELD_PER_RAD_UT = 20000.0


@dataclass(frozen=True)
class RigidEquilibrium:
    kind: str
    root_rotation_rad: float
    contact_mm: np.ndarray
    tip_mm: np.ndarray
    root_shift_mm: tuple = (0.0, 0.0)
    slips: int = 0

    @property
    def in_contact(self) -> bool:
        return self.kind != "free"

    def shape_mm(self, n: int = 101) -> np.ndarray:
        return np.linspace([0.0, 0.0], self.tip_mm, n + 1)


def _free() -> RigidEquilibrium:
    return RigidEquilibrium("free", 0.0, np.full(2, np.nan), np.array([REACH_MM, 0.0]))


class RigidWhiskerPhysics:
    """Rod contacts only: the whisker turns until it is tangent to the rod (frictionless)."""

    def __init__(self) -> None:
        self.solves = 0

    def free(self) -> RigidEquilibrium:
        return _free()

    def solve_shape(self, obstacle, previous) -> RigidEquilibrium:
        self.solves += 1
        center, radius = np.asarray(obstacle.center_mm), obstacle.radius_mm
        distance = float(np.hypot(*center))
        if distance <= radius:
            raise ValueError("rod on the pivot")
        angle = math.atan2(center[1], center[0]) - math.asin(radius / distance)
        along = math.sqrt(distance**2 - radius**2)
        if angle >= 0 or along > REACH_MM:
            return _free()
        direction = np.array([math.cos(angle), math.sin(angle)])
        return RigidEquilibrium("shaft", angle, along * direction, REACH_MM * direction)

    def solve_plane(self, plane, previous) -> RigidEquilibrium:
        raise NotImplementedError("the rigid stand-in meets rods and shapes only")

    def field_uT(self, equilibrium) -> np.ndarray:
        return STATIC_FIELD_UT + np.array([0.0, FIELD_PER_RAD_UT * equilibrium.root_rotation_rad, 0.0])
