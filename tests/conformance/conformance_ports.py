"""The boards the conformance scripts run against, each opened as a pyserial-like port.

- ``firmware``: the firmware cores built for the host (``build/firmware/host/*_sim``), driven
  over a pipe; their simulated clock runs ``SPEED`` times real time.
- ``twin``: the digital twin's virtual boards, ``sim://NAME/stage`` and ``sim://NAME/sensor``.
- ``avr``: the compiled .hex on simavr in a twin world, ``sim://NAME/sensor?firmware=avr``
  (the sensor board so far); skipped when simavr or its library is not installed.
- ``hardware`` (opt-in): flashed boards on the serial ports named by the environment variables
  ``WHISKERCAL_HW_STAGE`` and ``WHISKERCAL_HW_SENSOR``; skipped when they are not set.

Both expose ``write``, ``read(size)`` (waiting up to ``timeout`` seconds of device time),
``in_waiting``, ``reset_input_buffer``, ``close`` and ``now_s()`` (the device clock, s), so a
script measures time the same way on both.
"""

from __future__ import annotations

import itertools
import os
import serial as pyserial
import subprocess
import threading
import time
from pathlib import Path

import pytest

from avr_emulation import emulation_or_skip
from firmware_build import host_program

SPEED = 10.0  # firmware simulators: device seconds per real second
BACKENDS = ("firmware", "twin")
HARDWARE_PORTS = {"stage": "WHISKERCAL_HW_STAGE", "sensor": "WHISKERCAL_HW_SENSOR"}
ARDUINO_BOOT_S = 2.5  # opening the port resets the board; its bootloader waits before the sketch
_world_names = itertools.count()


class PipePort:
    """A host-built firmware simulator on a pipe, with pyserial's reading semantics.

    Parameters
    ----------
    argv
        The simulator and its options.
    speed
        How many device seconds pass per real second (the simulator's ``--speed``).
    """

    def __init__(self, argv: list[str], speed: float) -> None:
        self.speed = speed
        self.timeout = 1.0  # device seconds, as a sim:// port counts them
        self.portstr = f"pipe:{Path(argv[0]).name}"
        self._process = subprocess.Popen([*argv, "--speed", str(speed)], stdin=subprocess.PIPE,
                                         stdout=subprocess.PIPE, bufsize=0)
        self._started = time.monotonic()
        self._buffer = bytearray()
        self._arrived = threading.Condition()
        self._reader = threading.Thread(target=self._pump, daemon=True)
        self._reader.start()

    def _pump(self) -> None:
        while True:
            chunk = os.read(self._process.stdout.fileno(), 4096)  # returns what is there
            with self._arrived:
                if not chunk:
                    self._arrived.notify_all()
                    return
                self._buffer += chunk
                self._arrived.notify_all()

    def now_s(self) -> float:
        """Device time since the simulator started, s."""
        return (time.monotonic() - self._started) * self.speed

    @property
    def is_open(self) -> bool:
        return self._process.poll() is None

    @property
    def in_waiting(self) -> int:
        with self._arrived:
            return len(self._buffer)

    def write(self, data: bytes) -> int:
        self._process.stdin.write(bytes(data))
        self._process.stdin.flush()
        return len(data)

    def read(self, size: int = 1) -> bytes:
        """Up to ``size`` bytes, waiting up to ``timeout`` device seconds for all of them."""
        deadline = time.monotonic() + (self.timeout or 0.0) / self.speed
        with self._arrived:
            while len(self._buffer) < size and self._reader.is_alive():
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    break
                self._arrived.wait(remaining)
            data = bytes(self._buffer[:size])
            del self._buffer[:size]
            return data

    def reset_input_buffer(self) -> None:
        with self._arrived:
            self._buffer.clear()

    def close(self) -> None:
        if self._process.poll() is None:
            self._process.stdin.close()
            try:
                self._process.wait(timeout=5)
            except subprocess.TimeoutExpired:
                self._process.kill()
                self._process.wait()
        self._reader.join(timeout=5)


def open_firmware(board: str, *options: str) -> PipePort:
    """Start the host-built simulator of ``board`` (``stage_stepper`` or ``whisker_nano``).

    The stage prints its banner at power-up: wait for it (up to 10 s real time, for a loaded
    machine), so that the device clock has started when a script begins.
    """
    port = PipePort([str(host_program(board, "sim")), *options], SPEED)
    if board == "stage_stepper":
        deadline = time.monotonic() + 10.0
        while port.in_waiting == 0 and time.monotonic() < deadline and port.is_open:
            time.sleep(0.005)
    return port


def open_twin(board: str, query: str = ""):
    """Open the twin's ``stage`` or ``sensor`` board in a fresh world; skip if the twin is absent."""
    serial = pytest.importorskip("serial")
    try:
        import whiskercal.twin.devices.simport  # noqa: F401  (registers sim://)
    except ImportError as error:
        pytest.skip(f"the twin's sim:// boards are not available: {error}")
    name = f"conformance{next(_world_names)}x{time.monotonic_ns()}"
    url = f"sim://{name}/{board}" + (f"?{query}" if query else "")
    return serial.serial_for_url(url, timeout=1.0)


def open_emulated(board: str):
    """Open ``board``'s compiled image on simavr in a fresh twin world; skip if it cannot run."""
    emulation_or_skip(board)
    return open_twin(board, "firmware=avr")


class HardwarePort(pyserial.Serial):
    """A real board: a pyserial port whose device clock is the host's monotonic clock."""

    def now_s(self) -> float:
        return time.monotonic()


def open_hardware(board: str) -> HardwarePort:
    """Open the real ``stage`` or ``sensor`` board named by its environment variable, or skip."""
    name = os.environ.get(HARDWARE_PORTS[board])
    if not name:
        pytest.skip(f"set {HARDWARE_PORTS[board]} to the {board} board's serial port to run this")
    port = HardwarePort(name, 115200, timeout=1.0)
    time.sleep(ARDUINO_BOOT_S)  # a real board: waiting is real time here
    return port
