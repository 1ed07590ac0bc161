"""``whiskercal report``: one self-contained HTML report per calibration."""

from __future__ import annotations

import click

from whiskercal.cli.app import App, echo_json, force_option, pass_app


@click.command("report")
@click.argument("calibration", type=click.Path(dir_okay=False))
@click.option("--raw", "raw_path", type=click.Path(dir_okay=False), default=None,
              help="The raw grid the calibration was fitted to: grid, residuals, and the twin's "
              "truth when it has one.")
@click.option("--study", "study_path", type=click.Path(dir_okay=False), default=None,
              help="A flat-plane study file (whiskercal optimal-depth run): its table and figures.")
@click.option("--bench", "bench_dir", type=click.Path(file_okay=False), default=None,
              help="A directory written by `whiskercal bench`: its speed-accuracy charts.")
@click.option("--out", "out_path", required=True, type=click.Path(dir_okay=False),
              help="The HTML file to write (figures embedded, no external resources).")
@click.option("--allow-other-sensor", is_flag=True,
              help="Use a raw grid or study that does not belong with the calibration (another "
              "sensor id, a plan for another whisker reach, or not the file the calibration "
              "records it was fitted from or given its target by), with a warning; refused "
              "otherwise.")
@click.option("--json", "as_json", is_flag=True, help="Print what was written as JSON.")
@force_option
@pass_app
def command(app: App, calibration: str, raw_path: str | None, study_path: str | None,
            bench_dir: str | None, out_path: str, allow_other_sensor: bool, as_json: bool,
            force: bool) -> None:
    """Write an HTML report of a calibration artifact (CALIBRATION.h5).

    One self-contained file: the grid and fit residual map, the level sets and traced tips,
    the lookup curve and its error (against the twin's truth when the raw grid has one), the
    study table and figures, the speed-accuracy charts, and provenance (hashes, versions, times).
    """
    from whiskercal.atomic import refuse_existing, refuse_input_as_output
    from whiskercal.artifacts.cross_check import check_report_inputs
    from whiskercal.report.build import report_inputs, write_report

    refuse_input_as_output(out_path, report_inputs(calibration, raw_path, study_path, bench_dir),
                           "the report")
    refuse_existing([out_path], force, "the report")
    for warning in check_report_inputs(calibration, raw_path, study_path, allow_other_sensor):
        click.echo(f"warning: {warning}", err=True)
    if app.interactive:
        click.echo("drawing the report ...", err=True)
    path = write_report(out_path, calibration, raw_path, study_path, bench_dir)
    size = path.stat().st_size
    if as_json:
        echo_json({"report": str(path), "bytes": size, "calibration": calibration, "raw": raw_path,
                   "study": study_path, "bench": bench_dir})
    else:
        click.echo(f"wrote {path} ({size / 1024:.0f} KiB)")
