"""How long ``whiskercal fit`` takes against how close its tips come, for each tip model.

A lab refits after every session, so the fit's own time is a cost a user weighs against its
accuracy. Each recorded dataset in data/ (twin recordings with their ground truth) is fitted
in this process, one after the other, with each tip model:

- ``level-set``: the paper's level set, no (Y, Z) table (``--tip-model level-set
  --no-field-table``; the mechanics is still fitted for the estimate);
- ``mechanics``: the mechanics-informed z lookup, no table (``--tip-model mechanics
  --no-field-table``);
- ``auto``: fit's default: the better estimated of the two, then the (Y, Z) joint fit, its table
  and its own lookup where that is estimated closer still.

Each row gives the fit's wall and CPU time (s; the CPU time includes the fit's worker
processes), its stages' wall times (``timings_s``), the tip model shipped and its lookup
against the twin's true tips (RMS and max, mm, world frame, no fitted alignment). `run()`
returns JSON-able results with a Pareto chart of time against the RMS tip error, one panel per
dataset; `whiskercal bench --only fit-speed` collects them.
"""

from __future__ import annotations

import resource
import time
from pathlib import Path
from typing import Callable

import whiskercal

DATA = Path(whiskercal.__file__).resolve().parents[1] / "data"
DATASETS = ("twin-paper-75mm", "twin-short-60mm", "twin-long-110mm")
QUICK_DATASETS = ("twin-short-60mm",)
# the tip models, as `whiskercal fit` arguments after the regression's degree and samples
METHODS = {
    "level-set": ["--tip-model", "level-set", "--no-field-table"],
    "mechanics": ["--tip-model", "mechanics", "--no-field-table"],
    "auto": [],
}
BASE_ARGS = ["--degree", "5", "--samples", "20"]
# the chart: fit wall time against the lookup's RMS distance from the true tips, a panel per dataset
PARETO = {"x": "fit_s", "y": "lookup_vs_truth_rmse_mm", "panel": "dataset", "series": ["method"],
          "label": "tip_model", "x_label": "fit wall time (s)",
          "y_label": "lookup RMS error from the true tips (mm)"}


def fit_row(raw_path: Path, method: str) -> dict:
    """One fit of ``raw_path`` with tip model ``method``: times (s) and truth errors (mm)."""
    from whiskercal.artifacts.raw_grid import read_raw_grid
    from whiskercal.fit import fit, options_from_args

    options = options_from_args(BASE_ARGS + METHODS[method])
    raw = read_raw_grid(raw_path)
    wall, cpu = time.perf_counter(), _cpu_s()
    result = fit(raw, options)
    wall, cpu = time.perf_counter() - wall, _cpu_s() - cpu
    metrics = result.metrics
    return {"dataset": raw_path.parent.name, "method": method, "fit_s": wall, "cpu_s": cpu,
            "timings_s": dict(result.timings_s),
            "tip_model": metrics.get("tip_model", "level-set"),
            "field_table_written": result.field_table is not None,
            "lookup_vs_truth_rmse_mm": float(metrics.get("lookup_vs_truth_rmse_mm", "nan")),
            "lookup_vs_truth_max_mm": float(metrics.get("lookup_vs_truth_max_mm", "nan")),
            "estimated_tip_error_mm": float(metrics.get("estimated_tip_error_mm", "nan")),
            "default": method == "auto"}


def _cpu_s() -> float:
    """CPU time (s) of this process and of the worker processes it has waited for: the fit
    runs some of its fits side by side in forked workers (``mechfit.workers``)."""
    own, children = resource.getrusage(resource.RUSAGE_SELF), \
        resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


def run(quick: bool = False, progress: Callable | None = None,
        datasets: tuple[str, ...] | None = None) -> dict:
    """Fit every dataset (``QUICK_DATASETS`` when ``quick``) with every tip model.

    Returns
    -------
    dict
        ``rows`` (one per dataset and tip model, see the module's text), the ``pareto`` spec
        (fit wall time against the lookup's RMS error from the truth, a panel per dataset) and
        ``supports``: the default's time and error beside the fastest model's, per dataset.
    """
    chosen = datasets or (QUICK_DATASETS if quick else DATASETS)
    rows = []
    for name in chosen:
        for method in METHODS:
            rows.append(fit_row(DATA / name / "raw_grid.h5", method))
            if progress is not None:
                progress(rows[-1])
    return {"rows": rows, "pareto": dict(PARETO), "supports": _supports(rows)}


def _supports(rows: list[dict]) -> dict:
    """Per dataset: the default's wall time as a multiple of the level set's, and both errors."""
    found = {}
    for name in sorted({r["dataset"] for r in rows}):
        mine = {r["method"]: r for r in rows if r["dataset"] == name}
        found[name] = {"default_fit_s": mine["auto"]["fit_s"],
                       "default_time_ratio_to_level_set": mine["auto"]["fit_s"]
                       / mine["level-set"]["fit_s"],
                       "default_rmse_mm": mine["auto"]["lookup_vs_truth_rmse_mm"],
                       "level_set_rmse_mm": mine["level-set"]["lookup_vs_truth_rmse_mm"]}
    return {"rule": "the default ships the tip model estimated closest; this charts what its "
                    "extra fitting costs in time", **found}
