"""The stability map: where each method fails, and whether the failure is detected.

Every probe pushes one method past its working range and records, per setting, a ``status``:
``"ok"`` (a number came back), or the name of the exception or analysis flag that reported the
failure. A number that came back but lies far from the twin's truth (more than
``SILENT_LIMIT_MM``) is a **silent failure**; the map counts them, and the probes are what the
tests pin. Probes:

- ``z_range``: both tracers and the lookup for z from beyond the data's low end to beyond its
  high end (:class:`ZOutOfRangeError`, :class:`DomainExitError`);
- ``domain``: grids cut short of the tip (reach 72 .. 40 mm): the trace must extrapolate, and
  past 9.5 mm beyond the grid it stops (:class:`ExtrapolationLimitError`);
- ``vanishing_gradient``: a surface whose level set z = 0 is a ridge of zero gradient;
- ``paper_step``: the paper's fixed-step trace at steps up to 20 mm; a step too coarse for the
  surface drifts off the level set (:class:`TraceDriftError`);
- ``noise``: the averaged reading's noise from 1 to 300 µT, the whole calibration;
- ``kalman``: degenerate windows (identical tips, one tip, NaN) and an outlier;
- ``plane_slip``: the flat-plane study's slip into tangential contact, flagged by
  :func:`whiskercal.study.analysis.analyse_trial` from the data alone;
- ``stiffness_ratio``: the suspension-to-wire stiffness ratio k_θ·L/EI at which the level-set
  approximation of the tip (a contact at the tip reads like a contact on the shaft) breaks down.
  Nothing in a calibration can see this, so the map records it as a **documented limit** of the
  method (``documented_limit``; docs/bench.md), not as a run-time detection.

Each probe also counts its ``detected`` settings; ``supports["detections"]`` sums them per probe.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Callable

import numpy as np

from whiskercal.bench.timing import machine_info
from whiskercal.testing.twin_grid import (SimulatedGrid, calibrate_grid, noisy_z, simulate_grid,
                                        tip_error_mm, truth_curve, truth_points)
from whiskercal.errors import WhiskercalError
from whiskercal.model.calibrate import CalibrationOptions, build_problem
from whiskercal.model.kalman import ConstantStateKalman, KalmanParams
from whiskercal.model.surface import fit_fixed
from whiskercal.model.trace import trace_fast, trace_paper
from whiskercal.twin import truth

SILENT_LIMIT_MM = 2.0  # the paper's error bound of the flat-plane study
RETURNED = ("ok", "tip", "breaks down")  # statuses under which a number came back
STIFFNESS_RATIO_FACTORS = (0.2, 0.35, 0.5, 0.7, 1.0, 1.4, 2.0, 3.0, 5.0)


def _status(call: Callable[[], object]) -> tuple[str, object]:
    """("ok", result) or (exception class name, None) for an expected failure."""
    try:
        return "ok", call()
    except WhiskercalError as error:
        return type(error).__name__, None


def _true_tip(sensor, z_uT: float) -> np.ndarray:
    z_curve, _ = truth_curve(sensor)
    if not (z_curve.min() <= z_uT <= 0.0):
        return np.full(2, np.nan)
    return truth.true_tip(sensor, z_uT)


def _entry(setting, status: str, tip, true_tip) -> dict:
    error = float(np.linalg.norm(np.asarray(tip) - true_tip)) if tip is not None else float("nan")
    return {"setting": float(setting), "status": status, "error_vs_truth_mm": error,
            "silent": bool(status == "ok" and error > SILENT_LIMIT_MM)}


def _summary(entries: list[dict]) -> dict:
    statuses: dict[str, int] = {}
    for entry in entries:
        statuses[entry["status"]] = statuses.get(entry["status"], 0) + 1
    return {"statuses": statuses, "detected": sum(detected(e) for e in entries),
            "silent_failures": sum(e["silent"] for e in entries)}


def detected(entry: dict) -> bool:
    """Did the method itself report this setting's failure (an exception or an analysis flag)?"""
    return entry["status"] not in RETURNED


def z_range_probe(calibration, sensor, n: int = 25) -> dict:
    """Tracers and lookup over z from 15 % beyond the data's range on each side (µT)."""
    low, high = float(calibration.z_uT.min()), float(calibration.z_uT.max())
    span = high - low
    z_values = np.linspace(low - 0.15 * span, high + 0.15 * span, n)
    methods = {"fast": lambda z: trace_fast(calibration.problem, z).tip_mm,
               "paper 1e-2 mm": lambda z: trace_paper(calibration.problem, z, 1e-2).tip_mm,
               "lookup": lambda z: calibration.lookup(z)}
    result = {"setting_unit": "z µT", "data_range_uT": [low, high],
              "lookup_range_uT": [calibration.lookup.z_min_uT, calibration.lookup.z_max_uT]}
    for name, method in methods.items():
        entries = [_entry(z, *_status(lambda z=z: method(float(z))), _true_tip(sensor, z))
                   for z in z_values]
        result[name] = {"entries": entries, **_summary(entries)}
    return result


def domain_probe(grid: SimulatedGrid, reaches_mm=(71.75, 60.0, 50.0, 40.0), seed: int = 0) -> dict:
    """Calibrations on grids cut at a smaller reach: the trace must extrapolate to the tip."""
    z_uT = noisy_z(grid, seed=seed)
    reach = np.hypot(*grid.rod_center_mm.T)
    entries = []
    for limit in reaches_mm:
        keep = reach <= limit + 1e-9
        cut = replace(grid, rod_center_mm=grid.rod_center_mm[keep], z_true_uT=grid.z_true_uT[keep],
                      kind=grid.kind[keep], contact_mm=None, tip_mm=None)
        status, calibration = _status(lambda: calibrate_grid(cut, z_uT[keep]))
        error = {"rmse_mm": float("nan"), "max_mm": float("nan")}
        if calibration is not None:
            z_true, tips = truth_points(grid.sensor, calibration.lookup.z_min_uT,
                                        calibration.lookup.z_max_uT)
            error = tip_error_mm(calibration.lookup(z_true), tips)
        entries.append({"setting": float(limit), "status": status, "points": int(keep.sum()),
                        "error_vs_truth_mm": error["rmse_mm"], "max_error_vs_truth_mm": error["max_mm"],
                        "silent": bool(status == "ok" and error["max_mm"] > SILENT_LIMIT_MM)})
    return {"setting_unit": "grid reach mm", "entries": entries, **_summary(entries)}


def vanishing_gradient_probe(grid: SimulatedGrid, n: int = 9) -> dict:
    """A surface z = A·(θ - θ0)³ (exact in a cubic polar basis): its level set z = 0 is a ray of
    zero gradient, so tracing at z near 0 must stop with VanishingGradientError."""
    theta = np.arctan2(grid.rod_center_mm[:, 1], grid.rod_center_mm[:, 0])
    theta0 = float(np.median(theta))
    z_uT = -20000.0 * (theta - theta0) ** 3
    surface, _ = fit_fixed(grid.rod_center_mm, z_uT, 3, "polar")
    options = CalibrationOptions(trace_length_mm=grid.sensor.whisker.reach_mm)
    problem = build_problem(surface, grid.rod_center_mm, z_uT, options)
    span = float(np.ptp(z_uT))
    z_values = np.concatenate([[0.0], np.geomspace(1e-9, 1e-2, n - 1) * span])
    entries = []
    for z in z_values:
        status, _ = _status(lambda z=z: trace_fast(problem, float(z)))
        entries.append({"setting": float(z), "status": status, "silent": False})
    return {"setting_unit": "z µT (ridge at 0)", "min_gradient_uT_per_mm":
            problem.min_gradient_uT_per_mm, "entries": entries, **_summary(entries)}


def paper_step_probe(calibration, sensor, steps_mm=(0.01, 0.1, 0.5, 1.0, 2.0, 5.0, 10.0, 20.0),
                     n_z: int = 5) -> dict:
    """The paper's fixed-step trace at steps far beyond its 1e-3 mm, against the converged trace."""
    low, high = calibration.lookup.z_min_uT, calibration.lookup.z_max_uT
    z_values = np.linspace(low, high, n_z + 2)[1:-1]
    reference = [trace_fast(calibration.problem, float(z), rtol=1e-12, atol_mm=1e-12).tip_mm
                 for z in z_values]
    entries = []
    for step in steps_mm:
        for z, ref in zip(z_values, reference):
            status, result = _status(lambda: trace_paper(calibration.problem, float(z), step))
            entry = _entry(step, status, None if result is None else result.tip_mm, ref)
            entry["z_uT"] = float(z)
            entry["error_vs_reference_mm"] = entry.pop("error_vs_truth_mm")
            entries.append(entry)
    return {"setting_unit": "step mm", "entries": entries, **_summary(entries)}


def noise_probe(grid: SimulatedGrid, noise_uT=(1.0, 10.0, 30.0, 100.0, 300.0), seed: int = 0) -> dict:
    """Whole calibrations with the averaged reading's noise raised: tip error, CV RMSE, and
    whether the fit's scatter warning (the bootstrapped tip spread) reported it."""
    entries = []
    for noise in noise_uT:
        status, calibration = _status(lambda: calibrate_grid(grid, noisy_z(grid, noise, seed)))
        entry = {"setting": float(noise), "status": status, "cv_rmse_uT": float("nan"),
                 "error_vs_truth_mm": float("nan"), "max_error_vs_truth_mm": float("nan")}
        if calibration is not None:
            lookup = calibration.lookup
            z_true, tips = truth_points(grid.sensor, lookup.z_min_uT, lookup.z_max_uT)
            error = tip_error_mm(lookup(z_true), tips)
            entry.update(cv_rmse_uT=calibration.fit.cv_rmse_uT, error_vs_truth_mm=error["rmse_mm"],
                         max_error_vs_truth_mm=error["max_mm"], tip_spread_mm=calibration.tip_spread_mm)
            if any("scatter" in warning for warning in calibration.warnings):
                entry["status"] = status = "ScatterWarning"  # fit's own warning: reported
        entry["silent"] = bool(status == "ok" and entry["max_error_vs_truth_mm"] > SILENT_LIMIT_MM)
        entries.append(entry)
    return {"setting_unit": "noise µT", "entries": entries, **_summary(entries)}


def _feed(params: KalmanParams, raw_tips) -> tuple[list, ConstantStateKalman]:
    kalman = ConstantStateKalman(params)
    return [kalman.update(tip) for tip in raw_tips], kalman


def kalman_probe(seed: int = 0) -> list[dict]:
    """Degenerate and outlier windows: the state must stay finite and the outlier's pull small."""
    rng = np.random.default_rng(seed)
    tip = np.array([54.4, -50.8])
    cases = []
    out, kalman = _feed(KalmanParams(), [tip] * 30)
    cases.append({"case": "identical tips (singular R)", "finite": bool(np.all(np.isfinite(out[-1]))),
                  "status": "floored R", "state_error_mm": float(np.linalg.norm(out[-1] - tip))})
    out, _ = _feed(KalmanParams(), [tip])
    cases.append({"case": "one tip in the window (no R)", "finite": bool(np.all(np.isfinite(out[-1]))),
                  "status": "x0 = first tip, no update", "state_error_mm": float(np.linalg.norm(out[-1] - tip))})
    out, _ = _feed(KalmanParams(), [np.full(2, np.nan), tip, np.full(2, np.nan)])
    cases.append({"case": "NaN raw tips", "finite": bool(np.all(np.isfinite(out[-1]))),
                  "status": "ignored", "first_output_none": out[0] is None,
                  "state_error_mm": float(np.linalg.norm(out[-1] - tip))})
    noisy = list(tip + rng.normal(0.0, 0.1, (40, 2)))
    before, _ = _feed(KalmanParams(), noisy)
    after, _ = _feed(KalmanParams(), noisy + [tip + np.array([50.0, 0.0])])
    cases.append({"case": "50 mm outlier after 40 tips", "finite": bool(np.all(np.isfinite(after[-1]))),
                  "status": "damped", "outlier_pull_mm": float(np.linalg.norm(after[-1] - before[-1]))})
    status, _ = _status(lambda: KalmanParams(window=1))
    cases.append({"case": "window of 1 (no covariance)", "finite": True, "status": status})
    return cases


def run(quick: bool = False, progress: Callable[[dict], None] | None = None, seed: int = 0) -> dict:
    """The whole stability map (JSON-able). ``quick`` runs fewer settings per probe."""
    from whiskercal.bench.stability_scenes import plane_slip_probe, stiffness_ratio_probe

    say = progress or (lambda _row: None)
    grid = simulate_grid()
    calibration = calibrate_grid(grid, noisy_z(grid, seed=seed))
    probes = {
        "z_range": lambda: z_range_probe(calibration, grid.sensor, 9 if quick else 25),
        "domain": lambda: domain_probe(grid, (71.75, 50.0) if quick else (71.75, 60.0, 50.0, 40.0)),
        "vanishing_gradient": lambda: vanishing_gradient_probe(grid, 5 if quick else 9),
        "paper_step": lambda: paper_step_probe(calibration, grid.sensor,
                                               (0.1, 5.0) if quick else (0.01, 0.1, 0.5, 1.0, 2.0, 5.0, 10.0, 20.0),
                                               2 if quick else 5),
        "noise": lambda: noise_probe(grid, (1.0, 300.0) if quick else (1.0, 10.0, 30.0, 100.0, 300.0)),
        "kalman": kalman_probe,
        "plane_slip": lambda: plane_slip_probe(calibration, grid.sensor,
                                               (20.0, 50.0) if quick else (5.0, 20.0, 35.0, 40.0, 45.0, 50.0),
                                               quick=quick),
        "stiffness_ratio": lambda: stiffness_ratio_probe((1.0, 3.0) if quick else STIFFNESS_RATIO_FACTORS),
    }
    result = {"benchmark": "stability", "quick": quick, "machine": machine_info(),
              "silent_limit_mm": SILENT_LIMIT_MM, "probes": {}}
    for name, probe in probes.items():
        result["probes"][name] = _with_summary(probe())
        say({"probe": name})
    result["supports"] = _supports(result["probes"])
    return result


def _with_summary(probe):
    """A probe's result with its status counts, detections and silent failures."""
    if isinstance(probe, dict) and "entries" in probe and "statuses" not in probe:
        probe.update(_summary(probe["entries"]))
    return probe


def _detections(probe: dict) -> dict:
    """Detected and silent settings of one probe, over all its methods, by status."""
    entries = probe.get("entries") or [e for sub in probe.values() if isinstance(sub, dict)
                                       for e in sub.get("entries", [])]
    by_status: dict[str, int] = {}
    for entry in entries:
        if detected(entry):
            by_status[entry["status"]] = by_status.get(entry["status"], 0) + 1
    return {"detected": sum(by_status.values()), "detected_by": by_status,
            "silent": sum(bool(e.get("silent")) for e in entries)}


def _supports(probes: dict) -> dict:
    ratio = probes["stiffness_ratio"]
    return {"level_set_valid_ratio_range": ratio.get("valid_ratio_range"),
            "default_ratio": ratio.get("default_ratio"),
            "documented_limits": {"stiffness_ratio": ratio.get("documented_limit")},
            "detections": {name: _detections(probe) for name, probe in probes.items()
                           if isinstance(probe, dict)},
            "silent_failures": {name: probe.get("silent_failures", 0) for name, probe in probes.items()
                                if isinstance(probe, dict)}}
