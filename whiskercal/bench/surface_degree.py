"""Surface degree 1..8: cross-validated error, error against the twin's truth, evaluation time.

For each total degree the surface is fitted to a grid simulated through the twin's physics with
averaged-reading noise. Per degree:

- k-fold cross-validated RMSE (µT) of z, the error a user can measure without a twin;
- RMSE of the fitted surface against the noise-free z at the grid points (µT), the truth;
- the lookup's tip error against the twin's true tips (mm), where the degree is traceable;
- the time of one scalar evaluation with gradient (the tracer's inner call) and of a batch.

The default supported is the smallest degree within one standard error of the best CV RMSE (the
1-SE rule of :func:`~whiskercal.model.surface.choose_degree`), checked against the tip error.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from whiskercal.bench.timing import machine_info, per_call_s
from whiskercal.testing.twin_grid import calibrate_grid, noisy_z, simulate_grid, tip_error_mm, truth_points
from whiskercal.fit.options import FitOptions
from whiskercal.model.errors import ModelError
from whiskercal.model.surface import MAX_DEGREE, choose_degree, fit_fixed, kfold_rmse

BATCH_POINTS = 1000


def _evaluation_times(surface, points_mm: np.ndarray) -> tuple[float, float]:
    """Scalar value-and-gradient call (s) and batched evaluation per point (s)."""
    x, y = float(points_mm[0, 0]), float(points_mm[0, 1])
    scalar = per_call_s(lambda: surface.value_and_gradient(x, y))
    batch = np.resize(points_mm, (BATCH_POINTS, 2))
    return scalar, per_call_s(lambda: surface(batch)) / BATCH_POINTS


def _tip_error(grid, z_uT: np.ndarray, degree: int) -> dict:
    """The full calibration at one degree, its lookup against the twin's true tips (mm)."""
    try:
        calibration = calibrate_grid(grid, z_uT, degree=degree, lookup_kind="cubic")
    except ModelError as error:
        return {"rmse_mm": float("nan"), "max_mm": float("nan"), "failure": str(error)}
    lookup = calibration.lookup
    z_true, tips = truth_points(grid.sensor, lookup.z_min_uT, lookup.z_max_uT)
    error = tip_error_mm(lookup(z_true), tips)
    error["z_range_uT"] = [lookup.z_min_uT, lookup.z_max_uT]
    return error


def _row(grid, z_uT: np.ndarray, degree: int, folds: int, with_tips: bool) -> dict:
    points = grid.rod_center_mm
    cv_mean, cv_se = kfold_rmse(points, z_uT, degree, "polar", folds, seed=0)
    surface, condition = fit_fixed(points, z_uT, degree, "polar")
    scalar_s, batch_s = _evaluation_times(surface, points)
    row = {"degree": degree, "label": str(degree), "method": "polar surface",
           "cv_rmse_uT": cv_mean, "cv_se_uT": cv_se,
           "fit_rmse_uT": float(np.sqrt(np.mean((surface(points) - z_uT) ** 2))),
           "truth_rmse_uT": float(np.sqrt(np.mean((surface(points) - grid.z_true_uT) ** 2))),
           "condition_number": condition, "time_per_call_s": scalar_s,
           "batch_time_per_point_s": batch_s}
    if with_tips:
        tips = _tip_error(grid, z_uT, degree)
        row.update(tip_rmse_vs_truth_mm=tips["rmse_mm"], tip_max_vs_truth_mm=tips["max_mm"])
        if "failure" in tips:
            row["tip_failure"] = tips["failure"]
    return row


def run(quick: bool = False, progress: Callable[[dict], None] | None = None, seed: int = 0) -> dict:
    """CV, truth and tip errors and evaluation time for degrees 1..8 (µT, mm, s).

    Parameters
    ----------
    quick : bool
        Degrees 2..6 only, without the per-degree calibration (tip error).
    progress : callable, optional
        Called with each row as it is finished.
    seed : int
        Seed of the grid's measurement noise.
    """
    say = progress or (lambda _row: None)
    grid = simulate_grid()
    z_uT = noisy_z(grid, seed=seed)
    degrees = range(2, 7) if quick else range(1, MAX_DEGREE + 1)
    rows = []
    for degree in degrees:
        rows.append(_row(grid, z_uT, degree, folds=5, with_tips=not quick))
        say(rows[-1])
    cv = np.array([r["cv_rmse_uT"] for r in rows])
    se = np.array([r["cv_se_uT"] for r in rows])
    chosen = choose_degree(np.array([r["degree"] for r in rows]), cv, se)
    current = FitOptions().degree
    for row in rows:
        row["default"] = row["degree"] == current
    return {
        "benchmark": "surface-degree", "quick": quick, "machine": machine_info(),
        "units": {"time": "s", "z_error": "µT", "tip_error": "mm"},
        "setup": {"sensor": grid.sensor.sensor_id, "grid_points": len(z_uT),
                  "coordinates": "polar", "noise_uT": 1.0, "folds": 5},
        "rows": rows,
        "pareto": {"x": "time_per_call_s", "y": "cv_rmse_uT", "series": ["method"],
                   "label": "label", "x_label": "value + gradient per call (s)",
                   "y_label": "5-fold CV RMSE of z (µT)"},
        "supports": _supports(rows, chosen, current),
    }


def _supports(rows: list[dict], chosen: int, current) -> dict:
    tip_rows = [r for r in rows if np.isfinite(r.get("tip_rmse_vs_truth_mm", np.nan))]
    best_tip = min(tip_rows, key=lambda r: r["tip_rmse_vs_truth_mm"]) if tip_rows else None
    return {"degree_by_cv_1se": chosen, "current_default": current,
            "degree_by_tip_error": None if best_tip is None else best_tip["degree"],
            "rule": "smallest degree whose 5-fold CV RMSE is within one standard error of the best"}
