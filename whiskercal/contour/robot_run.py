"""The paper's closed loop on a robot: the follower drives whatever carries the sensor through a
``Robot`` (``robot.RosbridgeRobot``), one field sample at a time, and records the reconstruction
in the robot's world frame (the pose topic's frame).

The run first holds the robot still (a zero twist) for ``rest_s``: those samples, which must be
free of contact, give the rest reading (the median of each axis; z = Y - rest, the chip's Z
likewise) and the stream's rate, which the follower's config then takes. Then every sample goes
through the follower and its command out. No twin truth is read: the run file's true columns are
NaN and its kind "unknown"; ``contour evaluate`` measures it against an outline.

What stops a run, each leaving the samples run so far: the duration (complete), Ctrl-C, the
watchdog (no sample, or a pose older than ``watchdog_s``), the workspace box, a lost connection.
The caller gets the run and the error, sends the zero twist (the robot's ``close``), writes the
file, and reports the error.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Callable, Protocol

import numpy as np

from whiskercal.contour.run import COLUMNS
from whiskercal.errors import DeviceError
from whiskercal.follow import FollowConfig, Follower
from whiskercal.robot import RobotError, WatchdogError

ROBOT_COLUMNS = tuple(name for name in COLUMNS if name != "twin_slips")


class Recorder(Protocol):
    """Where a run's raw stream may go as well (an MCAP recorder: ``--record``): each sample's
    field (µT), stamp (s) and the end effector's pose at it."""

    def add(self, stamp_s: float, field_uT, effector_pose) -> None:
        """One sample."""


@dataclass
class RobotRun:
    """A run's samples (columns of :data:`ROBOT_COLUMNS`), how it ended and what it cost."""

    config: dict
    columns: dict[str, np.ndarray] = field(default_factory=dict)
    complete: bool = False
    wall_s: float = 0.0
    error: Exception | None = None
    rest_uT: tuple[float, float] = (math.nan, math.nan)
    rate_hz: float = math.nan
    latency_ms: dict = field(default_factory=dict)


@dataclass(frozen=True)
class RobotLoop:
    """The run's settings: duration of stream time (s), rest_s before it, the watchdog (s), and
    the follower's config (its rate replaced by the stream's)."""

    duration_s: float
    config: FollowConfig = FollowConfig()
    rest_s: float = 0.5
    watchdog_s: float = 0.2


def run_on_robot(robot, samples, tracker_at: Callable[[float], object], target_z_uT: float,
                 loop: RobotLoop, tip_mm_per_uT: float | None = None, reach_mm: float = 78.0,
                 on_progress: Callable[[float], None] | None = None,
                 recorder: Recorder | None = None) -> RobotRun:
    """Run the loop (see the module's docstring); the run, with ``error`` set when a robot error
    or Ctrl-C (``KeyboardInterrupt``) stopped it. ``tracker_at(rate_hz)``: the runtime tracker
    for the stream's rate, measured at rest before the run (its filter scaled to it). The robot
    is not stopped here: its ``close`` (the caller's ``with``) sends the zero twist on every
    way out."""
    run = RobotRun({})
    rows: dict[str, list] = {name: [] for name in ROBOT_COLUMNS}
    started = time.perf_counter()
    latencies: list[float] = []
    try:
        robot.stop()
        rest, rate = rest_reading(robot, samples, loop)
        run.rest_uT, run.rate_hz = rest, rate
        config = loop.config.replace(rate_hz=rate)
        run.config = config.to_dict()
        follower = Follower(tracker_at(rate), target_z_uT, config, reach_mm, tip_mm_per_uT)
        run.complete = _follow(robot, samples, follower, rest, loop, rows, latencies,
                               on_progress, recorder)
    except (RobotError, KeyboardInterrupt) as error:
        run.error = error
    run.wall_s = time.perf_counter() - started
    run.columns = {name: _column(name, values) for name, values in rows.items()}
    run.latency_ms = _latency_summary(latencies)
    return run


def rest_reading(robot, samples, loop: RobotLoop) -> tuple[tuple[float, float], float]:
    """The rest reading (Y, Z µT) and the stream's rate (Hz) from ``rest_s`` of samples taken
    with the robot held still (the first pose awaited too)."""
    readings, stamps = [], []
    first = None
    while first is None or stamps[-1] - first < loop.rest_s:
        sample = next_sample(samples, robot, loop.watchdog_s)
        first = sample.stamp_s if first is None else first
        readings.append(sample.field_uT)
        stamps.append(sample.stamp_s)
    if len(stamps) < 5:
        raise DeviceError(f"only {len(stamps)} samples in the {loop.rest_s:g} s at rest: the "
                          "stream's stamps do not advance at a rate the loop can run at")
    readings = np.asarray(readings, float)
    rate = 1.0 / float(np.median(np.diff(stamps)))
    return (float(np.median(readings[:, 1])), float(np.median(readings[:, 2]))), round(rate, 1)


def next_sample(samples, robot, watchdog_s: float):
    """The next sample, with the link checked and the pose fresh; WatchdogError otherwise."""
    sample = samples.next(watchdog_s)
    robot.link.check()
    if sample is None:
        raise WatchdogError(f"no field sample for {1e3 * watchdog_s:g} ms (watchdog): stopped")
    latest = robot.link.latest_pose()
    age = math.inf if latest is None else time.monotonic() - latest[2]
    if age > watchdog_s:
        raise WatchdogError(f"no pose for {1e3 * watchdog_s:g} ms (watchdog): stopped")
    return sample


def _follow(robot, samples, follower, rest, loop: RobotLoop, rows, latencies, on_progress,
            recorder) -> bool:
    """Every sample through the follower until ``duration_s`` of stream time; True at the end."""
    first = None
    while True:
        sample = next_sample(samples, robot, loop.watchdog_s)
        first = sample.stamp_s if first is None else first
        t_s = sample.stamp_s - first
        if t_s > loop.duration_s:
            return True
        tic = time.perf_counter()
        z_uT, axial_uT = sample.field_uT[1] - rest[0], sample.field_uT[2] - rest[1]
        step = follower.update(z_uT, robot, axial_uT)
        latencies.append((time.monotonic() - sample.received_s, sample.transit_s))
        _record(rows, t_s, z_uT, axial_uT, step, robot.pose(), time.perf_counter() - tic)
        if recorder is not None:
            recorder.add(sample.stamp_s, sample.field_uT, robot.effector_pose())
        if on_progress is not None and len(rows["t_s"]) % 300 == 0:
            on_progress(t_s)


def _record(rows, t_s, z_uT, axial_uT, step, pose, control_s) -> None:
    nan2 = np.full(2, np.nan)
    for name, value in (("t_s", t_s), ("z_uT", z_uT), ("axial_uT", axial_uT),
                        ("estimate_mm", step.contact_mm), ("true_tip_mm", nan2),
                        ("true_contact_mm", nan2), ("pose", pose), ("slip", step.slip),
                        ("phase", step.phase), ("kind", "unknown"), ("control_s", control_s)):
        rows[name].append(value)


def _column(name: str, values: list) -> np.ndarray:
    """A column as an array, the point columns (n, 2) or (n, 3) also when empty."""
    if values:
        return np.asarray(values)
    width = {"estimate_mm": 2, "true_tip_mm": 2, "true_contact_mm": 2, "pose": 3}.get(name)
    return np.empty((0, width)) if width else np.asarray(values, dtype=str if name in ("phase", "kind") else float)


def _latency_summary(latencies: list[tuple[float, float]]) -> dict:
    """ms, mean / 95th percentile / max: from a sample's arrival to its command sent (``loop``:
    waiting in the queue, the tracker, the follower, the publish), and from its stamp to its
    arrival (``transit``, NaN where the sender's clock is not this machine's)."""
    summary: dict = {"samples": len(latencies)}
    for index, name in enumerate(("loop", "transit")):
        values = 1e3 * np.asarray([pair[index] for pair in latencies], float)
        values = values[np.isfinite(values)]
        summary[name] = ({"mean": float(values.mean()), "p95": float(np.percentile(values, 95)),
                          "max": float(values.max())} if len(values) else None)
    return summary
