"""The acquisition loop: baseline, every grid point, after-baseline, with the safety checks.

The clients are injected (``StageClient``/``SensorClient`` or anything with the same methods,
docs/architecture.md), so the loop runs the same against a real rig, the twin and test fakes.
Nothing here sleeps: waiting is reading the sensor stream, which also keeps the serial buffer
from overflowing while the stage moves.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np

from whiskercal.artifacts.raw_grid import Baseline, PointRecord
from whiskercal.collect.checkpoint import Checkpoint
from whiskercal.collect.plan import GridPlan, Move
from whiskercal.collect.recorder import StreamRecorder, field_stats
from whiskercal.rig.overload import OverloadError, describe_axes
from whiskercal.errors import DeviceError
from whiskercal.rig.stage import StageAlarmError

# grbl's alarm for an encoder/step disagreement (docs/protocol.md).
ALARM_ENCODER_MISMATCH = 10
# How much sensor time each status poll waits for while the stage moves, s.
_POLL_S = 0.02


class EncoderMismatchError(DeviceError):
    """The stage's encoders and step counters disagree: missed steps or a stall."""


@dataclass
class Devices:
    """What identifying the devices found."""

    stage: dict[str, Any]
    sensor: str
    has_encoder: bool
    stage_settings: dict[int, float] = field(default_factory=dict)


@dataclass
class Progress:
    """Where the run is: points done (total, including resumed ones), points planned, rates."""

    done: int
    total: int
    taken_now: int
    elapsed_s: float

    @property
    def rate_per_s(self) -> float:
        """Points per second of wall time in this session."""
        return self.taken_now / self.elapsed_s if self.elapsed_s > 0 else 0.0

    @property
    def remaining_s(self) -> float:
        """Estimated wall time to finish, s (inf before the first point)."""
        rate = self.rate_per_s
        return (self.total - self.done) / rate if rate > 0 else float("inf")


def identify(stage, sensor) -> Devices:
    """Identify both devices and read the stage's settings (travel, encoder, tolerance)."""
    identity = stage.identify()
    settings = stage.settings()
    stage_info = {"version": identity.version, "name": identity.name, "proto": identity.proto,
                  "has_encoder": bool(identity.has_encoder)}
    return Devices(stage_info, sensor.identify(), bool(identity.has_encoder), settings)


class Collector:
    """Runs one collection session over the points of ``plan`` not yet in ``checkpoint``.

    Parameters
    ----------
    stage, sensor
        Connected clients (docs/architecture.md API).
    plan
        The grid plan; its config holds every setting.
    checkpoint
        Where each point goes, durably, as it is taken.
    devices
        The result of :func:`identify`.
    truth
        Callable returning the twin's ground truth (dict of ``TRUTH_FIELDS``) at the current
        instant, or None on a real rig.
    on_progress, stop_requested
        Called after each point; ``stop_requested()`` True stops after the current point.
    """

    def __init__(self, stage, sensor, plan: GridPlan, checkpoint: Checkpoint, devices: Devices,
                 truth: Callable[[], dict[str, Any]] | None = None,
                 on_progress: Callable[[Progress], None] | None = None,
                 stop_requested: Callable[[], bool] | None = None) -> None:
        self.stage, self.sensor, self.plan = stage, sensor, plan
        self.checkpoint, self.devices, self.truth = checkpoint, devices, truth
        self.on_progress = on_progress or (lambda progress: None)
        self.stop_requested = stop_requested or (lambda: False)
        self.config = plan.config
        resume_from = None
        if checkpoint.last_device_t_s is not None:
            resume_from = (checkpoint.last_device_t_s, checkpoint.last_wall_s)
        self.recorder = StreamRecorder(sensor, self.config.sensor.rate_hz, self.config.sensor.res,
                                       resume_from)
        self.recorder.overload_z_uT = self.config.safety.overload_z_uT
        self.here_mm: np.ndarray | None = None
        self.taken_now = 0
        self.stopped = False

    # -- the run ----------------------------------------------------------------------------
    def run(self) -> bool:
        """Take every remaining point and the after-baseline; True when the file is complete."""
        self._prepare_stage()
        self._start_sensor()
        try:
            self._baseline_before()
            started = time.monotonic()
            for index in range(len(self.plan)):
                if index in self.checkpoint.taken:
                    continue
                self._take_point(index)
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
        finally:
            self._stop_sensor()

    def _prepare_stage(self) -> None:
        """Home, or require a homed stage, as configured."""
        if self.config.motion.home:
            self.stage.home()
            return
        status = self.stage.status()
        if status.alarm:
            raise DeviceError("stage is in alarm (not homed); home it ($H) or set "
                              "motion.home = true in the config")
        self.here_mm = self.plan.to_whisker(status.mpos_mm)

    def _start_sensor(self) -> None:
        settings = self.config.sensor
        self.sensor.stop()  # a board left streaming refuses settings (ERR:3)
        self.sensor.configure(rate_hz=settings.rate_hz, gain=settings.gain, res=settings.res,
                              osr=settings.osr, filt=settings.filt)
        self.sensor.start()

    def _stop_sensor(self) -> None:
        try:
            self.sensor.stop()
        except DeviceError:
            pass  # an unplugged sensor: the error that ended the run is the one to report

    # -- baselines --------------------------------------------------------------------------
    def _baseline_before(self) -> None:
        before = self.checkpoint.baselines.get("before")
        if before is None:
            self._park()
            before = self._static_reading()
            self.checkpoint.set_baseline("before", before)
        self.recorder.static_y_uT = float(before.field_uT[1])

    def _baseline_after(self) -> None:
        self._park()
        self.checkpoint.set_baseline("after", self._static_reading())
        self.checkpoint.add_stream(self.recorder.take_chunk())

    def _static_reading(self) -> Baseline:
        acq = self.config.acquisition
        self.recorder.drain(guard=False)
        if acq.settle_s > 0:
            self.recorder.read_for(acq.settle_s, guard=False)
        block = self.recorder.read(acq.baseline_samples, guard=False)
        axes = self.recorder.saturated_axes(block)
        if axes:
            settings = self.config.sensor
            raise DeviceError(f"{describe_axes(axes)} saturated with the whisker at rest at "
                              f"GAIN_SEL {settings.gain}, RES {settings.res}: choose settings with a "
                              "wider range in [sensor] (docs/firmware.md)")
        mean, std, _ = field_stats(block)
        return Baseline(mean, std, float(np.mean(block.t_s)))

    def _park(self) -> None:
        here = self.here_mm if self.here_mm is not None else self._position_mm()
        self._execute(self.plan.moves_to(here, self.plan.park_mm, to_park=True))

    def _position_mm(self) -> np.ndarray:
        return self.plan.to_whisker(self.stage.status().mpos_mm)

    # -- one point --------------------------------------------------------------------------
    def _take_point(self, index: int) -> None:
        target = self.plan.rod_center_mm[index]
        here = self.here_mm if self.here_mm is not None else self._position_mm()
        status = self._execute(self.plan.moves_to(here, target), point=index)
        encoder = self._check_encoder(status, index)
        acq = self.config.acquisition
        try:
            self.recorder.drain()
            if acq.settle_s > 0:
                self.recorder.read_for(acq.settle_s)
            block = self.recorder.read(acq.samples_per_point, label=index)
        except OverloadError:
            self._retract()
            raise
        truth = self.truth() if self.truth is not None else None
        self.checkpoint.add_point(self._record(index, status, encoder, block),
                                  self.recorder.take_chunk(), truth)

    def _record(self, index: int, status, encoder: np.ndarray, block) -> PointRecord:
        mean, std, n_valid = field_stats(block)
        dropped, corrupt = self.recorder.take_counts()
        measured = encoder if np.all(np.isfinite(encoder)) else status.mpos_mm
        return PointRecord(plan_index=index, commanded_mm=self.plan.stage_mm[index].copy(),
                           encoder_mm=encoder, rod_center_mm=self.plan.to_whisker(measured),
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

    # -- motion -----------------------------------------------------------------------------
    def _execute(self, moves: list[Move], point: int = -1):
        """Run moves one by one, reading the sensor while each runs; return the last status."""
        status = None
        for move in moves:
            stage_xy = self.plan.to_stage(move.end_mm)
            try:
                self.stage.move_to(float(stage_xy[0]), float(stage_xy[1]), move.feed_mm_min)
                status = self.stage.wait_idle(self.config.motion.move_timeout_s,
                                              on_poll=self._read_while_moving)
            except OverloadError:
                self._back_off()
                raise
            except DeviceError as error:
                explained = _explain_alarm(error, point)
                if explained is error:
                    raise
                raise explained from error
            self.here_mm = move.end_mm
        return status if status is not None else self.stage.status()

    def _read_while_moving(self, status) -> None:
        self.recorder.read_for(_POLL_S)

    def _back_off(self) -> None:
        """Stop a move that overloads the whisker and lift the rod clear of it."""
        self.stage.hold()
        self._wait_stopped()
        self.stage.reset()
        if self.stage.status().alarm:
            self.stage.unlock()
        self.here_mm = None
        self._retract()

    def _wait_stopped(self) -> None:
        """Poll until a feed hold has brought the stage to rest (``Hold:1`` or ``Idle``)."""
        polls = int(self.config.motion.move_timeout_s / _POLL_S)
        for _ in range(polls):
            state = self.stage.status().state
            if state in ("Hold:1", "Idle") or state.startswith("Alarm"):
                return
            self.recorder.read_for(_POLL_S, guard=False)
        raise DeviceError("stage did not come to rest after a feed hold; check it by hand")

    def _retract(self) -> None:
        """Move the rod straight up (+y) to the safe height above the whisker."""
        here = self._position_mm()
        safe = np.array([here[0], max(here[1], self.config.approach.safe_y_mm)])
        if not np.allclose(here, safe):
            stage_xy = self.plan.to_stage(safe)
            self.stage.move_to(float(stage_xy[0]), float(stage_xy[1]),
                               self.config.motion.travel_feed_mm_min)
            self.stage.wait_idle(self.config.motion.move_timeout_s,
                                 on_poll=lambda status: self.recorder.read_for(_POLL_S, guard=False))
        self.here_mm = safe


def _explain_alarm(error: DeviceError, point: int) -> DeviceError:
    """Give the encoder alarm the same clear message as the host's own comparison."""
    if isinstance(error, StageAlarmError) and error.code == ALARM_ENCODER_MISMATCH:
        where = f" at point {point}" if point >= 0 else ""
        return EncoderMismatchError(
            f"stage encoder and step positions disagree{where} (ALARM:10): missed steps or a "
            "stall; re-home the stage and continue with --resume")
    return error
