"""The emulation harness (``firmware/sim``, built by ``make firmware-sim``) as a child process.

The harness runs a sketch's .hex on simavr and only advances the AVR when asked, so the twin
keeps the time: :meth:`AvrHarness.run_to` runs the AVR to a cycle and returns what its UART sent
on the way, answering the harness's requests (the MLX90393's conversions) from a callback. The
line protocol is described in ``firmware/sim/harness.h`` and docs/firmware.md ("Emulation").
"""

from __future__ import annotations

import os
import shutil
import subprocess
import weakref
from pathlib import Path
from typing import Callable

from serial.serialutil import SerialException

F_CPU_HZ = 16_000_000
SKETCHES = {"sensor": "whisker_nano", "stage": "stage_stepper"}

# a harness request line (split into words) -> the answer line
Responder = Callable[[list[str]], str]
# a harness report line that needs no answer (the stage's step counters)
Reporter = Callable[[list[str]], None]


def firmware_build_dir() -> Path:
    """Where ``make firmware-sim`` puts the harness and the .hex files (``build/firmware``)."""
    configured = os.environ.get("WHISKERCAL_FIRMWARE_BUILD")
    if configured:
        return Path(configured)
    return Path(__file__).resolve().parents[3] / "build" / "firmware"


def grbl_image(homing: str, origin: str = "") -> Path:
    """Stock grbl 1.1h built by ``make grbl-sim``: its own config.h (``homing=""``, Z homed
    first), the copy that homes X and Y in one cycle (``homing="xy"``), or that copy with
    HOMING_FORCE_SET_ORIGIN as well (``homing="xy"``, ``origin="set"``)."""
    variant = "stock" if homing != "xy" else ("xy-origin" if origin == "set" else "xy")
    return firmware_build_dir() / "grbl" / variant / "grbl.hex"


def harness_files(board: str, image: Path | None = None) -> tuple[Path, Path]:
    """(harness, .hex) for ``board`` (``sensor`` or ``stage``; ``image`` instead of the board's
    own sketch); raises ``SerialException`` with what to do when either is missing."""
    build = firmware_build_dir()
    harness = build / "sim" / "avr_harness"
    image = image or build / "avr" / f"{SKETCHES[board]}.hex"
    for path in (harness, image):
        if not path.is_file():
            if path.parent.parent.name == "grbl":
                raise SerialException(f"firmware=grbl needs {path}: run `WHISKERCAL_GRBL_SRC=DIR make grbl-sim` "
                                      "with DIR a checkout of gnea/grbl v1.1h (grbl is not part of whiskercal)")
            raise SerialException(f"firmware=avr needs {path}: run `make firmware-sim` (needs simavr, "
                                  "libsimavr-dev, libelf-dev, gcc-avr, avr-libc, arduino-core-avr)")
    return harness, image


def unavailable_reason(board: str = "sensor", image: Path | None = None) -> str | None:
    """Why ``firmware=avr`` (or the ``image`` given) cannot run here (None when it can): for
    tests that skip."""
    if shutil.which("simavr") is None:
        return "simavr is not installed"
    try:
        harness_files(board, image)
    except SerialException as error:
        return str(error)
    return None


def _stop(process: subprocess.Popen) -> None:
    if process.poll() is None:
        try:
            process.stdin.write("Q\n")
            process.stdin.flush()
            process.wait(timeout=2)
        except (OSError, ValueError, subprocess.TimeoutExpired):
            process.kill()
            process.wait()


class AvrHarness:
    """One running harness: an ATmega328P with ``board``'s sketch, at AVR cycle ``cycle``.

    ``image`` runs another .hex on the board (stock grbl on the stage), ``pins`` names the
    stage's pin map (``whiskercal`` or ``grbl``, ``firmware/sim/stage_part.h``).
    """

    def __init__(self, board: str, responder: Responder, reporter: Reporter | None = None,
                 image: Path | None = None, pins: str = "whiskercal") -> None:
        harness, image = harness_files(board, image)
        self.responder = responder
        self.reporter = reporter
        self._process = subprocess.Popen([str(harness), board, str(image), pins], stdin=subprocess.PIPE,
                                         stdout=subprocess.PIPE, text=True, bufsize=1)
        self._finalizer = weakref.finalize(self, _stop, self._process)
        self.cycle = 0
        self._expect_done()

    def _line(self) -> list[str]:
        line = self._process.stdout.readline()
        if not line:
            raise SerialException(f"the AVR emulation harness exited (status {self._process.wait()})")
        return line.split()

    def _send(self, line: str) -> None:
        try:
            self._process.stdin.write(line + "\n")
            self._process.stdin.flush()
        except (BrokenPipeError, ValueError) as error:
            raise SerialException(f"the AVR emulation harness is gone: {error}") from error

    def _expect_done(self) -> list[tuple[int, int]]:
        """Read up to the run's end ("K"); the UART bytes sent, as (cycle, byte)."""
        sent = []
        while True:
            words = self._line()
            if words[0] == "U":
                sent.append((int(words[1]), int(words[2], 16)))
            elif words[0] == "K":
                self.cycle = int(words[1])
                return sent
            elif words[0] == "X":
                raise SerialException(f"the emulated AVR crashed at cycle {words[1]}")
            elif words[0] == "P":
                if self.reporter is not None:
                    self.reporter(words)
            else:
                self._send(self.responder(words))

    def run_to(self, cycle: int) -> list[tuple[int, int]]:
        """Run the AVR to ``cycle``; the UART bytes it sent meanwhile, as (cycle, byte)."""
        if cycle <= self.cycle:
            return []
        self._send(f"R {cycle}")
        return self._expect_done()

    def feed(self, data: bytes) -> None:
        """Bytes into the AVR's UART at the current cycle (simavr paces them at the baud rate)."""
        if data:
            self._send(f"I {data.hex()}")
            self._expect_done()

    def send_request(self, line: str) -> None:
        """A request that only gets "K" (e.g. the stage's ``L`` switch positions)."""
        self._send(line)
        self._expect_done()

    def eeprom(self) -> bytes:
        """The EEPROM's 1 KiB now (kept by the host across a power-up, as the chip keeps it)."""
        self._send("E")
        words = self._line()
        if words[0] != "E":
            raise SerialException(f"the AVR emulation harness answered {' '.join(words)!r} to E")
        self._expect_done()
        return bytes.fromhex(words[2])

    def write_eeprom(self, data: bytes) -> None:
        """Put ``data`` into the EEPROM from address 0 (before the first run: there from the start)."""
        self.send_request(f"W {data.hex()}")

    def stack_use(self) -> tuple[int, int]:
        """(deepest stack since power-up, SRAM bytes never written), bytes: the harness paints
        the SRAM before the sketch starts and reads it back."""
        self._send("M")
        words = self._line()
        if words[0] != "M":
            raise SerialException(f"the AVR emulation harness answered {' '.join(words)!r} to M")
        self._expect_done()
        return int(words[2]), int(words[3])

    def interrupt_latency(self) -> dict[int, tuple[int, int, int]]:
        """Per interrupt vector since power-up: (calls, longest, total) latency in CPU cycles,
        from the flag being raised to the vector being called."""
        self._send("V")
        latency = {}
        while True:
            words = self._line()
            if words[0] != "V":
                break
            latency[int(words[1])] = (int(words[2]), int(words[3]), int(words[4]))
        self.cycle = int(words[1])
        return latency

    def close(self) -> None:
        """Stop the process."""
        self._finalizer()
