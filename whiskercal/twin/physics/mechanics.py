"""The whisker's statics, one import away: contacts with rods, planes, circles and polygons.

All functions are pure and deterministic; they take a `WhiskerParams`, an obstacle in the
whisker frame (mm, rad) and optionally the `previous` equilibrium along a path (a warm start,
and for the plane the stick-slip state), and return an `Equilibrium`.

- `free(whisker)`: the undeflected whisker.
- `solve_rod(whisker, rod_center_mm, rod_radius_mm, previous=None, side=1)`: the touch rod.
- `solve_plane(whisker, plane, previous=None)`: a sliding plane with Coulomb friction.
- `solve_shape(whisker, obstacle, previous=None)`: a `Circle` or convex `Polygon`.
- `plane_for_depth(whisker, depth_mm, slide_mm, tilt_rad=...)`: the study's plane.
- `cantilever_tip(alpha)`: tip of a rigid-root cantilever under a perpendicular tip load.
"""

from __future__ import annotations

from whiskercal.errors import UsageError
from whiskercal.twin.physics.cantilever import cantilever_tip
from whiskercal.twin.physics.contacts import free, solve_circle, solve_rod
from whiskercal.twin.physics.plane import solve_plane
from whiskercal.twin.physics.polygon import solve_polygon
from whiskercal.twin.physics.obstacles import (DEFAULT_MU_KINETIC, DEFAULT_MU_STATIC,
                                    DEFAULT_PLANE_TILT_RAD, STUDY_MOTION_SIGN, Circle, Plane,
                                    Polygon, plane_for_depth, regular_polygon)
from whiskercal.twin.physics.whisker import Equilibrium, WhiskerParams

__all__ = [
    "DEFAULT_MU_KINETIC", "DEFAULT_MU_STATIC", "DEFAULT_PLANE_TILT_RAD", "STUDY_MOTION_SIGN",
    "Circle", "Equilibrium", "Plane", "Polygon", "WhiskerParams", "cantilever_tip", "free",
    "plane_for_depth", "regular_polygon", "solve_plane", "solve_rod", "solve_shape",
]


def solve_shape(whisker: WhiskerParams, obstacle, previous: Equilibrium | None = None
                ) -> Equilibrium:
    """Equilibrium against a contour-scene obstacle: a `Circle` or a convex `Polygon`.

    Parameters
    ----------
    whisker : WhiskerParams
    obstacle : Circle or Polygon
        In the whisker frame (mm); frictionless.
    previous : Equilibrium, optional
        The state at the previous pose along a path (a warm start).

    Returns
    -------
    Equilibrium
    """
    if isinstance(obstacle, Circle):
        return solve_circle(whisker, obstacle, previous)
    if isinstance(obstacle, Polygon):
        return solve_polygon(whisker, obstacle, previous)
    raise UsageError(f"expected a Circle or a Polygon, got {type(obstacle).__name__}.")
