"""``whiskercal contour``: the paper's contour following on the twin, and its report."""

from __future__ import annotations

import sys
from types import SimpleNamespace

import click

from whiskercal.cli.app import App, echo_json, pass_app


@click.group("contour")
def command() -> None:
    """Follow an object's contour with the calibrated whisker (the paper's closed loop) on the
    digital twin, and measure the reconstruction against the object's true outline."""


@command.command("run")
@click.option("--shape", required=True, metavar="SHAPE",
              help="The object: cylinder (Ø160 mm), rounded-rect (a 160 mm square prism with "
                   "40 mm corners), octagon (70 mm sides, 30 mm corners); or an open scene: wall "
                   "(a 20 mm step and a 90° concave corner), corner:deg=N (a wall into a concave "
                   "corner opening N°, 60-120, and out along a second wall), step:mm=H (a wall "
                   "with a step of H mm, 4-40).")
@click.option("--artifact", type=click.Path(dir_okay=False), required=True,
              help="Calibration artifact (CAL.h5) of the twin's sensor, with a target; one from "
                   "a (Y, Z) table (written by `fit` by default) places the contacts from the Y and Z "
                   "axes (docs/contour.md).")
@click.option("--sensor", "sensor_name", default=None, metavar="ID_OR_PATH",
              help="The twin's sensor build: a shipped id or a .toml file [default: the default sensor].")
@click.option("--config", "config_path", type=click.Path(dir_okay=False), default=None,
              help="TOML file whose [follow] table overrides the controller's constants.")
@click.option("--target-uT", "target_uT", type=float, default=None,
              help="Deflection target, µT [default: the artifact's].")
@click.option("--speed", "speed_mm_s", type=float, default=None,
              help="Total speed (tangential and normal), mm/s [default: 8].")
@click.option("--duration", "duration_s", type=float, default=120.0, show_default=True,
              help="Robot time to run, s.")
@click.option("--mu-static", "mu_static", type=float, default=None,
              help="Static friction at the tip: Coulomb stick-slip on the object (the plane "
                   "study's model), sliding at --mu-kinetic; at least --mu-kinetic; not on the "
                   "wall [default: none].")
@click.option("--mu-kinetic", "mu_kinetic", type=float, default=0.0, show_default=True,
              help="Kinetic friction at the tip while it slides; alone (no --mu-static), "
                   "static friction equal to it (no stick-slip); 0: frictionless.")
@click.option("--seed", type=int, default=0, show_default=True,
              help="Seeds the start pose and the magnetometer noise.")
@click.option("--out", type=click.Path(dir_okay=False), required=True, help="The run file (HDF5).")
@click.option("--json", "as_json", is_flag=True, help="Print the run's summary as JSON.")
@pass_app
def run_command(app: App, shape, artifact, sensor_name, config_path, target_uT, speed_mm_s,
                duration_s, mu_static, mu_kinetic, seed, out, as_json) -> None:
    """Run the loop around SHAPE and record every sample (Ctrl-C keeps a readable partial run)."""
    from whiskercal.atomic import refuse_input_as_output
    from whiskercal.cli.progress import progress_bar
    from whiskercal.contour import contour_to_file, summarize
    from whiskercal.follow import load_follow_config
    from whiskercal.twin.sensor_file import resolve_sensor

    from whiskercal.twin.outlines import outline

    outline(shape)  # an unknown shape or a parameter out of range: one line, before any work
    refuse_input_as_output(out, [artifact] + ([config_path] if config_path else []), "the run")
    sensor = resolve_sensor(sensor_name) if sensor_name else None
    with progress_bar(app, "s", description=f"contour {shape}", as_json=as_json) as bar:
        def shown(t_s: float) -> None:
            bar.update(SimpleNamespace(done=int(t_s), total=int(duration_s), taken_now=int(t_s)))

        record = contour_to_file(shape, artifact, out, sensor=sensor, target_z_uT=target_uT,
                                 config=load_follow_config(config_path), speed_mm_s=speed_mm_s,
                                 duration_s=duration_s, seed=seed, mu_kinetic=mu_kinetic,
                                 mu_static=mu_static,
                                 on_progress=shown if bar else None)
    _print(summarize(record), as_json)
    if not record.complete:
        click.echo(f"stopped: the partial run is in {out}", err=True)
        sys.exit(130)


@command.command("report")
@click.argument("run_path", type=click.Path(dir_okay=False))
@click.option("--out", "out_dir", type=click.Path(file_okay=False), required=True,
              help="Directory for contour.png, contour.html and contour.json.")
@click.option("--json", "as_json", is_flag=True, help="Print the summary as JSON.")
def report_command(run_path, out_dir, as_json) -> None:
    """Measure a run against the object's true outline, in the world frame, without alignment."""
    from whiskercal.contour import read_contour_run
    from whiskercal.report.contour import write_report

    _print(write_report(read_contour_run(run_path), out_dir), as_json)


def _print(summary: dict, as_json: bool) -> None:
    if as_json:
        echo_json(summary)
        return
    for key, value in summary.items():
        click.echo(f"{key:22s} {value:.4g}" if isinstance(value, float) else f"{key:22s} {value}")
