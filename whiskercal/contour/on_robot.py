"""``contour run --robot`` as a library call: connect to a robot over rosbridge, run the loop on it
(``contour.robot_run``), and write the run file, also when the run was stopped.

Order on every way out: the zero twist first (the robot's ``close``), then the file (atomic: a
readable partial run), then the error that stopped it, if any, raised for the caller to report.
"""

from __future__ import annotations

import contextlib
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from whiskercal.artifacts.contour_run import ContourRunFile, write_contour_run
from whiskercal.contour.record import BagRecorder, refuse_existing
from whiskercal.contour.robot_run import RobotLoop, RobotRun, run_on_robot
from whiskercal.errors import UsageError
from whiskercal.mount import Mount
from whiskercal.robot import (FieldTopic, RobotTopics, RosbridgeLink, RosbridgeRobot, Safety,
                              SerialSamples)

ROBOT_SHAPE = "unknown"  # a robot run's object: what it followed is not the run's to know


@dataclass(frozen=True)
class RobotSetup:
    """Where the robot is and how to drive it: the rosbridge URL, its topics, the mount, the
    safety limits, a dry run, and the sensor's serial port (None: the field topic)."""

    url: str
    topics: RobotTopics = RobotTopics()
    mount: Mount = Mount()
    safety: Safety = Safety()
    dry_run: bool = False
    sensor_port: str | None = None
    connect_timeout_s: float = 10.0


def contour_on_robot(setup: RobotSetup, artifact: str | Path, out: str | Path, *,
                     duration_s: float, loop_config=None, target_z_uT: float | None = None,
                     echo: Callable[[str], None] = print,
                     on_progress: Callable[[float], None] | None = None,
                     record: str | Path | None = None, force: bool = False) -> ContourRunFile:
    """Run the loop on the robot for ``duration_s`` s of stream time with the calibration
    ``artifact`` and write ``out``; raise what stopped it early (after the file is written).

    ``record``: also write each sample's reading and the sensor base's pose as a ROS 2 bag
    there (``contour.record.BagRecorder``), also of a stopped run; an existing one is replaced
    only with ``force``.
    """
    from whiskercal import runtime
    from whiskercal.checks import number, positive
    from whiskercal.follow import FollowConfig

    positive(duration_s, "--duration", unit="s")
    calibration = runtime.load(artifact)
    target = calibration.target_z_uT if target_z_uT is None else number(target_z_uT, "--target-uT")
    if target is None:
        raise UsageError(f"{artifact} has no deflection target: write one with `whiskercal "
                         "optimal-depth report`, or give --target-uT")
    loop = RobotLoop(duration_s, loop_config or FollowConfig(), watchdog_s=setup.safety.watchdog_s)
    tip_mm_per_uT = calibration.tip_motion_mm_per_uT(target)
    refuse_existing(record, force)
    recorder = None if record is None else BagRecorder(record, setup.mount, replace=force)
    def tracker_at(rate_hz: float):  # the filter scaled to the stream's measured rate
        return calibration.tracker(out_of_range="clip", rate_hz=rate_hz)

    run = _run(setup, tracker_at, target, loop, tip_mm_per_uT,
               echo, on_progress, recorder)
    if record is not None:
        run.config.setdefault("robot", {})["record"] = str(record)
    result = _as_file(run, setup, artifact, calibration.sensor_id, target, tip_mm_per_uT)
    write_contour_run(out, result)
    result.path = str(out)
    if recorder is not None and recorder.stamps:
        recorder.write()
    if run.error is not None:
        raise run.error
    return result


def _run(setup: RobotSetup, tracker_at, target, loop, tip_mm_per_uT, echo, on_progress,
         recorder) -> RobotRun:
    """Connect, run, and stop the robot (a zero twist) however the run ended."""
    with connected(setup, echo) as (robot, samples):
        run = run_on_robot(robot, samples, tracker_at, target, loop, tip_mm_per_uT,
                           on_progress=on_progress, recorder=recorder)
        run.config["robot"] = {"sent": robot.sent, "clipped": robot.clipped,
                               "zero_twists": robot.zeros + 1}
    return run


@contextlib.contextmanager
def connected(setup: RobotSetup, echo: Callable[[str], None] = print):
    """The robot (``RosbridgeRobot`` through the setup's mount) and its field samples; leaving
    the block however (an error, Ctrl-C) sends the zero twist, then closes the stream and link."""
    link = RosbridgeLink(setup.url, setup.topics, setup.connect_timeout_s)
    samples = None
    try:
        samples = FieldTopic(link) if setup.sensor_port is None else SerialSamples(setup.sensor_port)
        with RosbridgeRobot(link, setup.mount, setup.safety, setup.dry_run, echo) as robot:
            yield robot, samples
    finally:
        if samples is not None:
            samples.close()
        link.close()


def _as_file(run: RobotRun, setup: RobotSetup, artifact, sensor_id: str, target: float,
             tip_mm_per_uT) -> ContourRunFile:
    robot = {"url": setup.url, "pose_topic": setup.topics.pose, "tf_frames": setup.topics.tf_frames,
             "twist_topic": setup.topics.twist,
             "twist_frame": setup.topics.twist_frame, "field_topic": setup.topics.field,
             "sensor_port": setup.sensor_port, "dry_run": setup.dry_run,
             "mount": {"x_mm": setup.mount.x_mm, "y_mm": setup.mount.y_mm,
                       "yaw_deg": setup.mount.yaw_deg},
             "max_speed_mm_s": setup.safety.speed_mm_s, "max_turn_rad_s": setup.safety.turn_rad_s,
             "box_mm": setup.safety.box_mm, "watchdog_s": setup.safety.watchdog_s,
             "rest_uT": list(run.rest_uT), "rate_hz": run.rate_hz, "latency_ms": run.latency_ms,
             "stopped_by": None if run.error is None else (str(run.error) or "Ctrl-C"),
             **run.config.pop("robot", {})}
    return ContourRunFile(ROBOT_SHAPE, np.zeros((0, 2)), math.nan, float(target), 0, run.complete,
                          run.wall_s, sensor_id, run.columns,
                          {"follow": run.config, "artifact": str(artifact),
                           "tip_mm_per_uT": tip_mm_per_uT, "robot": robot})


def summarize_robot_run(run: ContourRunFile) -> dict:
    """What a robot run did, from its own file (JSON-able); its error against an outline is
    ``contour evaluate``'s."""
    columns, robot = run.columns, run.config.get("robot", {})
    following = (columns["phase"] == "follow") & np.isfinite(columns["estimate_mm"][:, 0])
    t_s = columns["t_s"]
    return {"robot": robot.get("url"), "samples": int(len(t_s)),
            "duration_s": float(t_s[-1]) if len(t_s) else 0.0,
            "rate_hz": robot.get("rate_hz"), "contacts": int(following.sum()),
            "follow_share": float(following.mean()) if len(t_s) else 0.0,
            "z_mean_follow_uT": float(columns["z_uT"][following].mean()) if following.any() else math.nan,
            "target_z_uT": run.target_z_uT, "latency_ms": robot.get("latency_ms"),
            "control_ms_mean": 1e3 * float(columns["control_s"].mean()) if len(t_s) else 0.0,
            "twists_sent": robot.get("sent"), "twists_clipped": robot.get("clipped"),
            "dry_run": robot.get("dry_run"), "complete": run.complete,
            "stopped_by": robot.get("stopped_by")}
