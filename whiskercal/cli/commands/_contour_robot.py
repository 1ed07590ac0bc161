"""``contour run --robot``: the options that drive a robot over rosbridge, and the run."""

from __future__ import annotations

import sys
from types import SimpleNamespace

import click

from whiskercal.cli.app import App, echo_json, given_options

ROBOT_ONLY = ("pose_topic", "tf_frames", "twist_topic", "twist_frame", "field_topic",
              "watchdog_ms", "dry_run", "max_speed", "max_turn", "box")


def robot_options(function):
    """The robot options of ``contour run``, outermost last."""
    options = [
        click.option("--robot", "robot_url", default=None, metavar="rosbridge://HOST:PORT",
                     help="Drive a robot through its rosbridge server instead of the twin "
                          "(docs/robot.md); `sim serve --robot` serves the twin's."),
        click.option("--pose-topic", default="/whiskercal/pose", show_default=True,
                     help="geometry_msgs/PoseStamped of the end effector."),
        click.option("--tf-frames", default=None, metavar="PARENT,CHILD",
                     help="Read the end effector's pose from TF instead: --pose-topic is then "
                          "a tf2_msgs/TFMessage topic (e.g. /tf) carrying PARENT -> CHILD "
                          "directly (e.g. base_link,tool0)."),
        click.option("--twist-topic", default="/whiskercal/twist", show_default=True,
                     help="geometry_msgs/TwistStamped the robot's Cartesian controller obeys."),
        click.option("--twist-frame", default=None,
                     help="frame_id stamped on the twists, which are expressed in the pose "
                          "topic's frame [default: the poses' frame_id]."),
        click.option("--field-topic", default="/whiskercal/field", show_default=True,
                     help="sensor_msgs/MagneticField of the sensor (ignored with --sensor PORT)."),
        click.option("--mount", "mount_path", type=click.Path(dir_okay=False), default=None,
                     help="TOML [mount] table: the sensor's base frame on the end effector "
                          "[default: the end effector is the base frame]; on the twin, the "
                          "nominal mount the loop drives through (see --mount-error)."),
        click.option("--watchdog-ms", type=float, default=200.0, show_default=True,
                     help="No pose or no sample for this long: a zero twist and the run stops."),
        click.option("--dry-run", is_flag=True,
                     help="Print each twist instead of sending it (the robot never moves)."),
        click.option("--max-speed", type=float, default=20.0, show_default=True,
                     help="The end effector's speed limit, mm/s (commands are scaled down to it)."),
        click.option("--max-turn", type=float, default=0.5, show_default=True,
                     help="The end effector's turn-rate limit, rad/s (commands are clipped)."),
        click.option("--box", default=None, metavar="X_MIN,X_MAX,Y_MIN,Y_MAX",
                     help="Workspace box of the end effector in the pose topic's frame, mm: "
                          "leaving it stops the run [default: none]."),
    ]
    for option in reversed(options):
        function = option(function)
    return function


def refuse_robot_options(shape, robot: dict) -> None:
    """On the twin: --shape is needed, and a robot option given without --robot is a mistake
    (given at its default value too: ``given_options``)."""
    from whiskercal.errors import UsageError

    given = given_options(ROBOT_ONLY)
    if given:
        raise UsageError(f"{given[0]} drives a robot: give --robot too")
    if shape is None:
        raise UsageError("give --shape (the twin's object), or --robot rosbridge://HOST:PORT")


def run_on_robot(app: App, artifact, sensor_port, config_path, target_uT, speed_mm_s, duration_s,
                 out, as_json, *, shape, mu_static, mu_kinetic, seed, record, robot_url,
                 **robot) -> None:
    """The run on the robot; its summary; a stopped run ends non-zero after its file (and its
    bag, with ``record`` = (PATH, force)) is written."""
    from whiskercal.cli.progress import progress_bar
    from whiskercal.contour.on_robot import contour_on_robot, summarize_robot_run
    from whiskercal.errors import UsageError

    if shape is not None or mu_static is not None or mu_kinetic or seed:
        raise UsageError("--shape, --mu-static, --mu-kinetic and --seed are the twin's: a robot "
                         "follows what is in front of it")
    setup = robot_setup(robot_url, sensor_port, robot)
    config = _follow_config(config_path, speed_mm_s)
    echo = (lambda line: click.echo(line, err=True)) if as_json else click.echo
    with progress_bar(app, "s", description="contour on the robot", as_json=as_json) as bar:
        def shown(t_s: float) -> None:
            bar.update(SimpleNamespace(done=int(t_s), total=int(duration_s), taken_now=int(t_s)))

        try:
            run = contour_on_robot(setup, artifact, out, duration_s=duration_s,
                                   loop_config=config, target_z_uT=target_uT, echo=echo,
                                   on_progress=shown if bar else None, record=record[0],
                                   force=record[1])
        except KeyboardInterrupt:
            click.echo(f"stopped: the robot was sent a zero twist; the partial run is in {out}",
                       err=True)
            sys.exit(130)
    print_summary(summarize_robot_run(run), as_json)
    if record[0] is not None and not as_json:
        print_replay_hint(record[0], *run.config["robot"]["rest_uT"])


def print_replay_hint(bag, rest_y_uT: float, rest_z_uT: float) -> None:
    """How to replay a recorded bag: its rest reading, and its poses."""
    click.echo(f"recorded {bag} (replay it with --rest-uT {rest_y_uT:.3f} "
               f"--axial-rest-uT {rest_z_uT:.3f} --poses auto)")


def _follow_config(config_path, speed_mm_s):
    import dataclasses

    from whiskercal.checks import positive
    from whiskercal.follow import load_follow_config

    config = load_follow_config(config_path)
    if speed_mm_s is None:
        return config
    return config.replace(total_speed_mm_s=positive(speed_mm_s, "--speed", unit="mm/s"))


def robot_setup(robot_url: str, sensor_port, robot: dict):
    """The checked ``RobotSetup`` of the command's options."""
    from whiskercal.contour.on_robot import RobotSetup
    from whiskercal.mount import Mount, read_mount
    from whiskercal.robot import RobotTopics, Safety, parse_url
    from whiskercal.robot.safety import parse_box

    from whiskercal.checks import positive

    parse_url(robot_url)
    positive(robot["watchdog_ms"], "--watchdog-ms", unit="ms")
    safety = Safety(speed_mm_s=robot["max_speed"], turn_rad_s=robot["max_turn"],
                    box_mm=parse_box(robot["box"]), watchdog_s=robot["watchdog_ms"] / 1e3)
    topics = RobotTopics(pose=robot["pose_topic"], tf_frames=_frames(robot["tf_frames"]),
                         twist=robot["twist_topic"],
                         twist_frame=robot["twist_frame"],
                         field=None if sensor_port else robot["field_topic"])
    mount = read_mount(robot["mount_path"]) if robot["mount_path"] else Mount()
    return RobotSetup(robot_url, topics, mount, safety, robot["dry_run"], sensor_port)


def _frames(text: str | None) -> tuple[str, str] | None:
    from whiskercal.errors import UsageError

    if text is None:
        return None
    parts = [part.strip() for part in text.split(",")]
    if len(parts) != 2 or not all(parts):
        raise UsageError(f"--tf-frames must be PARENT,CHILD (e.g. base_link,tool0), not {text!r}")
    return parts[0], parts[1]


def print_summary(summary: dict, as_json: bool) -> None:
    """A run's summary: JSON, or one key and value a line."""
    if as_json:
        echo_json(summary)
        return
    for key, value in summary.items():
        click.echo(f"{key:22s} {value:.4g}" if isinstance(value, float) else f"{key:22s} {value}")
