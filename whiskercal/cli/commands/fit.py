"""``whiskercal fit``: a raw calibration grid -> the calibration artifact."""

from __future__ import annotations

import platform
import time
from dataclasses import asdict

import click
import numpy as np

from whiskercal.cli.app import App, echo_json, pass_app
from whiskercal.errors import UsageError


def _degree(value: str) -> int | str:
    if value == "auto":
        return value
    try:
        return int(value)
    except ValueError:
        raise click.BadParameter("a degree 1..8 or 'auto'") from None


def _recorded_trace_lengths_mm(grid) -> list[tuple[float, str]]:
    """Every trace length (mm) known for this grid, most authoritative first, with its source:
    the raw file's rig config, then the twin sensor of the same id."""
    found = []
    rig = grid.config.get("rig", {}) if isinstance(grid.config, dict) else {}
    if "trace_length_mm" in rig:
        found.append((float(rig["trace_length_mm"]), "the raw grid's rig config"))
    sensor = _twin_sensor(grid.sensor_id)
    if sensor is not None:
        found.append((float(sensor.whisker.reach_mm), f"the twin sensor {grid.sensor_id!r}"))
    return found


def _trace_length_mm(option: float | None, grid) -> tuple[float, list[str]]:
    """The trace length (mm) and any warning: --trace-length-mm, else the raw file's rig config,
    else the twin sensor of the same id; each source that disagrees with the one used is named."""
    known = _recorded_trace_lengths_mm(grid)
    if option is None and not known:
        raise UsageError("the trace length is unknown for this sensor: give --trace-length-mm "
                         "(arc length from the suspension's centre of rotation to the tip)")
    used, source = (option, "--trace-length-mm") if option is not None else known[0]
    warnings = [f"the trace length {used:g} mm of {source} overrides the {value:g} mm of {where}"
                for value, where in known if abs(value - used) > 1e-6]
    return used, warnings


def _twin_sensor(sensor_id: str):
    from whiskercal.twin.params import SENSORS

    return SENSORS.get(sensor_id)


def _truth_metrics(grid, calibration) -> tuple[dict, dict | None]:
    """Lookup against the twin's true tips (tip contact), and what the rod correction did."""
    sensor = _twin_sensor(grid.sensor_id)
    if grid.truth is None or sensor is None:
        return {}, None
    from whiskercal.twin import truth

    z_true, tips_true = truth.tip_curve(sensor)
    lookup = calibration.lookup
    inside = (z_true >= lookup.z_min_uT) & (z_true <= lookup.z_max_uT)
    tips = lookup(z_true[inside])
    error = np.linalg.norm(tips - tips_true[inside], axis=1)
    metrics = {"lookup_vs_truth_rmse_mm": float(np.sqrt(np.mean(error ** 2))),
               "lookup_vs_truth_max_mm": float(error.max()),
               "lookup_vs_truth_points": int(inside.sum())}
    contact = grid.truth.get("contact_mm")
    if contact is not None:
        true_contact = contact[calibration.used]
        known = np.all(np.isfinite(true_contact), axis=1)
        before = np.linalg.norm(grid.rod_center_mm[calibration.used] - true_contact, axis=1)[known]
        after = np.linalg.norm(calibration.contact_points_mm - true_contact, axis=1)[known]
        metrics["contact_error_uncorrected_mm"] = float(np.mean(before))
        metrics["contact_error_corrected_mm"] = float(np.mean(after))
    arrays = {"z_uT": z_true[inside], "true_tip_mm": tips_true[inside],
              "lookup_tip_mm": tips, "error_mm": error}
    return metrics, arrays


def _extension_metrics(calibration) -> dict:
    """How far past the grid the lookup's tips are extrapolated, and what is trusted (mm, µT)."""
    trusted = calibration.trusted_z_uT
    return {"extension_max_mm": float(calibration.lookup_report.max_extension_mm),
            "extension_limit_mm": float(calibration.extension_limit_mm),
            "extrapolated": bool(calibration.extrapolated),
            "trusted_z_uT": np.asarray(trusted if trusted is not None else (np.nan, np.nan), float)}


def _metrics(calibration) -> dict:
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
        **_extension_metrics(calibration),
    }


def _raw_metrics(grid) -> dict:
    return {"raw_complete": bool(grid.complete), "raw_points_planned": int(len(grid.plan_rod_center_mm))}


def _trusted_or_none(trusted) -> list[float] | None:
    trusted = np.asarray(trusted, float)
    return None if np.any(np.isnan(trusted)) else trusted.tolist()


def _summary(data, elapsed_s: float) -> dict:
    m = data.metrics
    summary = {"degree": data.degree, "coordinates": data.coordinates, "rmse": m["rmse_uT"],
               "r2": m["r2"], "cv_rmse": m["cv_rmse_uT"],
               "lookup_holdout_rmse_mm": m["lookup_holdout_rmse_mm"],
               "samples": int(len(data.lookup_z_uT)), "interpolant": data.lookup_kind,
               "z_range_uT": [float(data.lookup_z_uT[0]), float(data.lookup_z_uT[-1])],
               "points_used": m["points_used"], "raw_complete": m["raw_complete"],
               "extension_max_mm": m["extension_max_mm"],
               "extension_limit_mm": m["extension_limit_mm"],
               "extrapolated": m["extrapolated"],
               "trusted_z_uT": _trusted_or_none(m["trusted_z_uT"]),
               "expected_noise_uT": m["expected_noise_uT"],
               "tip_spread_mm": m.get("tip_spread_mm", float("nan")), "warnings": list(m["warnings"]),
               "elapsed_s": elapsed_s}
    for key in ("lookup_vs_truth_rmse_mm", "lookup_vs_truth_max_mm"):
        if key in m:
            summary[key] = m[key]
    return summary


@click.command("fit")
@click.argument("raw", type=click.Path(dir_okay=False))
@click.option("--out", "out_path", required=True, type=click.Path(dir_okay=False),
              help="Calibration artifact to write (HDF5).")
@click.option("--degree", default="5", show_default=True,
              help="Total degree of the surface polynomial, 1..8, or 'auto' (k-fold CV, 1-SE rule).")
@click.option("--coordinates", type=click.Choice(["polar", "cartesian"]), default="polar",
              show_default=True, help="Variables of the surface polynomial: (r, θ) about the "
              "root, or the paper's (x, y).")
@click.option("--samples", default=20, show_default=True, type=click.IntRange(2, 10_000),
              help="Tips precomputed for the lookup, evenly spread over the calibrated z range.")
@click.option("--tracer", type=click.Choice(["fast", "paper"]), default="fast", show_default=True,
              help="Level-set tracer: adaptive (fast) or the paper's fixed 1e-3 mm step (slow).")
@click.option("--interpolant", type=click.Choice(["auto", "linear", "cubic", "pchip", "akima",
                                                  "polynomial"]), default="auto",
              show_default=True, help="Lookup interpolant; auto picks the smallest hold-out error.")
@click.option("--trace-length-mm", type=float, default=None,
              help="Arc length from the root to the tip, mm [default: the raw file's rig config, "
              "or the twin sensor's].")
@click.option("--entry-radius-mm", type=float, default=None,
              help="Radius about the root where the trace enters the data, mm [default: a third "
              "of the trace length, at least the grid's nearest point].")
@click.option("--max-extension-mm", type=click.FloatRange(min=0.0), default=None,
              help="Longest straight extrapolation of a tip past the grid's far edge that is "
              "trusted, mm [default: 9.5, measured on the twin: docs/model.md].")
@click.option("--allow-extrapolation", is_flag=True,
              help="Write the artifact even when some tips lie farther past the grid than "
              "--max-extension-mm; that z range is marked and the runtime refuses it.")
@click.option("--no-rod-correction", is_flag=True,
              help="Fit rod centres as they are, without moving them by the rod radius.")
@click.option("--threshold-uT", "threshold_uT", default=300.0, show_default=True, type=float,
              help="Collision threshold stored for the runtime, µT from the static reading.")
@click.option("--json", "as_json", is_flag=True, help="Print the fit summary as JSON.")
@pass_app
def command(app: App, raw: str, out_path: str, degree: str, coordinates: str, samples: int,
            tracer: str, interpolant: str, trace_length_mm: float | None,
            entry_radius_mm: float | None, max_extension_mm: float | None,
            allow_extrapolation: bool, no_rod_correction: bool, threshold_uT: float,
            as_json: bool) -> None:
    """Fit a raw calibration grid (RAW.h5) and write the calibration artifact.

    Fits the surface z = f(x, y), traces the level set f = z from the root for the whisker's
    arc length at SAMPLES deflections, and stores the lookup z -> tip with the collision and
    filter settings the runtime uses. On a twin dataset the lookup is also measured against
    the twin's true tips.

    Refuses a grid that stops so far short of the tip that the trace would extrapolate more
    than --max-extension-mm past it (unless --allow-extrapolation), and warns, with the numbers,
    when the surface's CV error is far above the noise expected at the grid points.
    """
    from whiskercal.artifacts.calibration import data_from_calibration, write_calibration
    from whiskercal.artifacts.raw_grid import read_raw_grid
    from whiskercal.model.calibrate import MAX_EXTENSION_MM, CalibrationOptions
    from whiskercal.model.collision import CollisionParams
    from whiskercal.model.kalman import KalmanParams

    started = time.perf_counter()
    grid = read_raw_grid(raw)
    length_mm, length_warnings = _trace_length_mm(trace_length_mm, grid)
    options = CalibrationOptions(
        degree=_degree(degree), coordinates=coordinates, samples=samples, tracer=tracer,
        lookup_kind=interpolant, trace_length_mm=length_mm,
        entry_radius_mm=entry_radius_mm, correct_rod_radius=not no_rod_correction,
        max_extension_mm=MAX_EXTENSION_MM if max_extension_mm is None else max_extension_mm,
        allow_extrapolation=allow_extrapolation)
    say = (lambda message: click.echo(f"  {message} ...", err=True)) if app.interactive else None
    sem = grid.z_std_uT / np.sqrt(np.maximum(grid.n_samples, 1))
    calibration = _calibrate(grid, options, sem, say)
    warnings = length_warnings + calibration.warnings
    evidence = {"expected_noise_uT": calibration.expected_noise_uT,
                "cv_level_set_shift_mm": calibration.cv_level_set_shift_mm,
                "tip_spread_mm": calibration.tip_spread_mm}
    truth_metrics, truth_arrays = _truth_metrics(grid, calibration)
    data = data_from_calibration(
        calibration, sensor_id=grid.sensor_id, rod_radius_mm=grid.rod_radius_mm, tracer=tracer,
        kalman=KalmanParams(), collision=CollisionParams(threshold_uT=threshold_uT),
        metrics={**_metrics(calibration), **evidence, **_raw_metrics(grid), **truth_metrics,
                 "warnings": warnings},
        truth=truth_arrays, inputs={"raw_grid": grid.sha256}, config=_config(options, raw))
    write_calibration(out_path, data)
    _report(data, time.perf_counter() - started, out_path, as_json)


def _calibrate(grid, options, sem_uT: np.ndarray, say):
    """``calibrate`` with the refusal of a short grid told how to proceed."""
    from whiskercal.model.calibrate import calibrate
    from whiskercal.model.errors import ExtrapolationLimitError

    try:
        return calibrate(grid.rod_center_mm, grid.z_uT, grid.rod_radius_mm, options, sem_uT, say)
    except ExtrapolationLimitError as error:
        raise ExtrapolationLimitError(f"{error}; collect a grid that reaches farther, or pass "
                                      "--allow-extrapolation to mark that range") from None


def _config(options, raw: str) -> dict:
    import scipy

    return {"options": asdict(options), "raw_grid": str(raw),
            "versions": {"python": platform.python_version(), "numpy": np.__version__,
                         "scipy": scipy.__version__}}


def _report(data, elapsed_s: float, out_path: str, as_json: bool) -> None:
    summary = _summary(data, elapsed_s)
    if as_json:
        echo_json(summary)
        return
    click.echo(f"wrote {out_path}")
    if not summary["raw_complete"]:
        click.echo(f"note      the raw grid is incomplete: {data.metrics['points_total']} of "
                   f"{data.metrics['raw_points_planned']} planned points", err=True)
    click.echo(f"surface   degree {summary['degree']} ({summary['coordinates']}), "
               f"RMSE {summary['rmse']:.2f} µT, R² {summary['r2']:.5f}, "
               f"CV RMSE {summary['cv_rmse']:.2f} µT, {summary['points_used']} points")
    click.echo(f"lookup    {summary['samples']} samples, {summary['interpolant']}, z "
               f"{summary['z_range_uT'][0]:.0f}..{summary['z_range_uT'][1]:.0f} µT, hold-out "
               f"RMSE {summary['lookup_holdout_rmse_mm']:.5f} mm")
    click.echo(f"extension up to {summary['extension_max_mm']:.2f} mm past the grid (limit "
               f"{summary['extension_limit_mm']:.2f} mm)"
               + (", extrapolated range marked" if summary["extrapolated"] else ""))
    if "lookup_vs_truth_rmse_mm" in summary:
        click.echo(f"truth     lookup vs the twin's true tips: RMSE "
                   f"{summary['lookup_vs_truth_rmse_mm']:.3f} mm, max "
                   f"{summary['lookup_vs_truth_max_mm']:.3f} mm")
    for warning in summary["warnings"]:
        click.echo(f"warning   {warning}", err=True)
