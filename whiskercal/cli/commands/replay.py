"""``whiskercal replay``: a recorded magnetometer stream through a calibration's runtime tracker."""

from __future__ import annotations

import time

import click

from whiskercal.cli.app import App, echo_json, force_option, pass_app


def _rest(rest: str | None, rest_uT: float | None):
    if rest is not None and rest_uT is not None:
        from whiskercal.errors import UsageError

        raise UsageError("give either --rest or --rest-uT, not both")
    return rest_uT if rest_uT is not None else rest


@click.command("replay")
@click.argument("log", type=click.Path(dir_okay=False))
@click.option("--artifact", required=True, type=click.Path(dir_okay=False),
              help="Calibration artifact (HDF5) to replay the stream through.")
@click.option("--out", "out_dir", required=True, type=click.Path(file_okay=False),
              help="Folder for track.csv, track.h5, replay.png and summary.json.")
@click.option("--time-column", default=None,
              help="Time column of a table [default: the first of t_s, time_s, time, t, timestamp].")
@click.option("--field-column", default=None,
              help="Y-field column of a table, µT [default: the first of y_uT, field_y_uT, "
              "magnetic_y, y, by; case-insensitive].")
@click.option("--delimiter", default=None,
              help="comma, tab, semicolon, space or one character [default: detected from the "
              "header].")
@click.option("--time-unit", type=click.Choice(["s", "ms", "us", "ns"]), default="s",
              show_default=True, help="Unit of the time column.")
@click.option("--rest", type=click.Choice(["auto", "recorded"]), default=None,
              help="Static Y reading: the median of the first --rest-samples samples (auto) or "
              "the one a whiskercal HDF5 file recorded [default: recorded when the file has one, "
              "else auto].")
@click.option("--rest-uT", "rest_uT", type=float, default=None,
              help="Static Y reading of this session, µT (z = reading - rest).")
@click.option("--rest-samples", type=click.IntRange(min=1), default=100, show_default=True,
              help="Samples at the start, free of contact, whose median is --rest auto.")
@click.option("--sign", type=click.Choice(["1", "-1"]), default="1", show_default=True,
              help="-1 for a sensor mounted so that Y moves the other way from the calibration's.")
@click.option("--out-of-range", type=click.Choice(["clip", "nan", "raise"]), default="clip",
              show_default=True, help="z outside the calibrated range in contact: the edge tip "
              "(flagged), no tip (flagged), or stop with an error.")
@click.option("--allow-extrapolated", is_flag=True,
              help="Answer z in a range the artifact marks as extrapolated (flagged).")
@click.option("--json", "as_json", is_flag=True, help="Print the summary as JSON.")
@force_option
@pass_app
def command(app: App, log: str, artifact: str, out_dir: str, time_column: str | None,
            field_column: str | None, delimiter: str | None, time_unit: str, rest: str | None,
            rest_uT: float | None, rest_samples: int, sign: str, out_of_range: str,
            allow_extrapolated: bool, as_json: bool, force: bool) -> None:
    """Replay LOG (a CSV/TSV table or a whiskercal raw-grid / plane-study HDF5 file) through the
    calibration's tracker: collision detection, tip lookup and Kalman filter, sample by sample.

    z = sign x (Y reading - rest). The reading at rest differs between sessions by hundreds of
    µT: give it with --rest-uT, or let --rest auto take the median of the stream's first
    samples (docs/replay.md). Writes the tip track (CSV and HDF5), a plot and a summary.
    """
    from whiskercal import runtime
    from whiskercal.artifacts.h5io import sha256_file
    from whiskercal.replay import ReplayOptions, read_stream, replay, write_all
    from whiskercal.atomic import refuse_existing
    from whiskercal.replay.output import output_paths, refuse_inputs_as_outputs

    started = time.perf_counter()
    options = ReplayOptions(rest=_rest(rest, rest_uT), rest_samples=rest_samples, sign=int(sign),
                            out_of_range=out_of_range)
    refuse_inputs_as_outputs(out_dir, [log, artifact])
    refuse_existing(output_paths(out_dir).values(), force, "the replay output")
    calibration = runtime.load(artifact, allow_extrapolated=allow_extrapolated)
    stream = read_stream(log, time_column, field_column, delimiter, time_unit)
    result = replay(stream, calibration, options)
    summary = {"log": log, "artifact": artifact, **result.summary()}
    summary["elapsed_s"] = time.perf_counter() - started
    write_all(out_dir, result, summary, calibration.sensor_id,
              {"log": sha256_file(log), "artifact": sha256_file(artifact)})
    _report(summary, out_dir, as_json)


def _report(summary: dict, out_dir: str, as_json: bool) -> None:
    if as_json:
        echo_json(summary)
        return
    low, high = summary["calibrated_z_range_uT"]
    click.echo(f"wrote     {out_dir}/ (track.csv, track.h5, replay.png, summary.json)")
    click.echo(f"samples   {summary['samples']} over {summary['duration_s']:.2f} s, rest "
               f"{summary['rest_uT']:.1f} µT ({summary['rest_source']})")
    click.echo(f"contact   {summary['contact_samples']} samples: {summary['in_range']} in range "
               f"[{low:.0f}, {high:.0f}] µT, {summary['out_of_range']} out of range "
               f"({summary['out_of_range_below']} below, {summary['out_of_range_above']} above; "
               f"{summary['out_of_range_policy']})")
    click.echo(f"cost      {summary['per_sample_us']:.1f} µs per sample")
    for warning in summary["warnings"]:
        click.echo(f"warning   {warning}", err=True)
