"""``whiskercal contour``: the paper's contour following on the twin, and its report."""

from __future__ import annotations

import sys
from types import SimpleNamespace

import click

from whiskercal.cli.app import App, echo_json, force_option, pass_app
from whiskercal.cli.commands._contour_robot import (print_replay_hint, print_summary,
                                                   refuse_robot_options, robot_options,
                                                   run_on_robot)
from whiskercal.errors import UsageError


@click.group("contour")
def command() -> None:
    """Follow an object's contour with the calibrated whisker (the paper's closed loop) on the
    digital twin, or on a robot over rosbridge, and measure the reconstruction against the
    object's true outline."""


@command.command("run")
@click.option("--shape", default=None, metavar="SHAPE",
              help="The twin's object: cylinder (Ø160 mm), rounded-rect (a 160 mm square prism "
                   "with 40 mm corners), octagon (70 mm sides, 30 mm corners); or an open scene: "
                   "wall (a 20 mm step and a 90° concave corner), corner:deg=N (a wall into a "
                   "concave corner opening N°, 60-120, and out along a second wall), step:mm=H (a "
                   "wall with a step of H mm, 4-40). Required without --robot.")
@click.option("--artifact", type=click.Path(dir_okay=False), required=True,
              help="Calibration artifact (CAL.h5) of the twin's sensor, with a target; one from "
                   "a (Y, Z) table (written by `fit` by default) places the contacts from the Y and Z "
                   "axes (docs/contour.md).")
@click.option("--sensor", "sensor_name", default=None, metavar="ID_OR_PATH",
              help="The twin's sensor build: a shipped id or a .toml file [default: the default "
                   "sensor]; with --robot, the sensor board's serial port (e.g. /dev/ttyUSB1) "
                   "instead of --field-topic.")
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
@click.option("--nuisances", "nuisances_name", default=None, metavar="LEVEL",
              help="What a real rig adds (docs/error-budget.md): off, realistic (every nuisance "
                   "at its realistic level), realistic:NAME (drift, viscoelastic, contact or "
                   "robot alone) or a .toml file with a [nuisances] table [default: the --sensor "
                   "file's [nuisances] table, else off].")
@click.option("--rezero", is_flag=True,
              help="The tracker re-zeroes its rest whenever it is out of contact (drift); the "
                   "run starts out of contact.")
@click.option("--out", type=click.Path(dir_okay=False), required=True, help="The run file (HDF5).")
@click.option("--record", "record_path", type=click.Path(), default=None,
              help="Also write the magnetometer's stream and the sensor base's poses as a ROS 2 "
                   "bag (a folder: metadata.yaml and NAME.mcap) for `whiskercal replay` or "
                   "Foxglove, on the twin or (as the samples arrive) on a robot; the rest "
                   "reading to replay it with is in the run's config.")
@click.option("--mount-error", default=None, metavar="DX,DY,DEG",
              help="The twin's sensor truly sits off the nominal --mount by DX, DY mm and DEG "
                   "degrees (a real mount is never where its drawing says) [default: 0,0,0].")
@click.option("--json", "as_json", is_flag=True, help="Print the run's summary as JSON.")
@robot_options
@force_option
@pass_app
def run_command(app: App, shape, artifact, sensor_name, config_path, target_uT, speed_mm_s,
                duration_s, mu_static, mu_kinetic, seed, nuisances_name, rezero, out, record_path,
                mount_error, as_json, force, **robot) -> None:
    """Run the loop around SHAPE on the twin, or on a robot with --robot, and record every
    sample (Ctrl-C keeps a readable partial run)."""
    from whiskercal.atomic import refuse_existing, refuse_input_as_output
    from whiskercal.checks import seed as check_seed
    from whiskercal.cli.progress import progress_bar
    from whiskercal.contour import contour_to_file, summarize
    from whiskercal.contour.record import refuse_existing as refuse_existing_bag
    from whiskercal.follow import load_follow_config
    from whiskercal.twin.outlines import outline
    from whiskercal.twin.sensor_file import resolve_sensor

    refuse_input_as_output(out, [artifact] + ([config_path] if config_path else []), "the run")
    refuse_existing([out], force, "the run")
    refuse_existing_bag(record_path, force)
    check_seed(seed)
    if robot["robot_url"] is not None:
        if mount_error is not None:
            raise UsageError("--mount-error places the twin's sensor; a robot's mount is off by "
                             "what it is off by (`whiskercal mount-cal` measures it)")
        if nuisances_name is not None or rezero:
            raise UsageError("--nuisances and --rezero are the twin's: a robot brings its own")
        return run_on_robot(app, artifact, sensor_name, config_path, target_uT, speed_mm_s,
                            duration_s, out, as_json, shape=shape, mu_static=mu_static,
                            mu_kinetic=mu_kinetic, seed=seed, record=(record_path, force),
                            **robot)
    refuse_robot_options(shape, robot)
    outline(shape)  # an unknown shape or a parameter out of range: one line, before any work
    sensor = resolve_sensor(sensor_name) if sensor_name else None
    nuisances = _nuisances(nuisances_name, sensor_name)
    with progress_bar(app, "s", description=f"contour {shape}", as_json=as_json) as bar:
        def shown(t_s: float) -> None:
            bar.update(SimpleNamespace(done=int(t_s), total=int(duration_s), taken_now=int(t_s)))

        record = contour_to_file(shape, artifact, out, sensor=sensor, target_z_uT=target_uT,
                                 config=load_follow_config(config_path), speed_mm_s=speed_mm_s,
                                 duration_s=duration_s, seed=seed, mu_kinetic=mu_kinetic,
                                 mu_static=mu_static, record=record_path, force=force,
                                 mount=_twin_mount(robot["mount_path"], mount_error),
                                 nuisances=nuisances, rezero=rezero,
                                 on_progress=shown if bar else None)
    summary = summarize(record)
    if record_path is not None:
        summary["record"] = record.config["record"]["bag"]
    print_summary(summary, as_json)
    if record_path is not None and not as_json:
        rest = record.config["record"]["rest_field_uT"]
        print_replay_hint(record_path, rest[1], rest[2])
    if not record.complete:
        click.echo(f"stopped: the partial run is in {out}", err=True)
        sys.exit(130)


def _twin_mount(mount_path, mount_error):
    """(nominal mount, its error) for the twin, or None for neither."""
    from whiskercal.mount import Mount, parse_mount_error, read_mount

    if mount_path is None and mount_error is None:
        return None
    nominal = read_mount(mount_path) if mount_path else Mount()
    return nominal, parse_mount_error(mount_error or "0,0,0")


def _nuisances(name: str | None, sensor_name: str | None):
    """The run's nuisances: as named, else a sensor file's [nuisances] table, else off."""
    from whiskercal.twin.nuisances import load_nuisances, nuisances_named

    if name is None and sensor_name is not None and sensor_name.lower().endswith(".toml"):
        return load_nuisances(sensor_name)
    return nuisances_named(name)


@command.command("report")
@click.argument("run_path", type=click.Path(dir_okay=False))
@click.option("--out", "out_dir", type=click.Path(file_okay=False), required=True,
              help="Directory for contour.png, contour.html and contour.json.")
@click.option("--json", "as_json", is_flag=True, help="Print the summary as JSON.")
@force_option
def report_command(run_path, out_dir, as_json, force) -> None:
    """Measure a run against the object's true outline, in the world frame, without alignment."""
    from whiskercal.atomic import refuse_existing, refuse_input_as_output
    from whiskercal.contour import read_contour_run
    from whiskercal.report.contour import report_paths, write_report

    for output in report_paths(out_dir):
        refuse_input_as_output(output, [run_path])
    refuse_existing(report_paths(out_dir), force)
    print_summary(write_report(read_contour_run(run_path), out_dir), as_json)


@command.command("evaluate")
@click.argument("points_path", metavar="POINTS", type=click.Path(dir_okay=False))
@click.option("--outline", "spec", required=True, metavar="SPEC",
              help="The object: circle:d=D, rounded-rect:w=W,h=H,r=R, polygon:n=N,side=S,r=R "
                   "(a regular polygon, sides S long before their corners are rounded to R) or "
                   "polyline:FILE (x y per line); mm, centred at the origin (docs/evaluate.md).")
@click.option("--units", type=click.Choice(["mm", "m"]), default=None,
              help="Units of a table's x, y columns [default: mm; columns named *_mm, replay "
                   "tracks and contour runs are always mm].")
@click.option("--pose", "pose_text", default=None, metavar="X,Y,DEG",
              help="Where the outline's centre lies among the points (mm, mm, degrees): the pose "
                   "under --fit none [default: 0,0,0], a fit's start otherwise.")
@click.option("--fit", type=click.Choice(["none", "rigid", "similarity"]), default="rigid",
              show_default=True,
              help="none: the outline at --pose; rigid: its x, y and turn fitted; similarity: a "
                   "free scale too (the paper's metric), shown beside the rigid figures.")
@click.option("--out", "out_dir", type=click.Path(file_okay=False), default=None,
              help="Directory for evaluation.json and evaluation.png.")
@click.option("--json", "as_json", is_flag=True, help="Print the evaluation as JSON.")
def evaluate_command(points_path, spec, units, pose_text, fit, out_dir, as_json) -> None:
    """Measure the points of POINTS (a table of x, y, a replay's track or a contour run) against
    an outline: each point's distance to the continuous outline, and how much of it they cover."""
    from pathlib import Path

    from whiskercal.atomic import refuse_input_as_output
    from whiskercal.contour.evaluate import FILES, evaluate, parse_pose, write_evaluation
    from whiskercal.contour.outline_spec import parse_outline
    from whiskercal.contour.points import read_points

    outline = parse_outline(spec)
    for name in FILES.values() if out_dir is not None else ():
        refuse_input_as_output(Path(out_dir) / name, [points_path, outline.source], "the evaluation")
    pose = parse_pose(pose_text)
    evaluation = evaluate(read_points(points_path, units), outline, fit, pose)
    if out_dir is not None:
        write_evaluation(out_dir, evaluation)
    if as_json:
        echo_json(evaluation.summary)
        return
    for line in evaluation_lines(evaluation.summary):
        click.echo(line)


def evaluation_lines(summary: dict) -> list[str]:
    """The evaluation as a table: one column per placement (the given or rigid one, and the
    similarity one labelled as the paper's metric)."""
    names = [name for name in ("none", "rigid", "similarity") if name in summary]
    outline = summary["outline"]
    lines = [f"points    {summary['points']} ({summary['source']}; {summary['skipped']} without a point)",
             f"outline   {outline['spec']} ({'closed' if outline['closed'] else 'open'}, "
             f"{outline['length_mm']:.1f} mm)",
             f"{'':10s}" + "".join(f"{_heading(name):>16s}" for name in names)]
    rows = [("x_mm", "pose"), ("y_mm", "pose"), ("deg", "pose"), ("scale", "pose"),
            ("mean_mm", None), ("std_mm", None), ("median_mm", None), ("p95_mm", None),
            ("max_mm", None), ("coverage", None)]
    for key, group in rows:
        values = [(summary[name][group] if group else summary[name])[key] for name in names]
        lines.append(f"{key:10s}" + "".join(f"{value:16.4g}" for value in values))
    if "similarity" in summary:
        lines.append(f"similarity: {summary['similarity']['metric']}")
    return lines


def _heading(name: str) -> str:
    return {"none": "given pose", "rigid": "rigid", "similarity": "similarity*"}[name]
