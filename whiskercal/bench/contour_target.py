"""The study's rule checked on the closed loop: contour error against the deflection target.

The default sensor's recorded grid (``data/twin-paper-75mm``) is fitted with the paper's level
set as its z lookup (``fit --tip-model level-set``, whose lookup reproduces on any machine;
``fit``'s own default ships the mechanics' lookup) and given the target its recorded flat-plane study
chooses through it (``optimal-depth``); then the contour loop runs on the twin round each
object at a range of targets (|z| from 3 to 12 mT, the sign of the chosen one, and the chosen
one itself), each run compared with the object's true outline without alignment. Targets
past the calibrated range (|z| above its end) are listed, not run: the
lookup has no tip to give there. The full run does it twice, once per tip model: the z lookup
alone and the (Y, Z) table (``fit``'s default, fitted once and reused for every run, with the
target the study chooses through the table; ``--quick`` skips it). The same runs measure the
controller's own cost per sample (the twin's solve not included) against the sensor's 3.3 ms
period.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np

import whiskercal
from whiskercal.errors import UsageError
from whiskercal.plotting import pyplot, save_png

DATASET = Path(whiskercal.__file__).resolve().parents[1] / "data" / "twin-paper-75mm"
MAGNITUDES_UT = (3000.0, 4000.0, 5000.0, 6000.0, 7000.0, 8000.0, 9000.0, 10000.0, 11000.0, 12000.0)
PERIOD_MS = 1000.0 / 300.0


def calibrations_with_target(folder: Path, dataset: Path = DATASET,
                             field_table: bool = True) -> dict[str, Path]:
    """The dataset's grid fitted once, the level set as its z lookup (and the (Y, Z) table when
    asked), written as one artifact per tip model, each with the target the recorded study
    chooses through that artifact (as ``optimal-depth report`` does for a user's).
    """
    from dataclasses import replace

    from whiskercal import runtime
    from whiskercal.artifacts.raw_grid import read_raw_grid
    from whiskercal.fit import FitOptions, fit
    from whiskercal.study.artifact_target import write_target
    from whiskercal.study.report import build_report

    if not (dataset / "raw_grid.h5").exists() or not (dataset / "plane_study.h5").exists():
        raise UsageError(f"{dataset} holds no raw_grid.h5 and plane_study.h5: the contour-target "
                         "comparison runs from a source checkout with its data/")
    options = FitOptions(tip_model="level-set", field_table=field_table)
    result = fit(read_raw_grid(dataset / "raw_grid.h5"), options)
    plain = replace(result, field_table=None).write(folder / "calibration.h5")
    report = build_report(dataset / "plane_study.h5", runtime.load(plain))
    made = {"z-lookup": write_target(plain, folder / "calibration-target.h5", report.choice,
                                     report.study.sha256)}
    if field_table:
        table = result.write(folder / "calibration-table.h5")
        report = build_report(dataset / "plane_study.h5", runtime.load(table))
        made["yz-table"] = write_target(table, folder / "calibration-table-target.h5",
                                        report.choice, report.study.sha256)
    return made


def calibration_with_target(folder: Path, dataset: Path = DATASET) -> Path:
    """The dataset's grid fitted (the level set, no table), its study's chosen target written in."""
    return calibrations_with_target(folder, dataset, field_table=False)["z-lookup"]


def _targets(chosen_uT: float, range_end_uT: float, quick: bool,
             magnitudes_uT=MAGNITUDES_UT) -> tuple[list[float], list[float]]:
    """Targets to run (µT, the chosen one included) and those past the calibrated range."""
    sign = float(np.sign(chosen_uT))
    magnitudes = (8000.0,) if quick else magnitudes_uT
    inside = [sign * m for m in magnitudes if m <= abs(range_end_uT)]
    beyond = [sign * m for m in magnitudes if m > abs(range_end_uT)]
    return sorted(set(inside) | {float(chosen_uT)}, key=abs), beyond


def run(quick: bool = False, progress=None, field_table: bool | None = None,
        shapes: tuple[str, ...] | None = None, magnitudes_uT=MAGNITUDES_UT,
        duration_s: float | None = None) -> dict:
    """Contour error against target (rows), one series per tip model, the controller's cost.

    ``field_table`` (default: all but ``quick``) adds the (Y, Z) table's series; the table's fit
    (minutes) is done once and its artifact used for every run of the series.
    """
    from whiskercal import runtime
    from whiskercal.contour import target_sweep

    field_table = (not quick) if field_table is None else field_table
    shapes = shapes or (("cylinder",) if quick else ("cylinder", "rounded-rect", "octagon"))
    duration_s = duration_s or (8.0 if quick else 120.0)
    rows = []
    with tempfile.TemporaryDirectory(prefix="whiskercal-contour-target-") as folder:
        artifacts = calibrations_with_target(Path(folder), field_table=field_table)
        loaded = {series: runtime.load(path) for series, path in artifacts.items()}
        chosen = {series: float(calibration.target_z_uT) for series, calibration in loaded.items()}
        range_end = float(loaded["z-lookup"].z_range_uT[0])
        for series, artifact in artifacts.items():
            targets, beyond = _targets(chosen[series], range_end, quick, magnitudes_uT)
            tag = (lambda row, s=series: progress({"tip_model": s, **row})) if progress else None
            for row in target_sweep(artifact, targets, shapes, duration_s=duration_s, on_row=tag):
                rows.append({"tip_model": series, **row,
                             "default": row["target_z_uT"] == chosen[series]})
    return {"rows": rows, "chosen_target_z_uT": chosen, "calibrated_range_end_uT": range_end,
            "beyond_range_uT": beyond, "duration_s": duration_s,
            "controller": _controller_cost(rows), "supports": _supports(rows, chosen)}


def _controller_cost(rows: list[dict]) -> dict:
    mean = float(np.mean([r["control_ms_mean"] for r in rows]))
    slowest = float(np.max([r["control_ms_max"] for r in rows]))
    return {"mean_ms_per_sample": mean, "slowest_sample_ms": slowest, "period_ms": PERIOD_MS,
            "mean_share_of_period": mean / PERIOD_MS}


def _series(rows: list[dict]) -> dict[tuple[str, str], list[dict]]:
    """Rows by (tip model, shape), each list in order of |target|."""
    groups: dict[tuple[str, str], list[dict]] = {}
    for row in rows:
        groups.setdefault((row.get("tip_model", "z-lookup"), row["shape"]), []).append(row)
    return {key: sorted(mine, key=lambda r: abs(r["target_z_uT"])) for key, mine in groups.items()}


def _supports(rows: list[dict], chosen: dict[str, float]) -> dict:
    """Per tip model: the best target that went round, and the error at its chosen one."""
    best, at_chosen = {}, {}
    for (model, shape), mine in _series(rows).items():
        went_round = [r for r in mine if r["coverage"] >= 0.95]
        if went_round:
            best.setdefault(model, {})[shape] = min(
                went_round, key=lambda r: r["mean_error_mm"])["target_z_uT"]
        at_chosen.setdefault(model, {}).update(
            {shape: r["mean_error_mm"] for r in mine if r["target_z_uT"] == chosen[model]})
    return {"target_z_uT": chosen, "best_target_z_uT": best,
            "chosen_mean_error_mm": at_chosen,
            "controller_ms_per_sample": _controller_cost(rows)["mean_ms_per_sample"],
            "rule": "the target optimal-depth chose should give a contour error at or near the "
                    "lowest of the targets run (runs that covered < 95 % of the outline do not count)"}


LINE_STYLES = {"z-lookup": "-", "yz-table": "--"}
LABELS = {"z-lookup": "z lookup", "yz-table": "(Y, Z) table"}


def draw(result: dict, path: Path) -> Path:
    """Mean contour error (no alignment) against |target|, one line per tip model and object
    (colour: object, line: tip model); each tip model's chosen target marked, runs that did
    not go round hollow, the calibrated range's end drawn."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(7.5, 4.8))
    rows = result["rows"]
    colours = {shape: f"C{i}" for i, shape in enumerate(dict.fromkeys(r["shape"] for r in rows))}
    for (model, shape), mine in _series(rows).items():
        x = np.array([abs(r["target_z_uT"]) / 1000.0 for r in mine])
        y = np.array([r["mean_error_mm"] for r in mine])
        went_round = np.array([r["coverage"] >= 0.95 for r in mine])
        colour = colours[shape]
        ax.plot(x, y, LINE_STYLES.get(model, ":"), lw=1, color=colour,
                label=f"{shape}, {LABELS.get(model, model)}")
        ax.plot(x[went_round], y[went_round], "o", color=colour)
        ax.plot(x[~went_round], y[~went_round], "o", mfc="none", color=colour)
    for model, target in result["chosen_target_z_uT"].items():
        ax.axvline(abs(target) / 1000.0, color="k", ls=LINE_STYLES.get(model, ":"), lw=1,
                   label=f"optimal-depth's target, {LABELS.get(model, model)}")
    ax.axvline(abs(result["calibrated_range_end_uT"]) / 1000.0, color="grey", ls=":", lw=1,
               label="end of the calibrated range")
    errors = np.array([r["mean_error_mm"] for r in rows], float)
    errors = errors[np.isfinite(errors) & (errors > 0)]
    if errors.size and errors.max() > 20 * errors.min():  # a run that lost the surface
        ax.set_yscale("log")
    else:
        ax.set_ylim(bottom=0.0)
    ax.set_xlabel("|deflection target| (mT)")
    ax.set_ylabel("mean contour error, no alignment (mm)")
    ax.set_title("contour error against the deflection target (hollow: covered < 95 %)")
    ax.legend(fontsize=7)
    return save_png(fig, path)
