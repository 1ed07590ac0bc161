"""The flat-plane study on the rig: first contact, then one slide per depth, checkpointed per trial.

Order of work (docs/study.md):

1. identify both devices, home the stage (or require it homed), check every waypoint of every
   trial against the stage's travel (soft limits) before anything moves;
2. configure and start the sensor; park the plane clear of the whisker and measure the static
   baseline;
3. find first contact: step the plane in along its normal until |z| exceeds the threshold; that
   stage position is distance 0 (stored, so a resumed run does not search again);
4. per missing depth: back off, go to the slide start, push in to the depth, slide at constant
   velocity along the plane (a G1 with both axes when the plane is not aligned with one) while
   recording the stream and the stage's status, back off; add the trial to the file atomically.

The clients are passed in (``StageClient``/``SensorClient`` or anything with their methods), so
the loop runs unchanged on a real rig, on the twin and against test fakes.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from whiskercal.artifacts.plane_study import (PHASE_APPROACH, PHASE_RETRACT, PHASE_SLIDE,
                                              StudyWriter, TrialRecord)
from whiskercal.collect.loop import Progress
from whiskercal.errors import DeviceError, UsageError
from whiskercal.study import truth as truth_module
from whiskercal.study.config import PlaneGeometry
from whiskercal.study.detect import contact_onset_mm
from whiskercal.rig.overload import SENSOR_AXIS_Y, OverloadError
from whiskercal.study.recorder import POLL_PERIOD_S, StreamRecorder, stage_position_per_sample

ProgressCallback = Callable[[Progress], None]


class NoContactError(DeviceError):
    """The plane never touched the whisker within the search distance."""


@dataclass
class RunSummary:
    """What a run did (times on the stage port's clock: simulated on the twin)."""

    out: str
    trials_done: list[float] = field(default_factory=list)
    trials_skipped: list[float] = field(default_factory=list)
    complete: bool = False
    first_contact_stage_mm: list[float] = field(default_factory=list)
    stage_time_s: float = 0.0
    dropped: int = 0
    corrupt: int = 0


class StudyRun:
    """One run of the study against a stage and a sensor.

    Parameters
    ----------
    stage, sensor
        Open clients (see docs/architecture.md, "The rig interface").
    config
        The full study configuration (``whiskercal.study.config.load_config``).
    writer
        The study file, new or being resumed.
    world
        The twin's world when the sensor port is simulated (for /truth), else None.
    progress
        Called with a ``whiskercal.collect.loop.Progress`` (trials done of the total, rate, time
        left) before each trial and at the end.
    """

    def __init__(self, stage, sensor, config: dict, writer: StudyWriter, world=None,
                 progress: ProgressCallback | None = None):
        self.stage, self.sensor, self.config, self.writer = stage, sensor, config, writer
        self.world = world
        self.geometry = PlaneGeometry.from_config(config)
        if world is not None:
            truth_module.check_world(world, self.geometry)
        self.progress = progress or (lambda info: None)
        self.clock = getattr(getattr(stage, "transport", None), "now_s", None) or (lambda: 0.0)
        self.static_field_uT = np.full(3, np.nan)
        self.rate_hz = float(config["sensor"]["rate_hz"])
        self._poll_samples = max(1, int(self.rate_hz * POLL_PERIOD_S))

    # -- the whole run -------------------------------------------------------------------------
    def run(self) -> RunSummary:
        """Do every trial that the file does not hold yet; return what was done."""
        summary = RunSummary(out=str(self.writer.path))
        started = self.clock()
        # the plan with first contact where the geometry expects it, before anything moves
        self._check_travel(self.geometry.contact_guess_stage_mm())
        self._prepare()
        try:
            contact = self._baseline_and_contact(self.writer.header())
            summary.first_contact_stage_mm = contact.tolist()
            self._check_travel(contact)
            self._trials(contact, summary)
            self.writer.mark_complete()
            summary.complete = True
        except KeyboardInterrupt:
            self._stop_stage()  # the trial in progress is dropped; --resume redoes it
            raise
        finally:
            self._stop_sensor()
        summary.stage_time_s = float(self.clock() - started)
        return summary

    def _trials(self, contact: np.ndarray, summary: RunSummary) -> None:
        """Run and store every planned depth that the file does not hold yet."""
        done = set(self.writer.done_depths())
        depths = [float(d) for d in self.config["trials"]["depths_mm"]]
        summary.trials_skipped = [d for d in depths if d in done]
        wall_start = time.monotonic()
        for depth in (d for d in depths if d not in done):
            self._report_progress(summary, depths, wall_start)
            record = self._trial(contact, depth)
            self.writer.add_trial(record)
            summary.trials_done.append(depth)
            summary.dropped += int(record.attrs["dropped"])
            summary.corrupt += int(record.attrs["corrupt"])
        self._report_progress(summary, depths, wall_start)

    def _report_progress(self, summary: RunSummary, depths: list[float], wall_start: float) -> None:
        """Tell the progress callback how many trials are done (collect's Progress record)."""
        done = len(summary.trials_skipped) + len(summary.trials_done)
        self.progress(Progress(done=done, total=len(depths), taken_now=len(summary.trials_done),
                               elapsed_s=time.monotonic() - wall_start))

    def _prepare(self) -> None:
        self.stage.identify()
        self.sensor.identify()
        if self.config["safety"]["home"]:
            self.stage.home()
        elif self.stage.status().alarm:
            raise DeviceError("the stage is locked in alarm (not homed); home it or set "
                              "safety.home = true in the configuration")
        sensor = self.config["sensor"]
        self.sensor.configure(rate_hz=sensor["rate_hz"], gain=sensor["gain"], res=sensor["res"],
                              osr=sensor["osr"], filt=sensor["filt"])
        self.sensor.start()

    def _stop_stage(self) -> None:
        """Stop any move (feed hold, then flush the queue)."""
        try:
            self._halt()
        except DeviceError:
            pass  # the port is gone: the stage has stopped with it

    def _stop_sensor(self) -> None:
        try:
            self.sensor.stop()
        except DeviceError:
            pass  # the port may be gone (unplugged); the file already holds every finished trial

    # -- soft limits ---------------------------------------------------------------------------
    def _travel_mm(self) -> np.ndarray:
        settings = self.stage.settings()
        return np.array([settings.get(130, 200.0), settings.get(131, 200.0)], float)

    def _check_travel(self, contact_stage_mm: np.ndarray) -> None:
        """Refuse the run before moving when any waypoint leaves the stage's travel."""
        travel = self._travel_mm()
        margin = float(self.config["safety"]["travel_margin_mm"])
        for depth in self.config["trials"]["depths_mm"]:
            points = self.geometry.trial_waypoints_stage_mm(contact_stage_mm, float(depth), self.config)
            for name, point in points.items():
                if np.any(point < margin) or np.any(point > travel - margin):
                    raise UsageError(
                        f"the trial at {depth:g} mm needs the stage at ({point[0]:.1f}, {point[1]:.1f}) mm "
                        f"({name.replace('_', ' ')}), outside its travel 0..{travel[0]:g} x 0..{travel[1]:g} mm "
                        f"less {margin:g} mm; change geometry or trials in the configuration")

    # -- moves ---------------------------------------------------------------------------------
    def _move(self, target_mm: np.ndarray, speed_mm_s: float, recorder: StreamRecorder | None,
              phase: int) -> None:
        """Move in a straight line (G1) and wait, reading the sensor meanwhile."""
        if recorder is not None:
            recorder.phase = phase
        self.stage.move_to(float(target_mm[0]), float(target_mm[1]), speed_mm_s * 60.0)
        timeout = float(self.config["safety"]["move_timeout_s"])
        on_poll = recorder.on_poll if recorder is not None else self._drain
        self.stage.wait_idle(timeout, on_poll=on_poll)

    def _drain(self, status) -> None:
        """Between polls when nothing is recorded: read and discard, so the buffer never fills."""
        if not status.idle:
            self.sensor.read(self._poll_samples, timeout_s=1.0)
        self.sensor.read_available()

    def _mean_field(self, samples: int) -> tuple[np.ndarray, np.ndarray]:
        self.sensor.read_available()  # older samples were taken while moving
        block = self.sensor.read(samples, timeout_s=max(2.0, 3 * samples / self.rate_hz))
        return block.field_uT.mean(axis=0), block.field_uT.std(axis=0)

    # -- baseline and first contact ------------------------------------------------------------
    def _baseline_and_contact(self, header: dict) -> np.ndarray:
        contact_cfg = self.config["contact"]
        rapid = float(self.config["trials"]["rapid_speed_mm_s"])
        push = self.geometry.to_stage_vector(self.geometry.push_whisker)
        start = self.geometry.contact_guess_stage_mm() - float(contact_cfg["search_start_mm"]) * push
        self._move(start, rapid, None, PHASE_APPROACH)
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
        recorder = StreamRecorder(self.sensor, self.rate_hz, self.static_field_uT[SENSOR_AXIS_Y],
                                  float(self.config["safety"]["overload_uT"]), self.clock,
                                  res=int(self.config["sensor"]["res"]))
        self.sensor.read_available()
        try:
            self._move(points["slide_start"], float(trials["approach_speed_mm_s"]), recorder, PHASE_APPROACH)
            self._move(points["slide_end"], float(trials["speed_mm_s"]), recorder, PHASE_SLIDE)
            self._move(points["retracted_end"], float(trials["rapid_speed_mm_s"]), recorder, PHASE_RETRACT)
        except OverloadError:
            self._back_off(contact)
            raise
        return self._record(recorder, depth_mm, points)

    def _behind_contact(self, contact_stage_mm: np.ndarray) -> np.ndarray:
        """Where the stage is now, moved straight back along the normal to behind first contact."""
        here = np.asarray(self.stage.status().mpos_mm, float)[:2]
        depth = float(self.geometry.depth_of_stage_mm(here, contact_stage_mm)[0])
        push = self.geometry.to_stage_vector(self.geometry.push_whisker)
        return here - (depth + float(self.config["trials"]["retract_mm"])) * push

    def _halt(self) -> None:
        """Feed hold, wait until stopped, then flush the queue: a reset while the stage still
        moves would lose its position (grbl's ALARM:3); after a hold it keeps it."""
        self.stage.hold()
        for _ in range(500):  # ~10 s of 20 ms status polls
            state = self.stage.status().state
            if state.startswith("Hold:1") or state in ("Idle", "Alarm"):
                break
            self._drain_quietly()
        self.stage.reset()
        self.stage.unlock()

    def _drain_quietly(self) -> None:
        try:
            self.sensor.read(self._poll_samples, timeout_s=1.0)
        except DeviceError:
            pass

    def _back_off(self, reference_stage_mm: np.ndarray) -> None:
        """Stop, then retreat straight along the normal to ``retract_mm`` behind the reference
        (first contact) so the whisker is unloaded without sliding the plane."""
        try:
            self._halt()
            safe_mm = self._behind_contact(reference_stage_mm)
            self.stage.move_to(float(safe_mm[0]), float(safe_mm[1]),
                               float(self.config["trials"]["approach_speed_mm_s"]) * 60.0)
            self.stage.wait_idle(float(self.config["safety"]["move_timeout_s"]), on_poll=self._drain)
        except DeviceError:
            pass  # the overload is the error to report; a failed retreat must not hide it

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
