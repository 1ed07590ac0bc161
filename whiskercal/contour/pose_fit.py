"""Where an outline lies among a reconstruction's points: the pose (and, for the paper's metric,
the scale) that lays the outline best onto the points.

A pose places the outline in the points' frame: a point q of the outline (mm) lies at
``scale * R(theta) q + (x, y)``. ``rigid`` fits x, y and theta; ``similarity`` also the scale, as
the paper's evaluation did. The fit minimizes the sum of squared distances from each point to
the continuous outline (measured in the points' frame), from twelve turns of the outline about
the points' centre (or from a given pose), on an even subsample of the points; the best is then
refined on more of them.

A free scale lays an outline of any size onto the points, so a similarity fit that scales the
outline by less than half or more than twice is refused: the points do not show that object (or
they are in other units). A fit to points that span a small part of the outline's size, or to
too few points, is refused too: such points fit anywhere along the outline.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import shapely
from scipy.optimize import least_squares

from whiskercal.contour.outline_spec import SpecOutline
from whiskercal.errors import UsageError

FITS = ("none", "rigid", "similarity")
MIN_FIT_POINTS = 10  # distinct points a fit needs (3 or 4 unknowns, and some redundancy)
MIN_SPREAD_SHARE = 0.05  # the points' extent against the outline's below which a fit is refused
SCALE_RANGE = (0.5, 2.0)  # a similarity fit's scale outside this is refused
_START_TURNS = 12
_SAME_COST = 1e-4  # fits from two starts whose costs differ by less than this share are one fit
_START_POINTS, _REFINE_POINTS = 300, 2000
_START_STEPS, _MAX_STEPS = 30, 100  # least-squares evaluations from each start, and refining


class FitRefusedError(UsageError):
    """A fit that would lay the outline onto the points without meaning anything."""


@dataclass(frozen=True)
class Pose:
    """The outline's place in the points' frame: shift (mm), turn (rad) and scale (1: as stated)."""

    x_mm: float = 0.0
    y_mm: float = 0.0
    theta_rad: float = 0.0
    scale: float = 1.0

    def to_outline(self, points_mm: np.ndarray) -> np.ndarray:
        """Points (n, 2) from the points' frame into the outline's (mm of the stated outline)."""
        c, s = math.cos(self.theta_rad), math.sin(self.theta_rad)
        shifted = np.asarray(points_mm, float) - [self.x_mm, self.y_mm]
        return shifted @ np.array([[c, -s], [s, c]]) / self.scale

    def to_points(self, outline_mm: np.ndarray) -> np.ndarray:
        """Outline points (n, 2) into the points' frame (mm)."""
        c, s = math.cos(self.theta_rad), math.sin(self.theta_rad)
        turned = np.asarray(outline_mm, float) @ np.array([[c, s], [-s, c]])
        return self.scale * turned + [self.x_mm, self.y_mm]

    def describe(self) -> dict:
        """JSON-able: x_mm, y_mm, deg (and scale)."""
        return {"x_mm": self.x_mm, "y_mm": self.y_mm, "deg": math.degrees(self.theta_rad),
                "scale": self.scale}


def distances_mm(points_mm: np.ndarray, outline: SpecOutline, pose: Pose) -> np.ndarray:
    """Distance (n,) from each point to the continuous outline placed at ``pose``, mm."""
    inside = shapely.points(pose.to_outline(points_mm))
    return pose.scale * shapely.distance(inside, outline.geometry)


def fit_rigid(points_mm: np.ndarray, outline: SpecOutline, start: Pose | None = None) -> Pose:
    """The rigid pose (scale 1) that lays ``outline`` best onto ``points_mm``, from ``start``
    (None: twelve turns about the points' centre); :class:`FitRefusedError` for too few points
    or points that span too little of the outline."""
    _check_fittable(points_mm, outline)
    starts = [Pose(start.x_mm, start.y_mm, start.theta_rad)] if start else _starts(points_mm, outline)
    sample = _even(points_mm, _START_POINTS)
    found = [_refine(sample, outline, begin, scaled=False, steps=_START_STEPS) for begin in starts]
    costs = np.array([_cost(sample, outline, pose) for pose in found])
    # a symmetric outline fits as well at several turns: the one nearest 0° is reported
    equal = [pose for pose, cost in zip(found, costs) if cost <= costs.min() * (1 + _SAME_COST)]
    best = min(equal, key=lambda pose: abs(pose.theta_rad))
    return _refine(_even(points_mm, _REFINE_POINTS), outline, best, scaled=False)


def fit_similarity(points_mm: np.ndarray, outline: SpecOutline, rigid: Pose) -> Pose:
    """The pose and free scale that lay ``outline`` best onto ``points_mm``, from the ``rigid``
    fit; :class:`FitRefusedError` when the scale leaves :data:`SCALE_RANGE`."""
    scaled = _refine(_even(points_mm, _REFINE_POINTS), outline, rigid, scaled=True)
    if not SCALE_RANGE[0] <= scaled.scale <= SCALE_RANGE[1]:
        raise FitRefusedError(
            f"the similarity fit scales the outline by {scaled.scale:.4g}, outside "
            f"{SCALE_RANGE[0]:g}..{SCALE_RANGE[1]:g}: the points are not that object's size "
            "(other units? --units m for metres)")
    return scaled


def _check_fittable(points_mm: np.ndarray, outline: SpecOutline) -> None:
    distinct = len(np.unique(np.round(points_mm, 6), axis=0))
    if distinct < MIN_FIT_POINTS:
        raise FitRefusedError(f"a fit needs at least {MIN_FIT_POINTS} distinct points, the file "
                              f"has {distinct}: use --fit none with --pose")
    spread = float(np.linalg.norm(np.ptp(points_mm, axis=0)))
    if spread < MIN_SPREAD_SHARE * outline.size_mm:
        raise FitRefusedError(
            f"the points span {spread:.4g} mm, the outline {outline.size_mm:.4g} mm: a fit would "
            "lay them anywhere along it (other units? --units m for metres)")


def _starts(points_mm: np.ndarray, outline: SpecOutline) -> list[Pose]:
    """The outline's centre on the points' bounding-box centre, turned every 30°."""
    low, high = points_mm.min(axis=0), points_mm.max(axis=0)
    centre = (low + high) / 2
    poses = []
    for turn in np.arange(_START_TURNS) * 2 * math.pi / _START_TURNS:
        shift = centre - Pose(theta_rad=turn).to_points(outline.centre_mm[None])[0]
        poses.append(Pose(float(shift[0]), float(shift[1]), float(turn)))
    return poses


def _even(points_mm: np.ndarray, count: int) -> np.ndarray:
    """At most ``count`` points, evenly spaced through the array (its order kept)."""
    if len(points_mm) <= count:
        return points_mm
    return points_mm[np.linspace(0, len(points_mm) - 1, count).astype(int)]


def _cost(points_mm: np.ndarray, outline: SpecOutline, pose: Pose) -> float:
    return float(np.sum(_nearest(points_mm, outline, pose)[0] ** 2))


def _refine(points_mm: np.ndarray, outline: SpecOutline, start: Pose, scaled: bool,
            steps: int = _MAX_STEPS) -> Pose:
    """Least squares from ``start`` over x, y, theta (and log scale when ``scaled``), each
    point's residual its distance to the outline; the Jacobian holds the nearest points fixed
    (exact: the distance's gradient is the same along the outline at its nearest point)."""
    def pose_of(p: np.ndarray) -> Pose:
        return Pose(p[0], p[1], p[2], math.exp(np.clip(p[3], -20, 20)) if scaled else start.scale)

    def residuals(p: np.ndarray) -> np.ndarray:
        return _nearest(points_mm, outline, pose_of(p))[0]

    def jacobian(p: np.ndarray) -> np.ndarray:
        pose = pose_of(p)
        distance, nearest = _nearest(points_mm, outline, pose)
        away = (points_mm - nearest) / np.maximum(distance, 1e-12)[:, None]
        placed = nearest - [pose.x_mm, pose.y_mm]  # scale * R(theta) c
        turned = np.column_stack([-placed[:, 1], placed[:, 0]])  # its derivative in theta
        columns = [-away[:, 0], -away[:, 1], -np.sum(away * turned, axis=1)]
        if scaled:
            columns.append(-np.sum(away * placed, axis=1))
        return np.column_stack(columns)

    first = [start.x_mm, start.y_mm, start.theta_rad] + ([math.log(start.scale)] if scaled else [])
    radius = max(outline.size_mm / 2, 1.0)
    x_scale = [radius, radius, 1.0] + ([1.0] if scaled else [])
    found = least_squares(residuals, first, jac=jacobian, x_scale=x_scale, max_nfev=steps)
    pose = pose_of(found.x)
    return Pose(float(pose.x_mm), float(pose.y_mm), float(math.remainder(pose.theta_rad, 2 * math.pi)),
                float(pose.scale))


def _nearest(points_mm: np.ndarray, outline: SpecOutline, pose: Pose) -> tuple[np.ndarray, np.ndarray]:
    """Each point's distance (mm) to the outline placed at ``pose``, and its nearest point of
    the outline in the points' frame."""
    nearest = pose.to_points(outline.nearest(pose.to_outline(points_mm)))
    return np.linalg.norm(points_mm - nearest, axis=1), nearest
