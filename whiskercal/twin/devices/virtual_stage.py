"""The stage firmware of the twin: docs/protocol.md's grbl-style protocol over a simulated line.

It answers exactly what ``firmware/stage_stepper`` answers: the banner, ``ok``/``error:N``,
pushed ``ALARM:N``, realtime ``?``, ``!``, ``~`` and 0x18, ``$``, ``$H``, ``$X``, ``$I``, ``$$``,
``$N=v`` and G0/G1/G4/G17/G21/G90/G91/G94, with grbl 1.1's block rules. In ``stock`` mode it
behaves like plain grbl 1.1: no ``Enc:`` field, no ``[PROTO:...]``, no encoder settings or
alarms, and its machine space and limit alarms are grbl's (below). Every number it answers
with is a named code of the shared table (``rig.codes``).

Stock grbl 1.1 (gnea/grbl ``limits_go_home``, ``system_check_travel_limits``): after ``$H`` the
carriage stands at machine -$130+$27 (X and Y home toward their switches at the minimum,
``$23=3``) and the workspace is -$130..0; a HOMING_FORCE_SET_ORIGIN build (``origin="set"``)
stands at 0 and works in 0..$130. A target outside the workspace with ``$20=1`` is a soft-limit
alarm: a feed hold, then ``ALARM:2``, ALARM_PAUSE_S in which every byte is lost (a reset too),
``[MSG:Reset to continue]``, and until a reset the board ignores everything else (``?``
included); the reset answers the refused line's ``ok`` before its banner. A failed homing cycle
is ``ALARM:9``, the same pause, the ``ok`` of ``$H`` and a reset; a homing cycle serves no ``?``
until it ends. The twin's stage has switches at its minimum only: a ``$23`` that sends X or Y
toward the maximum finds no switch (``ALARM:9``). tests/data/grbl_transcripts pin all this down.

Time comes from outside: ``receive(data, t)`` and ``advance_to(t)`` are called with
non-decreasing simulated times; replies go into ``self.line`` with their transmission delay.
"""

from __future__ import annotations

import math
import re
from collections import deque

import numpy as np

from whiskercal.protocol.codes import StageAlarm, StageError
from whiskercal.twin.devices.clock import SerialLine
from whiskercal.twin.devices.stage import ENCODER_CHECK_PERIOD_S, WHISKERCAL_SETTINGS, StageMechanics

BANNER = "Grbl 1.1h ['$' for help]"
HELP = "[HLP:$$ $I $x=val $X $H ~ ! ? ctrl-x]"  # grbl 1.1's help line, with the commands answered here
PROTO = "whiskercal-stage-1"
FIRMWARE_VERSION = "0.1.0"
MAX_LINE_CHARS = 80
PLANNER_BLOCKS = 15
WCO_REFRESH_REPORTS = 10  # grbl 1.1 resends WCO every 10 reports at rest (30 while moving)
_WORD = re.compile(r"([A-Z])([-+]?(?:\d+\.?\d*|\.\d+))")
_TRAVEL_EPS_MM = 1e-6
# grbl prints these without decimals ($30/$31, the spindle's rpm, with none either)
_INTEGER_SETTINGS = (0, 1, 2, 3, 4, 5, 6, 10, 13, 20, 21, 22, 23, 26, 30, 31, 32, 200)
RESET_TO_CONTINUE = "[MSG:Reset to continue]"
# grbl's pause between a limit or homing alarm and what follows it (the message, or the ok of $H), s
ALARM_PAUSE_S = 0.5
MAX_LINE_NUMBER = 9999999  # grbl 1.1's largest N word
MAX_TOOL_NUMBER = 255  # grbl 1.1's largest T word
MM_PER_INCH = 25.4
# The stock board's settings where they differ from whiskercal's firmware: grbl's $10 (report
# MPos) and the homing direction this stage's switches need ($23=3: X and Y toward their minimum;
# grbl's own default 0 homes toward +, where the stage has no switch); the rest of grbl 1.1h's 34
# settings at grbl's defaults (step pulse, junction deviation, arcs, spindle, and Z's $102..$132,
# Z having no motor here). $$ lists them all; only the X/Y motion and homing ones act.
STOCK_SETTINGS = {0: 10, 1: 25, 2: 0, 3: 0, 4: 0, 5: 0, 6: 0, 10: 1, 11: 0.010, 12: 0.002, 13: 0,
                  21: 0, 23: 3, 26: 250, 30: 1000, 31: 0, 32: 0,
                  102: 250.0, 112: 500.0, 122: 10.0, 132: 200.0}
_LOCKED = 0  # ``alarm`` value for the lock after power-up: Alarm state without an ALARM:N
# The modal groups (grbl 1.1 / RS274NGC numbers) of the G codes this stage knows.
_NON_MODAL, _MOTION, _PLANE, _DISTANCE, _FEED_MODE, _UNITS = 0, 1, 2, 3, 5, 6
_G_GROUPS = {4: _NON_MODAL, 0: _MOTION, 1: _MOTION, 17: _PLANE, 90: _DISTANCE, 91: _DISTANCE,
             94: _FEED_MODE, 21: _UNITS}
# stock grbl also knows G53 (move in machine coordinates), G92/G92.1 (set/clear the work offset),
# G20 (inches) and the arcs G2/G3 (whose feed rate is checked; the twin draws no arcs)
_STOCK_G_GROUPS = {**_G_GROUPS, 53: _NON_MODAL, 92: _NON_MODAL, 92.1: _NON_MODAL, 20: _UNITS,
                   2: _MOTION, 3: _MOTION}


class GcodeError(Exception):
    """A line refused with ``error:code``."""

    def __init__(self, code: StageError) -> None:
        super().__init__(code)
        self.code = int(code)


def parse_words(line: str) -> list[tuple[str, float]]:
    """Split a G-code line into (letter, value) words; malformed input raises ``GcodeError``."""
    text = re.sub(r"\([^)]*\)|;.*$", "", line).replace(" ", "").upper()
    words, position = [], 0
    for match in _WORD.finditer(text):
        if match.start() != position:
            raise GcodeError(_bad_word(text[position]))
        words.append((match.group(1), float(match.group(2))))
        position = match.end()
    if position != len(text):
        raise GcodeError(_bad_word(text[position]))
    return words


def _bad_word(first: str) -> StageError:
    # a letter without a number, or something that is not a letter where a word should start
    return StageError.BAD_NUMBER_FORMAT if first.isalpha() else StageError.EXPECTED_COMMAND_LETTER


def read_block(words: list[tuple[str, float]], known: dict[float, int] = _G_GROUPS,
               stock: bool = False) -> tuple[dict[int, float], dict[str, float]]:
    """A block's G codes by modal group and its X, Y, F, P words, checked word by word as grbl does.

    ``known`` maps the G codes the board knows to their groups (stock grbl adds G53, G92...). N
    words (line numbers) are accepted and ignored, and with ``stock`` T words too (grbl 1.1
    checks their range and ignores tool changes); any other letter is ``error:20``.
    """
    groups: dict[int, float] = {}
    values: dict[str, float] = {}
    for letter, value in words:
        if stock and letter in "NT":
            _stock_number_word(letter, value)
        elif letter == "G":
            _g_word(value, groups, known)
        elif letter in "XYFP":
            if letter in values:
                raise GcodeError(StageError.WORD_REPEATED)
            if letter in "FP" and value < 0:
                raise GcodeError(StageError.NEGATIVE_VALUE)
            values[letter] = value
        elif letter != "N":
            raise GcodeError(StageError.UNSUPPORTED_COMMAND)  # M, S, T... and Z: two axes here
    return groups, values


def _stock_number_word(letter: str, value: float) -> None:
    if letter == "N" and value > MAX_LINE_NUMBER:
        raise GcodeError(StageError.INVALID_LINE_NUMBER)
    if letter == "T" and value > MAX_TOOL_NUMBER:
        raise GcodeError(StageError.MAX_VALUE_EXCEEDED)


def _g_word(value: float, groups: dict[int, float], known: dict[float, int]) -> None:
    group = known.get(value)  # G38.2 and the like: none (4.0 finds 4, 92.1 finds 92.1)
    if group is None:
        raise GcodeError(StageError.UNSUPPORTED_COMMAND)
    if group == _MOTION and _MOTION in groups:
        raise GcodeError(StageError.AXIS_WORDS_CONFLICT)  # grbl checks this before the group
    if group in groups:
        raise GcodeError(StageError.MODAL_GROUP_VIOLATION)
    groups[group] = int(value) if value == int(value) else value


class VirtualStage:
    """The stage board: protocol state machine on top of :class:`StageMechanics`.

    Parameters
    ----------
    mechanics
        The stage's motion and faults.
    stock
        Behave like plain grbl 1.1 (no encoders, grbl's machine space and limit alarms).
    homing
        ``"xy"``: the stock build's config.h homes X and Y (grbl's own homes Z first).
    origin
        ``"set"``: a stock build with HOMING_FORCE_SET_ORIGIN (machine zero where homing ends).
    """

    def __init__(self, mechanics: StageMechanics, stock: bool = False, homing: str = "",
                 origin: str = "") -> None:
        self.mech = mechanics
        self.stock = stock
        # stock grbl 1.1's config.h homes Z first; a two-axis stage has no Z switch to find
        self.homes_z_first = stock and homing != "xy"
        self.force_set_origin = stock and origin == "set"
        if stock:
            for number, value in STOCK_SETTINGS.items():
                self.mech.settings.setdefault(number, value)
            for number in WHISKERCAL_SETTINGS:
                self.mech.settings.pop(number, None)
        self.line = SerialLine()
        self._input = bytearray()
        self._overflow = False
        self._pending: deque[str | None] = deque()
        self.alarm: int | None = None
        self.homing_until_s: float | None = None
        self.hold_stop_s: float | None = None
        self._resume_requested = False
        self._reports_to_wco = 0
        self._ok_after_dwell = False
        self._absolute = True
        self._motion = 0
        self._feed_mm_min: float | None = None
        self._last_check_s = 0.0
        self._faults_done: set[str] = set()
        self._slipping = False  # a slip or stall happened since the last homing
        self._soft_limit_at_s: float | None = None  # stock: a soft-limit hold ends, then ALARM:2
        self._awaiting_reset = False  # stock: grbl's pause after a limit alarm
        # stock: grbl's silent ALARM_PAUSE_S after a limit or homing alarm, and what ends it
        self._pause_until_s: float | None = None
        self._after_pause = None
        self._ok_on_reset = False  # stock: the line that hit the soft limits is answered by a reset
        self._status_requested = False  # stock: a '?' during homing, served when homing ends
        # Z's step counter, mm: the stage has no Z motor, but stock grbl's failed Z search counts
        # its steps all the same (whiskercal's firmware has no Z: always 0)
        self.z_mm = 0.0
        self.now_s = 0.0
        self._boot(0.0, moving=False, power_up=True)

    # -- host bytes -------------------------------------------------------------------------
    def receive(self, data: bytes, t: float) -> None:
        """Bytes from the host arriving at time ``t``."""
        self.advance_to(t)
        for byte in data:
            if byte in b"?!~\x18":
                self._realtime(byte, t)
            elif byte == 0x0A:
                line = self._input.decode("ascii", errors="replace").strip("\r")
                self._pending.append(None if self._overflow else line)
                self._input.clear()
                self._overflow = False
                self._run_pending(t)
            elif len(self._input) < MAX_LINE_CHARS:
                self._input.append(byte)
            else:
                self._overflow = True  # grbl drops the rest and refuses the line

    def power_up(self, t: float) -> None:
        """Reset as at power-up: motion stops, the step counters restart at zero (homing lost)."""
        self.advance_to(t)
        self.mech.stop_now(t)
        self.mech.home_offset_mm = self.mech.commanded_mm(t)
        self.line.clear()
        self.alarm, self.homing_until_s = None, None
        self.z_mm = 0.0
        self._boot(t, moving=False, power_up=True)

    def _realtime(self, byte: int, t: float) -> None:
        if self._pause_until_s is not None:
            return  # grbl's pause after an alarm loses every realtime byte, a reset too
        if self._awaiting_reset and byte != 0x18:
            return  # grbl's pause after a limit alarm serves nothing but a reset
        if byte == ord("?") and self.stock and self.homing_until_s is not None:
            self._status_requested = True  # grbl's homing cycle serves no realtime report
        elif byte == ord("?"):
            self._send(self.status_report(t), t)
        elif byte == ord("!") and self.state(t) == "Run":
            self.hold_stop_s = self.mech.hold(t)
        elif byte == ord("~") and self.hold_stop_s is not None and self._soft_limit_at_s is None:
            self._resume_requested = True
            self._finish_hold(t)
        elif byte == 0x18:
            if self._ok_on_reset:
                self._send("ok", t)  # grbl returns from the refused line before it resets
            self._boot(t, moving=self.mech.busy(t) or self.homing_until_s is not None)

    def _boot(self, t: float, moving: bool, power_up: bool = False) -> None:
        self.mech.stop_now(t)
        self._pending.clear()
        self._input.clear()
        self.hold_stop_s, self._resume_requested = None, False
        self._soft_limit_at_s, self._awaiting_reset = None, False
        self._pause_until_s, self._after_pause, self._ok_on_reset = None, None, False
        self._status_requested = False
        self._absolute, self._motion, self._feed_mm_min, self._inches = True, 0, None, False
        self._work_offset_mm = np.zeros(2)  # stock grbl's G92 offset, cleared by a reset
        self._reports_to_wco, self._ok_after_dwell = 0, False
        if moving:
            self.homing_until_s = None
            self._raise_alarm(StageAlarm.ABORT_CYCLE, t)
        self._send(f"\r\n{BANNER}", t)
        if self.alarm is None and self.mech.settings[22] and power_up:
            self.alarm = _LOCKED  # locked after power-up until $H or $X, as grbl with homing enabled
        if self.alarm is not None:
            self._send("[MSG:'$H'|'$X' to unlock]", t)

    def _send(self, text: str, t: float) -> None:
        self.line.send((text + "\r\n").encode("ascii"), t)

    # -- time -------------------------------------------------------------------------------
    def next_event_s(self) -> float | None:
        """The next time the board will act on its own (finish homing, alarm, take a line)."""
        times = [self._next_fault_s(), self._next_check_s()]
        if self.homing_until_s is not None:
            times.append(self.homing_until_s)
        if self._soft_limit_at_s is not None:
            times.append(self._soft_limit_at_s)
        if self._pause_until_s is not None:
            times.append(self._pause_until_s)
        if self._resume_requested and self.hold_stop_s is not None:
            times.append(self.hold_stop_s)
        if self._pending and self.homing_until_s is None and self.mech.queue and not self.mech.paused:
            times.append(self.mech.active_end_s())
        if self._waits_for_motion():
            times.append(self.mech.active_end_s())
        times = [x for x in times if x is not None and x > self.now_s - 1e-12]
        return min(times) if times else None

    def _waits_for_motion(self) -> bool:
        """Stock grbl's G4 waits for the moves before it, and its "ok" for the dwell itself."""
        dwell_next = bool(self._pending) and _is_dwell(self._pending[0])
        return (self.stock and (self._ok_after_dwell or dwell_next) and not self.mech.paused
                and self.homing_until_s is None and self.mech.busy(self.now_s))

    def advance_to(self, t: float) -> None:
        """Run every internal event up to time ``t``."""
        handled = None
        while True:
            event = self.next_event_s()
            if event is None or event > t or event == handled:
                break
            handled = event
            self._step(max(event, self.now_s))
        self.mech.advance_to(t)
        self.now_s = max(self.now_s, t)

    def _step(self, t: float) -> None:
        self.mech.advance_to(t)
        self.now_s = t
        if self.homing_until_s is not None and t >= self.homing_until_s:
            self._end_homing(t)
        if self._soft_limit_at_s is not None and t >= self._soft_limit_at_s:
            self._soft_limit_alarm(t)
        if self._pause_until_s is not None and t >= self._pause_until_s:
            self._end_pause(t)
        self._apply_faults(t)
        self._check_encoders(t)
        self._finish_hold(t)
        self._run_pending(t)

    def _end_homing(self, t: float) -> None:
        if self._homing_finds_no_switch():  # only stock grbl's cycles: see _homing_finds_no_switch
            # grbl: the alarm; after its pause the ok of $H, then the reset ending a failed cycle
            self.homing_until_s, self._status_requested = None, False
            if self.homes_z_first:  # the search toward +Z, counted from 0, was stepped out in vain
                self.z_mm = 1.5 * self.mech.settings[132]
            self._raise_alarm(StageAlarm.HOMING_FAIL_APPROACH, t)
            self._pause(t, self._answer_failed_homing)
            return
        self.mech.finish_homing(self._homed_machine_mm())
        if self._status_requested:  # still "Home", at the final position
            self._status_requested = False
            self._send(self.status_report(t), t)
        self.homing_until_s = None
        self.alarm = None
        self._send("ok", t)

    def _answer_failed_homing(self, t: float) -> None:
        self._send("ok", t)
        self._boot(t, moving=False)

    def _pause(self, t: float, then) -> None:
        """Stock grbl's silent ALARM_PAUSE_S after a limit or homing alarm, then ``then(t)``."""
        self._pause_until_s, self._after_pause = t + ALARM_PAUSE_S, then

    def _end_pause(self, t: float) -> None:
        then = self._after_pause
        self._pause_until_s, self._after_pause = None, None
        then(t)

    def _homing_finds_no_switch(self) -> bool:
        """Z first (no Z switch here), or ``$23`` sends X or Y toward the maximum (no switch there)."""
        return self.homes_z_first or (self.stock and int(self.mech.settings[23]) & 3 != 3)

    def _homed_machine_mm(self) -> np.ndarray:
        """Machine position where homing leaves the carriage (pulled off the minimum switches):
        grbl sets the switch to -$130 and the workspace to -$130..0 unless it forces the origin."""
        if not self.stock or self.force_set_origin:
            return np.zeros(2)
        travel = np.array([self.mech.settings[130], self.mech.settings[131]])
        return -travel + self.mech.settings[27]

    def _workspace_mm(self) -> tuple[np.ndarray, np.ndarray]:
        """The soft-limit box in machine coordinates, mm: 0..travel (whiskercal's firmware and a
        HOMING_FORCE_SET_ORIGIN build homing toward the minimum) or stock grbl's -travel..0."""
        travel = np.array([self.mech.settings[130], self.mech.settings[131]])
        if not self.stock or self.force_set_origin:
            return np.zeros(2), travel
        return -travel, np.zeros(2)

    def _soft_limit(self, t: float) -> None:
        """Stock grbl's answer to a target outside the workspace: a feed hold, then the alarm."""
        self._soft_limit_at_s = self.mech.hold(t) if self.mech.busy(t) else t
        if self._soft_limit_at_s > t:
            self.hold_stop_s = self._soft_limit_at_s  # reported as Hold:1 while it decelerates
        else:
            self._soft_limit_alarm(t)

    def _soft_limit_alarm(self, t: float) -> None:
        self._soft_limit_at_s = None
        self._raise_alarm(StageAlarm.SOFT_LIMIT, t)
        self._awaiting_reset, self._ok_on_reset = True, True
        self._pause(t, lambda when: self._send(RESET_TO_CONTINUE, when))

    def _finish_hold(self, t: float) -> None:
        if self._resume_requested and self.hold_stop_s is not None and t >= self.hold_stop_s:
            self.hold_stop_s, self._resume_requested = None, False
            self.mech.resume(t)

    # -- faults -----------------------------------------------------------------------------
    def _fault_times(self) -> dict[str, float | None]:
        faults = self.mech.faults
        return {"missed_steps": faults.missed_steps_at_s, "stall": faults.stall_at_s,
                "encoder_magnet": faults.encoder_magnet_at_s, "encoder_bus": faults.encoder_bus_at_s}

    def _next_fault_s(self) -> float | None:
        times = [when for name, when in self._fault_times().items()
                 if when is not None and name not in self._faults_done]
        return min(times) if times else None

    def _apply_faults(self, t: float) -> None:
        for name, when in self._fault_times().items():
            if when is None or when > t or name in self._faults_done:
                continue
            self._faults_done.add(name)
            if name in ("missed_steps", "stall"):
                self._slipping = True
                self._last_check_s = when
            if name == "missed_steps":
                self.mech.miss_steps(when, self.mech.faults.missed_steps_mm)
            elif name == "stall":
                self.mech.stall(when)
        self._check_encoder_health(t)

    def _encoders_on(self) -> bool:
        return not self.stock and bool(self.mech.settings.get(200, 0))

    def _check_encoder_health(self, t: float) -> None:
        if not self._encoders_on() or self.alarm is not None:
            return
        if "encoder_bus" in self._faults_done:
            self._raise_alarm(StageAlarm.ENCODER_BUS, t)
        elif "encoder_magnet" in self._faults_done:
            self._raise_alarm(StageAlarm.ENCODER_MAGNET, t)

    def _next_check_s(self) -> float | None:
        # encoder and step counters can only disagree after a slip or a stall
        if not self._encoders_on() or self.alarm is not None or not self._slipping:
            return None
        return (math.floor(self._last_check_s / ENCODER_CHECK_PERIOD_S) + 1) * ENCODER_CHECK_PERIOD_S

    def _check_encoders(self, t: float) -> None:
        if self._next_check_s() is None or t < self._next_check_s():
            return
        self._last_check_s = t
        if self.homing_until_s is not None:
            return
        disagreement = np.abs(self.mech.encoder_mm(t) - self.mech.machine_mm(t))
        if np.max(disagreement) > self.mech.settings[202]:
            self._raise_alarm(StageAlarm.ENCODER_MISMATCH, t)

    def _raise_alarm(self, code: StageAlarm, t: float) -> None:
        self.mech.stop_now(t)
        self.homing_until_s = None
        self.hold_stop_s, self._resume_requested = None, False
        self._pending.clear()
        self.alarm = int(code)
        self._send(f"ALARM:{self.alarm}", t)

    # -- state and status -------------------------------------------------------------------
    def state(self, t: float) -> str:
        """grbl state name at time ``t``."""
        if self.alarm is not None:
            return "Alarm"
        if self.homing_until_s is not None:
            return "Home"
        if self.hold_stop_s is not None:
            return "Hold:1" if t < self.hold_stop_s else "Hold:0"  # GRBL 1.1: Hold:0 = hold complete
        return "Run" if self.mech.busy(t) else "Idle"

    def _position_field(self, x: float, y: float) -> str:
        """MPos, or (``$10`` bit 0 clear) WPos with grbl's WCO on the first report after a reset
        or a G92 and every WCO_REFRESH_REPORTS reports after that (the work offset is stock
        grbl's G92 offset, always zero with whiskercal's firmware)."""
        if int(self.mech.settings.get(10, 1)) & 1:
            return f"MPos:{x:.3f},{y:.3f},{self.z_mm:.3f}"
        wx, wy = self._work_offset_mm
        field = f"WPos:{x - wx:.3f},{y - wy:.3f},{self.z_mm:.3f}"
        if self._reports_to_wco == 0:
            field += f"|WCO:{wx:.3f},{wy:.3f},0.000"
            self._reports_to_wco = WCO_REFRESH_REPORTS
        self._reports_to_wco -= 1
        return field

    def status_report(self, t: float) -> str:
        """The ``<...>`` status line at time ``t``."""
        x, y = self.mech.machine_mm(t)
        report = f"<{self.state(t)}|{self._position_field(x, y)}|FS:{self.mech.speed_mm_min(t):.0f},0"
        if self._encoders_on():
            ex, ey = self.mech.encoder_mm(t)
            report += f"|Enc:{ex:.3f},{ey:.3f}"
        pins = self.mech.pins(t)
        return report + (f"|Pn:{pins}" if pins else "") + ">"

    # -- lines ------------------------------------------------------------------------------
    def _run_pending(self, t: float) -> None:
        if self._soft_limit_at_s is not None or self._awaiting_reset or self._pause_until_s is not None:
            return  # grbl sits in its soft-limit check, then in the alarm's pause
        if self._ok_after_dwell:
            if self.mech.busy(t):
                return  # stock grbl's main loop sits in the dwell; lines wait
            self._ok_after_dwell = False
            self._send("ok", t)
        while self._pending and self.homing_until_s is None:
            if len(self.mech.queue) >= PLANNER_BLOCKS:
                return  # grbl holds back the "ok" until the planner has room
            if self.stock and self.mech.busy(t) and _is_dwell(self._pending[0]):
                return  # stock grbl's G4 first waits for the planner to empty
            line = self._pending.popleft()
            try:
                self._execute(line, t)
            except GcodeError as error:
                self._send(f"error:{error.code}", t)

    def _execute(self, line: str | None, t: float) -> None:
        if line is None:
            raise GcodeError(StageError.OVERFLOW)
        text = line.strip()
        if text.startswith("$"):
            self._system_command(text[1:].upper().replace(" ", ""), t)
        elif text:
            if self.alarm is not None:
                raise GcodeError(StageError.SYSTEM_GC_LOCK)
            self._gcode(parse_words(text), t)
            if not self._ok_after_dwell and self._soft_limit_at_s is None and not self._awaiting_reset:
                self._send("ok", t)  # a line that hit the soft limits is never answered
        else:
            self._send("ok", t)

    def _system_command(self, command: str, t: float) -> None:
        handlers = {"": self._help, "$": self._list_settings, "I": self._build_info,
                    "X": self._unlock, "H": self._home}
        if command not in ("", "X") and self.state(t) not in ("Idle", "Alarm"):
            raise GcodeError(StageError.IDLE_ERROR)  # as grbl: settings, info and homing wait for the stage to rest
        if command in handlers:
            handlers[command](t)
        elif re.fullmatch(r"\d+=.*", command):
            self._set_setting(command, t)
        elif self.stock and not command[:1].isdigit():
            raise GcodeError(StageError.BAD_NUMBER_FORMAT)  # grbl reads an unknown $ letter as a number
        else:
            raise GcodeError(StageError.INVALID_STATEMENT)

    def _help(self, t: float) -> None:
        self._send(HELP, t)
        self._send("ok", t)

    def _list_settings(self, t: float) -> None:
        for number in sorted(self.mech.settings):
            value = self.mech.settings[number]
            text = f"{int(value)}" if number in _INTEGER_SETTINGS else f"{value:.3f}"
            self._send(f"${number}={text}", t)
        self._send("ok", t)

    def _build_info(self, t: float) -> None:
        if self.stock:
            self._send("[VER:1.1h.20190825:]", t)
            self._send("[OPT:V,15,128]", t)
        else:
            self._send(f"[VER:1.1h.{FIRMWARE_VERSION}:whiskercal-stage]", t)
            self._send("[OPT:V,15,128]", t)
            self._send(f"[PROTO:{PROTO}]", t)
        self._send("ok", t)

    def _unlock(self, t: float) -> None:
        if self.alarm is not None:
            self.alarm = None
            self._send("[MSG:Caution: Unlocked]", t)
        self._send("ok", t)
        self._check_encoder_health(t)  # a fault that is still there locks again at once

    def _home(self, t: float) -> None:
        if not self.mech.settings[22]:
            raise GcodeError(StageError.SETTING_DISABLED_HOMING)
        self.alarm = None
        self.hold_stop_s, self._resume_requested = None, False
        self._slipping = False  # homing re-references steps and encoders
        if self._homing_finds_no_switch():  # searches 1.5 x the travel at the seek rate in vain
            travel = self.mech.settings[132] if self.homes_z_first else max(self.mech.settings[130],
                                                                self.mech.settings[131])
            self.homing_until_s = t + 1.5 * travel / self.mech.settings[25] * 60.0
            return
        self.homing_until_s = self.mech.plan_homing(t)

    def _set_setting(self, command: str, t: float) -> None:
        number_text, value_text = command.split("=", 1)
        number = int(number_text)
        try:
            value = float(value_text)
        except ValueError:
            raise GcodeError(StageError.BAD_NUMBER_FORMAT) from None
        if number not in self.mech.settings:
            raise GcodeError(StageError.INVALID_STATEMENT)
        if value < 0:
            raise GcodeError(StageError.NEGATIVE_VALUE)
        self.mech.settings[number] = value
        self._send("ok", t)

    def _gcode(self, words: list[tuple[str, float]], t: float) -> None:
        """Check a whole block first; modal state and the queue change only when it is accepted."""
        groups, values = read_block(words, _STOCK_G_GROUPS if self.stock else _G_GROUPS, self.stock)
        inches = groups[_UNITS] == 20 if _UNITS in groups else self._inches
        values = _in_mm(values) if inches else values
        motion = groups.get(_MOTION, self._motion)
        absolute = groups[_DISTANCE] == 90 if _DISTANCE in groups else self._absolute
        feed = (values["F"] or None) if "F" in values else self._feed_mm_min  # F0: undefined
        dwell = groups.get(_NON_MODAL) == 4
        machine = groups.get(_NON_MODAL) == 53
        if dwell and "P" not in values:
            raise GcodeError(StageError.VALUE_WORD_MISSING)
        axes = "X" in values or "Y" in values
        # A motion command, or axis words in the modal motion mode; as in grbl, G0 and G1 without
        # axis words only set the mode, but G1 still needs a feed rate.
        if (axes or _MOTION in groups) and motion in (1, 2, 3) and feed is None:
            raise GcodeError(StageError.UNDEFINED_FEED_RATE)
        if motion in (2, 3) and (axes or _MOTION in groups):
            raise GcodeError(StageError.UNSUPPORTED_COMMAND)  # the twin draws no arcs
        if groups.get(_NON_MODAL) in (92, 92.1):
            self._set_work_offset(groups[_NON_MODAL], values)
            self._inches = inches
            return
        target = self._target(absolute, machine, values) if axes else None
        if target is not None and self._outside_soft_limits(target):
            self._soft_limit(t)
            return
        if dwell:
            self.mech.queue_dwell(values["P"], t)  # grbl dwells before it moves
            # stock grbl 1.1 dwells in its main loop and answers "ok" only after it; whiskercal's
            # firmware queues the dwell behind the moves and answers at once
            self._ok_after_dwell = self.stock and target is None
        if target is not None:
            self.mech.queue_move(target, feed if motion == 1 else None, t)
        self._motion, self._absolute, self._feed_mm_min = motion, absolute, feed
        self._inches = inches

    def _set_work_offset(self, code: float, values: dict[str, float]) -> None:
        """Stock grbl's G92 (the planned position becomes the given work coordinates) and G92.1
        (no offset), mm; whiskercal's firmware has neither, its work offset is always zero."""
        if code == 92.1:
            self._work_offset_mm = np.zeros(2)
        elif "X" not in values and "Y" not in values:
            raise GcodeError(StageError.NO_AXIS_WORDS)
        else:
            planned = self.mech.planned_end_mm() - self.mech.home_offset_mm
            for axis, letter in enumerate("XY"):
                if letter in values:
                    self._work_offset_mm[axis] = planned[axis] - values[letter]
        self._reports_to_wco = 0  # grbl sends WCO with the next report after a change

    def _target(self, absolute: bool, machine: bool, values: dict[str, float]) -> np.ndarray:
        """Machine target of a move, mm: G90 words are work coordinates (machine plus the G92
        offset), G53's are machine coordinates; outside the travel with soft limits on,
        whiskercal's firmware answers ``error:15``."""
        start = self.mech.planned_end_mm() - self.mech.home_offset_mm
        offset = np.array([values.get("X", 0.0), values.get("Y", 0.0)])
        work = np.zeros(2) if machine else self._work_offset_mm
        target = start + offset if not (absolute or machine) else np.array(
            [values.get("X", start[0] - work[0]), values.get("Y", start[1] - work[1])]) + work
        if not self.stock and self._outside_soft_limits(target):
            raise GcodeError(StageError.TRAVEL_EXCEEDED)
        return target

    def _outside_soft_limits(self, target: np.ndarray) -> bool:
        low, high = self._workspace_mm()
        outside = np.any(target < low - _TRAVEL_EPS_MM) or np.any(target > high + _TRAVEL_EPS_MM)
        return bool(self.mech.settings[20]) and bool(outside)


def _in_mm(values: dict[str, float]) -> dict[str, float]:
    """A block's X, Y and F words given in inches (G20), in mm and mm/min."""
    return {letter: value * MM_PER_INCH if letter in "XYF" else value for letter, value in values.items()}


def _is_dwell(line: str | None) -> bool:
    """Whether a G-code line holds G4 (G4, G04, g4; not G40 or a $ command)."""
    return line is not None and not line.lstrip().startswith("$") and \
        re.search(r"G0*4(?![0-9.])", line.upper().replace(" ", "")) is not None
