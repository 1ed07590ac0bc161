"""``whiskercal sim``: the digital twin's rig as serial ports for any tool."""

from __future__ import annotations

import math
import sys
import time

import click

from whiskercal.cli.app import App, echo_json, given_options, pass_app
from whiskercal.cli.commands._sim_robot import OUTLINE_SPECS, robot_sensor, serve_robot
from whiskercal.twin.scenes import scene_names


# the options of one way of serving only: the rig's boards on ptys, or the robot on rosbridge
RIG_ONLY = ("scene", "speed", "rod_radius", "stock", "homing", "origin", "faults", "firmware")
ROBOT_ONLY = ("shape", "port", "rate_hz", "artifact", "mount_path", "mount_error")


@click.group("sim")
def command() -> None:
    """Run the digital twin's stage and sensor boards outside whiskercal.

    In-process code opens them as sim://NAME/stage and sim://NAME/sensor instead.
    """


@command.command("serve")
@click.option("--scene", type=click.Choice(scene_names()), default="rod", show_default=True,
              help="What rides on the stage's end effector.")
@click.option("--seed", type=int, default=0, show_default=True, help="Seed of the noise and faults.")
@click.option("--speed", type=float, default=1.0, show_default=True,
              help="Simulated seconds per real second (1 = real time).")
@click.option("--sensor", default=None, metavar="ID_OR_PATH",
              help="A shipped sensor id or a .toml sensor file [default: the default sensor].")
@click.option("--rod-radius", type=float, default=1.5, show_default=True, help="Touch rod radius, mm.")
@click.option("--stock", is_flag=True, help="Stage behaves like plain grbl 1.1 (no encoders).")
@click.option("--homing", type=click.Choice(["xy"]), default=None,
              help="The stock board's config.h homes X and Y (default: grbl's own, Z first).")
@click.option("--origin", type=click.Choice(["set"]), default=None,
              help="The stock build has HOMING_FORCE_SET_ORIGIN (default: grbl's -travel..0 space).")
@click.option("--fault", "faults", multiple=True, metavar="NAME@SECONDS",
              help="Inject a fault: missed_steps@T[:mm], stall@T, encoder_magnet@T, encoder_bus@T.")
@click.option("--firmware", type=click.Choice(["python", "avr", "grbl"]), default="python", show_default=True,
              help="avr: both boards are their compiled .hex on simavr (make firmware-sim) instead of "
                   "the twin's Python boards; grbl: the stage is stock grbl 1.1h on simavr (make grbl-sim, "
                   "--homing/--origin choose the build), the sensor the twin's Python board.")
@click.option("--duration", type=float, default=None,
              help="Stop after this many real seconds (default: run until Ctrl-C).")
@click.option("--json", "as_json", is_flag=True, help="Print the pty paths (with --robot: the "
              "rosbridge URL, topics and outline) as JSON.")
@click.option("--robot", "as_robot", is_flag=True,
              help="Serve the twin's mobile base against --shape behind a rosbridge WebSocket on "
                   "127.0.0.1 instead of the rig's boards (docs/robot.md).")
@click.option("--shape", type=click.Choice(sorted(OUTLINE_SPECS)), default=None,
              help="With --robot: the object in front of the base.")
@click.option("--port", type=int, default=9090, show_default=True,
              help="With --robot: the WebSocket's port (0: any free one).")
@click.option("--rate-hz", type=float, default=300.0, show_default=True,
              help="With --robot: poses and field samples per second (the paper's board: 300 or 30).")
@click.option("--artifact", type=click.Path(dir_okay=False), default=None,
              help="With --robot: serve the build this calibration was made on.")
@click.option("--mount", "mount_path", type=click.Path(dir_okay=False), default=None,
              help="With --robot: TOML [mount] table; the pose and twists are then the end "
                   "effector's that carries the base so.")
@click.option("--mount-error", default=None, metavar="DX,DY,DEG",
              help="With --robot: the sensor truly sits off --mount by DX, DY mm and DEG degrees "
                   "(what `whiskercal mount-cal` measures) [default: 0,0,0].")
@pass_app
def serve(app: App, scene: str, seed: int, speed: float, sensor: str | None, rod_radius: float,
          stock: bool, homing: str | None, origin: str | None, faults: tuple[str, ...], firmware: str,
          duration: float | None, as_json: bool, as_robot: bool, shape, port, rate_hz, artifact,
          mount_path, mount_error) -> None:
    """Expose a simulated rig on two pseudo-terminals until Ctrl-C (with --robot: the twin's
    mobile base on a rosbridge WebSocket).

    Prints the stage's and the sensor's pty paths; open them with any serial tool or pass
    them to whiskercal commands as device names.
    """
    from whiskercal.checks import number, positive
    from whiskercal.errors import UsageError
    from whiskercal.twin.devices.simport import PtyBridge, world_from_options

    positive(speed, "--speed (simulated seconds per real second)")
    number(rod_radius, "--rod-radius", low=0, unit="mm")
    if duration is not None:
        number(duration, "--duration (leave it out to run until Ctrl-C)", low=0, unit="s")
    misplaced = given_options(RIG_ONLY if as_robot else ROBOT_ONLY)
    if misplaced:
        raise UsageError(f"{misplaced[0]} is for the rig's boards, not --robot" if as_robot else
                         f"{misplaced[0]} is for --robot")
    if as_robot:
        if shape is None:
            raise UsageError("--robot serves the twin's base against an object: give --shape")
        return serve_robot(shape, seed, robot_sensor(sensor, artifact), port, rate_hz, duration,
                           mount_path, as_json, mount_error)
    options = {"scene": [scene], "seed": [str(seed)], "rod_radius": [str(rod_radius)],
               "stock": ["1" if stock else "0"], "homing": [homing or ""],
               "origin": [origin or ""], "fault": list(faults)}
    if sensor is not None:
        options["sensor"] = [sensor]
    world = world_from_options("serve", options)
    if firmware != "python":
        _use_emulated_boards(world, firmware)
    bridge = PtyBridge(world, speed)
    info = {"stage": bridge.paths["stage"], "sensor": bridge.paths["sensor"], "scene": scene,
            "seed": seed, "speed": speed, "sensor_id": world.sensor.sensor_id, "firmware": firmware}
    if as_json:
        echo_json(info)
    else:
        click.echo(f"stage  {info['stage']}\nsensor {info['sensor']}\n(Ctrl-C to stop)")
    sys.stdout.flush()
    end = time.monotonic() + duration if duration is not None else math.inf
    try:
        bridge.serve(lambda: time.monotonic() >= end)
    except KeyboardInterrupt:
        pass
    finally:
        bridge.close()


def _use_emulated_boards(world, firmware: str) -> None:
    """Both boards as their .hex on simavr (``avr``), or the stage as stock grbl (``grbl``); a
    missing harness or image is the user's to build."""
    from serial.serialutil import SerialException

    from whiskercal.errors import UsageError

    try:
        world.use_emulated_stage_board(firmware)
        if firmware == "avr":
            world.use_emulated_sensor_board()
    except SerialException as error:
        raise UsageError(str(error)) from error
