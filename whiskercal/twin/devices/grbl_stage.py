"""Stock grbl 1.1h on simavr as the stage: ``sim://NAME/stage?firmware=grbl[&homing=xy]``.

grbl is not part of whiskercal (it is GPL and lives in its own repository): ``make grbl-sim``
builds a checkout of gnea/grbl v1.1h, unchanged (``WHISKERCAL_GRBL_SRC``), with its own config.h
(Z homed first, then X and Y), with a copy of config.h whose only homing cycle homes X and Y
together (``homing=xy``), and with that copy and HOMING_FORCE_SET_ORIGIN (``homing=xy&origin=set``:
machine zero where homing ends). The image runs in the same harness as whiskercal's own stage
firmware, with stock grbl's ATmega328P pin map (``firmware/sim/stage_part.h``): its step counters
move the twin's carriage (``avr_stage.StepTrace``), the X and Y limit switches close where the
Python stage's do (1 mm below the homed zero), its Z axis has neither motor nor switch, and there
are no encoders.

A new board's EEPROM is blank, so grbl restores its generic defaults (250 steps/mm, 500 mm/min,
homing off). The twin's board is set up as its owner would set up a real one: once, over its
serial line, with :data:`OWNER_SETTINGS` (the belt's steps/mm and the twin stage's rates,
accelerations, travel and homing settings, the switches at the negative end: ``$23=3``). The
EEPROM that leaves is kept in the build directory next to the image and loaded at every
power-up; what a host changes over the port (``$10=0``, say) is kept when the port is opened
again, as the chip's EEPROM keeps it.

grbl answers some lines long after they arrive and in silence meanwhile (``$H`` after its
debounce pauses, ``G4`` after the moves before it and the dwell, the line that raised an alarm
after the reset), so while a line is unanswered the board steps time in small quanta: its answer
reaches the host when grbl sends it, not when the host's read times out.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

from serial.serialutil import SerialException

from whiskercal.atomic import write_text
from whiskercal.errors import UsageError
from whiskercal.twin.devices.avr_board import QUANTUM_S
from whiskercal.twin.devices.avr_harness import F_CPU_HZ, AvrHarness, grbl_image
from whiskercal.twin.devices.avr_stage import AvrStageBoard
from whiskercal.twin.devices.stage import DEFAULT_SETTINGS, StageFaults

# grbl's $N as the twin's stage needs them; $23=3 homes X and Y towards their negative ends, where
# the switches are. Everything else stays at grbl's defaults ($10=1: MPos reports).
OWNER_SETTINGS: dict[int, float] = {
    **{n: DEFAULT_SETTINGS[n] for n in (20, 22, 24, 25, 27, 100, 101, 110, 111, 120, 121, 130, 131)},
    23: 3,
}
_SETUP_QUANTUM_CYCLES = F_CPU_HZ // 1000
_SETUP_LIMIT_CYCLES = 2 * F_CPU_HZ  # per answer: a setting write takes ~0.1 s of EEPROM time


def _no_request(words: list[str]) -> str:
    raise SerialException(f"unexpected request from the grbl board's harness: {' '.join(words)}")


def _run_until(harness: AvrHarness, text: bytes, start: int) -> tuple[int, bytes]:
    """Run the AVR from cycle ``start`` until its UART has sent ``text``; (cycle, bytes sent)."""
    sent, cycle = bytearray(), start
    while text not in sent:
        if cycle - start > _SETUP_LIMIT_CYCLES:
            raise SerialException(f"the grbl image did not send {text!r} while being set up; it sent {bytes(sent)!r}")
        cycle += _SETUP_QUANTUM_CYCLES
        sent += bytes(byte for _, byte in harness.run_to(cycle))
    return cycle, bytes(sent)


def _run_quiet(harness: AvrHarness, start: int) -> int:
    """Run the AVR until its UART has been silent for 20 ms; the cycle then."""
    cycle, quiet_since = start, start
    while cycle - quiet_since < 20 * _SETUP_QUANTUM_CYCLES:
        cycle += _SETUP_QUANTUM_CYCLES
        if harness.run_to(cycle):
            quiet_since = cycle
    return cycle


def _set_up(image: Path, settings: dict[int, float]) -> bytes:
    """Power up a blank board, send it ``settings`` line by line; its EEPROM afterwards."""
    harness = AvrHarness("stage", _no_request, image=image, pins="grbl")
    try:
        cycle, _ = _run_until(harness, b"['$' for help]\r\n", 0)  # error:7, the defaults, the banner
        cycle = _run_quiet(harness, cycle)  # then both startup lines fail (">:error:7")
        # soft limits ($20=1) are refused (error:10) until homing ($22=1) is on
        for number, value in sorted(settings.items(), key=lambda item: (item[0] == 20, item[0])):
            line = f"${number}={value:g}"
            harness.feed(line.encode("ascii") + b"\n")
            cycle, answer = _run_until(harness, b"\r\n", cycle)
            if answer != b"ok\r\n":
                raise SerialException(f"the grbl image answered {answer!r} to {line!r} while being set up")
        return harness.eeprom()
    finally:
        harness.close()


def owner_eeprom(image: Path, settings: dict[int, float] | None = None) -> bytes:
    """The EEPROM of ``image``'s board once set up with ``settings`` (:data:`OWNER_SETTINGS`);
    made once per image and settings and kept next to the image."""
    settings = OWNER_SETTINGS if settings is None else settings
    key = hashlib.sha256(image.read_bytes() + repr(sorted(settings.items())).encode()).hexdigest()[:16]
    kept = image.parent / f"eeprom-{key}.hex"
    if kept.is_file():
        return bytes.fromhex(kept.read_text())
    data = _set_up(image, settings)
    write_text(kept, data.hex())
    return data


class GrblStageBoard(AvrStageBoard):
    """The stage board played by stock grbl 1.1h (see the module docstring).

    Parameters
    ----------
    start_mm, now_s, backlash_mm, faults
        As for :class:`AvrStageBoard` (the encoder faults have nothing to act on: no encoders).
    homing
        ``"xy"`` for the image that homes X and Y in one cycle, ``""`` for grbl's own config.h.
    origin
        ``"set"`` for the XY image built with HOMING_FORCE_SET_ORIGIN (machine zero where homing
        ends); refused with grbl's own config.h, which has no such build here.
    """

    pins = "grbl"

    def __init__(self, start_mm, now_s: float, backlash_mm: float, faults: StageFaults | None = None,
                 homing: str = "", origin: str = "") -> None:
        if origin == "set" and homing != "xy":
            raise UsageError("sim:// firmware=grbl with origin=set needs homing=xy (the HOMING_FORCE_SET_ORIGIN "
                             "build homes X and Y in one cycle)")
        self.image = grbl_image(homing, origin)
        self.eeprom = owner_eeprom(self.image) if self.image.is_file() else b""
        super().__init__(start_mm, now_s, backlash_mm, faults)

    def _start(self, t: float) -> None:
        self._unanswered = 0  # lines grbl has taken and not yet answered with ok or error:N
        self._output = bytearray()
        super()._start(t)

    def receive(self, data: bytes, t: float) -> None:
        """Bytes from the host at time ``t``; its lines are counted until answered."""
        self._unanswered += data.count(b"\n")
        super().receive(data, t)

    def _put_on_line(self, sent: list[tuple[int, int]]) -> None:
        super()._put_on_line(sent)
        self._output += bytes(byte for _, byte in sent)
        *lines, rest = bytes(self._output).split(b"\n")
        self._output = bytearray(rest)
        for line in lines:
            if line.startswith((b"ok", b"error:")):
                self._unanswered = max(self._unanswered - 1, 0)
            elif line.startswith(b"Grbl "):
                self._unanswered = 0  # a reset: grbl dropped what it had not taken

    def next_event_s(self) -> float | None:
        """As any emulated board's; and a quantum ahead while a line waits for its answer."""
        event = super().next_event_s()
        if event is None and self._unanswered > 0:
            return self.now_s + QUANTUM_S
        return event

    def _make_harness(self) -> AvrHarness:
        harness = AvrHarness(self.kind, self._answer, self._report, image=self.image, pins=self.pins)
        harness.write_eeprom(self.eeprom)
        return harness

    def power_up(self, t: float) -> None:
        """Reset as opening the port does; the EEPROM (grbl's settings) stays as it was."""
        self.advance_to(t)
        self.eeprom = self.harness.eeprom()
        super().power_up(t)
