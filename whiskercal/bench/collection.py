"""Collection: samples per point and settle time against fit error and total stage time.

Stage time is the plan's own estimate (:func:`~whiskercal.collect.estimate.plan_summary`:
trapezoidal moves plus settling and averaging at every point and both baselines) for the default
plan with the acquisition settings changed. Fit error comes from grids simulated through the
twin: the noise-free z of every point (``solve_rod`` + the magnet field) goes through the
magnetometer model sample by sample (offset, white noise, quantization at the configured gain and
resolution), the samples are averaged, the averaged static baseline is subtracted, and the grid
is fitted and calibrated exactly as ``whiskercal fit`` does. Errors are against the twin's truth:
the surface against the noise-free z (µT), the lookup against the true tips (mm).

The twin's mechanics are quasi-static (no ring-down after a move), so settle time changes the
stage time but not the twin's readings: its fit error is measured once per sample count. The
settle default rests on the real rig, which the twin cannot speak for (docs/bench.md).
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from whiskercal.bench.timing import machine_info
from whiskercal.testing.twin_grid import calibrate_grid, simulate_grid, tip_error_mm, truth_points
from whiskercal.collect.config import load_config
from whiskercal.collect.estimate import plan_summary
from whiskercal.collect.plan import build_plan
from whiskercal.fit.options import FitOptions
from whiskercal.model.errors import ModelError
from whiskercal.model.surface import fit_fixed
from whiskercal.twin import truth
from whiskercal.twin.physics.magnetometer import to_counts, to_uT

SAMPLES_PER_POINT = (1, 3, 10, 30, 100)
SETTLE_S = (0.0, 0.1, 0.3, 1.0)
# The tip error may grow by this share over the noise-free grid's before noise counts as costly.
TIP_TOLERANCE_SHARE = 0.05


def stage_time_s(samples_per_point: int, settle_s: float) -> float:
    """Estimated total stage time (s) of the default grid with these acquisition settings (the
    tip sweep off: the fit errors here are the grid's, docs/bench.md)."""
    config = load_config().replace(acquisition={"samples_per_point": int(samples_per_point),
                                                "settle_s": float(settle_s)},
                                   sweep={"enabled": False})
    return float(plan_summary(build_plan(config))["estimated_stage_time_s"])


def measured_z(grid, samples_per_point: int, baseline_samples: int, seed: int) -> np.ndarray:
    """Averaged Y readings minus the averaged static baseline (µT), through the magnetometer model."""
    config = load_config()
    meter = grid.sensor.magnetometer.with_settings(
        gain=config.sensor.gain, res=config.sensor.res, osr=config.sensor.osr,
        filt=config.sensor.filt)
    rng = np.random.default_rng(seed)
    static = truth.static_field_uT(grid.sensor)
    fields = np.broadcast_to(static, (len(grid.z_true_uT), samples_per_point, 3)).copy()
    fields[..., 1] += grid.z_true_uT[:, None]
    averaged = to_uT(to_counts(fields, meter, rng), meter)[..., 1].mean(axis=1)
    baseline = to_uT(to_counts(np.broadcast_to(static, (baseline_samples, 3)), meter, rng),
                     meter)[:, 1].mean()
    return averaged - baseline


def _surface_error_uT(grid, z_uT: np.ndarray, degree: int) -> float:
    """RMSE (µT) of the surface fitted to ``z_uT`` against the grid's noise-free z."""
    surface, _ = fit_fixed(grid.rod_center_mm, z_uT, degree, "polar")
    return float(np.sqrt(np.mean((surface(grid.rod_center_mm) - grid.z_true_uT) ** 2)))


def _grid_errors(grid, z_uT: np.ndarray, degree: int) -> dict:
    z_error = _surface_error_uT(grid, z_uT, degree)
    try:
        lookup = calibrate_grid(grid, z_uT, degree=degree, lookup_kind="cubic").lookup
    except ModelError as error:
        return {"surface_vs_truth_rmse_uT": z_error, "tip_rmse_vs_truth_mm": float("nan"),
                "failure": str(error)}
    z_true, tips = truth_points(grid.sensor, lookup.z_min_uT, lookup.z_max_uT)
    return {"surface_vs_truth_rmse_uT": z_error,
            "tip_rmse_vs_truth_mm": tip_error_mm(lookup(z_true), tips)["rmse_mm"],
            "z_noise_rms_uT": float(np.sqrt(np.mean((z_uT - grid.z_true_uT) ** 2)))}


def run(quick: bool = False, progress: Callable[[dict], None] | None = None, seed: int = 0) -> dict:
    """Stage time and fit errors over samples per point and settle time (s, µT, mm).

    Parameters
    ----------
    quick : bool
        Two sample counts and two settle times, surface error only (no calibration).
    progress : callable, optional
        Called with each row as it is finished.
    seed : int
        Seed of the simulated readings.
    """
    say = progress or (lambda _row: None)
    config, degree, grid = load_config(), int(FitOptions().degree), simulate_grid()
    counts, settles = ((3, 30), (0.0, 0.3)) if quick else (SAMPLES_PER_POINT, SETTLE_S)
    noise_free = _grid_errors(grid, grid.z_true_uT, degree) if not quick else {}
    rows = []
    for n in counts:
        z_uT = measured_z(grid, n, config.acquisition.baseline_samples, seed)
        errors = _quick_errors(grid, z_uT, degree) if quick else _grid_errors(grid, z_uT, degree)
        for settle in settles:
            rows.append(_row(n, settle, errors, config))
            say(rows[-1])
    return {
        "benchmark": "collection", "quick": quick, "machine": machine_info(),
        "units": {"time": "s", "z_error": "µT", "tip_error": "mm"},
        "setup": {"sensor": grid.sensor.sensor_id, "grid_points": len(grid.z_true_uT),
                  "surface_degree": degree,
                  "baseline_samples": config.acquisition.baseline_samples,
                  "stage_time": "plan_summary estimated_stage_time_s (trapezoidal moves + dwell)",
                  "settle_effect_in_twin": "none: quasi-static mechanics, no ring-down model",
                  "noise_free_grid": noise_free},
        "rows": rows,
        "pareto": {"x": "stage_time_s", "y": "surface_vs_truth_rmse_uT", "series": ["series"],
                   "label": "label", "x_label": "estimated stage time (s)",
                   "y_label": "surface RMSE vs noise-free z (µT)"},
        "supports": _supports(rows, noise_free, config),
    }


def _quick_errors(grid, z_uT: np.ndarray, degree: int) -> dict:
    """Surface error and reading noise only (µT): no calibration, for the quick run."""
    return {"surface_vs_truth_rmse_uT": _surface_error_uT(grid, z_uT, degree),
            "z_noise_rms_uT": float(np.sqrt(np.mean((z_uT - grid.z_true_uT) ** 2)))}


def _row(samples: int, settle_s: float, errors: dict, config) -> dict:
    current = (config.acquisition.samples_per_point, config.acquisition.settle_s)
    return {"samples_per_point": samples, "settle_s": settle_s, "label": f"{samples}",
            "series": f"settle {settle_s:g} s", "stage_time_s": stage_time_s(samples, settle_s),
            "default": (samples, settle_s) == current, **errors}


def _supports(rows: list[dict], noise_free: dict, config) -> dict:
    """Fewest samples whose tip error stays within TIP_TOLERANCE_SHARE of the noise-free grid's."""
    current = {"samples_per_point": config.acquisition.samples_per_point,
               "settle_s": config.acquisition.settle_s}
    reference = noise_free.get("tip_rmse_vs_truth_mm")
    if reference is None or not np.isfinite(reference):
        return {"samples_per_point": None, "current_default": current,
                "rule": "needs the full run (tip errors)"}
    limit = reference * (1 + TIP_TOLERANCE_SHARE)
    good = sorted({r["samples_per_point"] for r in rows
                   if r.get("tip_rmse_vs_truth_mm", np.inf) <= limit})
    return {"samples_per_point": good[0] if good else None, "current_default": current,
            "noise_free_tip_rmse_mm": reference, "tip_limit_mm": limit,
            "rule": f"fewest samples per point whose lookup tip RMSE vs truth is within "
                    f"{TIP_TOLERANCE_SHARE:.0%} of the noise-free grid's"}
