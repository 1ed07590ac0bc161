"""A flat plate through the end effector's point: the optimal-depth study's plane."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property
from typing import ClassVar

import numpy as np

from whiskercal.twin.physics.obstacles import Plane
from whiskercal.twin.scenes.base import SceneBase

# Outward normal in the whisker frame: back toward the root, tilted 20° to -y (the study's
# plane, reference/README.md).
DEFAULT_PLANE_NORMAL_RAD = math.pi + math.radians(20.0)


@dataclass
class PlaneFixture(SceneBase):
    """A flat plate whose surface passes through the end effector's point.

    Moving the stage along the plate's normal changes the contact depth; moving it along the
    plate slides the surface under the whisker's tip (``Plane.slide_mm``). The plate is
    ``2 * half_length_mm`` long and ``thickness_mm`` thick behind its surface: only a whisker
    inside that box touches it (the mechanics then treat the surface as an infinite plane).
    The friction values left None keep the mechanics' defaults (``physics.obstacles``). The
    plate remembers which way it last slid along itself: a push straight in keeps sliding the
    friction the way it went before.
    """

    name: ClassVar[str] = "plane"
    normal_rad: float = DEFAULT_PLANE_NORMAL_RAD
    mu_static: float | None = None
    mu_kinetic: float | None = None
    slip_rebound: float | None = None
    half_length_mm: float = 60.0
    thickness_mm: float = 10.0
    _motion_sign: int = field(default=1, init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        # checked here, not at the first touch: the world turns solver errors into "failed"
        # samples, and friction the plane refuses would fail every one of them
        self.obstacle(np.zeros(2), 1)

    def touches(self, points_mm: np.ndarray, tool_mm: np.ndarray) -> bool:
        """True when any of the points (mm) lies inside the plate."""
        depth = (tool_mm - points_mm) @ self._normal
        along = (points_mm - tool_mm) @ self._tangent
        inside = (depth >= 0) & (depth <= self.thickness_mm) & (np.abs(along) <= self.half_length_mm)
        return bool(np.any(inside))

    def moved(self, from_mm: np.ndarray, to_mm: np.ndarray) -> None:
        """Note the direction of any slide along the surface."""
        along = float(self._tangent @ (to_mm - from_mm))
        if abs(along) > 1e-12:
            self._motion_sign = 1 if along > 0 else -1

    def solve(self, physics, tool_mm: np.ndarray, previous):
        """The whisker against the plate, stick-slip continued from ``previous``."""
        return physics.solve_plane(self.obstacle(tool_mm, self._motion_sign), previous)

    def obstacle(self, tool_mm: np.ndarray, motion_sign: int) -> Plane:
        """The plate as a ``Plane`` (slid by the tool's position along it) moving ``motion_sign``."""
        normal, tangent = self._normal, self._tangent
        offset = normal[0] * tool_mm[0] + normal[1] * tool_mm[1]
        along = tangent[0] * tool_mm[0] + tangent[1] * tool_mm[1]
        return Plane(offset * normal, self.normal_rad, along, motion_sign=motion_sign,
                     **self._friction)

    def tangent(self) -> np.ndarray:
        """Unit vector the stage slides the surface along (whisker frame)."""
        return self._tangent.copy()

    # cached: the world asks at every step of a slide
    @cached_property
    def _normal(self) -> np.ndarray:
        return np.array([math.cos(self.normal_rad), math.sin(self.normal_rad)])

    @cached_property
    def _tangent(self) -> np.ndarray:
        return np.array([-math.sin(self.normal_rad), math.cos(self.normal_rad)])

    @cached_property
    def _friction(self) -> dict:
        given = (("mu_static", self.mu_static), ("mu_kinetic", self.mu_kinetic),
                 ("slip_rebound", self.slip_rebound))
        return {name: value for name, value in given if value is not None}
