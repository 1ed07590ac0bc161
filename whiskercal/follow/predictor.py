"""The next contact point from the last key points: a cubic B-spline extrapolated one step."""

from __future__ import annotations

import numpy as np
from scipy.interpolate import splev, splprep


def predict_next(points_mm: np.ndarray) -> np.ndarray:
    """The point one key-point step past the last of ``points_mm`` (n >= 4, oldest first), mm.

    The spline goes through the points with centripetal parameters scaled to 0..1; evenly spaced
    key points make them nearly uniform, so the next point lies at u = 1 + 1/(n - 1) (the paper's
    extrapolation).
    """
    points = np.asarray(points_mm, float)
    steps = np.sqrt(np.linalg.norm(np.diff(points, axis=0), axis=1))
    u = np.concatenate([[0.0], np.cumsum(steps)])
    if u[-1] <= 0:
        return points[-1].copy()
    u /= u[-1]
    spline, _ = splprep(points.T, u=u, k=3, s=0.0)
    x, y = splev(1.0 + 1.0 / (len(points) - 1), spline, ext=0)
    return np.array([float(x), float(y)])
