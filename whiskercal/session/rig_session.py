"""One session on the rig: both boards open, identified, configured, and left safe on every exit.

Every run that moves the stage against the whisker (collect, the flat-plane study, and later
contour following and shaft contact) does the same things around its own work: open both ports,
identify the boards and read the stage's settings, home (or require a homed stage), configure and
start the sensor, move in the whisker frame or in stage coordinates while the sensor stream is
read, take measurements on samples converted after the stage came to rest, stop and back off on
an overload, and, however the run ends (an error, Ctrl-C), halt a moving stage, stop the stream
and close the ports. ``RigSession`` does these once, for all of them::

    with RigSession.open(stage_url, sensor_url, config) as rig:
        rig.start()                        # homes (or checks homing), starts the stream
        rig.move_to(point_mm, feed_mm_min) # whisker frame
        block = rig.measure(30, settle_s=0.3)

Nothing moves before ``start()``, so a run can check its plan against the stage's travel
(``rig.travel_mm``) and open its output file first. Ground truth from the twin is not the
session's business: the pipeline stage that needs it reads it from ``rig.sensor_port``.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np

from whiskercal.errors import DeviceError
from whiskercal.protocol.codes import StageAlarm
from whiskercal.protocol.sensor_config import SensorConfig
from whiskercal.rig.machine_space import MachineSpace
from whiskercal.rig.machine_space import machine_space as board_space
from whiskercal.rig.sensor import SampleBlock
from whiskercal.rig.stage import CRITICAL_ALARMS, StageAlarmError, StageStatus
from whiskercal.session.frame import RigFrame, outside_travel

# How much sensor time each status poll waits for while the stage moves, s.
POLL_S = 0.02
# grbl settings that state the stage's travel, X and Y ($130/$131), mm.
TRAVEL_SETTINGS = (130, 131)
# A sensor whose clock never reaches the wanted time would keep a measurement reading forever.
_MAX_STALE_SAMPLES = 100_000

SampleSink = Callable[[SampleBlock], None]
PollCallback = Callable[[StageStatus], None]


class EncoderMismatchError(DeviceError):
    """The stage's encoders and step counters disagree: missed steps or a stall."""


@dataclass(frozen=True)
class SessionConfig:
    """What a session needs to know about the rig.

    ``frame`` maps the whisker frame to stage coordinates; ``sensor`` holds the board's settings;
    ``home`` runs the homing cycle at ``start()`` (else a homed stage is required);
    ``move_timeout_s`` bounds one move (s); ``travel_mm`` is the travel assumed when the stage
    does not state its own ($130/$131); ``home_setting`` names the configuration key of
    ``home`` in messages.
    """

    frame: RigFrame
    sensor: SensorConfig = field(default_factory=SensorConfig)
    home: bool = True
    move_timeout_s: float = 60.0
    travel_mm: tuple[float, float] = (200.0, 200.0)
    home_setting: str = "home"


@dataclass
class Devices:
    """What identifying the boards found: the stage's identity and settings, the sensor's."""

    stage: dict[str, Any]
    sensor: str
    has_encoder: bool
    stage_settings: dict[int, float] = field(default_factory=dict)


@dataclass(frozen=True)
class SessionSummary:
    """The parts of a run's summary the session knows: frames lost, times (s)."""

    dropped: int
    corrupt: int
    stage_time_s: float
    wall_time_s: float


class RigSession:
    """A stage and a sensor client used together (see the module's docstring).

    Parameters
    ----------
    stage, sensor
        Connected clients (``StageClient``/``SensorClient`` or anything with their methods).
    config
        The rig's geometry and settings.
    owned
        The clients this session opened and so closes.
    """

    def __init__(self, stage, sensor, config: SessionConfig, owned: tuple = ()) -> None:
        self.stage, self.sensor, self.config = stage, sensor, config
        self.devices = Devices({}, "", False)
        self.sink: SampleSink = _discard
        self._owned = owned
        self._streaming = False
        self._closed = False
        # the stage port's clock, s: simulated time on the twin
        self.stage_clock: Callable[[], float] = (
            getattr(getattr(stage, "transport", None), "now_s", None) or (lambda: 0.0))
        self._started = (self.stage_clock(), time.monotonic())

    # -- opening and closing -----------------------------------------------------------------
    @classmethod
    def open(cls, stage_port, sensor_port, config: SessionConfig, *, stage_client=None,
             sensor_client=None) -> "RigSession":
        """Connect to both boards and identify them; nothing moves yet.

        ``stage_port``/``sensor_port`` are URLs, device names or open pyserial objects; ready
        clients (``stage_client``/``sensor_client``) are used as they are and left open.
        """
        from whiskercal.rig.sensor import SensorClient
        from whiskercal.rig.stage import StageClient

        opened: list = []
        try:
            stage = stage_client or _opened(StageClient(stage_port), opened)
            sensor = sensor_client or _opened(SensorClient(sensor_port), opened)
            session = cls(stage, sensor, config, tuple(opened))
            session.devices = identify(stage, sensor)
        except BaseException:
            for client in opened:
                client.close()
            raise
        return session

    def __enter__(self) -> "RigSession":
        return self

    def __exit__(self, *exc_info) -> None:
        self.close()

    def close(self) -> None:
        """Halt a moving stage, stop the stream this session started, close what it opened.

        Runs on every exit from the ``with`` block; device errors here are swallowed, because
        the error that ended the run (an unplugged board, say) is the one to report.
        """
        if self._closed:
            return
        self._closed = True
        try:
            self._halt_if_moving()
        except DeviceError:
            pass
        finally:
            self._stop_stream()
            for client in self._owned:
                client.close()

    def _halt_if_moving(self) -> None:
        state = self.stage.status().state
        if state.startswith(("Run", "Jog", "Hold", "Home")):
            self.halt()

    def _stop_stream(self) -> None:
        if not self._streaming:
            return
        self._streaming = False
        try:
            self.sensor.stop()
        except DeviceError:
            pass

    # -- what the boards are -----------------------------------------------------------------
    @property
    def sensor_port(self):
        """The sensor's port object (a simulated port carries the twin's world, for truth)."""
        return getattr(getattr(self.sensor, "transport", None), "port", None)

    @property
    def machine_space(self) -> MachineSpace | None:
        """Where stage coordinates lie in a stock grbl board's machine space (``rig.machine_space``):
        the layout found at homing, or before it the one its ``$$`` predicts; None for
        whiskercal's firmware, whose machine coordinates are the stage coordinates."""
        if self.devices.stage.get("proto", "") is not None:  # whiskercal's firmware, or unknown
            return None
        return getattr(self.stage, "space", None) or board_space(self.devices.stage_settings)

    @property
    def travel_mm(self) -> tuple[float, float]:
        """The stage's travel (mm): how far stage coordinates run from 0 inside the board's
        workspace; its own $130/$131 when it states them, else the configured."""
        if self.machine_space is not None:
            return self.machine_space.travel_mm
        values = [self.devices.stage_settings.get(n) for n in TRAVEL_SETTINGS]
        if all(v is not None for v in values):
            return float(values[0]), float(values[1])
        return self.config.travel_mm

    def outside_travel(self, points_stage_mm, margin_mm: float) -> np.ndarray:
        """Mask of stage positions (..., 2) mm outside the travel less ``margin_mm``."""
        return outside_travel(points_stage_mm, self.travel_mm, margin_mm)

    # -- starting ----------------------------------------------------------------------------
    def start(self) -> None:
        """Home (or require a homed stage), then configure the sensor and start its stream."""
        self._prepare_stage()
        self._start_stream()

    def _prepare_stage(self) -> None:
        stock = self.machine_space is not None
        if stock:
            self.stage.space = None  # a client used before keeps no earlier board's mapping
        if self.config.home:
            self.stage.home()
        elif self.stage.status().alarm:
            raise DeviceError(f"stage is in alarm (not homed); home it ($H) or set "
                              f"{self.config.home_setting} = true in the configuration")
        if stock:
            self.stage.space = self._map_machine_space()

    def _map_machine_space(self) -> MachineSpace:
        """The stock board's layout, from its settings and where homing left it; a board whose
        position lies outside the workspace that layout gives cannot be mapped."""
        here_mm = np.asarray(self.stage.status().mpos_mm, float)[:2]
        homed = self.config.home
        space = board_space(self.devices.stage_settings, here_mm if homed else None,
                            None if homed else here_mm)
        if np.any(here_mm < space.low_mm - 1e-3) or np.any(here_mm > space.high_mm + 1e-3):
            raise DeviceError(
                f"the stage's machine position {np.round(here_mm, 3).tolist()} mm lies outside the "
                f"workspace its settings give ({space.layout}: x {space.low_mm[0]:g}..{space.high_mm[0]:g}, "
                f"y {space.low_mm[1]:g}..{space.high_mm[1]:g} mm); "
                + ("check $22, $23, $27 and $130/$131" if self.config.home else
                   f"home it with {self.config.home_setting} = true") + " (docs/stage.md)")
        return space

    def _start_stream(self) -> None:
        settings = self.config.sensor
        self.sensor.stop()  # a board left streaming refuses settings (ERR:3)
        self.sensor.configure(rate_hz=settings.rate_hz, gain=settings.gain, res=settings.res,
                              osr=settings.osr, filt=settings.filt)
        self._streaming = True  # from here on, leaving the session sends STOP
        self.sensor.start()

    # -- frames and position -----------------------------------------------------------------
    @property
    def frame(self) -> RigFrame:
        """The whisker frame in stage coordinates."""
        return self.config.frame

    def to_stage(self, points_mm) -> np.ndarray:
        """Whisker-frame points (..., 2) to stage coordinates, mm."""
        return self.frame.to_stage(points_mm)

    def to_whisker(self, points_stage_mm) -> np.ndarray:
        """Stage coordinates (..., 2) to whisker-frame points, mm."""
        return self.frame.to_whisker(points_stage_mm)

    def status(self) -> StageStatus:
        """The stage's status report."""
        return self.stage.status()

    def position_stage_mm(self) -> np.ndarray:
        """Where the stage says it is (machine position), mm."""
        return np.asarray(self.stage.status().mpos_mm, float)[:2]

    def position_mm(self) -> np.ndarray:
        """Where the stage says it is, in the whisker frame, mm."""
        return self.to_whisker(self.position_stage_mm())

    # -- motion ------------------------------------------------------------------------------
    def move_to(self, point_mm, feed_mm_min: float, on_poll: PollCallback | None = None,
                where: str = "") -> StageStatus:
        """Move in a straight line to a whisker-frame point (mm) and wait until the stage is Idle.

        ``on_poll(status)`` is called after every status poll, to read the sensor meanwhile
        (default: :meth:`read_while_waiting`); ``where`` (" at point 7") goes into messages.
        """
        return self.move_to_stage(self.to_stage(point_mm), feed_mm_min, on_poll, where)

    def move_to_stage(self, point_stage_mm, feed_mm_min: float,
                      on_poll: PollCallback | None = None, where: str = "") -> StageStatus:
        """As :meth:`move_to`, to a position in stage coordinates (mm)."""
        x_mm, y_mm = (float(v) for v in np.asarray(point_stage_mm, float)[:2])
        try:
            self.stage.move_to(x_mm, y_mm, feed_mm_min)
            return self.stage.wait_idle(self.config.move_timeout_s,
                                        on_poll=on_poll or self.read_while_waiting)
        except StageAlarmError as error:
            if error.code in CRITICAL_ALARMS:
                self._recover_from_limit(error)
            if error.code != StageAlarm.ENCODER_MISMATCH:
                raise
            raise EncoderMismatchError(
                f"stage encoder and step positions disagree{where} (ALARM:100): missed steps or a "
                "stall; re-home the stage and continue with --resume") from error

    def _recover_from_limit(self, error: StageAlarmError) -> None:
        """A limit alarm pauses grbl until a reset: run grbl's recovery (``StageClient.recover``)
        and stop the run with what happened; the position is kept after a soft limit."""
        try:
            self.stage.recover(error.code)
        except DeviceError as failed:
            raise DeviceError(f"{error}; recovering from it failed: {failed}") from error
        after = ("the stage was reset and unlocked at the same position; check $130/$131 and the "
                 "rig's frame, then continue with --resume" if error.code == StageAlarm.SOFT_LIMIT
                 else "the stage was reset and stays locked: home it, then continue with --resume")
        raise DeviceError(f"{error}; {after}") from error

    def read_while_waiting(self, status: StageStatus) -> None:
        """Between status polls: read one poll period of samples into :attr:`sink`, so the
        board's stream never piles up while the stage moves."""
        if self._streaming and not status.idle:
            self.sink(self.sensor.read(_poll_samples(self.config.sensor), timeout_s=1.0))

    def halt(self) -> None:
        """Stop now: feed hold, wait until the stage is at rest, flush its queue.

        A reset while the stage still moves would lose its position (grbl's ALARM:3); after a
        hold it keeps it. An alarm left by the reset is unlocked.
        """
        self.stage.hold()
        self._wait_at_rest()
        self.stage.reset()
        if self.stage.status().alarm:
            self.stage.unlock()

    def _wait_at_rest(self) -> None:
        polls = int(self.config.move_timeout_s / POLL_S)
        for _ in range(polls):
            status = self.stage.status()
            if status.state in ("Hold:0", "Idle") or status.alarm:  # GRBL 1.1: Hold:0 = at rest
                return
            if self._streaming:  # else each status round trip is the wait
                self._read_quietly()
        raise DeviceError("stage did not come to rest after a feed hold; check it by hand")

    def _read_quietly(self) -> None:
        """Read one poll period into the sink; a sensor that fails must not keep the stage from
        being stopped."""
        try:
            self.sink(self.sensor.read(_poll_samples(self.config.sensor), timeout_s=1.0))
        except DeviceError:
            pass

    def back_off(self, retreat_stage_mm: Callable[[np.ndarray], np.ndarray],
                 feed_mm_min: float) -> None:
        """Halt, then move to ``retreat_stage_mm(here_stage_mm)``: the escape from an overload.

        Device errors on the way are swallowed: the error that made the caller back off is the
        one to report, and a failed retreat must not hide it.
        """
        try:
            self.halt()
            self.move_to_stage(retreat_stage_mm(self.position_stage_mm()), feed_mm_min)
        except DeviceError:
            pass

    # -- measuring ---------------------------------------------------------------------------
    def sync(self) -> float:
        """Board time (s) from which every sample was converted after now (``SensorClient.sync``)."""
        return self.sensor.sync()

    def measure(self, n: int, settle_s: float = 0.0,
                on_stale: SampleSink | None = None) -> SampleBlock:
        """``n`` samples converted at least ``settle_s`` (s) after now, by the sensor's clock.

        Call it once the stage is at rest (a move has returned Idle). Which samples are fresh is
        decided by the board's own timestamps against a sync exchange (``SensorClient.sync``),
        never by what has arrived: a host that fell behind the stream (a busy machine) finds
        samples from before the stage arrived still queued in the OS's buffers. The older
        samples read on the way go to ``on_stale`` (default :attr:`sink`), in order.
        """
        return self.samples_from(self.sync() + settle_s, n, on_stale)

    def samples_from(self, t_from_s: float, n: int,
                     on_stale: SampleSink | None = None) -> SampleBlock:
        """The first ``n`` samples whose board time is at least ``t_from_s`` (s)."""
        on_stale = on_stale or self.sink
        fresh: list[SampleBlock] = []
        got = stale = 0
        rate_hz = float(self.config.sensor.rate_hz)
        while got < n:
            block = self.sensor.read(n - got, timeout_s=(n - got) / rate_hz + 1.0)
            older, newer = block.split(int(np.searchsorted(block.t_s, t_from_s)))
            if len(older):
                on_stale(older)
                stale += len(older)
            if len(newer):
                fresh.append(newer)
                got += len(newer)
            if stale > _MAX_STALE_SAMPLES:
                raise DeviceError(f"the sensor's clock did not reach {t_from_s:.3f} s within "
                                  f"{stale} samples; is its timestamp counter running?")
        return SampleBlock.join(fresh)

    # -- the run's summary -------------------------------------------------------------------
    def summary(self) -> SessionSummary:
        """Frames dropped and corrupt so far, stage-clock and wall time since the session opened."""
        stage_start, wall_start = self._started
        return SessionSummary(dropped=int(self.sensor.dropped), corrupt=int(self.sensor.corrupt),
                              stage_time_s=float(self.stage_clock() - stage_start),
                              wall_time_s=float(time.monotonic() - wall_start))


def identify(stage, sensor) -> Devices:
    """Identify both boards and read the stage's settings (travel, encoder, tolerance)."""
    identity = stage.identify()
    settings = stage.settings()
    stage_info = {"version": identity.version, "name": identity.name, "proto": identity.proto,
                  "has_encoder": bool(identity.has_encoder)}
    return Devices(stage_info, sensor.identify(), bool(identity.has_encoder), settings)


def _opened(client, opened: list):
    opened.append(client)
    return client


def _discard(block: SampleBlock) -> None:
    """The default sink: samples nobody records."""


def _poll_samples(sensor: SensorConfig) -> int:
    return max(1, int(round(POLL_S * sensor.rate_hz)))
