"""The acquisition loop: baseline, every grid point, after-baseline, with the safety checks.

The loop runs on a ``RigSession`` (whiskercal/session), which holds the clients, the frames,
the moves, the halt and the measurement on samples chosen by the sensor's own clock; so the loop
runs the same against a real rig, the twin and test fakes. Nothing here sleeps: waiting is
reading the sensor stream, which also keeps the serial buffer from overflowing while the stage
moves.
"""

from __future__ import annotations

import time
from typing import Any, Callable

import numpy as np

from whiskercal.artifacts.raw_grid import Baseline, PointRecord
from whiskercal.collect.checkpoint import Checkpoint
from whiskercal.collect.plan import GridPlan, Move
from whiskercal.collect.recorder import StreamRecorder, field_stats
from whiskercal.errors import DeviceError
from whiskercal.progress import Progress
from whiskercal.protocol.codes import StageAlarm
from whiskercal.rig.overload import OverloadError, describe_axes
from whiskercal.rig.stage import StageAlarmError
from whiskercal.session import Devices, EncoderMismatchError, RigSession
from whiskercal.session.rig_session import POLL_S

__all__ = ["Collector", "Devices", "EncoderMismatchError", "Progress"]

# Two quanta of an AS5600 on a 40 mm belt turn (40/4096 mm): an encoder reading this close to the
# step count agrees with it, whichever way it rounded.
STEP_COUNT_AGREES_MM = 0.02


def rod_position_mm(step_mm, encoder_mm) -> np.ndarray:
    """Where the carriage stands (stage mm): the step count where the encoder agrees with it to
    within the encoder's resolution (``STEP_COUNT_AGREES_MM``), else the encoder.

    The step count resolves a microstep (1/80 mm on the default stage) where a magnetic encoder
    reads a quantum of about 1/100 mm and its nonlinearity on top; the field's slope near the
    tip turns that quantum into more than the noise of a point's mean (docs/calibration.md,
    "Where the rod stands"). The encoder still checks every point (``_check_encoder``): where the
    two part by more than its resolution, steps were lost and the encoder is the measurement.
    """
    step = np.asarray(step_mm, float)
    encoder = np.asarray(encoder_mm, float)
    if not np.all(np.isfinite(encoder)) or np.max(np.abs(encoder - step)) <= STEP_COUNT_AGREES_MM:
        return step.copy()
    return encoder.copy()


class Collector:
    """Runs one collection session over the points of ``plan`` not yet in ``checkpoint``.

    Parameters
    ----------
    rig
        The open rig session (not yet started: ``run`` starts it).
    plan
        The grid plan; its config holds every setting.
    checkpoint
        Where each point goes, durably, as it is taken.
    truth
        ``truth(t_start_s, t_end_s)``: the twin's ground truth (dict of ``TRUTH_FIELDS``) over
        the board times of a point's samples, or None on a real rig.
    on_progress, stop_requested
        Called after each point; ``stop_requested()`` True stops after the current point.
    """

    def __init__(self, rig: RigSession, plan: GridPlan, checkpoint: Checkpoint,
                 truth: Callable[[float, float], dict[str, Any]] | None = None,
                 on_progress: Callable[[Progress], None] | None = None,
                 stop_requested: Callable[[], bool] | None = None) -> None:
        self.rig, self.plan, self.checkpoint, self.truth = rig, plan, checkpoint, truth
        self.on_progress = on_progress or (lambda progress: None)
        self.stop_requested = stop_requested or (lambda: False)
        self.config = plan.config
        resume_from = None
        if checkpoint.last_device_t_s is not None:
            resume_from = (checkpoint.last_device_t_s, checkpoint.last_wall_s)
        self.recorder = StreamRecorder(rig.sensor, self.config.sensor.rate_hz, self.config.sensor.res,
                                       resume_from)
        self.recorder.overload_z_uT = self.config.safety.overload_z_uT
        # every sample the session reads on its own (halts, retreats, settling) is kept too
        rig.sink = lambda block: self.recorder.keep(block, -1, guard=False)
        self.here_mm: np.ndarray | None = None
        self.taken_now = 0
        self.stopped = False
        # plan indices skipped because the guard tripped at or above them in their column
        self.beyond_guard: set[int] = set()
        # sensor-clock times (s) bounding this run's points: the rod leaving the park position
        # after the baseline (or the first point's first sample on a resume), the last sample
        self.points_from_s: float | None = None
        self.points_to_s: float | None = None

    @property
    def points_time_s(self) -> float | None:
        """Sensor-clock time from the rod leaving the baseline to the last point's last sample
        (s), this run; None before a point is taken."""
        if self.points_from_s is None or self.points_to_s is None:
            return None
        return self.points_to_s - self.points_from_s

    @property
    def devices(self) -> Devices:
        """What identifying the boards found."""
        return self.rig.devices

    # -- the run ----------------------------------------------------------------------------
    def run(self) -> bool:
        """Take every remaining point and the after-baseline; True when the file is complete."""
        self.rig.start()
        self._baseline_before()
        started = time.monotonic()
        for index in range(len(self.plan)):
            if index in self.checkpoint.taken or index in self.beyond_guard:
                continue
            try:
                self._take_point(index)
            except OverloadError:
                if self.config.safety.on_overload == "stop":
                    raise
                self._end_column(index)
                continue
            self.taken_now += 1
            self.on_progress(Progress(len(self.checkpoint.taken), len(self.plan),
                                      self.taken_now, time.monotonic() - started))
            if self.stop_requested():
                self.stopped = True
                self._retract()
                self.checkpoint.add_stream(self.recorder.take_chunk())
                return False
        self._baseline_after()
        return True

    def _end_column(self, index: int) -> None:
        """Skip ``index`` and the deeper points of its column (the rod is already backed off)."""
        points = self.plan.rod_center_mm
        # a tip-sweep point stands alone: its neighbours lie on other rays
        part = np.arange(len(points)) >= self.plan.sweep_from
        same_column = np.isclose(points[:, 0], points[index, 0]) & (part == part[index])
        if part[index]:
            same_column &= np.arange(len(points)) == index
        deeper = np.flatnonzero(same_column & (points[:, 1] <= points[index, 1]))
        self.beyond_guard.update(int(i) for i in deeper if int(i) not in self.checkpoint.taken)
        self.checkpoint.add_stream(self.recorder.take_chunk())

    # -- baselines --------------------------------------------------------------------------
    def _baseline_before(self) -> None:
        before = self.checkpoint.baselines.get("before")
        if before is None:
            self._park()
            before = self._static_reading()
            self.checkpoint.set_baseline("before", before)
            self.points_from_s = self._baseline_end_s
        self.recorder.static_y_uT = float(before.field_uT[1])

    def _baseline_after(self) -> None:
        self._park()
        self.checkpoint.set_baseline("after", self._static_reading())
        self.checkpoint.add_stream(self.recorder.take_chunk())

    def _static_reading(self) -> Baseline:
        acq = self.config.acquisition
        block = self.recorder.keep(self.rig.measure(acq.baseline_samples, acq.settle_s), guard=False)
        axes = self.recorder.saturated_axes(block)
        if axes:
            settings = self.config.sensor
            raise DeviceError(f"{describe_axes(axes)} saturated with the whisker at rest at "
                              f"GAIN_SEL {settings.gain}, RES {settings.res}: choose settings with a "
                              "wider range in [sensor] (docs/firmware.md)")
        mean, std, _ = field_stats(block)
        self._baseline_end_s = float(block.t_s[-1])
        return Baseline(mean, std, float(np.mean(block.t_s)))

    def _park(self) -> None:
        here = self.here_mm if self.here_mm is not None else self.rig.position_mm()
        self._execute(self.plan.moves_to(here, self.plan.park_mm, to_park=True))

    # -- one point --------------------------------------------------------------------------
    def _take_point(self, index: int) -> None:
        target = self.plan.rod_center_mm[index]
        here = self.here_mm if self.here_mm is not None else self.rig.position_mm()
        status = self._execute(self.plan.moves_to(here, target), point=index)
        encoder = self._check_encoder(status, index)
        acq = self.config.acquisition
        try:
            samples = self.rig.measure(acq.samples_per_point, acq.settle_s,
                                       on_stale=lambda older: self.recorder.keep(older, -1))
            block = self.recorder.keep(samples, label=index)
        except OverloadError:
            self._retract()
            raise
        self._confirm_still(encoder, index)
        if self.points_from_s is None:  # resumed: the baseline was measured before
            self.points_from_s = float(samples.t_s[0])
        self.points_to_s = float(samples.t_s[-1])
        truth = None
        if self.truth is not None:
            truth = self.truth(float(samples.t_s[0]), float(samples.t_s[-1]))
        self.checkpoint.add_point(self._record(index, status, encoder, block),
                                  self.recorder.take_chunk(), truth)

    def _record(self, index: int, status, encoder: np.ndarray, block) -> PointRecord:
        mean, std, n_valid = field_stats(block)
        dropped, corrupt = self.recorder.take_counts()
        return PointRecord(plan_index=index, commanded_mm=self.plan.stage_mm[index].copy(),
                           encoder_mm=encoder, rod_center_mm=self.plan.to_whisker(rod_position_mm(status.mpos_mm, encoder)),
                           field_mean_uT=mean, field_std_uT=std, n_samples=n_valid,
                           t_start_s=float(block.t_s[0]), t_end_s=float(block.t_s[-1]),
                           dropped=dropped, corrupt=corrupt)

    def _check_encoder(self, status, index: int) -> np.ndarray:
        """The encoder position (NaN without encoders); a disagreement stops the run."""
        if not self.devices.has_encoder or status.enc_mm is None:
            return np.full(2, np.nan)
        error_mm = float(np.max(np.abs(np.asarray(status.enc_mm) - status.mpos_mm)))
        tolerance = self.config.safety.encoder_tolerance_mm
        if error_mm > tolerance:
            raise EncoderMismatchError(
                f"stage encoder and step positions disagree by {error_mm:.2f} mm at point {index} "
                f"(tolerance {tolerance:g} mm): missed steps or a stall; re-home the stage and "
                "continue with --resume")
        return np.asarray(status.enc_mm, float).copy()

    def _confirm_still(self, encoder_mm: np.ndarray, index: int) -> None:
        """Steps missed while the samples were read move the rod under them, after the check
        before: read the encoder again and refuse the point (it is re-taken on resume) when the
        stage alarmed or the position moved, rather than save it where the rod no longer was."""
        if not np.all(np.isfinite(encoder_mm)):
            return  # no encoder: nothing measures the carriage (docs/inputs-and-outputs.md)
        try:
            status = self.rig.status()
        except StageAlarmError as error:
            if error.code != StageAlarm.ENCODER_MISMATCH:
                raise
            status = None
        after = None if status is None or status.alarm else self._check_encoder(status, index)
        moved = np.inf if after is None else float(np.max(np.abs(after - encoder_mm)))
        if moved > self.config.safety.encoder_tolerance_mm:
            how = (f"the stage raised ALARM:{int(StageAlarm.ENCODER_MISMATCH)}" if after is None
                   else f"it moved {moved:.2f} mm")
            raise EncoderMismatchError(
                f"stage encoder position changed while point {index} was sampled ({how}): missed "
                "steps or a stall; the point was not saved; re-home the stage and continue with "
                "--resume")

    # -- motion -----------------------------------------------------------------------------
    def _execute(self, moves: list[Move], point: int = -1):
        """Run moves one by one, reading the sensor while each runs; return the last status."""
        status = None
        for move in moves:
            try:
                status = self.rig.move_to(move.end_mm, move.feed_mm_min, on_poll=self._read_while_moving,
                                          where=f" at point {point}" if point >= 0 else "")
            except OverloadError:
                self._back_off()
                raise
            self.here_mm = move.end_mm
        return status if status is not None else self.rig.status()

    def _read_while_moving(self, status) -> None:
        self.recorder.read_for(POLL_S)

    def _back_off(self) -> None:
        """Stop a move that overloads the whisker and lift the rod clear of it."""
        self.here_mm = None
        self.rig.back_off(lambda here_stage_mm: self.plan.to_stage(
            self._safe_above(self.plan.to_whisker(here_stage_mm))),
            self.config.motion.travel_feed_mm_min)

    def _retract(self) -> None:
        """Move the rod straight up (+y) to the safe height above the whisker."""
        here = self.rig.position_mm()
        safe = self._safe_above(here)
        if not np.allclose(here, safe):
            self.rig.move_to(safe, self.config.motion.travel_feed_mm_min)
        self.here_mm = safe

    def _safe_above(self, here_mm: np.ndarray) -> np.ndarray:
        """Straight above a whisker-frame position, at least at the safe y, mm."""
        return np.array([here_mm[0], max(here_mm[1], self.config.approach.safe_y_mm)])
