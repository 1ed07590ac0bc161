"""``whiskercal fit``: a raw calibration grid -> the calibration artifact."""

from __future__ import annotations

import time

import click
import numpy as np

from whiskercal.atomic import refuse_existing, refuse_input_as_output
from whiskercal.cli.app import App, echo_json, force_option, pass_app


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
               "tip_spread_mm": m.get("tip_spread_mm", float("nan")),
               "tip_model": m.get("tip_model", "level-set"),
               "estimated_tip_error_mm": m.get("estimated_tip_error_mm", float("nan")),
               "collision_threshold_uT": float(data.collision["threshold_uT"]),
               "collision_threshold_source": m.get("collision_threshold_source", "given"),
               "collision_tip_motion_mm": float(m.get("collision_tip_motion_mm", float("nan"))),
               "warnings": list(m["warnings"]),
               "elapsed_s": elapsed_s}
    for key in ("lookup_vs_truth_rmse_mm", "lookup_vs_truth_max_mm"):
        if key in m:
            summary[key] = m[key]
    if "field_table_estimated_tip_error_mm" in m:  # not with --no-field-table
        for key in ("field_table_estimated_tip_error_mm",
                    "field_table_held_estimated_tip_error_mm"):
            summary[key] = float(m.get(key, float("nan")))
        summary["field_table_written"] = data.field_table is not None
        table = m.get("field_table", {})
        if "stage_offset_mm" in table:  # absent where the (Y, Z) model could not be fitted
            x, y = (float(v) for v in table["stage_offset_mm"])
            # x is fitted only with a tip sweep (mechfit.magnetfit.stage_offset_axes)
            summary["stage_offset_mm"] = [x if table.get("tip_sweep_points") else None, y]
    if "load_branches_written" in m:  # the table withheld because the readings fold
        for key in ("load_branches_estimated_tip_error_mm",
                    "load_branches_held_estimated_tip_error_mm"):
            summary[key] = float(m[key])
        summary["load_branches_written"] = data.load_branches is not None
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
              "trusted, mm [default: 9.5 for a 78 mm trace length, measured on the twin "
              "(docs/model.md), scaled with the trace length].")
@click.option("--allow-extrapolation", is_flag=True,
              help="Write the artifact even when some tips lie farther past the grid than "
              "--max-extension-mm; that z range is marked and the runtime refuses it.")
@click.option("--no-rod-correction", is_flag=True,
              help="Fit rod centres as they are, without moving them by the rod radius.")
@click.option("--threshold-uT", "threshold_uT", default=None, type=float,
              help="Collision threshold stored for the runtime, µT from the static reading "
              "[default: the paper's 300 µT, or on a build where 300 µT is a tip moved more "
              "than 3 mm the z of that motion on the fitted model, at least 20 times one "
              "sample's noise].")
@click.option("--tip-model", type=click.Choice(["auto", "mechanics", "level-set"]),
              default="auto", show_default=True,
              help="Tip model shipped in the lookup: auto, the mechanics-informed fit "
              "(suspension + elastica solved for a frictionless tip contact) where the grid pins "
              "the suspension down, else the paper's level set, and the same fitted to Y and "
              "Z with the (Y, Z) table where that is estimated closer still; or the first two "
              "by name. The mechanics is fitted either way for the error estimate. Where the "
              "level set cannot be traced, an identified model ships whatever is asked (the Y "
              "fit, else the Y and Z fit's with the table on), and fit refuses only when "
              "none is (docs/calibration.md).")
@click.option("--field-table/--no-field-table", default=True, show_default=True,
              help="Also fit the suspension and the magnet's field to the Y and Z axes and store "
              "a (Y, Z) -> tip table: the runtime then places tips pushed with friction or by "
              "slanted surfaces (docs/calibration.md). Withheld, with a warning, where its own "
              "error estimate says it cannot be trusted. Most of a default fit's time (timings_s "
              "in --json, docs/fit-time.md); --no-field-table leaves it out.")
@click.option("--json", "as_json", is_flag=True, help="Print the fit summary as JSON.")
@force_option
@pass_app
def command(app: App, raw: str, out_path: str, degree: str, coordinates: str, samples: int,
            tracer: str, interpolant: str, trace_length_mm: float | None,
            entry_radius_mm: float | None, max_extension_mm: float | None,
            allow_extrapolation: bool, no_rod_correction: bool, threshold_uT: float | None,
            tip_model: str, field_table: bool, as_json: bool, force: bool) -> None:
    """Fit a raw calibration grid (RAW.h5) and write the calibration artifact.

    Fits the surface z = f(x, y), traces the level set f = z from the root for the whisker's
    arc length at SAMPLES deflections (or solves the fitted mechanics for a tip contact), and
    stores the lookup z -> tip with the collision and filter settings the runtime uses. On a
    twin dataset the lookup is also compared with the twin's true tips.

    Every fit estimates its own RMS tip error without the truth (estimated_tip_error_mm, from
    how firmly the grid pins the suspension model down) and warns when it exceeds 0.25 mm or
    cannot be estimated. By default it also writes the (Y, Z) -> tip table and estimates that
    table's error the same way, for one reading (field_table_estimated_tip_error_mm) and for a
    contact held 30 samples (field_table_held_estimated_tip_error_mm); the table is withheld
    when the held estimate exceeds 0.5 mm or the (Y, Z) model leaves twice the noise. Where it
    is withheld because one (Y, Z) reading fits tip loads far apart, the model's loads are
    written instead (load_branches_*: the runtime follows each contact's load from its start),
    when following them is estimated to err 0.5 mm or less held.

    Refuses a grid that stops so far short of the tip that the trace would extrapolate more
    than --max-extension-mm past it (unless --allow-extrapolation), and warns, with the numbers,
    when the surface's CV error is far above the noise expected at the grid points.
    """
    from whiskercal.artifacts.raw_grid import read_raw_grid
    from whiskercal.fit import FitOptions, fit
    from whiskercal.fit.args import parse_degree

    refuse_input_as_output(out_path, [raw], "the calibration artifact")
    refuse_existing([out_path], force, "the calibration artifact")
    started = time.perf_counter()
    grid = read_raw_grid(raw)
    read_s = time.perf_counter() - started
    options = FitOptions(
        degree=parse_degree(degree), coordinates=coordinates, samples=samples, tracer=tracer,
        interpolant=interpolant, trace_length_mm=trace_length_mm,
        entry_radius_mm=entry_radius_mm, allow_extrapolation=allow_extrapolation,
        max_extension_mm=max_extension_mm,
        rod_correction=not no_rod_correction, threshold_uT=threshold_uT, tip_model=tip_model,
        field_table=field_table)
    say = (lambda message: click.echo(f"  {message} ...", err=True)) if app.interactive else None
    result = fit(grid, options, say)
    writing = time.perf_counter()
    data = result.artifact_data()
    result.write(out_path)
    timings = {"read": read_s, **result.timings_s, "write": time.perf_counter() - writing}
    _report(data, time.perf_counter() - started, out_path, as_json, timings)


def _report(data, elapsed_s: float, out_path: str, as_json: bool, timings_s: dict) -> None:
    summary = _summary(data, elapsed_s)
    summary["timings_s"] = timings_s  # wall time per stage: read, the fit's stages, write
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
    click.echo(f"tip model {summary['tip_model']}, estimated tip error "
               f"{summary['estimated_tip_error_mm']:.3f} mm RMS")
    if "field_table_written" in summary:
        click.echo(f"(Y, Z)    table {'written' if summary['field_table_written'] else 'withheld'}"
                   f", estimated tip error {summary['field_table_estimated_tip_error_mm']:.3f}"
                   f" mm RMS ({summary['field_table_held_estimated_tip_error_mm']:.3f} held)")
    if "stage_offset_mm" in summary:
        x, y = summary["stage_offset_mm"]
        along = "x not fitted: no tip sweep" if x is None else f"x {x:+.4f} mm"
        click.echo(f"stage     rods found y {y:+.4f} mm off their recorded places ({along}; "
                   "backlash, origin)")
    if "load_branches_written" in summary:
        click.echo(f"(Y, Z)    load branches "
                   f"{'written' if summary['load_branches_written'] else 'withheld'}, followed "
                   f"from each contact's start, estimated tip error "
                   f"{summary['load_branches_estimated_tip_error_mm']:.3f} mm RMS "
                   f"({summary['load_branches_held_estimated_tip_error_mm']:.3f} held)")
    motion = summary["collision_tip_motion_mm"]
    click.echo(f"contact   above {summary['collision_threshold_uT']:.0f} µT "
               f"({summary['collision_threshold_source']})"
               + (f", a tip moved {motion:.1f} mm" if np.isfinite(motion) else ""))
    if "lookup_vs_truth_rmse_mm" in summary:
        click.echo(f"truth     lookup vs the twin's true tips: RMSE "
                   f"{summary['lookup_vs_truth_rmse_mm']:.3f} mm, max "
                   f"{summary['lookup_vs_truth_max_mm']:.3f} mm")
    for warning in summary["warnings"]:
        click.echo(f"warning   {warning}", err=True)
