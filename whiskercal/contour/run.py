"""One contour-following run on the twin: the follower drives the mobile sensor around an object.

``run_contour`` starts the sensor outside the object, pointing at it, and runs the loop for a
duration of robot time (or until stopped), recording every sample: time, z and the chip's Z
axis (fed to the tracker, which uses it when the calibration carries a (Y, Z) table), the
estimated contact (world frame), the twin's true tip and contact, the pose, the contact kind,
the slips the follower detected and the twin's true slip events (with stick-slip friction).
A run on an open scene ends once the twin's tip passes the scene's far end.
Each change of the follower's phase is recorded too (:data:`TRANSITION_COLUMNS`: the sample,
its time, the two phases and the rule). The estimate is never aligned to the truth;
docs/contour.md has the metrics.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from whiskercal.contour.mounted import MountedTwin
from whiskercal.follow import FollowConfig, Follower
from whiskercal.twin.mobile import MobileSensor
from whiskercal.twin.outlines import Outline

COLUMNS = ("t_s", "z_uT", "axial_uT", "estimate_mm", "true_tip_mm", "true_contact_mm", "pose", "slip",
           "phase", "kind", "control_s", "twin_slips")
TRANSITION_COLUMNS = ("sample", "t_s", "source", "target", "rule")


@dataclass
class ContourRun:
    """A run's samples (columns of :data:`COLUMNS`) and what made it."""

    shape: str
    sensor_id: str
    target_z_uT: float
    config: dict
    seed: int
    columns: dict[str, np.ndarray] = field(default_factory=dict)
    transitions: dict[str, np.ndarray] = field(default_factory=dict)
    complete: bool = False
    wall_s: float = 0.0
    mount: dict | None = None  # the nominal and the twin's true mount, when the run had one


def start_pose(outline: Outline, tilt_deg: float, standoff_mm: float, rng,
               reach_mm: float) -> np.ndarray:
    """A pose outside the object at a random point of its outline: the whisker leans
    ``tilt_deg`` back from the surface's inward normal there, its tip ``standoff_mm`` short.
    On an open outline (the wall) the point is drawn evenly along its first 10-60 mm: the
    follower keeps the object on its left, so it then travels past every feature of it."""
    points = outline.points() if outline.closed else outline.dense(1.0)[10:60]
    index = int(rng.integers(len(points)))
    tangent = points[(index + 1) % len(points)] - points[index - 1]
    inward = np.array([-tangent[1], tangent[0]]) / np.linalg.norm(tangent)  # counter-clockwise
    heading = math.atan2(inward[1], inward[0]) - math.radians(tilt_deg)
    base = points[index] - (reach_mm + standoff_mm) * np.array([math.cos(heading), math.sin(heading)])
    return np.array([*base, heading])


def run_contour(outline: Outline, sensor, tracker, target_z_uT: float, config: FollowConfig,
                duration_s: float, seed: int = 0, on_progress: Callable[[float], None] | None = None,
                stop_requested: Callable[[], bool] | None = None,
                friction=None, tip_mm_per_uT: float | None = None, mount=None,
                nuisances=None) -> ContourRun:
    """Run the loop for ``duration_s`` s of robot time, or until stopped (a partial run);
    ``friction``: a ``Coulomb``, friction at the tip (``twin.mobile``), None: frictionless;
    ``tip_mm_per_uT``: the calibration's tip motion per µT at the target (scales the PID);
    ``mount``: (nominal ``Mount``, error (dx mm, dy mm, dyaw deg)): the loop drives the end
    effector through the nominal mount, the twin carries the sensor at the nominal one moved
    by the error (``contour.mounted``); None: the loop drives the sensor's base frame itself;
    ``nuisances``: what a real rig adds (``twin.nuisances``; its robot's ``rate_hz``, when set,
    is the loop's rate)."""
    rng = np.random.default_rng(seed)
    reach_mm = sensor.whisker.reach_mm
    if nuisances is not None and nuisances.robot.rate_hz > 0:
        config = config.replace(rate_hz=nuisances.robot.rate_hz)
    robot = MobileSensor(sensor, outline, start_pose(outline, config.tilt_deg, 5.0, rng, reach_mm),
                         seed=seed, friction=friction, nuisances=nuisances)
    run = ContourRun(outline.name, sensor.sensor_id, float(target_z_uT), config.to_dict(), seed)
    if mount is not None:
        robot = MountedTwin.placed(robot, *mount)
        run.mount = robot.truth()
    follower = Follower(tracker, target_z_uT, config, reach_mm, tip_mm_per_uT)
    rows: dict[str, list] = {name: [] for name in COLUMNS}
    changes: dict[str, list] = {name: [] for name in TRANSITION_COLUMNS}
    dt, steps = 1.0 / config.rate_hz, int(round(duration_s * config.rate_hz))
    started = time.perf_counter()
    sample = robot.step(0.0)
    try:
        for index in range(steps):
            tic = time.perf_counter()
            step = follower.update(sample.z_uT, robot, sample.axial_uT)
            _record(rows, index * dt, sample, step, robot.pose(), time.perf_counter() - tic)
            _record_transitions(changes, index, index * dt, step)
            if sample.kind == "collision":  # driven into the wall: a real run would end here
                break
            if _past_the_end(outline, sample):  # an open scene followed to its end: done
                run.complete = True
                break
            if stop_requested is not None and stop_requested():  # after a sample: never empty
                break
            sample = robot.step(dt)
            if on_progress is not None and index % int(config.rate_hz) == 0:
                on_progress(index * dt)
        else:
            run.complete = True
    except KeyboardInterrupt:  # Ctrl-C: keep what was run (complete stays False)
        pass
    run.wall_s = time.perf_counter() - started
    whole = min(len(values) for values in rows.values())  # an interrupt mid-sample: drop it
    run.columns = {name: np.asarray(values[:whole]) for name, values in rows.items()}
    transitions = _transition_arrays(changes)
    kept = transitions["sample"] < whole
    run.transitions = {name: values[kept] for name, values in transitions.items()}
    return run


def _past_the_end(outline: Outline, sample) -> bool:
    """Has the twin's tip passed an open scene's far end? Past it the solid goes on only so
    that no false edge stands there; what is followed there is not the scene."""
    contact = sample.contact_mm
    return (not outline.closed and contact is not None and bool(np.all(np.isfinite(contact)))
            and outline.past_end(contact))


def _record(rows, t_s: float, sample, step, pose, control_s: float) -> None:
    for name, value in (("t_s", t_s), ("z_uT", sample.z_uT), ("axial_uT", sample.axial_uT),
                        ("estimate_mm", step.contact_mm),
                        ("true_tip_mm", sample.tip_mm), ("true_contact_mm", sample.contact_mm),
                        ("pose", pose), ("slip", step.slip), ("phase", step.phase),
                        ("kind", sample.kind), ("control_s", control_s),
                        ("twin_slips", sample.slips)):
        rows[name].append(value)


def _record_transitions(changes, index: int, t_s: float, step) -> None:
    for transition in step.transitions:
        for name, value in (("sample", index), ("t_s", t_s), ("source", transition.source.value),
                            ("target", transition.target.value), ("rule", transition.rule)):
            changes[name].append(value)


def _transition_arrays(changes) -> dict[str, np.ndarray]:
    """The transitions as columns (typed also when there are none)."""
    kinds = {"sample": np.int64, "t_s": float, "source": str, "target": str, "rule": str}
    return {name: np.asarray(values, dtype=kinds[name]) for name, values in changes.items()}
