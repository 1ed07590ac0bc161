"""The sensor board of the twin: ``firmware/whisker_nano``'s framed stream over a simulated line.

Sample frames at the configured rate carry the world's raw counts, a sequence number and the
board's µs clock; commands get one text frame each. Each conversion is triggered on the board's
timer and sent once it has been read over I2C, so a frame reaches the host a conversion time,
the I2C exchange and its 1.65 ms on the wire after its timestamp. The board's transmit buffer holds 64 bytes, as an Arduino
Nano's does: a board that cannot send a frame drops it and flags ``TX_OVERFLOW`` on the next.

Faults (for reliability tests): frames corrupted or lost on the way (``corrupt_rate``,
``drop_rate`` per frame, seeded), and a disconnect at a given time (handled by the port).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Callable

import numpy as np

from whiskercal.protocol.codes import SensorError, SensorStatus
from whiskercal.protocol.frames import encode_sample, encode_text
from whiskercal.protocol.mlx90393 import sample_time_ms
from whiskercal.protocol.sensor_config import SensorConfig
from whiskercal.twin.devices.clock import SerialLine

FIRMWARE_ID = "whisker_nano fw=0.1.0 proto=1"
TX_BUFFER_BYTES = 64
MAX_COMMAND_CHARS = 32
_SETTING_RANGES = {"RATE": (1, 500), "GAIN": (0, 7), "RES": (0, 3), "OSR": (0, 3), "FILT": (0, 7)}
_SETTING_FIELDS = {"RATE": "rate_hz", "GAIN": "gain", "RES": "res", "OSR": "osr", "FILT": "filt"}

# (conversion times s (n,), board settings) -> (raw counts (n, 3), saturated (n,))
Reading = Callable[[np.ndarray, SensorConfig], tuple[np.ndarray, np.ndarray]]


@dataclass
class SensorFaults:
    """Faults of the sensor link: per-frame probabilities and a disconnect time (s)."""

    corrupt_rate: float = 0.0
    drop_rate: float = 0.0
    disconnect_at_s: float | None = None


class VirtualSensor:
    """The sensor board.

    Parameters
    ----------
    reading
        ``reading(times_s, config) -> (counts, saturated)``: what the MLX90393 converts at
        those times (in order; the world steps its physics through them).
    faults
        Link faults to inject.
    rng
        Seeded generator for the faults.
    clock_drift_ppm
        How fast the board's µs clock runs against simulated time (a Nano's resonator).
    """

    def __init__(self, reading: Reading, faults: SensorFaults | None = None,
                 rng: np.random.Generator | None = None, clock_drift_ppm: float = 0.0) -> None:
        self.reading = reading
        self.faults = faults or SensorFaults()
        self.rng = rng or np.random.default_rng(0)
        self.clock_drift_ppm = clock_drift_ppm
        self.line = SerialLine()
        self.config = SensorConfig()
        self.streaming = False
        self.seq = 0
        self.now_s = 0.0
        self._input = bytearray()
        self._next_trigger_s = math.inf
        self._overflowed = False
        self.frames_sent = 0  # frames put on the line (corrupted ones included)
        self.frames_lost = 0  # frames the link fault swallowed
        self.frames_corrupted = 0
        self.frames_overflowed = 0  # frames the board skipped with its transmit buffer full

    # -- time -------------------------------------------------------------------------------
    def _conversion_s(self) -> float:
        return sample_time_ms(self.config.osr, self.config.filt) / 1000.0

    def next_event_s(self) -> float | None:
        """When the next sample is ready to send (None when stopped)."""
        if not self.streaming:
            return None
        return self._next_trigger_s + self._conversion_s()

    def advance_to(self, t: float) -> None:
        """Convert and send every sample that is ready by time ``t``."""
        if self.streaming:
            triggers = self._due_triggers(t)
            if triggers:
                counts, saturated = self.reading(np.array(triggers), self.config)
                conversion = self._conversion_s()
                for trigger, row, flag in zip(triggers, counts, saturated):
                    self._emit_sample(trigger, trigger + conversion, row, flag)
        self.now_s = max(self.now_s, t)

    def _due_triggers(self, t: float) -> list[float]:
        """Trigger times of the samples that are ready by ``t`` (and before a disconnect)."""
        disconnect = self.faults.disconnect_at_s
        limit = t if disconnect is None else min(t, np.nextafter(disconnect, -np.inf))
        conversion, period = self._conversion_s(), 1.0 / self.config.rate_hz
        triggers = []
        while self._next_trigger_s + conversion <= limit:
            triggers.append(self._next_trigger_s)
            self._next_trigger_s += period
        return triggers

    def _emit_sample(self, trigger_s: float, ready_s: float, counts: np.ndarray, saturated: bool) -> None:
        status = SensorStatus.SATURATED if saturated else 0
        if self._overflowed:
            status |= SensorStatus.TX_OVERFLOW
        t_us = int(round(trigger_s * 1e6 * (1 + self.clock_drift_ppm * 1e-6)))
        frame = encode_sample(self.seq, t_us, tuple(int(c) for c in counts), int(status))
        self.seq += 1
        if self.line.backlog_bytes(ready_s) + len(frame) > TX_BUFFER_BYTES:
            self._overflowed = True  # Serial.write would block the loop: the firmware skips
            self.frames_overflowed += 1
            return
        self._overflowed = False
        self._transmit(frame, ready_s)

    def _transmit(self, frame: bytes, t: float) -> None:
        if self.faults.drop_rate and self.rng.random() < self.faults.drop_rate:
            self.frames_lost += 1
            return
        if self.faults.corrupt_rate and self.rng.random() < self.faults.corrupt_rate:
            self.frames_corrupted += 1
            damaged = bytearray(frame)
            damaged[int(self.rng.integers(2, len(frame)))] ^= 1 << int(self.rng.integers(8))
            frame = bytes(damaged)
        self.frames_sent += 1
        self.line.send(frame, t)

    # -- commands ---------------------------------------------------------------------------
    def power_up(self, t: float) -> None:
        """Reset (as an Arduino does when its port is opened): stopped, default settings."""
        self.advance_to(t)
        self.streaming, self.config, self.seq = False, SensorConfig(), 0
        self._input.clear()
        self.line.clear()

    def receive(self, data: bytes, t: float) -> None:
        """Bytes from the host arriving at time ``t``."""
        self.advance_to(t)
        for byte in data:
            if byte == 0x0A:
                text = self._input.decode("ascii", errors="replace").strip("\r").strip()
                self._input.clear()
                self._reply(self._answer(text, t), t)
            elif len(self._input) <= MAX_COMMAND_CHARS:
                self._input.append(byte)

    def _reply(self, text: str, t: float) -> None:
        self.line.send(encode_text(text), t)

    def _answer(self, text: str, t: float) -> str:
        if len(text) > MAX_COMMAND_CHARS:
            return f"ERR:{int(SensorError.LINE_TOO_LONG)}"
        command, _, argument = text.upper().partition(" ")
        if command == "ID":
            return f"OK {FIRMWARE_ID}"
        if command == "CFG?":
            c = self.config
            return f"OK rate={c.rate_hz} gain={c.gain} res={c.res} osr={c.osr} filt={c.filt}"
        if command in ("START", "STOP"):
            self._set_streaming(command == "START", t)
            return "OK"
        if command in _SETTING_RANGES:
            return self._set(command, argument.strip())
        return f"ERR:{int(SensorError.UNKNOWN_COMMAND)}"

    def _set_streaming(self, on: bool, t: float) -> None:
        if on and not self.streaming:
            self._next_trigger_s = t + 1.0 / self.config.rate_hz
        self.streaming = on

    def _set(self, command: str, argument: str) -> str:
        if self.streaming:
            return f"ERR:{int(SensorError.BUSY_STREAMING)}"
        low, high = _SETTING_RANGES[command]
        if not argument.isdigit() or not low <= int(argument) <= high:
            return f"ERR:{int(SensorError.BAD_VALUE)}"
        candidate = replace(self.config, **{_SETTING_FIELDS[command]: int(argument)})
        if sample_time_ms(candidate.osr, candidate.filt) > 1000.0 / candidate.rate_hz:
            return f"ERR:{int(SensorError.RATE_TOO_HIGH)}"
        self.config = candidate
        return "OK"
