"""The numbers a fit records in its artifact's /metrics (µT, mm): the surface, the lookup, the
extrapolation, the evidence for the model's size and the raw grid's completeness."""

from __future__ import annotations

import numpy as np


def surface_and_lookup_metrics(calibration) -> dict:
    """The surface fit's and the lookup's quality, and the points used."""
    fit, lookup = calibration.fit, calibration.lookup_report
    return {
        "rmse_uT": fit.rmse_uT, "r2": fit.r2, "cv_rmse_uT": fit.cv_rmse_uT,
        "condition_number": fit.condition_number,
        "degrees": np.asarray(fit.degrees, np.int32),
        "cv_rmse_by_degree_uT": fit.cv_rmse_by_degree, "cv_se_by_degree_uT": fit.cv_se_by_degree,
        "lookup_holdout_rmse_mm": lookup.holdout_rmse_mm,
        "lookup_holdout_rmse_xy_mm": np.asarray(lookup.holdout_rmse_xy_mm),
        "lookup_rmse_by_kind_mm": dict(lookup.rmse_by_kind_mm),
        "points_used": int(calibration.used.sum()), "points_total": int(len(calibration.used)),
        **extension_metrics(calibration),
    }


def extension_metrics(calibration) -> dict:
    """How far past the grid the lookup's tips are extrapolated, and what is trusted (mm, µT)."""
    trusted = calibration.trusted_z_uT
    return {"extension_max_mm": float(calibration.lookup_report.max_extension_mm),
            "extension_limit_mm": float(calibration.extension_limit_mm),
            "extrapolated": bool(calibration.extrapolated),
            "trusted_z_uT": np.asarray(trusted if trusted is not None else (np.nan, np.nan), float)}


def evidence_metrics(calibration) -> dict:
    """The noise the fit was judged against and what its errors mean at the tip."""
    return {"expected_noise_uT": calibration.expected_noise_uT,
            "cv_level_set_shift_mm": calibration.cv_level_set_shift_mm,
            "tip_spread_mm": calibration.tip_spread_mm}


def raw_metrics(raw) -> dict:
    """Whether the raw grid was collected whole, and how many points it planned."""
    return {"raw_complete": bool(raw.complete), "raw_points_planned": int(len(raw.plan_rod_center_mm))}
