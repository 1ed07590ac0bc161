"""Tip extraction: the paper's fixed-step trace, the adaptive trace and the lookup, time against error.

One calibration is fitted to a grid simulated through the twin's physics (default sensor, default
plan, averaged-reading noise). Every method then finds the tip for the same z values, spread
over the lookup's range:

- ``paper``: :func:`~whiskercal.model.trace.trace_paper` at fixed steps 1e-1 .. 1e-3 mm;
- ``fast``: :func:`~whiskercal.model.trace.trace_fast` at tolerances 1e-3 .. 1e-11;
- ``lookup``: :class:`~whiskercal.model.lookup.TipLookup` with 5 .. 80 samples and each interpolant.

Two errors per method: against the **converged reference** (the adaptive trace at 1e-12, which
isolates the method's own numerical error) and against the **twin's true tip** (which adds the
calibration's model error, the error a user sees). A method's numerical error only matters while
it is not small against the model error: that is how the defaults are chosen.
"""

from __future__ import annotations

import time
from typing import Callable

import numpy as np

from whiskercal.bench.timing import machine_info, per_call_s
from whiskercal.testing.twin_grid import (calibrate_grid, noisy_z, simulate_grid, tip_error_mm,
                                        truth_points)
from whiskercal.model.lookup import KINDS, TipLookup
from whiskercal.model.trace import trace_fast, trace_many, trace_paper

PAPER_STEPS_MM = (1e-1, 3e-2, 1e-2, 3e-3, 1e-3)
FAST_TOLERANCES = (1e-3, 1e-5, 1e-7, 1e-9, 1e-11)
LOOKUP_SAMPLES = (5, 10, 20, 40, 80)
REFERENCE_TOLERANCE = 1e-12
# A method's numerical error is negligible when it is below this share of the model error.
NEGLIGIBLE_SHARE = 0.1


def _timed_tips(trace: Callable[[float], np.ndarray], z_values: np.ndarray) -> tuple[np.ndarray, float]:
    """Tips for every z and the mean time per call (s); one call per z (each lasts > 0.1 ms)."""
    trace(float(z_values[0]))  # warm-up
    started = time.perf_counter()
    tips = np.array([trace(float(z)) for z in z_values])
    return tips, (time.perf_counter() - started) / len(z_values)


def _row(method: str, setting: float, unit: str, time_s: float, tips: np.ndarray,
         reference: np.ndarray, true_tips: np.ndarray) -> dict:
    numeric, total = tip_error_mm(tips, reference), tip_error_mm(tips, true_tips)
    return {"method": method, "setting": setting, "setting_unit": unit,
            "label": f"{setting:g}", "time_per_call_s": time_s,
            "error_vs_reference_mm": numeric["rmse_mm"],
            "max_error_vs_reference_mm": numeric["max_mm"],
            "error_vs_truth_mm": total["rmse_mm"], "max_error_vs_truth_mm": total["max_mm"]}


def _tracer_rows(problem, z_trace, reference, truth, steps, tolerances, say) -> list[dict]:
    rows = []
    for step in steps:
        tips, t = _timed_tips(lambda z, s=step: trace_paper(problem, z, step_mm=s).tip_mm, z_trace)
        rows.append(_row("paper", step, "step mm", t, tips, reference, truth))
        say(rows[-1])
    for tol in tolerances:
        tips, t = _timed_tips(lambda z, r=tol: trace_fast(problem, z, rtol=r, atol_mm=r).tip_mm,
                              z_trace)
        rows.append(_row("fast", tol, "rtol", t, tips, reference, truth))
        say(rows[-1])
    return rows


def _lookup_rows(problem, z_range, z_eval, reference, truth, samples, default, say) -> list[dict]:
    rows = []
    for n in samples:
        knots = np.linspace(z_range[0], z_range[1], n)
        knot_tips = trace_many(problem, knots, "fast")
        for kind in KINDS:
            if kind == "akima" and n < 3:
                continue
            lookup = TipLookup(knots, knot_tips, kind)
            middle = float(z_eval[len(z_eval) // 2])
            t = per_call_s(lambda: lookup.tip_scalar(middle))
            row = _row("lookup", n, "samples", t, lookup(z_eval), reference, truth)
            row.update(kind=kind, label=f"{n}", default=(n, kind) == default)
            rows.append(row)
            say(row)
    return rows


def _reference_tips(problem, z_values: np.ndarray) -> np.ndarray:
    """Converged tips (mm): the adaptive trace at REFERENCE_TOLERANCE."""
    return np.array([trace_fast(problem, float(z), rtol=REFERENCE_TOLERANCE,
                                atol_mm=REFERENCE_TOLERANCE).tip_mm for z in z_values])


def _supports(rows: list[dict], model_error_mm: float, default: tuple[int, str]) -> dict:
    """The cheapest settings whose numerical error is negligible against the model error."""
    limit = NEGLIGIBLE_SHARE * model_error_mm
    good = [r for r in rows if r["error_vs_reference_mm"] <= limit]
    fastest = {m: min((r for r in good if r["method"] == m), key=lambda r: r["time_per_call_s"],
                      default=None) for m in ("paper", "fast", "lookup")}
    smallest = min((r for r in good if r["method"] == "lookup"), key=lambda r: r["setting"],
                   default=None)
    return {
        "model_error_mm": model_error_mm, "negligible_below_mm": limit,
        "lookup_samples": None if smallest is None else int(smallest["setting"]),
        "lookup_kind": None if smallest is None else smallest["kind"],
        "fast_rtol": None if fastest["fast"] is None else fastest["fast"]["setting"],
        "paper_step_mm": None if fastest["paper"] is None else fastest["paper"]["setting"],
        "current_default": {"lookup_samples": default[0], "lookup_kind": default[1]},
        "rule": f"smallest setting whose error against the converged trace is at most "
                f"{NEGLIGIBLE_SHARE:g} x the converged trace's error against the twin's truth",
    }


def _evaluation_sets(sensor, z_range, quick: bool):
    """z values (µT) and true tips (mm) for the lookup (dense) and for the tracers (a subset)."""
    z_truth, true_tips = truth_points(sensor, *z_range)
    stride = 4 if quick else 1
    z_eval, true_eval = z_truth[1:-1][::stride], true_tips[1:-1][::stride]
    every = max(1, len(z_eval) // (3 if quick else 12))
    return z_eval, true_eval, z_eval[::every], true_eval[::every]


def _ratios(rows: list[dict], default: tuple[int, str]) -> dict:
    """Time ratios (same run) between the paper's trace, the adaptive one and the default lookup."""
    def time_of(method, setting, kind=None):
        found = [r["time_per_call_s"] for r in rows if r["method"] == method
                 and r["setting"] == setting and r.get("kind") == kind]
        return found[0] if found else float("nan")

    lookup = time_of("lookup", default[0], default[1])
    paper, fast = time_of("paper", 1e-3), time_of("fast", 1e-7)
    return {"paper_1e-3_over_lookup": paper / lookup, "fast_1e-7_over_lookup": fast / lookup,
            "paper_1e-3_over_fast_1e-7": paper / fast}


def run(quick: bool = False, progress: Callable[[dict], None] | None = None, seed: int = 0) -> dict:
    """Time and error of every tip-extraction method and setting (s, mm).

    Parameters
    ----------
    quick : bool
        Fewer z values and settings (for tests): seconds instead of about a minute.
    progress : callable, optional
        Called with each row as it is finished.
    seed : int
        Seed of the grid's measurement noise.
    """
    say = progress or (lambda _row: None)
    grid = simulate_grid()
    calibration = calibrate_grid(grid, noisy_z(grid, seed=seed))
    problem, lookup = calibration.problem, calibration.lookup
    z_range = (lookup.z_min_uT, lookup.z_max_uT)
    z_eval, true_eval, z_trace, true_trace = _evaluation_sets(grid.sensor, z_range, quick)
    ref_trace, ref_eval = _reference_tips(problem, z_trace), _reference_tips(problem, z_eval)
    default = (len(lookup.z_knots_uT), lookup.kind)
    rows = _tracer_rows(problem, z_trace, ref_trace, true_trace,
                        PAPER_STEPS_MM[::2][:2] if quick else PAPER_STEPS_MM,
                        FAST_TOLERANCES[::2] if quick else FAST_TOLERANCES, say)
    rows += _lookup_rows(problem, z_range, z_eval, ref_eval, true_eval,
                         (5, 20) if quick else LOOKUP_SAMPLES, default, say)
    model_error = tip_error_mm(ref_eval, true_eval)["rmse_mm"]
    return {
        "benchmark": "tip-extraction", "quick": quick, "machine": machine_info(),
        "units": {"time": "s", "error": "mm", "z": "µT"},
        "setup": {"sensor": grid.sensor.sensor_id, "grid_points": len(grid.z_true_uT),
                  "surface_degree": calibration.surface.degree, "z_range_uT": list(z_range),
                  "lookup_eval_points": len(z_eval), "trace_eval_points": len(z_trace),
                  "reference": f"trace_fast at rtol = atol = {REFERENCE_TOLERANCE:g}",
                  "reference_error_vs_truth_mm": model_error},
        "rows": rows,
        "time_ratios": _ratios(rows, default),
        "pareto": {"x": "time_per_call_s", "y": "error_vs_reference_mm", "series": ["method", "kind"],
                   "label": "label", "x_label": "time per call (s)",
                   "y_label": "RMS error vs converged trace (mm)"},
        "pareto_truth": {"x": "time_per_call_s", "y": "error_vs_truth_mm",
                         "series": ["method", "kind"], "label": "label",
                         "x_label": "time per call (s)", "y_label": "RMS error vs twin truth (mm)"},
        "supports": _supports(rows, model_error, default),
    }
