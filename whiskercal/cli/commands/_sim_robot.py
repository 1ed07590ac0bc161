"""``sim serve --robot``: the twin's mobile base behind a rosbridge WebSocket on 127.0.0.1."""

from __future__ import annotations

import asyncio
import math
import sys

import click

from whiskercal.cli.app import echo_json

# each object as an outline SPEC (``contour evaluate``), the flat sides' polygons with a side
# facing -y, as the twin builds them, centred on the world's origin
OUTLINE_SPECS = {"cylinder": "circle:d=160", "rounded-rect": "rounded-rect:w=160,h=160,r=40",
                 "octagon": "polygon:n=8,side=70,r=30"}


def robot_sensor(sensor_name, artifact):
    """The twin's build: --sensor, else the one --artifact was calibrated on, else the default."""
    from whiskercal import runtime
    from whiskercal.errors import UsageError
    from whiskercal.twin.params import DEFAULT_SENSOR
    from whiskercal.twin.sensor_file import resolve_sensor

    sensor = resolve_sensor(sensor_name) if sensor_name else None
    if artifact is None:
        return sensor or DEFAULT_SENSOR
    calibrated = runtime.load(artifact).sensor_id
    if sensor is not None and sensor.sensor_id != calibrated:
        raise UsageError(f"{artifact} was calibrated on sensor {calibrated!r}, not on "
                         f"--sensor {sensor.sensor_id!r}")
    return sensor or resolve_sensor(calibrated)


def serve_robot(shape: str, seed: int, sensor, port: int, rate_hz: float, duration_s, mount_path,
                as_json: bool, mount_error: str | None = None) -> None:
    """Serve until ``duration_s`` (None: Ctrl-C); print where, once the port is bound."""
    import numpy as np

    from whiskercal.checks import integer, positive
    from whiskercal.contour.run import start_pose
    from whiskercal.follow import FollowConfig
    from whiskercal.mount import Mount, parse_mount_error, read_mount
    from whiskercal.twin.devices.rosbridge_robot import RobotTwinServer, Topics
    from whiskercal.twin.mobile import MobileSensor
    from whiskercal.twin.outlines import outline

    positive(rate_hz, "--rate-hz", high=2000.0, unit="Hz")
    integer(port, "--port", low=0)
    shape_outline = outline(shape)
    pose = start_pose(shape_outline, FollowConfig().tilt_deg, 5.0, np.random.default_rng(seed),
                      sensor.whisker.reach_mm)
    mobile = MobileSensor(sensor, shape_outline, pose, seed=seed)
    mount = read_mount(mount_path) if mount_path else None
    if mount_error is not None:  # the twin carries the sensor where it truly sits
        mount = (mount or Mount()).offset_by(parse_mount_error(mount_error))
    server = RobotTwinServer(mobile, rate_hz, Topics(), mount, port)
    ready = lambda served: _announce(served, shape, seed, sensor.sensor_id, pose, as_json)
    try:
        asyncio.run(server.run(duration_s, ready))
    except KeyboardInterrupt:
        pass
    click.echo(f"served {server.samples} samples, skipped {server.skipped} (the solver behind the "
               f"wall clock; the latest {1e3 * server.lag_max_s:.1f} ms after its stamp), took "
               f"{server.twists} twists, refused {server.refused}", err=True)


def _announce(server, shape, seed, sensor_id, pose, as_json) -> None:
    topics = server.topics
    info = {"robot": server.url, "topics": {"field": topics.field, "pose": topics.pose,
                                            "twist": topics.twist},
            "frames": {"world": topics.world_frame, "end_effector": topics.effector_frame,
                       "sensor": topics.sensor_frame},
            "outline": OUTLINE_SPECS[shape], "outline_pose": "0,0,0", "shape": shape,
            "rate_hz": server.rate_hz, "seed": seed, "sensor_id": sensor_id,
            "start_pose": [float(pose[0]), float(pose[1]), math.degrees(float(pose[2]))],
            "true_mount": server.carried.truth()}
    if as_json:
        echo_json(info)
    else:
        click.echo(f"robot  {info['robot']}\ntopics {info['topics']}\noutline {info['outline']} "
                   f"at {info['outline_pose']}\n(Ctrl-C to stop)")
    sys.stdout.flush()

