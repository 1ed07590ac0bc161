"""How good a reconstructed contour is, against the object's true outline (world frame, mm).

``mean_error_mm`` / ``std_error_mm``: the distance from each estimated contact to the true outline,
with no alignment of any kind. ``aligned_mean_error_mm``: the same after the estimate is moved by
the similarity (scale, rotation, translation) that best lays it onto the outline, as the paper's
evaluation did; reported apart, only to compare with the paper, and NaN where the alignment
degenerates (scales the estimate by less than half or more than twice). ``coverage``: the share
of the outline's reachable length (all of a closed outline; an open one's from where the run
first touched it on) within 2 mm of some estimate. ``contour evaluate`` measures any
reconstruction against any outline (``contour.evaluate``).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

COVERAGE_RADIUS_MM = 2.0
_ALIGN_ITERATIONS = 20
_ALIGN_SCALES = (0.5, 2.0)  # an alignment scaling the points beyond these has degenerated


def distances_mm(points_mm: np.ndarray, outline_mm: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Distance (n,) from each point to a densely sampled outline, and the nearest outline points."""
    distance, index = cKDTree(outline_mm).query(points_mm)
    return distance, outline_mm[index]


def similarity(source: np.ndarray, target: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """Scale, rotation (2x2) and translation that best map ``source`` onto ``target`` (Umeyama);
    the scale NaN where ``source`` has no spread."""
    mu_s, mu_t = source.mean(axis=0), target.mean(axis=0)
    a, b = source - mu_s, target - mu_t
    u, sigma, vt = np.linalg.svd(b.T @ a / len(source))
    d = np.diag([1.0, np.sign(np.linalg.det(u @ vt))])
    rotation = u @ d @ vt
    spread = float(np.mean(np.sum(a ** 2, axis=1)))
    if spread == 0.0:  # the source at one place: any scale fits it, none is the answer
        return float("nan"), rotation, mu_t - mu_s
    scale = float(np.trace(np.diag(sigma) @ d) / spread)
    return scale, rotation, mu_t - scale * rotation @ mu_s


def aligned_errors_mm(points_mm: np.ndarray, outline_mm: np.ndarray) -> np.ndarray:
    """Distances after the best similarity alignment (iterated closest points); NaN when the
    alignment scales the points by less than half or more than twice: shrunk onto a piece of
    the outline, points of any shape lie on it, so such a figure would mean nothing. NaN too
    for points with no spread (one place, repeated), which no similarity can scale."""
    moved, scale = points_mm.copy(), 1.0
    for _ in range(_ALIGN_ITERATIONS):
        _, nearest = distances_mm(moved, outline_mm)
        scale, rotation, shift = similarity(points_mm, nearest)
        if not np.isfinite(scale):
            break
        moved = scale * points_mm @ rotation.T + shift
    if not _ALIGN_SCALES[0] <= scale <= _ALIGN_SCALES[1]:
        return np.full(len(points_mm), np.nan)
    return distances_mm(moved, outline_mm)[0]


def coverage(points_mm: np.ndarray, outline_mm: np.ndarray) -> float:
    """Share of the (evenly sampled) outline within COVERAGE_RADIUS_MM of some point."""
    if len(points_mm) == 0:
        return 0.0
    distance, _ = cKDTree(points_mm).query(outline_mm, distance_upper_bound=COVERAGE_RADIUS_MM)
    return float(np.mean(np.isfinite(distance)))


def contour_metrics(points_mm: np.ndarray, outline_mm: np.ndarray,
                    reachable_mm: np.ndarray | None = None) -> dict[str, float]:
    """The metrics of the module's docstring for estimated contacts (n, 2) and a dense outline;
    the coverage of ``reachable_mm`` (a dense part of it; None: all of it)."""
    reachable_mm = outline_mm if reachable_mm is None else reachable_mm
    if len(points_mm) == 0:
        nan = float("nan")
        return {"mean_error_mm": nan, "std_error_mm": nan, "max_error_mm": nan,
                "aligned_mean_error_mm": nan, "coverage": 0.0, "contacts": 0}
    errors = distances_mm(points_mm, outline_mm)[0]
    aligned = aligned_errors_mm(points_mm, outline_mm)
    return {"mean_error_mm": float(errors.mean()), "std_error_mm": float(errors.std()),
            "max_error_mm": float(errors.max()), "aligned_mean_error_mm": float(aligned.mean()),
            "coverage": coverage(points_mm, reachable_mm), "contacts": int(len(points_mm))}
