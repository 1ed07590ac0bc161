"""The contour scenes' objects: extruded convex shapes seen from above, in the world frame (mm).

Each is a convex core (a point or a convex polygon) grown by a corner radius, as the paper's
objects are: a cylinder (Ø 160 mm), a square prism with rounded corners (160 mm wide, 40 mm
radius) and an octagonal prism (70 mm sides, 30 mm corner radius). The whisker meets them through
the twin's frictionless shape contact (``physics.obstacles.Circle`` / ``Polygon``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from whiskercal.errors import UsageError
from whiskercal.twin.physics.obstacles import Circle, Polygon

SHAPES = ("cylinder", "rounded-rect", "octagon")
_ARC_STEP_RAD = math.radians(3.0)  # corner arcs as polygon edges 3° apart (0.014 mm sag at 40 mm)


@dataclass(frozen=True)
class Outline:
    """A convex core (vertices, counter-clockwise; one vertex for a disc) grown by ``radius_mm``."""

    name: str
    core_mm: np.ndarray
    radius_mm: float

    def obstacle(self):
        """The object as the twin's contact solver takes it (world frame, mm)."""
        if len(self.core_mm) == 1:
            return Circle(self.core_mm[0], self.radius_mm)
        return Polygon(self.points(_ARC_STEP_RAD))

    def points(self, step_rad: float = math.radians(0.5)) -> np.ndarray:
        """The outline as counter-clockwise points (n, 2), corner arcs every ``step_rad``."""
        if len(self.core_mm) == 1:
            angles = np.arange(0.0, 2 * math.pi, step_rad)
            return self.core_mm[0] + self.radius_mm * np.column_stack([np.cos(angles), np.sin(angles)])
        parts = []
        core = self.core_mm
        for i, vertex in enumerate(core):
            before, after = core[i - 1], core[(i + 1) % len(core)]
            start = _outward_angle(before, vertex)
            end = _outward_angle(vertex, after)
            end += 2 * math.pi if end < start else 0.0
            angles = np.linspace(start, end, max(2, int(math.ceil((end - start) / step_rad)) + 1))
            parts.append(vertex + self.radius_mm * np.column_stack([np.cos(angles), np.sin(angles)]))
        return np.vstack(parts)

    def dense(self, spacing_mm: float = 0.05) -> np.ndarray:
        """Points along the whole outline no more than ``spacing_mm`` apart (for distances)."""
        ring = self.points()
        ring = np.vstack([ring, ring[:1]])
        pieces = []
        for a, b in zip(ring[:-1], ring[1:]):
            count = max(1, int(math.ceil(np.linalg.norm(b - a) / spacing_mm)))
            pieces.append(a + (b - a) * (np.arange(count)[:, None] / count))
        return np.vstack(pieces)

    @property
    def perimeter_mm(self) -> float:
        """Length of the outline, mm."""
        ring = self.points()
        return float(np.sum(np.linalg.norm(np.roll(ring, -1, axis=0) - ring, axis=1)))


def _outward_angle(a: np.ndarray, b: np.ndarray) -> float:
    """Direction of the outward normal of the counter-clockwise edge a -> b, rad."""
    edge = b - a
    return math.atan2(-edge[0], edge[1])


def _regular(sides: int, apothem_mm: float) -> np.ndarray:
    angles = (np.arange(sides) + 0.5) * 2 * math.pi / sides - math.pi / 2
    return apothem_mm / math.cos(math.pi / sides) * np.column_stack([np.cos(angles), np.sin(angles)])


def outline(name: str, center_mm=(0.0, 0.0), rotation_rad: float = 0.0) -> Outline:
    """One of :data:`SHAPES`, centred at ``center_mm`` and turned by ``rotation_rad``."""
    if name == "cylinder":
        core, radius = np.zeros((1, 2)), 80.0
    elif name == "rounded-rect":  # 160 mm wide, corners of 40 mm radius
        core, radius = _regular(4, 80.0 - 40.0), 40.0
    elif name == "octagon":  # 70 mm sides, corners of 30 mm radius
        apothem = 70.0 / (2 * math.tan(math.pi / 8))
        core, radius = _regular(8, apothem - 30.0), 30.0
    else:
        raise UsageError(f"unknown shape {name!r}; use one of {', '.join(SHAPES)}")
    turn = np.array([[math.cos(rotation_rad), -math.sin(rotation_rad)],
                     [math.sin(rotation_rad), math.cos(rotation_rad)]])
    return Outline(name, core @ turn.T + np.asarray(center_mm, float), radius)
