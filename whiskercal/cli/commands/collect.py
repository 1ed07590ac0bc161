"""``whiskercal collect``: run the calibration grid on the stage and record the raw dataset."""

from __future__ import annotations

import signal
import sys
from contextlib import contextmanager

import click

from whiskercal.atomic import refuse_input_as_output
from whiskercal.cli.app import App, abort, echo_json, pass_app
from whiskercal.errors import UsageError


@contextmanager
def _stop_on_ctrl_c():
    """First Ctrl-C asks the run to stop after the current point; a second one interrupts."""
    requested = {"stop": False}
    previous = signal.getsignal(signal.SIGINT)

    def handler(signum, frame):
        if requested["stop"]:
            raise KeyboardInterrupt
        requested["stop"] = True
        click.echo("\nstopping after the current point (Ctrl-C again to abort at once)", err=True)

    signal.signal(signal.SIGINT, handler)
    try:
        yield lambda: requested["stop"]
    finally:
        signal.signal(signal.SIGINT, previous)


def _print_plan(summary: dict, as_json: bool) -> None:
    if as_json:
        echo_json(summary)
        return
    click.echo(f"points           {summary['points']} in {summary['columns']} columns")
    if summary.get("tip_sweep_points"):
        click.echo(f"tip sweep        the last {summary['tip_sweep_points']} of them")
    click.echo(f"whisker frame    x {summary['whisker_x_mm'][0]:g}..{summary['whisker_x_mm'][1]:g} mm, "
               f"y {summary['whisker_y_mm'][0]:g}..{summary['whisker_y_mm'][1]:g} mm")
    click.echo(f"stage frame      x {summary['stage_x_mm'][0]:g}..{summary['stage_x_mm'][1]:g} mm, "
               f"y {summary['stage_y_mm'][0]:g}..{summary['stage_y_mm'][1]:g} mm")
    click.echo(f"path             {summary['path_length_mm']:.0f} mm in {summary['moves']} moves")
    click.echo(f"stage time       {summary['estimated_stage_time_s']:.0f} s (estimated, "
               "without the homing cycle)")
    click.echo(f"points time      {summary['estimated_points_time_s']:.0f} s (estimated, first "
               "point to last)")
    click.echo(f"limits           {'ok' if summary['limits_ok'] else 'VIOLATED'} "
               f"(travel {summary['travel_mm'][0]:g} x {summary['travel_mm'][1]:g} mm)")
    for problem in summary["problems"]:
        click.echo(f"  {problem}")


def _print_run(summary, as_json: bool) -> None:
    for warning in summary.warnings:
        click.echo(f"warning: {warning}", err=True)
    if as_json:
        echo_json(summary.to_dict())
        return
    drift = "n/a" if summary.baseline_drift_uT is None else f"{summary.baseline_drift_uT:.1f} µT"
    click.echo(f"points           {summary.points}/{summary.planned} "
               f"({'complete' if summary.complete else 'partial'})")
    click.echo(f"stage time       {summary.stage_time_s:.1f} s (wall {summary.wall_time_s:.1f} s)")
    if summary.points_time_s is not None:
        click.echo(f"points time      {summary.points_time_s:.1f} s (first point to last, "
                   "sensor clock)")
    click.echo(f"frames           {summary.dropped} dropped, {summary.corrupt} corrupt")
    click.echo(f"baseline drift   {drift}")
    click.echo(f"output           {summary.output}")


def _dry_run(plan, stage: str | None, as_json: bool) -> None:
    from whiskercal.collect.estimate import plan_summary
    from whiskercal.collect.run import read_stage_settings

    travel, accel, rate = None, None, None
    if stage:
        settings, travel = read_stage_settings(stage)
        accel = min(settings.get(120, 0), settings.get(121, 0)) or None
        rate = min(settings.get(110, 0), settings.get(111, 0)) or None
    summary = plan_summary(plan, travel, accel, rate)
    _print_plan(summary, as_json)
    if not summary["limits_ok"]:
        abort("the plan leaves the stage travel (see above)", UsageError.exit_code)


@click.command("collect")
@click.option("--stage", metavar="URL", help="Stage port: /dev/ttyUSB0 or sim://NAME/stage.")
@click.option("--sensor", metavar="URL", help="Sensor port: /dev/ttyUSB1 or sim://NAME/sensor.")
@click.option("--out", "out", type=click.Path(dir_okay=False), metavar="RAW.h5",
              help="The raw dataset to write (an existing one is refused: see --resume and "
                   "--force).")
@click.option("--config", "config_path", type=click.Path(dir_okay=False), metavar="FILE",
              help="TOML file overriding the defaults in whiskercal/collect/default_grid.toml.")
@click.option("--plan", "plan_name", default="full", show_default=True, metavar="NAME",
              help="The named plan: full (the paper's 180-point lattice and the 28-point tip "
                   "sweep) or quick (a coarser lattice, 5 tip-sweep points at the tip, a shorter "
                   "settle: about a minute of stage time, as accurate as full only where "
                   "bench --only calibration-time says so, docs/calibration.md). A --config "
                   "file's keys override the plan's.")
@click.option("--resume", is_flag=True,
              help="Continue the partial run in --out (same plan and config) without "
                   "re-taking or losing any point.")
@click.option("--dry-run", is_flag=True,
              help="Print the plan (points, ranges, path, estimated time, limit checks) and "
                   "move nothing; with --stage, only its settings are read.")
@click.option("--json", "as_json", is_flag=True, help="Print the summary as JSON.")
@click.option("--force", is_flag=True,
              help="Replace a finished dataset in --out (the new run's file is renamed over it "
                   "once its header is written); a partial run is continued with --resume, "
                   "never replaced.")
@pass_app
def command(app: App, stage, sensor, out, config_path, plan_name, resume, dry_run, as_json,
            force) -> None:
    """Collect the calibration grid: touch the whisker at every planned point.

    Homes the stage (or requires it homed), measures the static baseline with the rod parked,
    visits each grid point from +y, averages the sensor there and appends the point to RAW.h5
    at once; then measures the baseline again. Ctrl-C stops cleanly after the current point;
    a crash, kill or unplugged device loses nothing: continue with --resume. After a crash,
    lift the rod clear of the whisker before resuming: the homing cycle moves X first.
    """
    from whiskercal.collect.config import load_config
    from whiskercal.collect.plan import build_plan

    if out:
        refuse_input_as_output(out, [config_path], "the raw dataset")
    plan = build_plan(load_config(config_path, plan_name))
    if dry_run:
        _dry_run(plan, stage, as_json)
        return
    if not (stage and sensor and out):
        raise UsageError("collect needs --stage, --sensor and --out (or --dry-run)")
    from whiskercal.cli.progress import progress_bar
    from whiskercal.collect.run import collect

    with _stop_on_ctrl_c() as stop_requested, \
            progress_bar(app, "points", description="collect", as_json=as_json) as bar:
        summary = collect(stage, sensor, out, plan, resume=resume, force=force,
                          on_progress=bar.update if bar else None, stop_requested=stop_requested)
    _print_run(summary, as_json)
    for warning in summary.warnings:
        click.echo(f"warning: {warning}", err=True)
    if summary.stopped:
        click.echo(f"stopped: {summary.points} of {summary.planned} points saved in "
                   f"{summary.output}; continue with --resume", err=True)
        sys.exit(130)
