"""The next contact point from the last key points: a cubic B-spline extrapolated one step."""

from __future__ import annotations

import warnings

import numpy as np
from scipy.interpolate import splev, splprep


def predict_next(points_mm: np.ndarray, noise_mm: float = 0.0) -> np.ndarray:
    """The point one key-point step past the last of ``points_mm`` (n >= 4, oldest first), mm."""
    return surface_step(points_mm, noise_mm)[1]


def surface_step(points_mm: np.ndarray, noise_mm: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """The spline's last point and the point one key-point step past it (mm), through
    ``points_mm`` (n >= 4, oldest first).

    The spline goes through the points with centripetal parameters scaled to 0..1; evenly spaced
    key points make them nearly uniform, so the next point lies at u = 1 + 1/(n - 1) (the paper's
    extrapolation). ``noise_mm`` (the key points' scatter, rms) makes it a smoothing spline
    (residual sum of squares at most n·noise²): an interpolating cubic extrapolated from
    points 2 mm apart turns the direction by several degrees for every 0.1 mm of scatter.
    """
    points = np.asarray(points_mm, float)
    steps = np.sqrt(np.linalg.norm(np.diff(points, axis=0), axis=1))
    u = np.concatenate([[0.0], np.cumsum(steps)])
    if u[-1] <= 0:
        return points[-1].copy(), points[-1].copy()
    u /= u[-1]
    with warnings.catch_warnings():
        # FITPACK may stop short of the exact residual asked for (its iteration limit, or s
        # below what the knots allow) and says so; the spline it returns still smooths
        warnings.simplefilter("ignore", RuntimeWarning)
        spline, _ = splprep(points.T, u=u, k=3, s=len(points) * noise_mm ** 2)
    x, y = splev([1.0, 1.0 + 1.0 / (len(points) - 1)], spline, ext=0)
    return np.array([x[0], y[0]]), np.array([x[1], y[1]])
