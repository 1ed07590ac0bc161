"""Client for the grbl-style stage (docs/protocol.md, "Stage").

Works with any grbl 1.1 board; with whiskercal's firmware (``[PROTO:whiskercal-stage-1]``) it
also reads the AS5600 encoder positions from the ``Enc:`` status field. Replies are matched to
commands in order; pushed ``ALARM:N`` lines raise :class:`StageAlarmError` wherever they appear.
"""

from __future__ import annotations

import dataclasses
import re
from dataclasses import dataclass
from typing import Callable

import numpy as np

from whiskercal.errors import DeviceError
from whiskercal.protocol.codes import StageAlarm, describe
from whiskercal.rig.machine_space import MachineSpace
from whiskercal.rig.transport import DeviceTimeout, Transport, open_port

_STATUS = re.compile(r"^<([^|>]+)((?:\|[^|>]*)*)>$")
# plain decimal numbers as grbl prints them (float() would also take "nan", "1_0", " 1")
_NUMBER = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?\Z", re.ASCII)
_SETTING = re.compile(r"\$(\d+)=(.*)\Z", re.ASCII | re.DOTALL)
_POLL_INTERVAL_S = 0.02
_MAX_LINE_BYTES = 256
STATUS_TRIES = 3  # '?' sent again when unanswered (grbl drops it during an alarm's pause)
LATE_REPORT_WAIT_S = 0.05
# grbl 1.1's limit alarms stop everything until a reset; it says so with this message first
CRITICAL_ALARMS = (StageAlarm.HARD_LIMIT, StageAlarm.SOFT_LIMIT)
RESET_TO_CONTINUE = "[MSG:Reset to continue]"
ALARM_LOCK_MESSAGE = "[MSG:'$H'|'$X' to unlock]"


class StageAlarmError(DeviceError):
    """The stage reported ``ALARM:N``; ``code`` is N (see ``codes.StageAlarm``)."""

    def __init__(self, code: int, where: str, hint: str = "") -> None:
        self.code = code
        super().__init__(f"stage on {where} raised ALARM:{code}: {describe('STAGE_ALARM', code)}"
                         + (f"; {hint}" if hint else ""))


HOMING_HINT = ("stock grbl 1.1 homes Z first and a two-axis stage has no Z switch: build grbl "
               "with the X-and-Y homing cycle in config.h (docs/stage.md), or set $22=0, put the "
               "stage at its origin by hand and collect with [motion] home = false; a board that "
               "homes X and Y finds no switch when $23 sends an axis away from it")


class StageCommandError(DeviceError):
    """The stage answered ``error:N`` to a command; ``code`` is N (see ``codes.StageError``)."""

    def __init__(self, code: int, command: str, where: str) -> None:
        self.code = code
        super().__init__(f"stage on {where} refused {command!r} with error:{code}: "
                         f"{describe('STAGE_ERROR', code)}")


@dataclass(frozen=True)
class StageStatus:
    """One status report. Positions in mm, in the stage's coordinates: the board's machine
    coordinates, mapped by ``StageClient.space`` when one is set; ``enc_mm`` is None on stock grbl."""

    state: str
    mpos_mm: np.ndarray
    enc_mm: np.ndarray | None
    feed_mm_min: float
    pins: str = ""
    wco_mm: np.ndarray | None = None

    @property
    def feed(self) -> float:
        """Current feed rate, mm/min (same as ``feed_mm_min``)."""
        return self.feed_mm_min

    @property
    def idle(self) -> bool:
        """True when the stage stands still with an empty motion queue."""
        return self.state == "Idle"

    @property
    def alarm(self) -> bool:
        """True when the stage is locked in alarm."""
        return self.state.startswith("Alarm")


@dataclass(frozen=True)
class StageIdentity:
    """What ``$I`` and the first status report told about the board."""

    version: str
    name: str
    options: str
    proto: str | None
    has_encoder: bool
    banner: str | None = None

    @property
    def whiskercal_firmware(self) -> bool:
        """True for whiskercal's firmware (or its twin), False for a stock grbl board."""
        return self.proto is not None


def parse_status(line: str, wco_mm: np.ndarray | None = None) -> StageStatus:
    """Parse ``<Idle|MPos:1,2,0|FS:0,0|Enc:1,2>``; unknown fields are ignored.

    grbl 1.1 reports ``MPos`` or, with ``$10`` bit 0 clear, ``WPos``; it then sends the work
    coordinate offset ``WCO`` (MPos = WPos + WCO) only every few reports, so the caller passes
    the last one it saw (``wco_mm``) and keeps the one returned in ``StageStatus.wco_mm``.

    A report is refused (DeviceError naming the line) unless its position holds finite x, y, z,
    ``Enc`` when present finite x, y, and the feed of ``FS``/``F`` is a finite number >= 0: a
    position the host cannot trust must stop the run, not move the stage.
    """
    match = _STATUS.match(line.strip())
    if match is None:
        raise DeviceError(f"stage sent a malformed status report: {line!r}")
    fields = dict(_split_field(f) for f in match.group(2).split("|") if f)
    if "WCO" in fields:
        wco_mm = _numbers(fields["WCO"], 3, "WCO", line)[:2]
    mpos = _machine_position(fields, wco_mm, line)
    enc = _numbers(fields["Enc"], 2, "Enc", line) if "Enc" in fields else None
    feed = _numbers(fields.get("FS", fields.get("F", "0")), 1, "FS", line)[0]
    if feed < 0:
        raise DeviceError(f"stage sent a status report with a negative feed: {line!r}")
    return StageStatus(match.group(1), mpos, enc[:2] if enc is not None else None,
                       float(feed), fields.get("Pn", ""), wco_mm)


def _machine_position(fields: dict[str, str], wco_mm: np.ndarray | None, line: str) -> np.ndarray:
    """x, y in machine coordinates (mm) from MPos, or from WPos and the work offset."""
    if "MPos" in fields:
        if "WPos" in fields:
            _numbers(fields["WPos"], 3, "WPos", line)
        return _numbers(fields["MPos"], 3, "MPos", line)[:2]
    if "WPos" not in fields:
        raise DeviceError(f"stage sent a status report without MPos or WPos: {line!r}")
    wpos = _numbers(fields["WPos"], 3, "WPos", line)[:2]
    if wco_mm is None:
        raise DeviceError(f"stage reported WPos before any WCO, so its machine position is unknown "
                          f"(set $10=1 so grbl reports MPos, or ask again): {line!r}")
    return wpos + np.asarray(wco_mm, float)


def _numbers(text: str, count: int, name: str, line: str) -> np.ndarray:
    """At least ``count`` comma-separated finite decimal numbers, or a DeviceError naming ``name``."""
    parts = text.split(",")
    if len(parts) < count or not all(_NUMBER.match(part) for part in parts):
        raise DeviceError(f"stage sent a status report whose {name} is not {count} or more "
                          f"numbers: {line!r}")
    values = np.array([float(part) for part in parts])
    if not np.all(np.isfinite(values)):
        raise DeviceError(f"stage sent a status report with a non-finite {name}: {line!r}")
    return values


def _split_field(field: str) -> tuple[str, str]:
    name, _, value = field.partition(":")
    return name, value


def parse_setting(line: str) -> tuple[int, float] | None:
    """``$N=value`` (grbl's ``$$`` lines, an optional ``(comment)`` after the value) -> (N, value).

    Lines that are not settings return None; a setting line whose value is missing, not a
    number or not finite raises DeviceError naming the line.
    """
    match = _SETTING.match(line.strip())
    if match is None:
        return None
    words = match.group(2).split()
    if not words or not _NUMBER.match(words[0]) or not np.isfinite(float(words[0])):
        raise DeviceError(f"stage sent a setting without a finite number: {line!r}")
    return int(match.group(1)), float(words[0])


class StageClient:
    """Talk to the stage on ``port`` (a name/URL or an open pyserial object).

    Parameters
    ----------
    port
        ``/dev/ttyUSB0``, ``sim://NAME/stage`` or an open pyserial object.
    timeout_s
        How long a command may take to be answered, s (homing has its own timeout).
    """

    def __init__(self, port, timeout_s: float = 2.0) -> None:
        self.transport = Transport(open_port(port), "stage")
        self.timeout_s = timeout_s
        self._pending = bytearray()
        self.banner: str | None = None
        self.work_offset_mm: np.ndarray | None = None  # grbl's last WCO (x, y), mm
        # where stage coordinates lie in the board's machine space (a stock grbl board's layout,
        # rig.machine_space); None: they are the board's machine coordinates (whiskercal's firmware)
        self.space: MachineSpace | None = None
        self._reset_awaited = False  # grbl printed "Reset to continue": only a reset goes on

    def close(self) -> None:
        """Close the port. Nothing is sent: a stage that is moving keeps moving (see
        ``whiskercal.session.RigSession``, which halts it first)."""
        self.transport.close()

    def __enter__(self) -> "StageClient":
        return self

    def __exit__(self, *exc_info) -> None:
        self.close()

    # -- lines ------------------------------------------------------------------------------
    def _read_line(self, timeout_s: float, what: str) -> str:
        deadline = self.transport.now_s() + timeout_s
        while b"\n" not in self._pending:
            remaining = deadline - self.transport.now_s()
            chunk = self.transport.read_some(_MAX_LINE_BYTES, max(remaining, 0.0))
            if not chunk and remaining <= 0:
                raise self.transport.timed_out(what, timeout_s)
            self._pending += chunk
        line, _, rest = bytes(self._pending).partition(b"\n")
        self._pending = bytearray(rest)
        return line.decode("ascii", errors="replace").rstrip("\r")

    def _reply_line(self, timeout_s: float, what: str) -> str:
        """The next line that is not a push; pushed alarms raise, banners are remembered."""
        while True:
            line = self._read_line(timeout_s, what)
            if line.startswith("ALARM:"):
                raise StageAlarmError(_code(line), self.transport.name)
            if line.startswith("Grbl "):
                self.banner = line
                continue
            self._note_message(line)
            if line and not line.startswith("[MSG:"):
                return line

    def command(self, line: str, timeout_s: float | None = None) -> list[str]:
        """Send one line, wait for ``ok``; return the lines before it. ``error:N`` raises."""
        timeout_s = self.timeout_s if timeout_s is None else timeout_s
        self.transport.write(line.encode("ascii") + b"\n")
        answer: list[str] = []
        while True:
            reply = self._reply_line(timeout_s, repr(line))
            if reply == "ok":
                return answer
            if reply.startswith("error:"):
                raise StageCommandError(_code(reply), line, self.transport.name)
            if not reply.startswith("<"):
                answer.append(reply)

    # -- queries ----------------------------------------------------------------------------
    def status(self) -> StageStatus:
        """Ask for a status report (realtime ``?``) and parse it.

        grbl drops a ``?`` it cannot serve (during an alarm's pause), so one left unanswered for
        a third of the timeout is sent again, up to STATUS_TRIES times in all.
        """
        for attempt in range(STATUS_TRIES):
            self.transport.write(b"?")
            try:
                line = self._status_line(self.timeout_s / STATUS_TRIES)
            except DeviceTimeout:
                if attempt == STATUS_TRIES - 1:
                    raise self.transport.timed_out("the status request '?'", self.timeout_s) from None
                continue
            if attempt:  # the earlier '?' may still be answered: that report must not be read later
                self._drain_pushes(LATE_REPORT_WAIT_S)
            status = parse_status(line, self.work_offset_mm)
            self.work_offset_mm = status.wco_mm  # grbl sends WCO only every few reports
            return self._in_stage_coordinates(status)
        raise AssertionError("unreachable")

    def _in_stage_coordinates(self, status: StageStatus) -> StageStatus:
        if self.space is None:
            return status
        enc = None if status.enc_mm is None else self.space.to_stage(status.enc_mm)
        return dataclasses.replace(status, mpos_mm=self.space.to_stage(status.mpos_mm), enc_mm=enc)

    def _status_line(self, timeout_s: float) -> str:
        while True:
            line = self._reply_line(timeout_s, "the status request '?'")
            if line.startswith("<"):
                return line

    def identify(self, boot_wait_s: float = 2.5) -> StageIdentity:
        """Wait for the banner, ask ``$I``, and check for the encoder field.

        Opening an Arduino's port resets it and its bootloader swallows what arrives in the
        first second or two, so until a banner has been seen this waits up to ``boot_wait_s``
        (s) for one; a board that did not reset is asked anyway.
        """
        self._drain_pushes()
        if self.banner is None:
            self._wait_for_banner(boot_wait_s)
        version, name, options, proto = "", "", "", None
        for line in self.command("$I"):
            if line.startswith("[VER:"):
                version, _, name = line[5:-1].partition(":")
            elif line.startswith("[OPT:"):
                options = line[5:-1]
            elif line.startswith("[PROTO:"):
                proto = line[7:-1]
        if not version:
            raise DeviceError(f"the device on {self.transport.name} does not answer '$I' like grbl")
        has_encoder = self.status().enc_mm is not None
        return StageIdentity(version, name, options, proto, has_encoder, self.banner)

    def settings(self) -> dict[int, float]:
        """All ``$N=value`` settings as numbers; a malformed setting line raises DeviceError."""
        parsed = (parse_setting(line) for line in self.command("$$"))
        return dict(setting for setting in parsed if setting is not None)

    def set_setting(self, number: int, value: float) -> None:
        """Write setting ``$number`` (stored in the board's EEPROM)."""
        self.command(f"${number}={value:g}")

    # -- motion -----------------------------------------------------------------------------
    def move_to(self, x_mm: float, y_mm: float, feed_mm_min: float) -> None:
        """Queue a linear move to stage position (x, y) mm at ``feed_mm_min``; returns at ``ok``.

        With a :attr:`space` the target is mapped into the board's machine space, checked
        against its workspace (DeviceError, nothing sent) and sent in machine coordinates
        (``G53``), whatever work offset the board holds.
        """
        if feed_mm_min <= 0:
            raise ValueError(f"feed rate must be positive, got {feed_mm_min} mm/min")
        if self.space is None:
            self.command(f"G90 G1 X{x_mm:.3f} Y{y_mm:.3f} F{feed_mm_min:.1f}")
            return
        x_mm, y_mm = self.space.to_machine([x_mm, y_mm])
        self.space.check([x_mm, y_mm], self.transport.name)
        self.command(f"G90 G53 G1 X{x_mm:.3f} Y{y_mm:.3f} F{feed_mm_min:.1f}")

    def dwell(self, seconds: float, queued_motion_s: float = 60.0) -> None:
        """Dwell ``seconds`` s after the queued moves.

        grbl 1.1 answers a ``G4`` only once the moves before it are done and the dwell is over
        (whiskercal's firmware queues it and answers at once), so the answer is waited for up to
        ``seconds`` plus ``queued_motion_s`` (s), the longest the queued moves may take.
        """
        self.command(f"G4 P{seconds:.3f}", timeout_s=seconds + queued_motion_s)

    def wait_idle(self, timeout_s: float = 60.0,
                  on_poll: Callable[[StageStatus], None] | None = None) -> StageStatus:
        """Poll ``?`` until the stage is ``Idle``; an alarm raises, as does ``timeout_s`` (s).

        ``on_poll(status)`` is called after every report, so the caller can read the sensor
        stream while the stage moves; without it the client waits ~20 ms between polls by
        reading (which also catches a pushed ``ALARM:N`` at once).
        """
        deadline = self.transport.now_s() + timeout_s
        while True:
            status = self.status()
            if on_poll is not None:
                on_poll(status)
            if status.idle:
                return status
            if status.alarm:
                raise DeviceError(f"stage on {self.transport.name} is in alarm; "
                                  "send $X to unlock or $H to home")
            if self.transport.now_s() > deadline:
                raise self.transport.timed_out("Idle (the move did not finish)", timeout_s)
            if on_poll is None:
                self._drain_pushes(_POLL_INTERVAL_S)

    def home(self, timeout_s: float = 120.0) -> None:
        """Run the homing cycle ``$H``; grbl answers ``ok`` once homing is done.

        A switch not found (ALARM:9) is told as a stage that needs another homing cycle: stock
        grbl 1.1 homes Z first, and a two-axis stage has no Z switch.
        """
        try:
            self.command("$H", timeout_s)
        except StageAlarmError as error:
            if error.code != StageAlarm.HOMING_FAIL_APPROACH:
                raise
            raise StageAlarmError(error.code, self.transport.name, HOMING_HINT) from None

    def unlock(self) -> None:
        """Clear an alarm lock without homing (``$X``)."""
        self.command("$X")

    def hold(self) -> None:
        """Feed hold (realtime ``!``): decelerate to a stop, keep the queue."""
        self.transport.write(b"!")

    def resume(self) -> None:
        """Cycle start (realtime ``~``): continue after a hold."""
        self.transport.write(b"~")

    def reset(self, timeout_s: float = 5.0) -> str:
        """Soft reset (0x18): stop at once, flush the queue; returns the banner."""
        self.transport.write(b"\x18")
        self._pending.clear()
        self._reset_awaited = False
        while True:
            line = self._read_line(timeout_s, "the soft reset")
            if line.startswith("Grbl "):
                self.banner = line
                return line

    def recover(self, code: int, timeout_s: float = 5.0) -> None:
        """Bring the board back from ``ALARM:code`` in grbl 1.1's order.

        After a limit alarm (1, 2) grbl prints ``[MSG:Reset to continue]`` and ignores everything
        but a reset, and a reset that arrives before that message is lost; so the message is
        waited for (``timeout_s``, s), then the reset (0x18) and its banner, then
        ``[MSG:'$H'|'$X' to unlock]``, then ``$X``. A soft limit keeps the position (grbl stops
        with a feed hold first); after a hard limit (1) the board stays locked: re-home it.
        """
        if code in CRITICAL_ALARMS and not self._reset_awaited:
            self._wait_for_message(RESET_TO_CONTINUE, timeout_s)
        self.reset(timeout_s)
        self._wait_for_message(ALARM_LOCK_MESSAGE, timeout_s)
        if code != StageAlarm.HARD_LIMIT:
            self.unlock()

    def _wait_for_message(self, message: str, timeout_s: float) -> None:
        while True:
            line = self._read_line(timeout_s, repr(message))
            if line.startswith("Grbl "):
                self.banner = line
            self._note_message(line)
            if line == message:
                return

    def _note_message(self, line: str) -> None:
        if line == RESET_TO_CONTINUE:
            self._reset_awaited = True

    def _wait_for_banner(self, wait_s: float) -> None:
        deadline = self.transport.now_s() + wait_s
        while self.banner is None and self.transport.now_s() < deadline:
            self._drain_pushes(deadline - self.transport.now_s())

    def _drain_pushes(self, wait_s: float = 0.0) -> None:
        """Consume pushed lines (banner, messages, alarms) and stray reports that arrive within
        ``wait_s`` s."""
        self._pending += self.transport.read_some(_MAX_LINE_BYTES, wait_s)
        while b"\n" in self._pending:
            line = self._read_line(0.0, "a pushed message")
            self._note_message(line)
            if line.startswith("ALARM:"):
                raise StageAlarmError(_code(line), self.transport.name)
            if line.startswith("Grbl "):
                self.banner = line


def _code(line: str) -> int:
    try:
        return int(line.split(":", 1)[1])
    except (IndexError, ValueError):
        raise DeviceError(f"stage sent an unreadable code line: {line!r}") from None
