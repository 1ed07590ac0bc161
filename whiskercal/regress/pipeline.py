"""Recompute every stage on a recorded dataset and flatten the results into named quantities.

The stages run exactly as a user runs them: ``whiskercal.fit.fit`` (what `whiskercal fit` runs,
with the options of the golden file's `whiskercal fit` arguments) writes a calibration artifact;
the study report (`whiskercal optimal-depth report`'s ``build_report``) localizes every trial
through ``whiskercal.runtime``; the chosen target is written into a copy of the artifact, which
``whiskercal.runtime`` loads again.

Quantity names say where a number comes from (``fit.rmse_uT``, ``lookup.tip_x_mm[07]``,
``study.trial[20mm].filtered_mean_mm``, ``study.target.z_uT``, ``runtime.target_z_uT``).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Callable

import numpy as np

from whiskercal.errors import WhiskercalError
from whiskercal.regress.golden import Dataset


class StageFailedError(WhiskercalError):
    """A stage of the pipeline failed on a recorded dataset (its message names both)."""


# Fit metrics kept as golden quantities (the artifact's /metrics attributes).
FIT_METRICS = ("rmse_uT", "r2", "cv_rmse_uT", "condition_number", "lookup_holdout_rmse_mm",
               "points_used", "points_total", "lookup_vs_truth_rmse_mm", "lookup_vs_truth_max_mm",
               "lookup_vs_truth_points", "contact_error_uncorrected_mm",
               "contact_error_corrected_mm", "tip_model")
# Per-trial columns of the study report kept as golden quantities.
TRIAL_COLUMNS = ("n_samples", "contact_fraction", "median_z_uT", "raw_mean_mm", "raw_std_mm",
                 "filtered_mean_mm", "filtered_std_mm", "off_plane_fraction", "n_slips",
                 "unlocalized_fraction", "slid_mm", "kink_depth_mm", "tangential",
                 "true_raw_mean_mm", "true_filtered_mean_mm", "true_tangential_fraction",
                 "failing", "reasons", "unmapped_samples")
# Per-trial columns of the shaft study report kept as golden quantities (not its timing).
SHAFT_COLUMNS = ("samples_in_contact", "median_error_mm", "final_error_mm", "travel_to_1mm",
                 "localized_share_after_5mm", "gross_error_share", "kind_accuracy", "kind_accuracy_all",
                 "kind_decided_share")


def recompute(dataset: Dataset, pipeline: dict[str, Any], workdir: Path,
              say: Callable[[str], None] | None = None) -> tuple[dict[str, Any], str]:
    """Run fit, lookup, study report and runtime on ``dataset``; return (quantities, sensor_id).

    Parameters
    ----------
    dataset
        The recorded dataset (its files already checked).
    pipeline
        ``fit_args`` for `whiskercal fit`, the report's ``margin_weight_mm``, and
        ``default_fit_args`` for the default fit checked beside it (``regress.default_fit``;
        skipped when absent).
    workdir
        A scratch directory for the artifacts.
    say
        Progress callback (one short line per stage), or None.
    """
    say = say or (lambda message: None)
    artifact = workdir / f"{dataset.name}-calibration.h5"
    say(f"{dataset.name}: fit")
    run_fit(dataset.raw_grid, artifact, list(pipeline.get("fit_args", [])))
    from whiskercal.artifacts.calibration import read_calibration

    data = read_calibration(artifact)
    quantities = {**fit_quantities(data), **lookup_quantities(data)}
    say(f"{dataset.name}: study report")
    report = _study_report(dataset, artifact, float(pipeline.get("margin_weight_mm", 0.1)))
    quantities.update(study_quantities(report.as_dict()))
    if report.choice is not None:
        quantities.update(_runtime_quantities(artifact, workdir, report))
    if dataset.shaft_study is not None:
        say(f"{dataset.name}: shaft study report")
        quantities.update(shaft_quantities(dataset, artifact))
    if pipeline.get("default_fit_args") is not None:
        from whiskercal.regress.default_fit import default_fit_quantities

        say(f"{dataset.name}: the default fit")
        quantities.update(default_fit_quantities(dataset.raw_grid, workdir,
                                                 list(pipeline["default_fit_args"])))
    return quantities, data.sensor_id


def run_fit(raw_grid: Path, artifact: Path, fit_args: list[str]) -> None:
    """Fit ``raw_grid`` as `whiskercal fit RAW --out ARTIFACT [fit_args]` does and write the
    artifact; a stage that fails is named with the dataset."""
    from whiskercal.artifacts.raw_grid import read_raw_grid
    from whiskercal.fit import fit, options_from_args

    try:
        options = options_from_args(fit_args)
    except WhiskercalError as error:  # bad fit_args in golden.json
        raise StageFailedError(f"{raw_grid.parent.name}: whiskercal fit "
                               f"{' '.join(fit_args)}: {error}") from None
    try:
        fit(read_raw_grid(raw_grid), options).write(artifact)
    except WhiskercalError as error:
        raise StageFailedError(f"{raw_grid.parent.name}: whiskercal fit failed: "
                               f"{error}") from None


def fit_quantities(data) -> dict[str, Any]:
    """The surface fit's metrics and settings from a calibration artifact."""
    found = {"fit.degree": int(data.degree), "fit.coordinates": data.coordinates}
    for key in FIT_METRICS:
        if key in data.metrics:
            found[f"fit.{key}"] = _plain(data.metrics[key])
    # whether the fit warned of its tip error: a decision, where the estimate's digits are not
    found["fit.tip_error_warned"] = any("tip error" in str(w)
                                       for w in data.metrics.get("warnings", []))
    # whether the artifact carries the (Y, Z) table (fit's default; withheld where its own
    # estimate says it cannot be trusted): the study reads Z through it when it does
    found["fit.field_table_written"] = data.field_table is not None
    return found


def lookup_quantities(data) -> dict[str, Any]:
    """The lookup table: its interpolant, every sample's z and tip."""
    found: dict[str, Any] = {"lookup.kind": data.lookup_kind,
                             "lookup.samples": int(len(data.lookup_z_uT))}
    for i, (z, tip) in enumerate(zip(data.lookup_z_uT, data.lookup_tip_mm)):
        found[f"lookup.z_uT[{i:02d}]"] = float(z)
        found[f"lookup.tip_x_mm[{i:02d}]"] = float(tip[0])
        found[f"lookup.tip_y_mm[{i:02d}]"] = float(tip[1])
    return found


def _study_report(dataset: Dataset, artifact: Path, margin_weight_mm: float):
    from whiskercal import runtime
    from whiskercal.study.report import build_report

    try:
        return build_report(dataset.study, runtime.load(artifact), margin_weight_mm=margin_weight_mm)
    except WhiskercalError as error:
        raise StageFailedError(f"{dataset.name}: the study report failed: {error}") from None


def study_quantities(report: dict) -> dict[str, Any]:
    """The per-trial table, the failing depths and the chosen target from a report's dict."""
    found: dict[str, Any] = {
        "study.failing_depths_mm": list(report["failing_depths_mm"]),
        "study.passing_mean_filtered_mm": _plain(report["passing_mean_filtered_mm"])}
    for row in report["trials"]:
        label = f"study.trial[{row['depth_mm']:g}mm]"
        for column in TRIAL_COLUMNS:
            if column in row:
                found[f"{label}.{column}"] = _plain(row[column])
    choice = report.get("choice")
    if choice is None:
        found["study.target.depth_mm"] = None
        return found
    found["study.target.depth_mm"] = float(choice["depth_mm"])
    found["study.target.z_uT"] = float(choice["z_uT"])
    found["study.target.score_mm"] = float(choice["score_mm"])
    for depth, score in sorted(choice.get("scores_mm", {}).items(), key=lambda kv: float(kv[0])):
        found[f"study.target.scores_mm[{float(depth):g}mm]"] = float(score)
    return found


def shaft_quantities(dataset: Dataset, artifact: Path) -> dict[str, Any]:
    """The shaft study report's per-trial table (`whiskercal shaft-study report`'s numbers, its
    timing apart) through the artifact's shaft localizer."""
    from whiskercal import runtime
    from whiskercal.shaftstudy.report import build_report as build_shaft_report

    try:
        report = build_shaft_report(dataset.shaft_study, runtime.load(artifact))
    except WhiskercalError as error:
        raise StageFailedError(f"{dataset.name}: the shaft study report failed: "
                               f"{error}") from None
    found: dict[str, Any] = {}
    for row in report.as_dict()["trials"]:
        for column in SHAFT_COLUMNS:
            found[f"shaft.trial[{row['name']}].{column}"] = _plain(row[column])
    return found


def _runtime_quantities(artifact: Path, workdir: Path, report) -> dict[str, Any]:
    """Write the target into a copy of the artifact and read it back as a robot would."""
    from whiskercal import runtime
    from whiskercal.study.artifact_target import target_artifact_path, write_target

    with_target = write_target(artifact, target_artifact_path(artifact, workdir), report.choice,
                               report.study.sha256)
    calibration = runtime.load(with_target)
    tip = calibration.tip(calibration.target_z_uT)
    return {"runtime.target_z_uT": float(calibration.target_z_uT),
            "runtime.tip_x_mm_at_target": float(tip[0]),
            "runtime.tip_y_mm_at_target": float(tip[1])}


def _plain(value: Any) -> Any:
    """numpy scalars and arrays as JSON-able Python values; NaN stays a float NaN."""
    if isinstance(value, np.ndarray):
        return [_plain(v) for v in value.tolist()]
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if value is None:
        return math.nan
    return value
