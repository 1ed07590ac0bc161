"""Small fakes of the stage and sensor clients that honour docs/architecture.md's API.

They share one simulated clock: stage moves take trapezoid time, sensor reads advance the clock
by n / rate. The whisker is a crude stand-in (a straight line on the whisker frame's x axis
that the rod rotates about the root), enough to give every point a known noise-free z.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass, field

import numpy as np

from whiskercal.collect.estimate import trapezoid_time_s
from whiskercal.errors import DeviceError
from whiskercal.protocol.codes import StageAlarm
from whiskercal.rig.sensor import SampleBlock
from whiskercal.rig.stage import StageAlarmError, StageIdentity, StageStatus

STATIC_Y_UT = 1160.0
UT_PER_DEG = -200.0
LSB_UT = 0.6


@dataclass
class FakeWorld:
    """Clock (s), geometry and the faults to inject."""

    origin_stage_mm: tuple = (40.0, 100.0)  # as default_grid.toml
    rod_radius_mm: float = 1.5
    length_mm: float = 75.0
    t_s: float = 0.0
    noise_uT: float = 3.0
    missed_steps_after_moves: int | None = None
    encoder_alarm_after_moves: int | None = None
    disconnect_after_reads: int | None = None
    bad_frames_every_reads: int | None = None
    drift_uT_per_s: float = 0.0
    rng: np.random.Generator = field(default_factory=lambda: np.random.default_rng(7))

    def rod_whisker_mm(self, stage_mm) -> np.ndarray:
        return np.asarray(stage_mm, float) - self.origin_stage_mm

    def z_uT(self, stage_mm) -> float:
        """Noise-free deflection: the root turns until the line clears the rod."""
        x, y = self.rod_whisker_mm(stage_mm)
        if not 0 < x < self.length_mm or y > self.rod_radius_mm:
            return 0.0
        angle = np.degrees(np.arctan2(y - self.rod_radius_mm, x))
        # below -50 deg the rod is under the whisker, on the far side of the root's reach
        return UT_PER_DEG * -angle if -50.0 < angle < 0 else 0.0

    def __post_init__(self) -> None:
        self.lock = threading.RLock()
        self.truth = FakeTruth()

    @property
    def now_s(self) -> float:
        return self.t_s


class FakeTruth:
    """Per-sample truth rows, read like the twin world's record (``arrays()``)."""

    def __init__(self) -> None:
        self.blocks: list[dict] = []

    def add(self, t_s: np.ndarray, stage_mm: np.ndarray, tool_mm: np.ndarray, z_uT: float) -> None:
        n = len(t_s)
        self.blocks.append({"t_s": t_s, "stage_mm": np.tile(stage_mm, (n, 1)),
                            "tool_mm": np.tile(tool_mm, (n, 1)), "z_true_uT": np.full(n, z_uT),
                            "kind": np.full(n, "shaft" if z_uT else "free")})

    def arrays(self) -> dict:
        return {name: np.concatenate([b[name] for b in self.blocks]) for name in self.blocks[0]}


class _Transport:
    def __init__(self, world, port=None):
        self.world, self.port, self.name = world, port, "fake"


    def now_s(self) -> float:
        return self.world.t_s


class FakeSimPort:
    """Stands for a sim:// port object: it carries the world, which reports truth."""

    def __init__(self, world):
        self.world = world


class FakeStage:
    """A stage with encoders (``encoder=False``: stock grbl) on the world's clock."""

    def __init__(self, world: FakeWorld, encoder: bool = True, homed: bool = False) -> None:
        self.world, self.encoder = world, encoder
        world.stage = self
        self.transport = _Transport(world)
        self.state = "Idle" if homed else "Alarm"
        self.true_mm = np.zeros(2)
        self.mpos_mm = np.zeros(2)
        self.target_mm = np.zeros(2)
        self.move_end_s = 0.0
        self.moves = 0
        self.commands: list[str] = []

    def identify(self) -> StageIdentity:
        proto = "whiskercal-stage-1" if self.encoder else None
        return StageIdentity("1.1h.0", "fake", "V", proto, self.encoder)

    def settings(self) -> dict[int, float]:
        return {130: 200.0, 131: 200.0, 120: 200.0, 121: 200.0, 110: 3000.0, 111: 3000.0}

    def home(self) -> None:
        self.commands.append("$H")
        self.true_mm[:] = self.mpos_mm[:] = self.target_mm[:] = 0.0
        self.state = "Idle"

    def unlock(self) -> None:
        self.state = "Idle"

    def move_to(self, x_mm: float, y_mm: float, feed_mm_min: float) -> None:
        if self.state.startswith("Alarm"):
            raise DeviceError("stage locked in alarm")
        self.commands.append(f"G1 X{x_mm:.3f} Y{y_mm:.3f} F{feed_mm_min:.0f}")
        self.moves += 1
        start = self.mpos_mm.copy()
        self.target_mm = np.array([x_mm, y_mm])
        duration = trapezoid_time_s(float(np.hypot(*(self.target_mm - start))), feed_mm_min, 200.0)
        self.move_start_mm, self.move_start_s = start, self.world.t_s
        self.move_end_s = self.world.t_s + duration
        self.state = "Run"

    def _advance(self) -> None:
        if self.state == "Run":
            span = max(self.move_end_s - self.move_start_s, 1e-9)
            share = min((self.world.t_s - self.move_start_s) / span, 1.0)
            self.mpos_mm = self.move_start_mm + share * (self.target_mm - self.move_start_mm)
            if share >= 1.0:
                self.state = "Idle"
                self._arrive()
        self.true_mm = self.mpos_mm + self._slip()

    def _slip(self) -> np.ndarray:
        after = self.world.missed_steps_after_moves
        return np.array([0.0, 0.8]) if after is not None and self.moves > after else np.zeros(2)

    def _arrive(self) -> None:
        after = self.world.encoder_alarm_after_moves
        if after is not None and self.moves > after:
            self.state = "Alarm"
            raise StageAlarmError(int(StageAlarm.ENCODER_MISMATCH), "fake")

    def status(self) -> StageStatus:
        self._advance()
        enc = self.true_mm.copy() if self.encoder else None
        return StageStatus(self.state, self.mpos_mm.copy(), enc, 0.0)

    def wait_idle(self, timeout_s: float = 60.0, on_poll=None) -> StageStatus:
        deadline = self.world.t_s + timeout_s
        while True:
            status = self.status()
            if on_poll is not None:
                on_poll(status)
            else:
                self.world.t_s += 0.02
            if status.idle:
                return status
            if status.alarm:
                raise DeviceError("stage in alarm")
            if self.world.t_s > deadline:
                raise DeviceError("move timed out")

    def hold(self) -> None:
        self.commands.append("!")
        self._advance()
        self.state = "Hold:0"
        self.move_end_s = self.world.t_s
        self.target_mm = self.mpos_mm.copy()

    def reset(self) -> str:
        self.commands.append("reset")
        self.state = "Idle"
        return "Grbl 1.1h ['$' for help]"

    def resume(self) -> None:
        pass


class FakeSensor:
    """A 300 Hz sensor whose Y axis follows the world's z (plus noise, drift)."""

    def __init__(self, world: FakeWorld, sim: bool = True) -> None:
        self.world = world
        self.transport = _Transport(world, FakeSimPort(world) if sim else object())
        self.streaming = False
        self.rate_hz = 300
        self.seq = 0
        self.reads = 0
        self.configured: dict = {}
        self.dropped = self.corrupt = 0

    def identify(self) -> str:
        return "whisker_nano fw=0.1.0 proto=1"

    def configure(self, **settings) -> dict:
        if self.streaming:
            raise DeviceError("busy streaming")
        self.configured = settings
        self.rate_hz = settings.get("rate_hz") or self.rate_hz
        return settings

    def start(self) -> None:
        self.streaming = True

    def stop(self) -> None:
        self.streaming = False

    def sync(self) -> float:
        """Nothing is ever buffered here: the next sample read is the first fresh one."""
        if not self.streaming:
            raise DeviceError("not streaming")
        return self.world.t_s + 1.0 / self.rate_hz

    def read_available(self) -> SampleBlock:
        """Nothing is ever buffered here: every read makes its samples on the spot."""
        empty = np.zeros(0)
        return SampleBlock(seq=empty.astype(int), t_s=empty, counts=np.zeros((0, 3), int),
                           field_uT=np.zeros((0, 3)), status=np.zeros(0, np.uint8), dropped=0, corrupt=0)

    def read(self, n: int, timeout_s: float = 1.0) -> SampleBlock:
        if not self.streaming:
            raise DeviceError("not streaming")
        self.reads += 1
        after = self.world.disconnect_after_reads
        if after is not None and self.reads > after:
            raise DeviceError("sensor on fake is disconnected or not responding")
        t_s = self.world.t_s + np.arange(1, n + 1) / self.rate_hz
        self.world.t_s = float(t_s[-1])
        self.world.stage._advance()
        true_mm = self.world.stage.true_mm
        self.world.truth.add(t_s, true_mm, self.world.rod_whisker_mm(true_mm), self.world.z_uT(true_mm))
        y_uT = (STATIC_Y_UT + self.world.drift_uT_per_s * t_s + self.world.z_uT(self.world.stage.true_mm)
                + self.world.rng.normal(0, self.world.noise_uT, n))
        counts = np.column_stack([np.full(n, 100), np.round(y_uT / LSB_UT), np.full(n, -50)]).astype(int)
        every = self.world.bad_frames_every_reads
        bad = every is not None and self.reads % every == 0
        seq = self.seq + np.arange(n) + (1 if bad else 0)
        self.seq = int(seq[-1]) + 1
        self.dropped += int(bad)
        self.corrupt += int(bad)
        return SampleBlock(seq=seq, t_s=t_s, counts=counts, field_uT=counts * LSB_UT,
                           status=np.zeros(n, np.uint8), dropped=int(bad), corrupt=int(bad))
