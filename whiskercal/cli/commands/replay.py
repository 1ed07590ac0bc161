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


def _frames(text: str | None) -> tuple[str, str] | None:
    if text is None:
        return None
    parts = [part.strip().lstrip("/") for part in text.split(",")]
    if len(parts) != 2 or not all(parts):
        from whiskercal.errors import UsageError

        raise UsageError(f"--pose-frames must be PARENT,CHILD (two frame names), not {text!r}")
    return parts[0], parts[1]


_STREAM_OPTIONS = [
    click.option("--time-column", default=None, help="Time column of a table with a header "
                 "[default: the first of t_s, time_s, time, t, timestamp]."),
    click.option("--field-column", default=None, help="Y-field column of a table with a header "
                 "[default: the first of y_uT, field_y_uT, magnetic_y, y, by; case-insensitive]."),
    click.option("--axial-column", default=None, help="Z-field column of a table with a header "
                 "('none': Y alone) [default: the first of z_uT, field_z_uT, magnetic_z, z, bz, "
                 "where the header has one]."),
    click.option("--columns", default=None, help="A table's columns by position: t,y or t,x,y,z "
                 "(_ skips one) [default for a table without a header: t,y for two columns, "
                 "t,x,y,z for four]."),
    click.option("--delimiter", default=None, help="comma, tab, semicolon, space or one "
                 "character [default: detected from the first line]."),
    click.option("--time-unit", type=click.Choice(["s", "ms", "us", "ns"]), default="s",
                 show_default=True, help="Unit of a table's time column."),
    click.option("--field-unit", type=click.Choice(["T", "mT", "uT", "nT", "G"]), default=None,
                 help="Unit of the field [default: tesla in a sensor_msgs/MagneticField message, "
                 "µT elsewhere]."),
    click.option("--field-topic", default=None, help="A bag's field topic [default: its one "
                 "sensor_msgs/msg/MagneticField topic]."),
    click.option("--rate-hz", type=float, default=300.0, show_default=True,
                 help="The sensor's sample rate; a stream whose time stamps imply a rate 20 times "
                 "off is refused (a time unit read wrong)."),
]
_POSE_OPTIONS = [
    click.option("--poses", default=None, metavar="TOPIC_OR_FILE", help="The robot's poses: a "
                 "topic of the bag, 'auto' (its one pose topic), or a file (a bag, an echo log of "
                 "poses, a table t_s,x_mm,y_mm,heading_rad). Adds the world frame."),
    click.option("--pose-frames", default=None, metavar="PARENT,CHILD",
                 help="The transform of a /tf topic to take as the poses."),
    click.option("--mount", "mount_path", type=click.Path(dir_okay=False), default=None,
                 help="TOML [mount] table: the sensor's base frame on the end effector "
                 "(x_mm, y_mm, yaw_deg) [default: the poses are the sensor's base frame]."),
    click.option("--max-pose-gap-ms", type=float, default=100.0, show_default=True,
                 help="A sample farther than this from every pose gets no world point."),
    click.option("--pose-latency-ms", default="0", show_default=True, metavar="MS|auto",
                 help="A pose stamped t describes the robot at t minus this; auto: the latency "
                 "that places the contacts the smoothest, estimated from the data "
                 "(docs/error-budget.md)."),
]
_REST_OPTIONS = [
    click.option("--rest", type=click.Choice(["auto", "recorded"]), default=None,
                 help="Static reading: the median of the first --rest-samples samples (auto) or "
                 "the one a whiskercal HDF5 file recorded [default: recorded when the file has "
                 "one, else auto]."),
    click.option("--rest-uT", "rest_uT", type=float, default=None,
                 help="Static Y reading of this session, µT (z = reading - rest)."),
    click.option("--axial-rest-uT", "axial_rest_uT", type=float, default=None,
                 help="Static Z reading of this session, µT [default: as --rest]."),
    click.option("--rest-samples", type=click.IntRange(min=1), default=100, show_default=True,
                 help="Samples at the start, free of contact, whose median is --rest auto."),
    click.option("--sign", type=click.Choice(["1", "-1"]), default="1", show_default=True,
                 help="-1 for a sensor mounted so that Y moves the other way from the "
                 "calibration's."),
    click.option("--axial-sign", type=click.Choice(["1", "-1"]), default="1", show_default=True,
                 help="The same for the Z axis."),
]


def _options(options):
    def decorate(function):
        for option in reversed(options):
            function = option(function)
        return function
    return decorate


@click.command("replay")
@click.argument("log", type=click.Path())
@click.option("--artifact", required=True, type=click.Path(dir_okay=False),
              help="Calibration artifact (HDF5) to replay the stream through.")
@click.option("--out", "out_dir", required=True, type=click.Path(file_okay=False),
              help="Folder for track.csv, track.h5, replay.png and summary.json (with poses also "
              "world.png and the ROS 2 bag rosbag/).")
@_options(_STREAM_OPTIONS)
@_options(_POSE_OPTIONS)
@_options(_REST_OPTIONS)
@click.option("--out-of-range", type=click.Choice(["clip", "nan", "raise"]), default="clip",
              show_default=True, help="z outside the calibrated range in contact: the edge tip "
              "(flagged), no tip (flagged), or stop with an error.")
@click.option("--allow-extrapolated", is_flag=True,
              help="Answer z in a range the artifact marks as extrapolated (flagged).")
@click.option("--json", "as_json", is_flag=True, help="Print the summary as JSON.")
@force_option
@pass_app
def command(app: App, log: str, artifact: str, out_dir: str, as_json: bool, **settings) -> None:
    """Replay LOG through the calibration's tracker: collision detection, tip lookup and Kalman
    filter, sample by sample. LOG is a ROS bag (a rosbag2 folder, MCAP or sqlite3, or a ROS 1
    .bag), a rostopic echo log, a CSV/TSV table with or without a header, or a whiskercal
    raw-grid / plane-study HDF5 file (docs/recordings.md).

    z = sign x (Y reading - rest); with three axes the Z axis too, read through the artifact's
    (Y, Z) table. The reading at rest differs between sessions by hundreds of µT: give it with
    --rest-uT, or let --rest auto take the median of the stream's first samples
    (docs/replay.md). With --poses (and --mount) the contacts are placed in the world frame.
    """
    from whiskercal import runtime
    from whiskercal.atomic import refuse_existing
    from whiskercal.recording import regular_file
    from whiskercal.replay.output import output_paths, refuse_inputs_as_outputs

    started = time.perf_counter()
    options = _replay_options(settings)
    refuse_inputs_as_outputs(out_dir, [log, artifact])
    refuse_existing(output_paths(out_dir).values(), settings.pop("force"), "the replay output")
    calibration = runtime.load(regular_file(artifact, "the artifact"),
                               allow_extrapolated=settings["allow_extrapolated"])
    stream = _read_stream(log, settings)
    world = _world(log, settings)
    _replay_and_write(log, artifact, out_dir, stream, calibration, options, world, started,
                      as_json)


def _replay_options(settings: dict):
    from whiskercal.replay import ReplayOptions

    return ReplayOptions(rest=_rest(settings["rest"], settings["rest_uT"]),
                         rest_samples=settings["rest_samples"], sign=int(settings["sign"]),
                         out_of_range=settings["out_of_range"],
                         axial_rest=settings["axial_rest_uT"],
                         axial_sign=int(settings["axial_sign"]))


def _read_stream(log: str, settings: dict):
    from whiskercal.checks import positive
    from whiskercal.recording import RecordingOptions, TableOptions, check_rate
    from whiskercal.replay import read_stream

    rate_hz = positive(settings["rate_hz"], "--rate-hz", high=1e6, unit="Hz")
    table = TableOptions(settings["time_column"], settings["field_column"],
                         settings["axial_column"], settings["columns"], settings["delimiter"],
                         settings["time_unit"])
    stream = read_stream(log, options=RecordingOptions(table, settings["field_topic"],
                                                       settings["field_unit"]))
    check_rate(stream.t_s, rate_hz, stream.source, " (a table's --time-unit)")
    return stream


def _world(log: str, settings: dict):
    from whiskercal.checks import number
    from whiskercal.errors import UsageError
    from whiskercal.mount import Mount, read_mount
    from whiskercal.recording import read_poses, regular_file
    from whiskercal.replay import WorldFrame

    if settings["poses"] is None:
        for name in ("pose_frames", "mount_path"):
            if settings[name] is not None:
                raise UsageError(f"--{name.replace('_path', '').replace('_', '-')} needs --poses")
        return None
    gap_ms = number(settings["max_pose_gap_ms"], "--max-pose-gap-ms", low=0.0, low_open=True,
                    high=60_000.0, unit="ms")
    latency = settings["pose_latency_ms"]
    latency_ms = None if latency == "auto" else number(
        _as_float(latency, "--pose-latency-ms"), "--pose-latency-ms", low=-60_000.0,
        high=60_000.0, unit="ms")
    mount_path = settings["mount_path"]
    mount = read_mount(regular_file(mount_path, "the mount file")) if mount_path else Mount()
    poses = read_poses(settings["poses"], log, _frames(settings["pose_frames"]))
    return WorldFrame(poses, mount, gap_ms * 1e-3, None if latency_ms is None else latency_ms * 1e-3,
                      mount_path or "none (the poses are the sensor's base frame)")


def _as_float(text: str, option: str) -> float:
    """An option's number, or its one-line refusal."""
    from whiskercal.errors import UsageError

    try:
        return float(text)
    except ValueError:
        raise UsageError(f"{option} must be a number of ms or auto, not {text!r}") from None


def _replay_and_write(log, artifact, out_dir, stream, calibration, options, world, started,
                      as_json) -> None:
    from pathlib import Path

    from whiskercal.artifacts.h5io import sha256_file
    from whiskercal.replay import replay, write_all

    result = replay(stream, calibration, options, world)
    summary = {"log": log, "artifact": artifact, **result.summary()}
    summary["elapsed_s"] = time.perf_counter() - started
    inputs = {"artifact": sha256_file(artifact)}
    if Path(log).is_file():
        inputs["log"] = sha256_file(log)
    paths = write_all(out_dir, result, summary, calibration.sensor_id, inputs, stream.field_uT)
    summary["files"] = {key: path.name for key, path in paths.items()}
    _report(summary, out_dir, as_json)


def _report(summary: dict, out_dir: str, as_json: bool) -> None:
    if as_json:
        echo_json(summary)
        return
    low, high = summary["calibrated_z_range_uT"]
    files = ", ".join(summary.get("files", {}).values()) or "track.csv, track.h5, replay.png"
    click.echo(f"wrote     {out_dir}/ ({files})")
    axes = "Y alone" if summary["axes"] == 1 else "X, Y, Z"
    click.echo(f"samples   {summary['samples']} over {summary['duration_s']:.2f} s, "
               f"{axes}, rest {summary['rest_uT']:.1f} µT "
               f"({summary['rest_source']})")
    click.echo(f"contact   {summary['contact_samples']} samples: {summary['in_range']} in range "
               f"[{low:.0f}, {high:.0f}] µT, {summary['out_of_range']} out of range "
               f"({summary['out_of_range_below']} below, {summary['out_of_range_above']} above; "
               f"{summary['out_of_range_policy']})")
    world = summary["world"]
    if world:
        click.echo(f"world     {world['world_points']} contact points; "
                   f"{world['samples_without_pose']} samples farther than "
                   f"{world['max_pose_gap_ms']:g} ms from a pose")
    click.echo(f"cost      {summary['per_sample_us']:.1f} µs per sample")
    for warning in summary["warnings"]:
        click.echo(f"warning   {warning}", err=True)
