"""The flat-plane study on the rig: first contact, then one slide per depth, checkpointed per trial.

Order of work (docs/study.md):

1. identify both devices, check every waypoint of every trial against the stage's travel (soft
   limits) before anything moves, home the stage (or require it homed);
2. configure and start the sensor; park the plane clear of the whisker and measure the static
   baseline;
3. find first contact: step the plane in along its normal until |z| exceeds the threshold; that
   stage position is distance 0 (stored, so a resumed run does not search again);
4. per missing depth: back off, go to the slide start, push in to the depth, slide at constant
   velocity along the plane (a G1 with both axes when the plane is not aligned with one) while
   recording the stream and the stage's status, back off; add the trial to the file atomically.

The run goes through a ``RigSession`` (whiskercal/session), which halts the stage and stops the
sensor however the run ends, so it runs unchanged on a real rig, on the twin and on test fakes.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from whiskercal.artifacts import h5io
from whiskercal.artifacts.plane_study import (PHASE_APPROACH, PHASE_RETRACT, PHASE_SLIDE,
                                              StudyWriter, TrialRecord)
from whiskercal.collect.faults import frame_loss, frame_loss_warning
from whiskercal.errors import DeviceError, UsageError
from whiskercal.progress import Progress
from whiskercal.protocol.sensor_config import SensorConfig
from whiskercal.rig.overload import SENSOR_AXIS_Y, OverloadError
from whiskercal.session import RigSession, SessionConfig
from whiskercal.study import truth as truth_module
from whiskercal.study.config import PlaneGeometry
from whiskercal.study.detect import contact_onset_mm
from whiskercal.study.recorder import StreamRecorder, stage_position_per_sample

ProgressCallback = Callable[[Progress], None]


class NoContactError(DeviceError):
    """The plane never touched the whisker within the search distance."""


@dataclass
class RunSummary:
    """What a run did (stage time on the stage port's clock: simulated on the twin; s)."""

    out: str
    trials_done: list[float] = field(default_factory=list)
    trials_skipped: list[float] = field(default_factory=list)
    complete: bool = False
    first_contact_stage_mm: list[float] = field(default_factory=list)
    stage_time_s: float = 0.0
    dropped: int = 0
    corrupt: int = 0
    wall_time_s: float = 0.0
    frame_loss: float = 0.0  # (dropped + corrupt) / frames sent during this run's trials
    warnings: list[str] = field(default_factory=list)


def session_config(config: dict) -> SessionConfig:
    """What the rig session needs from a study configuration."""
    sensor, safety = config["sensor"], config["safety"]
    return SessionConfig(frame=PlaneGeometry.from_config(config).frame,
                         sensor=SensorConfig(int(sensor["rate_hz"]), int(sensor["gain"]),
                                             int(sensor["res"]), int(sensor["osr"]),
                                             int(sensor["filt"])),
                         home=bool(safety["home"]), move_timeout_s=float(safety["move_timeout_s"]),
                         home_setting="safety.home")


def run_study(stage_port, sensor_port, out_path: str | Path, config: dict, resume: bool = False,
              progress: ProgressCallback | None = None, *, stage_client=None,
              sensor_client=None, force: bool = False) -> RunSummary:
    """Run (or with ``resume`` continue) the study into ``out_path``; return what was done. An
    existing finished study is replaced only with ``force`` (``StudyWriter``).

    ``stage_port``/``sensor_port`` are URLs, device names or open pyserial objects; ready
    clients (``stage_client``/``sensor_client``) are used as they are and left open. On the
    twin (a simulated sensor port) the world's rig must carry the configured plane, and each
    trial gets the twin's truth per sample.

    Raises
    ------
    WhiskercalError
        Device failures, alarms, the overload guard, no contact, a refused resume; every
        finished trial is in the file and ``resume`` continues with the rest.
    """
    h5io.refuse_to_replace_run(Path(out_path), resume, force, "study")  # before any port opens
    with RigSession.open(stage_port, sensor_port, session_config(config),
                         stage_client=stage_client, sensor_client=sensor_client) as rig:
        world = getattr(rig.sensor_port, "world", None)
        if world is not None:
            truth_module.check_world(world, PlaneGeometry.from_config(config))  # before a file
        writer = StudyWriter(out_path, config, _sensor_id(world, rig), resume=resume,
                             force=force)
        return StudyRun(rig, config, writer, world=world, progress=progress).run()


def _sensor_id(world, rig: RigSession) -> str:
    """The twin's sensor id, else the board's identity line."""
    sensor_params = getattr(world, "sensor", None)
    if sensor_params is not None and getattr(sensor_params, "sensor_id", None):
        return str(sensor_params.sensor_id)
    return rig.devices.sensor


class StudyRun:
    """One run of the study on an open rig session.

    Parameters
    ----------
    rig
        The open session (not yet started: ``run`` starts it).
    config
        The full study configuration (``whiskercal.study.config.load_config``).
    writer
        The study file, new or being resumed.
    world
        The twin's world when the sensor port is simulated (for /truth), else None.
    progress
        Called with a ``whiskercal.progress.Progress`` (trials done of the total, rate, time
        left) before each trial and at the end.
    """

    def __init__(self, rig: RigSession, config: dict, writer: StudyWriter, world=None,
                 progress: ProgressCallback | None = None):
        self.rig, self.config, self.writer, self.world = rig, config, writer, world
        self.geometry = PlaneGeometry.from_config(config)
        if world is not None:
            truth_module.check_world(world, self.geometry)
        self.progress = progress or (lambda info: None)
        self.static_field_uT = np.full(3, np.nan)
        self.rate_hz = float(config["sensor"]["rate_hz"])

    # -- the whole run -------------------------------------------------------------------------
    def run(self) -> RunSummary:
        """Do every trial that the file does not hold yet; return what was done."""
        summary = RunSummary(out=str(self.writer.path))
        # the plan with first contact where the geometry expects it, before anything moves
        self._check_travel(self.geometry.contact_guess_stage_mm())
        self.rig.start()
        contact = self._baseline_and_contact(self.writer.header())
        summary.first_contact_stage_mm = contact.tolist()
        self._check_travel(contact)
        self._trials(contact, summary)
        self.writer.mark_complete()
        summary.complete = True
        session = self.rig.summary()
        summary.stage_time_s, summary.wall_time_s = session.stage_time_s, session.wall_time_s
        summary.dropped, summary.corrupt = session.dropped, session.corrupt
        return summary

    def _trials(self, contact: np.ndarray, summary: RunSummary) -> None:
        """Run and store every planned depth that the file does not hold yet."""
        done = set(self.writer.done_depths())
        depths = [float(d) for d in self.config["trials"]["depths_mm"]]
        summary.trials_skipped = [d for d in depths if d in done]
        frames = np.zeros(3, int)  # kept, dropped, corrupt
        wall_start = time.monotonic()
        for depth in (d for d in depths if d not in done):
            self._report_progress(summary, depths, wall_start)
            record = self._trial(contact, depth)
            self.writer.add_trial(record)
            summary.trials_done.append(depth)
            frames += (record.stream["seq"].size, record.attrs["dropped"], record.attrs["corrupt"])
        self._frame_loss(summary, frames)
        self._report_progress(summary, depths, wall_start)

    def _frame_loss(self, summary: RunSummary, frames: np.ndarray) -> None:
        """The trials' lost fraction of frames, and a warning above ``safety.max_frame_loss``."""
        kept, dropped, corrupt = (int(v) for v in frames)
        summary.frame_loss = frame_loss(kept, dropped, corrupt)
        warning = frame_loss_warning(kept, dropped, corrupt,
                                     float(self.config["safety"]["max_frame_loss"]))
        summary.warnings = [warning] if warning else []

    def _report_progress(self, summary: RunSummary, depths: list[float], wall_start: float) -> None:
        """Tell the progress callback how many trials are done."""
        done = len(summary.trials_skipped) + len(summary.trials_done)
        self.progress(Progress(done=done, total=len(depths), taken_now=len(summary.trials_done),
                               elapsed_s=time.monotonic() - wall_start))

    # -- soft limits ---------------------------------------------------------------------------
    def _check_travel(self, contact_stage_mm: np.ndarray) -> None:
        """Refuse the run before moving when any waypoint leaves the stage's travel."""
        travel = self.rig.travel_mm
        margin = float(self.config["safety"]["travel_margin_mm"])
        for depth in self.config["trials"]["depths_mm"]:
            points = self.geometry.trial_waypoints_stage_mm(contact_stage_mm, float(depth), self.config)
            for name, point in points.items():
                if self.rig.outside_travel(point, margin):
                    raise UsageError(
                        f"the trial at {depth:g} mm needs the stage at ({point[0]:.1f}, {point[1]:.1f}) mm "
                        f"({name.replace('_', ' ')}), outside its travel 0..{travel[0]:g} x 0..{travel[1]:g} mm "
                        f"less {margin:g} mm; change geometry or trials in the configuration")

    # -- moves and measurements ----------------------------------------------------------------
    def _move(self, target_mm: np.ndarray, speed_mm_s: float, recorder: StreamRecorder | None,
              phase: int) -> None:
        """Move in a straight line (G1) and wait, reading the sensor meanwhile."""
        if recorder is not None:
            recorder.phase = phase
        self.rig.move_to_stage(target_mm, speed_mm_s * 60.0,
                               on_poll=recorder.on_poll if recorder is not None else None)

    def _move_clear(self, target_mm: np.ndarray, speed_mm_s: float) -> None:
        """Move to ``target_mm``, whose plane stands short of the tip, by the shortest path whose
        plate never holds a point of the undeflected whisker and which stays inside the travel
        (``PlaneGeometry.clear_paths_stage_mm``): a straight move from home can carry the plate
        across the whole wire."""
        here = self.rig.position_stage_mm()
        margin = float(self.config["safety"]["travel_margin_mm"])
        for path in self.geometry.clear_paths_stage_mm(here, target_mm):
            inside = not any(self.rig.outside_travel(point, margin) for point in path[1:-1])
            if inside and not self.geometry.path_touches_wire(path):
                for point in path[1:]:
                    self._move(point, speed_mm_s, None, PHASE_APPROACH)
                return
        raise UsageError(
            f"no path inside the stage's travel carries the plate from ({here[0]:.1f}, "
            f"{here[1]:.1f}) mm to the contact search at ({target_mm[0]:.1f}, {target_mm[1]:.1f}) "
            "mm without touching the whisker; move the plate clear of the tip by hand, or check "
            "[geometry] (the plate's size, the whisker's origin)")

    def _mean_field(self, samples: int) -> tuple[np.ndarray, np.ndarray]:
        """Mean and spread (µT) of samples converted after the stage came to rest."""
        block = self.rig.measure(samples)
        return block.field_uT.mean(axis=0), block.field_uT.std(axis=0)

    # -- baseline and first contact ------------------------------------------------------------
    def _baseline_and_contact(self, header: dict) -> np.ndarray:
        contact_cfg = self.config["contact"]
        rapid = float(self.config["trials"]["rapid_speed_mm_s"])
        push = self.geometry.to_stage_vector(self.geometry.push_whisker)
        start = self.geometry.contact_guess_stage_mm() - float(contact_cfg["search_start_mm"]) * push
        self._move_clear(start, rapid)
        baseline, baseline_std = self._mean_field(int(contact_cfg["baseline_samples"]))
        self.static_field_uT = baseline
        if "first_contact_stage_mm" in header:
            # a resumed run keeps distance 0 where the first run found it
            return np.asarray(header["first_contact_stage_mm"], float)
        contact, z_uT = self._search_contact(start, push)
        self.writer.write_header(baseline, baseline_std, contact, z_uT)
        return contact

    def _search_contact(self, start: np.ndarray, push: np.ndarray) -> tuple[np.ndarray, float]:
        """Step in along the normal until |z| passes the threshold; return where contact began.

        The onset is the steps' z extrapolated back to zero (``detect.contact_onset_mm``), not
        the step past the threshold, which lies threshold/slope deeper.
        """
        cfg = self.config["contact"]
        step, limit = float(cfg["search_step_mm"]), float(cfg["search_max_mm"])
        speed = float(self.config["trials"]["approach_speed_mm_s"])
        steps: list[tuple[float, float, float]] = []  # (distance mm, z µT, sample std µT)
        for k in range(1, int(np.ceil(limit / step)) + 1):
            position = start + k * step * push
            self._move(position, speed, None, PHASE_APPROACH)
            mean, std = self._mean_field(int(cfg["samples_per_step"]))
            z_uT = float(mean[SENSOR_AXIS_Y] - self.static_field_uT[SENSOR_AXIS_Y])
            steps.append((k * step, z_uT, float(std[SENSOR_AXIS_Y])))
            if abs(z_uT) > float(self.config["safety"]["overload_uT"]):
                self._back_off(start)  # straight back to retract_mm behind the search start
                raise OverloadError(f"deflection |z| reached {abs(z_uT):.0f} µT during the contact "
                                    "search, beyond the overload guard; the plane was backed off")
            if abs(z_uT) > float(cfg["threshold_uT"]):
                self._move(start, speed, None, PHASE_RETRACT)
                distance, z_steps, std = np.array(steps).T
                noise = float(np.median(std)) / np.sqrt(int(cfg["samples_per_step"]))
                return start + contact_onset_mm(distance, z_steps, noise) * push, z_uT
        self._move(start, speed, None, PHASE_RETRACT)
        raise NoContactError(f"the plane did not touch the whisker within {limit:g} mm of the search "
                             f"start ({start[0]:.1f}, {start[1]:.1f}) mm; check the geometry in the "
                             "configuration")

    # -- one trial -----------------------------------------------------------------------------
    def _trial(self, contact: np.ndarray, depth_mm: float) -> TrialRecord:
        trials = self.config["trials"]
        points = self.geometry.trial_waypoints_stage_mm(contact, depth_mm, self.config)
        self._move(points["retracted_start"], float(trials["rapid_speed_mm_s"]), None, PHASE_RETRACT)
        # the trial's stream starts with the samples converted after the stage came to rest
        fresh_from_s = self.rig.sync()
        recorder = StreamRecorder(self.rig.sensor, self.rate_hz, self.static_field_uT[SENSOR_AXIS_Y],
                                  float(self.config["safety"]["overload_uT"]),
                                  self.rig.stage_clock, res=int(self.config["sensor"]["res"]),
                                  fresh_from_s=fresh_from_s)
        try:
            self._move(points["slide_start"], float(trials["approach_speed_mm_s"]), recorder, PHASE_APPROACH)
            self._move(points["slide_end"], float(trials["speed_mm_s"]), recorder, PHASE_SLIDE)
            self._move(points["retracted_end"], float(trials["rapid_speed_mm_s"]), recorder, PHASE_RETRACT)
        except OverloadError:
            self._back_off(contact)
            raise
        return self._record(recorder, depth_mm, points)

    def _back_off(self, reference_stage_mm: np.ndarray) -> None:
        """Stop, then retreat straight along the normal to ``retract_mm`` behind the reference
        (first contact) so the whisker is unloaded without sliding the plane."""
        push = self.geometry.to_stage_vector(self.geometry.push_whisker)
        retract_mm = float(self.config["trials"]["retract_mm"])

        def behind_reference(here_mm: np.ndarray) -> np.ndarray:
            depth = float(self.geometry.depth_of_stage_mm(here_mm, reference_stage_mm)[0])
            return here_mm - (depth + retract_mm) * push

        self.rig.back_off(behind_reference,
                          float(self.config["trials"]["approach_speed_mm_s"]) * 60.0)

    def _record(self, recorder: StreamRecorder, depth_mm: float, points: dict) -> TrialRecord:
        stream = recorder.stream_arrays()
        stage = recorder.stage_arrays()
        n = stream["seq"].size
        stage_per_sample = stage_position_per_sample(stage, n)
        point, normal = self.geometry.plane_line_whisker(stage_per_sample)
        attrs = {"slide_start_stage_mm": points["slide_start"], "slide_end_stage_mm": points["slide_end"],
                 "speed_mm_s": float(self.config["trials"]["speed_mm_s"]),
                 "travel_mm": float(self.config["trials"]["travel_mm"]),
                 "static_field_uT": self.static_field_uT,
                 "dropped": recorder.dropped, "corrupt": recorder.corrupt}
        truth = (truth_module.per_sample(self.world, stream["t_s"], self.rate_hz)
                 if self.world is not None else None)
        return TrialRecord(depth_mm=depth_mm, stream=stream, stage=stage,
                           plane={"point_mm": point, "normal": normal}, attrs=attrs, truth=truth)
