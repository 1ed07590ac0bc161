"""``whiskercal mount-cal``: where the sensor really sits on the robot, from touches on a known
cylinder."""

from __future__ import annotations

import click

from whiskercal.cli.app import echo_json, force_option
from whiskercal.cli.commands._contour_robot import refuse_robot_options, robot_options, robot_setup


@click.command("mount-cal")
@click.option("--artifact", type=click.Path(dir_okay=False), required=True,
              help="Calibration artifact (CAL.h5) of the sensor on the robot, with a target: the "
                   "presses hold fractions of its deflection target.")
@click.option("--object", "object_spec", default="circle:d=160", show_default=True,
              metavar="circle:d=D",
              help="The known cylinder, diameter in mm (the twin's is circle:d=160 at 0,0).")
@click.option("--object-pose", default=None, metavar="X,Y",
              help="The cylinder's centre in the robot's world frame (the pose topic's), mm "
                   "[default: 0,0].")
@click.option("--side", "side_deg", type=float, default=180.0, show_default=True,
              help="Direction from the cylinder's centre toward where the robot presses from, "
                   "deg from the world's +x axis: the stations centre on it.")
@click.option("--arc", "arc_deg", type=float, default=120.0, show_default=True,
              help="How far round the cylinder the stations spread, deg (360: all round).")
@click.option("--stations", type=int, default=4, show_default=True,
              help="Stations along the arc; each presses at three tilts and three depths.")
@click.option("--target-uT", "target_uT", type=float, default=None,
              help="The deflection the depths are fractions of, µT [default: the artifact's target].")
@click.option("--out", type=click.Path(dir_okay=False), required=True,
              help="The fitted mount file (TOML [mount]) for replay, contour evaluate and "
                   "contour run --robot --mount.")
@click.option("--track", "track_path", type=click.Path(dir_okay=False), default=None,
              help="Fit the held touches of a replay track instead of pressing (a recording "
                   "replayed with --poses and no --mount; --artifact the one it was replayed with).")
@click.option("--json", "as_json", is_flag=True, help="Print the fit (and on the twin its error) as JSON.")
@robot_options
@force_option
def command(artifact, object_spec, object_pose, side_deg, arc_deg, stations, target_uT, out,
            track_path, as_json, force, robot_url, mount_path, **robot) -> None:
    """Press the whisker on a cylinder of known size and place at a few poses and fit the
    sensor's mount on the end effector (x, y, yaw with their uncertainty) to the tips.

    --robot sim://cylinder[?mount_error=DX,DY,DEG&seed=N&rate_hz=R] (the default) is the twin
    in process, its sensor truly off the nominal --mount by DX, DY mm and DEG degrees;
    --robot rosbridge://HOST:PORT drives a robot as `contour run --robot` does (its topics,
    limits and watchdog; a zero twist on every way out). docs/mount-cal.md.
    """
    from whiskercal.atomic import refuse_existing, refuse_input_as_output
    from whiskercal.checks import number
    from whiskercal.mount import Mount, read_mount
    from whiskercal.errors import UsageError
    from whiskercal.mountcal import (TWIN_URL, Routine, mount_cal, mount_cal_recorded,
                                     parse_cylinder, write_result)

    refuse_input_as_output(out, [artifact, mount_path, track_path], "the mount")
    refuse_existing([out], force, "the mount")
    cylinder = parse_cylinder(object_spec, object_pose)
    nominal = read_mount(mount_path) if mount_path else Mount()
    target = None if target_uT is None else number(target_uT, "--target-uT", high=0.0, unit="µT")
    routine = Routine(cylinder, nominal, number(side_deg, "--side", low=-360.0, high=360.0),
                      arc_deg, stations, target)
    url = robot_url or TWIN_URL
    if track_path is not None:
        if robot_url is not None:
            raise UsageError("--track fits a recording: leave out --robot")
        result = mount_cal_recorded(track_path, artifact, routine)
    else:
        setup = None
        if url.startswith("sim:"):
            refuse_robot_options("cylinder", robot)
        else:
            setup = robot_setup(url, None, {**robot, "mount_path": mount_path})
        echo = (lambda line: click.echo(line, err=True)) if as_json else click.echo
        result = mount_cal(artifact, routine, url, setup, echo)
    write_result(out, result)
    summary = result.summary()
    if as_json:
        echo_json(summary)
        return
    fit, (sx, sy, syaw) = result.fit, result.fit.std
    click.echo(f"mount   x {fit.mount.x_mm:.3f} ± {sx:.3f} mm, y {fit.mount.y_mm:.3f} ± {sy:.3f} mm, "
               f"yaw {fit.mount.yaw_deg:.3f} ± {syaw:.3f} deg ({len(result.touches)} touches, "
               f"residual RMS {summary['mount']['residual_rms_mm']:.3f} mm)")
    if "truth" in summary:
        error = summary["truth"]["fit_error"]
        click.echo(f"twin    off the true mount by x {error['x_mm']:+.3f} mm, y {error['y_mm']:+.3f} mm, "
                   f"yaw {error['yaw_deg']:+.3f} deg")
    click.echo(f"wrote   {out}")
