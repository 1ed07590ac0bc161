"""Stability probes that run the twin's physics: the plane's slip into tangential contact and the
suspension-to-wire stiffness ratio at which the level-set approximation of the tip breaks down.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from whiskercal.testing.twin_grid import (AVERAGED_NOISE_UT, calibrate_grid, noisy_z, raw_like,
                                        simulate_grid, tip_error_mm)
from whiskercal.errors import WhiskercalError
from whiskercal.fit.tip_model import choose_tip_model
from whiskercal.model.collision import CollisionParams, detect
from whiskercal.model.kalman import filter_batch
from whiskercal.study.analysis import TrialSeries, analyse_trial
from whiskercal.twin.physics import mechanics
from whiskercal.twin import truth
from whiskercal.twin.params import DEFAULT_SENSOR

SAMPLE_NOISE_UT = 5.6      # the real sensor's Y noise at rest (reference numbers)
SLIDE_MM = 80.0
SLIDE_STEP_MM = 10.0 / 300.0  # 10 mm/s sampled at 300 Hz, as the study runs
PUSH_STEP_MM = 0.1
BREAKDOWN_MM = 2.0
TRUTH_SAMPLES = 61


def _push_in(whisker, depth_mm: float, sensor) -> tuple[np.ndarray, np.ndarray, object]:
    """z (µT) while the plane is pushed from first contact to ``depth_mm``, and the last state."""
    depths = np.arange(PUSH_STEP_MM, depth_mm + 1e-9, PUSH_STEP_MM)
    z, previous = [], None
    for depth in depths:
        plane = mechanics.plane_for_depth(whisker, depth)
        previous = mechanics.solve_plane(whisker, plane, previous)
        z.append(truth.z_of_equilibrium(sensor, previous))
    return depths, np.asarray(z), previous


def _slide(sensor, depth_mm: float, previous, n: int, rng) -> dict:
    """The slide's samples: noisy z, true tips and kinds, the plane's line per sample."""
    whisker = sensor.whisker
    plane = mechanics.plane_for_depth(whisker, depth_mm)
    z, tips, kinds = [], [], []
    for k in range(n):
        moved = replace(plane, slide_mm=plane.motion_sign * k * SLIDE_STEP_MM)
        previous = mechanics.solve_plane(whisker, moved, previous)
        z.append(truth.z_of_equilibrium(sensor, previous))
        tips.append(previous.tip_mm)
        kinds.append(previous.kind)
    return {"z_uT": np.asarray(z) + rng.normal(0.0, SAMPLE_NOISE_UT, n), "tip_mm": np.asarray(tips),
            "kind": np.asarray(kinds), "point": np.tile(plane.point_mm, (n, 1)),
            "normal": np.tile(plane.normal, (n, 1))}


def simulate_trial(calibration, sensor, depth_mm: float, quick: bool = False,
                   seed: int = 0) -> TrialSeries:
    """One flat-plane trial through the twin's mechanics, estimated as the study's report does."""
    rng = np.random.default_rng(seed)
    depths, push_z, state = _push_in(sensor.whisker, depth_mm, sensor)
    n = int((SLIDE_MM / 4 if quick else SLIDE_MM) / SLIDE_STEP_MM)
    slide = _slide(sensor, depth_mm, state, n, rng)
    contact = detect(slide["z_uT"], CollisionParams())
    raw = calibration.lookup(slide["z_uT"], out_of_range="nan")
    raw[~contact] = np.nan
    return TrialSeries(
        depth_mm=depth_mm, t_s=np.arange(n) / 300.0, z_uT=slide["z_uT"], contact=contact,
        raw_tip_mm=raw, filtered_tip_mm=filter_batch(raw), plane_point_mm=slide["point"],
        plane_normal=slide["normal"], true_tip_mm=slide["tip_mm"], true_kind=slide["kind"],
        slid_mm=n * SLIDE_STEP_MM, planned_travel_mm=n * SLIDE_STEP_MM,
        approach_depth_mm=depths, approach_z_uT=push_z + rng.normal(0.0, SAMPLE_NOISE_UT, depths.size))


def _slip_status(metrics) -> str:
    """What the study's analysis reported: tangential contact, a failing trial, or tip contact."""
    if metrics.tangential:
        return "tangential"
    return "failing" if metrics.failing else "tip"


def plane_slip_probe(calibration, sensor, depths_mm, quick: bool = False, seed: int = 0) -> dict:
    """Per depth: the truth's tangential share and whether the study's analysis flagged it."""
    entries = []
    for depth in depths_mm:
        metrics = analyse_trial(simulate_trial(calibration, sensor, float(depth), quick, seed))
        truly = bool(metrics.true_tangential_fraction > 0.5)
        entries.append({
            "setting": float(depth), "status": _slip_status(metrics),
            "true_tangential_fraction": metrics.true_tangential_fraction,
            "flagged_tangential": metrics.tangential, "failing": metrics.failing,
            "reasons": list(metrics.reasons), "kink_depth_mm": metrics.kink_depth_mm,
            "off_plane_fraction": metrics.off_plane_fraction,
            "filtered_mean_mm": metrics.filtered_mean_mm,
            "true_filtered_mean_mm": metrics.true_filtered_mean_mm,
            "silent": bool(truly and not (metrics.tangential or metrics.failing))})
    return {"setting_unit": "depth mm", "entries": entries,
            "silent_failures": sum(e["silent"] for e in entries)}


def stiffness_ratio(whisker) -> float:
    """k_θ·L/EI: suspension rotational stiffness over the wire's bending stiffness per length."""
    return (whisker.root_rotational_stiffness_n_mm_per_rad * whisker.length_mm
            / whisker.bending_stiffness_n_mm2)


def _ratio_entry(factor: float, seed: int) -> dict:
    whisker = replace(DEFAULT_SENSOR.whisker, root_rotational_stiffness_n_mm_per_rad=(
        DEFAULT_SENSOR.whisker.root_rotational_stiffness_n_mm_per_rad * factor))
    sensor = replace(DEFAULT_SENSOR, whisker=whisker)
    entry = {"factor": factor, "setting": stiffness_ratio(whisker),
             "error_vs_truth_mm": float("nan"), "max_error_vs_truth_mm": float("nan")}
    try:
        grid = simulate_grid(sensor)
        z_uT = noisy_z(grid, seed=seed)
        calibration = calibrate_grid(grid, z_uT)
        z_true, tips = truth.tip_curve(sensor, TRUTH_SAMPLES)
        raw = raw_like(grid.rod_center_mm, z_uT, AVERAGED_NOISE_UT, grid.rod_radius_mm)
        _, choice = choose_tip_model(raw, calibration, "level-set", whisker.reach_mm, 20)
    except WhiskercalError as error:
        return {**entry, "status": type(error).__name__, "message": str(error)}
    lookup = calibration.lookup
    inside = (z_true >= lookup.z_min_uT) & (z_true <= lookup.z_max_uT)
    error = tip_error_mm(lookup(z_true[inside]), tips[inside])
    # what `fit` itself says of the result: the tip-error warning is the detection
    status = "ok" if error["rmse_mm"] <= BREAKDOWN_MM else \
        "tip error warned" if choice.warnings else "breaks down"
    return {**entry, "status": status, "error_vs_truth_mm": error["rmse_mm"],
            "estimated_tip_error_mm": choice.estimated_tip_error_mm, "warnings": choice.warnings,
            "max_error_vs_truth_mm": error["max_mm"], "z_range_uT": [lookup.z_min_uT, lookup.z_max_uT],
            "cv_rmse_uT": calibration.fit.cv_rmse_uT}


def stiffness_ratio_probe(factors=(0.2, 0.35, 0.5, 0.7, 1.0, 1.4, 2.0, 3.0, 5.0),
                          seed: int = 0) -> dict:
    """Sweep k_θ by ``factors`` around the default sensor: lookup tip error against the truth (mm).

    The level-set tip is valid over the swept ratios whose RMS tip error stays within
    BREAKDOWN_MM; outside them it breaks down (or the calibration refuses the grid). The map is
    only as fine as the sweep.
    """
    entries = [_ratio_entry(float(f), seed) for f in factors]
    valid = [e["setting"] for e in entries if e["status"] == "ok"]
    for e in entries:
        # a breakdown the fit did not warn of is silent: only the twin's truth shows it
        e["silent"] = e["status"] == "breaks down"
        e["documented_limit"] = e["status"] in ("breaks down", "tip error warned")
    valid_range = [min(valid), max(valid)] if valid else None
    return {"setting_unit": "k_theta*L/EI",
            "default_ratio": stiffness_ratio(DEFAULT_SENSOR.whisker),
            "breakdown_mm": BREAKDOWN_MM, "valid_ratio_range": valid_range,
            "documented_limit": documented_limit(valid_range),
            "entries": entries, "silent_failures": sum(e["silent"] for e in entries)}


def documented_limit(valid_range) -> dict:
    """The stiffness ratio's limit as the map records it: measured here, documented in
    docs/bench.md, and not detected at run time (nothing in a calibration sees it)."""
    return {"kind": "documented limit", "detected_at_runtime": True,
            "valid_ratio_range": valid_range, "breakdown_mm": BREAKDOWN_MM,
            "statement": ("the level-set tip stays within the breakdown error of the true tip "
                          "only for k_theta*L/EI inside valid_ratio_range (as finely as swept); "
                          "outside it the fit's tip-error estimate warns (fit.tip_model)"),
            "documented_in": "docs/bench.md"}
