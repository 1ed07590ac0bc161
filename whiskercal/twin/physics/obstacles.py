"""Obstacles the whisker meets, in the whisker frame (mm, rad): a sliding plane, circles, polygons.

Obstacles are immutable; moving one means making a new one (``dataclasses.replace``). The side
an obstacle comes from decides which way it wraps the whisker: ``side = +1`` is an obstacle on
the whisker's +y side pushing it toward -y, as the calibration rod and the study plane do.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from functools import cached_property

import numpy as np

from whiskercal.errors import UsageError
from whiskercal.twin.physics.coulomb import (DEFAULT_MU_KINETIC, DEFAULT_MU_STATIC,
                                             DEFAULT_SLIP_REBOUND, Coulomb)

# The study's plane: its normal tilted about 20° from the whisker axis (reference/README.md).
DEFAULT_PLANE_TILT_RAD = math.radians(20.0)
# The study's stage moves the plane toward -tangent (the tip is dragged toward +y): with it the
# defaults slip into tangential contact at 45 mm (docs/twin.md, "Mechanics").
STUDY_MOTION_SIGN = -1


def finite_point(name: str, value) -> np.ndarray:
    """`value` as a float array of shape (2,), or a UsageError naming `name`."""
    try:
        point = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise UsageError(f"{name} must be two finite numbers (mm), got {value!r}.") from None
    if point.shape != (2,) or not np.all(np.isfinite(point)):
        raise UsageError(f"{name} must be two finite numbers (mm), got {value!r}.")
    return point


def finite_number(name: str, value, minimum: float = -math.inf) -> float:
    """`value` as a finite float >= `minimum`, or a UsageError naming `name`."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise UsageError(f"{name} must be a number, got {value!r}.") from None
    if not math.isfinite(number) or number < minimum:
        raise UsageError(f"{name} must be a finite number >= {minimum:g}, got {value!r}.")
    return number


def _check_side(side) -> int:
    if side not in (1, -1):
        raise UsageError(f"side must be +1 or -1, got {side!r}.")
    return int(side)


@dataclass(frozen=True)
class Plane:
    """A flat surface that the stage slides along itself, with Coulomb friction.

    Attributes
    ----------
    point_mm : ndarray, shape (2,)
        A point of the surface when `slide_mm` is 0.
    normal_rad : float
        Direction of the outward normal (pointing from the surface toward the whisker).
    slide_mm : float
        How far the stage has moved the surface along its tangent, (-sin, cos) of `normal_rad`.
    mu_static, mu_kinetic : float
        Coulomb coefficients at the whisker's tip (static >= kinetic).
    motion_sign : int
        +1 when the stage moves the surface toward +tangent, -1 otherwise; a solve without
        history assumes steady sliding in this direction.
    slip_rebound : float
        How far a slip overshoots the kinetic equilibrium, 0..1 (`Coulomb.slip_rebound`).
    """

    point_mm: np.ndarray
    normal_rad: float
    slide_mm: float = 0.0
    mu_static: float = DEFAULT_MU_STATIC
    mu_kinetic: float = DEFAULT_MU_KINETIC
    motion_sign: int = 1
    slip_rebound: float = DEFAULT_SLIP_REBOUND

    def __post_init__(self) -> None:
        object.__setattr__(self, "point_mm", finite_point("plane point_mm", self.point_mm))
        finite_number("plane normal_rad", self.normal_rad)
        finite_number("plane slide_mm", self.slide_mm)
        self.coulomb  # checks the friction coefficients
        _check_side(self.motion_sign)

    @cached_property
    def coulomb(self) -> Coulomb:
        """The tip's friction against this surface (the model every stick-slip contact shares)."""
        return Coulomb(self.mu_static, self.mu_kinetic, self.slip_rebound)

    @property
    def rest_ratio(self) -> float:
        """|F_t|/F_n where a slipping tip comes to rest and sticks again (`Coulomb.rest_ratio`)."""
        return self.coulomb.rest_ratio

    @cached_property
    def normal(self) -> np.ndarray:
        """Outward unit normal."""
        return np.array([math.cos(self.normal_rad), math.sin(self.normal_rad)])

    @cached_property
    def tangent(self) -> np.ndarray:
        """Unit tangent, the normal turned by +90°; `slide_mm` is measured along it."""
        return np.array([-math.sin(self.normal_rad), math.cos(self.normal_rad)])

    @cached_property
    def offset_mm(self) -> float:
        """n·p for every point p of the surface (sliding does not change it)."""
        return float(self.normal @ self.point_mm)

    def material_point_mm(self, anchor_mm: float) -> np.ndarray:
        """Where the surface point with plane coordinate `anchor_mm` is now."""
        return self.point_mm + (anchor_mm + self.slide_mm) * self.tangent

    def anchor_of(self, point_mm: np.ndarray) -> float:
        """The plane coordinate (in the moving surface's own frame) of a point on it."""
        return float(self.tangent @ (np.asarray(point_mm) - self.point_mm) - self.slide_mm)


@dataclass(frozen=True)
class Circle:
    """A circular obstacle (a rod seen from above), frictionless.

    Attributes
    ----------
    center_mm : ndarray, shape (2,)
    radius_mm : float
    side : int
        +1: it comes from the whisker's +y side and pushes toward -y; -1 the other way.
    """

    center_mm: np.ndarray
    radius_mm: float
    side: int = 1

    def __post_init__(self) -> None:
        object.__setattr__(self, "center_mm", finite_point("circle center_mm", self.center_mm))
        finite_number("radius_mm", self.radius_mm, 0.0)
        _check_side(self.side)

    def moved(self, offset_mm: np.ndarray) -> "Circle":
        """The same circle moved by `offset_mm`."""
        return replace(self, center_mm=self.center_mm + offset_mm)

    def reaches(self, points_mm: np.ndarray) -> bool:
        """True when any of the points (n, 2) lies on or inside the circle."""
        return bool(np.min(np.hypot(*(points_mm - self.center_mm).T)) <= self.radius_mm)


@dataclass(frozen=True)
class Polygon:
    """A convex polygon obstacle; vertices in counter-clockwise order (mm). Frictionless (the
    tip's stick-slip on it is `physics.shape_friction`'s)."""

    vertices_mm: np.ndarray
    side: int = 1

    def __post_init__(self) -> None:
        vertices = np.asarray(self.vertices_mm, dtype=float)
        if vertices.ndim != 2 or vertices.shape[1] != 2 or len(vertices) < 3:
            raise UsageError("a polygon needs at least three (x, y) vertices in mm.")
        if not np.all(np.isfinite(vertices)):
            raise UsageError("polygon vertices must be finite numbers (mm).")
        edges = _following(vertices) - vertices
        after = _following(edges)
        turns = edges[:, 0] * after[:, 1] - edges[:, 1] * after[:, 0]
        if np.any(turns <= 0):
            raise UsageError("polygon vertices must be convex and counter-clockwise.")
        object.__setattr__(self, "vertices_mm", vertices)
        _check_side(self.side)

    @cached_property
    def outward_normals(self) -> np.ndarray:
        """Unit outward normal of each edge i (from vertex i to i+1), shape (k, 2); computed
        once (the contact solver asks for it many times per pose)."""
        edges = _following(self.vertices_mm) - self.vertices_mm
        normals = np.column_stack([edges[:, 1], -edges[:, 0]])
        return normals / np.linalg.norm(normals, axis=1, keepdims=True)

    @cached_property
    def edge_offsets_mm(self) -> np.ndarray:
        """n_i·v_i of each edge i: a point p lies outside edge i's line when n_i·p exceeds it."""
        return np.einsum("ij,ij->i", self.outward_normals, self.vertices_mm)

    def depth_mm(self, points_mm: np.ndarray) -> np.ndarray:
        """How far each point lies inside the polygon (negative outside), shape (n,)."""
        return np.min(self.edge_offsets_mm[None, :] - points_mm @ self.outward_normals.T, axis=1)

    def edge_distances_mm(self, point_mm: np.ndarray) -> np.ndarray:
        """Distance (mm) from `point_mm` to each edge i (from vertex i to i+1), shape (k,)."""
        vertices = self.vertices_mm
        edge = _following(vertices) - vertices
        share = np.clip(((point_mm - vertices) * edge).sum(axis=1) / (edge * edge).sum(axis=1),
                        0.0, 1.0)
        return np.linalg.norm(vertices + share[:, None] * edge - point_mm, axis=1)

    def seen_from(self, turn: np.ndarray, origin_mm: np.ndarray) -> "Polygon":
        """The same polygon in a frame at `origin_mm` (mm) turned by `turn` (the 2x2 rotation from
        this frame to that one). A rigid move keeps it convex and counter-clockwise, so nothing
        is checked again, and its normals and edge offsets follow from this one's (a moving
        scene builds the object in the sensor's frame at every period)."""
        moved = object.__new__(Polygon)
        object.__setattr__(moved, "vertices_mm", (self.vertices_mm - origin_mm) @ turn.T)
        object.__setattr__(moved, "side", self.side)
        moved.__dict__["outward_normals"] = self.outward_normals @ turn.T
        moved.__dict__["edge_offsets_mm"] = self.edge_offsets_mm - self.outward_normals @ origin_mm
        return moved

    def moved(self, offset_mm: np.ndarray) -> "Polygon":
        """The same polygon moved by `offset_mm`."""
        return replace(self, vertices_mm=self.vertices_mm + offset_mm)

    def reaches(self, points_mm: np.ndarray) -> bool:
        """True when any of the points (n, 2) lies on or inside the polygon."""
        return bool(np.max(self.depth_mm(points_mm)) >= 0)

    def crosses_polyline(self, points_mm: np.ndarray, tol_mm: float = 1e-6) -> bool:
        """Does any segment of the polyline through `points_mm` (n, 2) cut into the polygon
        deeper than `tol_mm`? (Separating axes: the edge normals and each segment's normal.)"""
        points = np.asarray(points_mm, dtype=float)
        height = points @ self.outward_normals.T - self.edge_offsets_mm  # (n, k) above each edge
        separated = (np.minimum(height[:-1], height[1:]) >= -tol_mm).any(axis=1)
        if separated.all():  # the usual case, and most of a moving scene's calls: done
            return False
        # only the segments no edge separates need their own normal as the axis
        starts, ends = points[:-1][~separated], points[1:][~separated]
        direction = ends - starts
        across = np.empty_like(direction)
        across[:, 0], across[:, 1] = -direction[:, 1], direction[:, 0]
        across /= np.maximum(np.sqrt((across * across).sum(axis=1, keepdims=True)), 1e-300)
        signed = across @ self.vertices_mm.T - (across * starts).sum(axis=1)[:, None]
        apart = (signed >= -tol_mm).all(axis=1) | (signed <= tol_mm).all(axis=1)
        return not apart.all()


def _following(rows: np.ndarray) -> np.ndarray:
    """Row i + 1 at row i, the last row followed by the first (``np.roll(rows, -1, axis=0)``,
    without its overhead: polygons are built at every pose of a moving scene)."""
    return np.concatenate([rows[1:], rows[:1]])


def regular_polygon(center_mm, circumradius_mm: float, n_sides: int,
                    rotation_rad: float = 0.0, side: int = 1) -> Polygon:
    """A regular polygon (an octagon for the contour scenes) around `center_mm`."""
    angles = rotation_rad + 2 * np.pi * np.arange(n_sides) / n_sides
    center = finite_point("center_mm", center_mm)
    radius = finite_number("circumradius_mm", circumradius_mm, 0.0)
    return Polygon(center + radius * np.column_stack([np.cos(angles), np.sin(angles)]), side)


def plane_for_depth(whisker, depth_mm: float, slide_mm: float = 0.0,
                    tilt_rad: float = DEFAULT_PLANE_TILT_RAD, **friction) -> Plane:
    """The study's plane pushed `depth_mm` past the undeflected tip along its normal.

    The outward normal points back toward the root, tilted `tilt_rad` toward -y from the
    whisker's axis, so pressing on the tip pushes the whisker toward -y. At depth 0 the surface
    touches the undeflected tip. `friction` passes mu_static, mu_kinetic, motion_sign to `Plane`
    (motion_sign defaults to the study's, `STUDY_MOTION_SIGN`).
    """
    friction.setdefault("motion_sign", STUDY_MOTION_SIGN)
    depth = finite_number("depth_mm", depth_mm)
    normal_rad = math.pi + finite_number("tilt_rad", tilt_rad)
    normal = np.array([math.cos(normal_rad), math.sin(normal_rad)])
    tip = np.array([whisker.reach_mm, 0.0])
    return Plane(tip + depth * normal, normal_rad, finite_number("slide_mm", slide_mm), **friction)
