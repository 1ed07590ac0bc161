"""The compiled firmware in the loop: a board of the twin played by its .hex on simavr.

:class:`AvrBoard` keeps the time and the UART of any emulated board (the stage's is in
``avr_stage``). ``sim://NAME/sensor?firmware=avr`` puts :class:`AvrSensorBoard` where the world's Python sensor
board (``virtual_sensor``) would be: the same world, the same physics and noise, but the frames
come from ``whisker_nano.hex`` running on an emulated ATmega328P, which reads an emulated
MLX90393 over its TWI (``firmware/sim``). Each conversion the firmware starts asks the world for
the counts at that moment (``World.reading``, so the ground truth is recorded as for the Python
board), and the chip answers the read only once its conversion time has passed.

Time: the world drives. Advancing the board to time t runs the AVR to the cycle of t (16 MHz from
the moment the board was powered up, scaled by the world's clock drift); the bytes its UART sent
go on the simulated line at the cycles they were written. Host bytes enter the AVR's UART at the
baud rate. What the Python board models as link faults (``corrupt``, ``drop``) is not applied to
the emulated board: its frames are whatever the firmware sends.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np

from whiskercal.protocol.mlx90393 import conversion_time_ms
from whiskercal.protocol.sensor_config import SensorConfig
from whiskercal.twin.devices.avr_harness import F_CPU_HZ, AvrHarness
from whiskercal.twin.devices.clock import SerialLine
from whiskercal.twin.devices.virtual_sensor import Reading

# While the firmware talks (or was just talked to) the port steps time in this quantum, so that
# its bytes reach the host when they were sent; once it has been silent for IDLE_S a read
# without a timeout may stop waiting, as with the Python board.
QUANTUM_S = 0.001
IDLE_S = 1.0
UART_INPUT_CHUNK = 32  # bytes handed to the AVR's 64-byte receive FIFO at a time
# Bytes the host sends before the sketch's setup() has enabled the UART would be lost; an
# emulated board starts at once (no bootloader), so they are held until this long after power-up.
SETUP_S = 0.001


@dataclass
class AvrPortFaults:
    """What the port sets on an emulated board: its disconnect time (s)."""

    disconnect_at_s: float | None = None


class AvrBoard:
    """A board of the twin played by a sketch's .hex on simavr: time, the UART and the line.

    Subclasses name the sketch (``kind``: ``sensor`` or ``stage``) and answer the harness's
    requests (:meth:`_answer`); ``now_s`` is the world's time when the board is plugged in (its
    power-up), ``clock_drift_ppm`` how fast its 16 MHz resonator runs against simulated time.
    """

    kind = ""

    def __init__(self, now_s: float, clock_drift_ppm: float = 0.0) -> None:
        self.faults = AvrPortFaults()
        self.line = SerialLine()
        self.cycles_per_s = F_CPU_HZ * (1 + clock_drift_ppm * 1e-6)
        self.now_s = now_s
        self._start(now_s)

    def _start(self, t: float) -> None:
        self.powered_at_s = t
        self._input: deque[tuple[float, bytes]] = deque()
        self._active_until_s = t + IDLE_S  # the sketch starts up
        self.harness = self._make_harness()

    def _make_harness(self) -> AvrHarness:
        """The harness with this board's sketch, fresh from power-up."""
        return AvrHarness(self.kind, self._answer, self._report)

    def _answer(self, words: list[str]) -> str:
        raise ValueError(f"unexpected request from the AVR emulation harness: {' '.join(words)}")

    def _report(self, words: list[str]) -> None:
        """A line of the harness that needs no answer."""

    # -- time -------------------------------------------------------------------------------
    def _cycle(self, t: float) -> int:
        return int(round((t - self.powered_at_s) * self.cycles_per_s))

    def _time(self, cycle: int) -> float:
        return self.powered_at_s + cycle / self.cycles_per_s

    def next_event_s(self) -> float | None:
        """A quantum ahead while the firmware is active; None once it has long been silent."""
        if self._input:
            return max(self._input[0][0], self.now_s + QUANTUM_S)
        return self.now_s + QUANTUM_S if self._active_until_s > self.now_s else None

    def advance_to(self, t: float) -> None:
        """Run the AVR to time ``t``, handing it the host's bytes as they arrive."""
        while self._input and self._input[0][0] <= t:
            when, data = self._input.popleft()
            self._run_to(when)
            self.harness.feed(data)
        self._run_to(t)

    def _run_to(self, t: float) -> None:
        if t <= self.now_s:
            return
        self._put_on_line(self.harness.run_to(self._cycle(t)))
        self.now_s = t

    def _put_on_line(self, sent: list[tuple[int, int]]) -> None:
        """The UART's bytes onto the line, back-to-back bytes as one chunk (a frame arrives whole)."""
        byte_cycles = self.line.byte_time_s(1) * self.cycles_per_s
        chunk, first, last = bytearray(), 0, -math.inf
        for cycle, byte in sent:
            if chunk and cycle - last > 1.5 * byte_cycles:
                self.line.send(bytes(chunk), self._time(first))
                chunk = bytearray()
            if not chunk:
                first = cycle
            chunk.append(byte)
            last = cycle
        if chunk:
            self.line.send(bytes(chunk), self._time(first))
            self._active_until_s = self._time(last) + IDLE_S

    def keep_active(self, until_s: float) -> None:
        """Step time in quanta at least until ``until_s`` (the board is doing something)."""
        self._active_until_s = max(self._active_until_s, until_s)

    # -- the host's side ----------------------------------------------------------------------
    def power_up(self, t: float) -> None:
        """Reset, as opening the USB port resets an Arduino: a fresh AVR from time ``t``."""
        self.advance_to(t)
        self.harness.close()
        self.line.clear()
        self._start(t)

    def receive(self, data: bytes, t: float) -> None:
        """Bytes from the host at time ``t``: into the AVR's UART at the baud rate."""
        self.advance_to(t)
        start = max(t, self.powered_at_s + SETUP_S, self._input[-1][0] if self._input else t)
        for offset in range(0, len(data), UART_INPUT_CHUNK):
            self._input.append((start + self.line.byte_time_s(offset), bytes(data[offset:offset + UART_INPUT_CHUNK])))
        self.keep_active(t + IDLE_S)
        self.advance_to(t)

    def close(self) -> None:
        """Stop the emulation."""
        self.harness.close()


class AvrSensorBoard(AvrBoard):
    """The sensor board played by ``whisker_nano.hex`` (see the module docstring).

    Parameters
    ----------
    reading
        The world's ``reading(times_s, config) -> (counts, saturated)``.
    now_s, clock_drift_ppm
        As for :class:`AvrBoard`.
    """

    kind = "sensor"

    def __init__(self, reading: Reading, now_s: float, clock_drift_ppm: float = 0.0) -> None:
        self.reading = reading
        self.conversions = 0
        super().__init__(now_s, clock_drift_ppm)

    def _answer(self, words: list[str]) -> str:
        """The emulated MLX90393 starts a conversion: the world's counts at that moment."""
        if words[0] != "F":
            return super()._answer(words)
        gain, res, osr, filt = (int(word) for word in words[2:6])
        config = SensorConfig(gain=gain, res=res, osr=osr, filt=filt)
        counts, _ = self.reading(np.array([self._time(int(words[1]))]), config)
        self.conversions += 1
        x, y, z = (int(c) for c in counts[0])
        return f"{x} {y} {z} {int(round(conversion_time_ms(osr, filt) * 1000))}"
