"""The shaft study on the rig: per trial, push the rod onto the shaft and slide it, recording.

Per missing trial (a radial distance and an approach direction, ``config.trial_plan``): move the
rod clear above the whisker, push it in along the approach line, slide it along the whisker's
axis, lift it off; the sensor's stream, the stage's position per status poll (interpolated to
each sample, as a robot knows its own motion) and, on the twin, the true contact per sample are
kept. Each trial is added to the file atomically; ``resume`` runs only the missing ones. The run
goes through a ``RigSession``, which halts the stage and stops the sensor however it ends.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from whiskercal.artifacts import h5io
from whiskercal.artifacts.shaft_study import ShaftStudyWriter, ShaftTrial
from whiskercal.protocol.sensor_config import SensorConfig
from whiskercal.errors import UsageError
from whiskercal.rig.overload import SENSOR_AXIS_Y, OverloadError, check_overload
from whiskercal.session import RigFrame, RigSession, SessionConfig
from whiskercal.shaftstudy.config import trial_plan


@dataclass
class ShaftRunSummary:
    """What a run did."""

    out: str
    trials_done: list[str] = field(default_factory=list)
    trials_skipped: list[str] = field(default_factory=list)
    complete: bool = False


def session_config(config: dict) -> SessionConfig:
    """What the rig session needs from a shaft study configuration."""
    rig, sensor, safety = config["rig"], config["sensor"], config["safety"]
    return SessionConfig(frame=RigFrame.from_degrees(rig["origin_stage_mm"], float(rig["angle_deg"])),
                         sensor=SensorConfig(*(int(sensor[k]) for k in ("rate_hz", "gain", "res",
                                                                        "osr", "filt"))),
                         home=bool(safety["home"]), move_timeout_s=float(safety["move_timeout_s"]),
                         home_setting="safety.home")


def run_shaft_study(stage_port, sensor_port, out_path: str | Path, config: dict,
                    resume: bool = False, progress=None, force: bool = False) -> ShaftRunSummary:
    """Run (or continue) the shaft study into ``out_path``; return what was done. An existing
    finished file is replaced only with ``force``."""
    h5io.refuse_to_replace_run(Path(out_path), resume, force, "shaft study")  # before any port opens
    summary = ShaftRunSummary(out=str(out_path))
    with RigSession.open(stage_port, sensor_port, session_config(config)) as rig:
        world = getattr(rig.sensor_port, "world", None)
        if world is not None:
            _check_world(world, config)  # before a file is written
        sensor_id = str(getattr(getattr(world, "sensor", None), "sensor_id", "") or
                        rig.devices.sensor)
        writer = ShaftStudyWriter(out_path, config, sensor_id, resume=resume, force=force)
        done = set(writer.done())
        rig.start()
        _rise_clear(rig, config)
        rig.move_to(config["safety"]["park_mm"], _feed(config, "travel_speed_mm_s"))
        static = rig.measure(int(config["safety"]["baseline_samples"]), settle_s=0.2).field_uT.mean(0)
        writer.write_baseline(static)
        plan = trial_plan(config)
        for index, trial in enumerate(plan):
            if trial["name"] in done:
                summary.trials_skipped.append(trial["name"])
                continue
            writer.add_trial(_trial(rig, config, trial, static, world))
            summary.trials_done.append(trial["name"])
            if progress is not None:
                progress(index + 1, len(plan))
        writer.mark_complete()
        summary.complete = True
    return summary


def _check_world(world, config: dict) -> None:
    """Refuse a simulated rig that carries no rod, or sits elsewhere than the configuration says
    (the recorded positions would not be the rod's)."""
    if world.config.fixture.name != "rod":
        raise UsageError(f"the simulated rig carries a {type(world.config.fixture).__name__}, not "
                         "the rod: open the stage as sim://NAME/stage (scene=rod)")
    geometry = world.config.geometry
    frame = RigFrame.from_degrees(config["rig"]["origin_stage_mm"], float(config["rig"]["angle_deg"]))
    if (np.max(np.abs(np.asarray(geometry.origin_stage_mm) - frame.origin)) > 1e-6
            or abs(geometry.angle_rad - frame.angle_rad) > 1e-9):
        raise UsageError("the configuration's [rig] origin and angle differ from the simulated "
                         "rig's; set them to match docs/twin.md")


def _rise_clear(rig: RigSession, config: dict) -> None:
    """From wherever homing left the rod (below the whisker, -y), pass beyond the whisker's reach
    before rising to the trials' side (+y), so the rod never crosses the shaft."""
    here = rig.position_mm()
    safe_y = float(config["trials"]["safe_y_mm"])
    if here[1] >= safe_y:
        return
    beyond = max(float(here[0]), float(config["rig"]["trace_length_mm"]) + 10.0)
    feed = _feed(config, "travel_speed_mm_s")
    rig.move_to([beyond, here[1]], feed)
    rig.move_to([beyond, safe_y], feed)


def _feed(config: dict, key: str) -> float:
    return float(config["trials"][key]) * 60.0


class _Recorder:
    """Sensor blocks and stage polls of one trial, each poll tagged with the samples before it."""

    def __init__(self, rig: RigSession, static: np.ndarray, config: dict, t_from_s: float):
        self.rig, self.static, self.config, self.t_from_s = rig, static, config, t_from_s
        self.blocks, self.polls, self.count, self.phase, self.phases = [], [], 0, 0, []

    def sink(self, block) -> None:
        check_overload(block.field_uT, block.counts, block.status, res=int(self.config["sensor"]["res"]),
                       static_y_uT=float(self.static[SENSOR_AXIS_Y]),
                       limit_uT=float(self.config["safety"]["overload_uT"]))
        _, block = block.split(int(np.searchsorted(block.t_s, self.t_from_s)))
        if len(block):
            self.blocks.append(block)
            self.phases.append(np.full(len(block), self.phase, np.int8))
            self.count += len(block)

    def on_poll(self, status) -> None:
        self.polls.append((self.count, *np.asarray(status.mpos_mm, float)[:2]))
        self.rig.read_while_waiting(status)


def _trial(rig: RigSession, config: dict, trial: dict, static: np.ndarray, world) -> ShaftTrial:
    rig.move_to(trial["start"], _feed(config, "travel_speed_mm_s"))
    recorder = _Recorder(rig, static, config, rig.sync())
    rig.sink = recorder.sink
    try:
        for phase, (target, speed) in enumerate([("pushed", "push_speed_mm_s"),
                                                 ("slid", "slide_speed_mm_s"),
                                                 ("leave", "push_speed_mm_s")]):
            recorder.phase = phase
            rig.move_to(trial[target], _feed(config, speed), on_poll=recorder.on_poll)
    except OverloadError:
        rig.sink = lambda block: None
        safe_y = float(config["trials"]["safe_y_mm"])
        rig.back_off(lambda here: rig.to_stage([rig.to_whisker(here)[0], safe_y]),
                     _feed(config, "push_speed_mm_s"))  # straight off the whisker, not along it
        raise
    finally:
        rig.sink = lambda block: None
    return _record(rig, trial, recorder, static, world)


def _record(rig: RigSession, trial: dict, recorder: _Recorder, static: np.ndarray, world) -> ShaftTrial:
    from whiskercal.rig.sensor import SampleBlock

    block = SampleBlock.join(recorder.blocks)
    polls = np.asarray(recorder.polls, float).reshape(-1, 3)
    samples = np.arange(len(block), dtype=float)
    stage = np.column_stack([np.interp(samples, polls[:, 0], polls[:, axis]) for axis in (1, 2)])
    stream = {"t_s": block.t_s, "field_uT": block.field_uT,
              "z_uT": block.field_uT[:, SENSOR_AXIS_Y] - static[SENSOR_AXIS_Y],
              "phase": np.concatenate(recorder.phases) if recorder.phases else np.zeros(0, np.int8),
              "position_mm": rig.to_whisker(stage)}
    attrs = {"approach_deg": trial["approach_deg"], "start_mm": trial["start"],
             "pushed_mm": trial["pushed"], "slid_mm": trial["slid"]}
    truth = _truth(world, block.t_s, float(rig.config.sensor.rate_hz)) if world is not None else None
    return ShaftTrial(trial["name"], trial["radial_mm"], stream, attrs, truth)


def _truth(world, t_s: np.ndarray, rate_hz: float) -> dict[str, np.ndarray]:
    """The twin's true contact, rod centre, kind and noise-free z at each sample's board time."""
    with world.lock:
        record = world.truth.arrays()
    times = np.asarray(record["t_s"], float)
    right = np.clip(np.searchsorted(times, t_s), 1, max(times.size - 1, 1))
    left = right - 1
    nearest = np.where(np.abs(times[left] - t_s) <= np.abs(times[right] - t_s), left, right)
    found = np.abs(times[nearest] - t_s) <= 0.5 / rate_hz

    def pick(name):
        values = np.asarray(record[name], float)[nearest]
        values[~found] = np.nan
        return values

    kind = np.where(found, np.asarray(record["kind"]).astype(str)[nearest], "unknown").astype("U10")
    return {"contact_mm": pick("contact_mm"), "rod_center_mm": pick("tool_mm"),
            "kind": kind, "z_true_uT": pick("z_true_uT")}
