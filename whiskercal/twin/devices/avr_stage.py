"""The stage board played by ``stage_stepper.hex`` on simavr (``sim://NAME/stage?firmware=avr``).

The firmware's step pulses are counted by the harness into motor steps; here they become the
carriage's physical position over time (:class:`StepTrace`), which replaces the world's Python
stage mechanics, so the whisker, the sensor and the ground truth follow the emulated firmware's
moves. The limit switches close where the Python stage's do (the carriage at -$27 = -1 mm in
the homed frame, judged on the motor position), and each AS5600 read returns the pulley's angle
(4096 counts per 40 mm turn, as the twin's belt).

Faults of the world (``fault=`` URL option): ``missed_steps`` slips the pulleys against the last
direction of motion (the encoders see it, the step counters do not), ``stall`` freezes them for
good, ``encoder_magnet`` takes Y's magnet away, ``encoder_bus`` silences X's encoder.
"""

from __future__ import annotations

import bisect

import numpy as np

from whiskercal.twin.devices.avr_board import AvrBoard
from whiskercal.twin.devices.stage import AS5600_COUNTS_PER_TURN, DEFAULT_SETTINGS, StageFaults

STEPS_PER_MM = np.array([DEFAULT_SETTINGS[100], DEFAULT_SETTINGS[101]])  # the belt's, not a setting
MM_PER_TURN = DEFAULT_SETTINGS[201]
SWITCH_MM = -DEFAULT_SETTINGS[27]  # the switches close at the pull-off distance below machine zero
AS5600_MAGNET_DETECTED = 0x20


class StepTrace:
    """The carriage's physical position (mm) from the motor step counters, piecewise linear in
    time between the moments they were read; backlash as a dead band, slips and a stall."""

    def __init__(self, start_mm, now_s: float, backlash_mm: float) -> None:
        self.backlash_mm = backlash_mm
        self._times = [now_s]
        self._mm = [np.asarray(start_mm, dtype=float)]
        self._path = [0.0]  # distance travelled by the motors up to each entry
        self.base_mm = self._mm[0].copy()  # where step count 0 is
        self._carriage = (now_s, self._mm[0].copy())
        self._slips: list[tuple[float, np.ndarray]] = []
        self.stall_from_s: float | None = None

    def record(self, t: float, steps) -> None:
        """The counters read ``steps`` at time ``t`` (non-decreasing)."""
        position = self.base_mm + np.asarray(steps, dtype=float) / STEPS_PER_MM
        if t <= self._times[-1]:
            return
        if np.array_equal(position, self._mm[-1]):
            if len(self._mm) >= 2 and np.array_equal(self._mm[-2], position):
                self._times[-1] = t  # still at rest: stretch the last entry
                return
        self._path.append(self._path[-1] + float(np.hypot(*(position - self._mm[-1]))))
        self._times.append(t)
        self._mm.append(position)

    def rebase(self, t: float) -> None:
        """The counters restart from 0 (a reset of the board) where the motors are at ``t``."""
        self.base_mm = self.commanded_mm(t)

    def _locate(self, t: float) -> tuple[int, float]:
        index = bisect.bisect_right(self._times, t) - 1
        if index < 0:
            return 0, 0.0
        if index >= len(self._times) - 1:
            return len(self._times) - 1, 0.0
        t0, t1 = self._times[index], self._times[index + 1]
        return index, (t - t0) / (t1 - t0)

    def commanded_mm(self, t: float) -> np.ndarray:
        """Where the step counters put the carriage at time ``t`` (physical mm)."""
        index, fraction = self._locate(t)
        if fraction == 0.0:
            return self._mm[index].copy()
        return self._mm[index] + fraction * (self._mm[index + 1] - self._mm[index])

    def path_length_mm(self, t0: float, t1: float) -> float:
        """Distance the motors travelled between ``t0`` and ``t1``, mm."""
        def travelled(t):
            index, fraction = self._locate(t)
            if fraction == 0.0:
                return self._path[index]
            return self._path[index] + fraction * (self._path[index + 1] - self._path[index])
        return max(travelled(t1) - travelled(t0), 0.0)

    def slip(self, t: float, distance_mm: float) -> None:
        """The pulleys lose ``distance_mm`` against the last direction of motion before ``t``."""
        index, _ = self._locate(t)
        direction = np.array([1.0, 0.0])
        for back in range(index, 0, -1):
            delta = self._mm[back] - self._mm[back - 1]
            if np.any(delta):
                direction = delta / np.hypot(*delta)
                break
        self._slips.append((t, -distance_mm * direction))

    def pulley_mm(self, t: float) -> np.ndarray:
        """Where the motor shafts really are (physical mm)."""
        if self.stall_from_s is not None and t >= self.stall_from_s:
            t = self.stall_from_s
        total = sum((amount for when, amount in self._slips if when <= t), np.zeros(2))
        return self.commanded_mm(t) + total

    def carriage_mm(self, t: float) -> np.ndarray:
        """The carriage after the belt's dead band (physical mm); asked in time order."""
        half = self.backlash_mm / 2
        pulley = self.pulley_mm(t)
        carriage = np.clip(self._carriage[1], pulley - half, pulley + half)
        if t >= self._carriage[0]:
            self._carriage = (t, carriage)
        return carriage


class AvrStageBoard(AvrBoard):
    """The stage board played by ``stage_stepper.hex`` (see the module docstring).

    Parameters
    ----------
    start_mm
        The carriage's physical position when the board is plugged in, mm.
    now_s
        The world's time then.
    backlash_mm
        The belt's dead band, mm.
    faults
        The world's stage faults.
    """

    kind = "stage"

    def __init__(self, start_mm, now_s: float, backlash_mm: float, faults: StageFaults | None = None) -> None:
        self.trace = StepTrace(start_mm, now_s, backlash_mm)
        self.stage_faults = faults or StageFaults()
        self._slipped = False
        self._z_steps = 0
        if self.stage_faults.stall_at_s is not None:
            self.trace.stall_from_s = self.stage_faults.stall_at_s
        super().__init__(now_s)

    def _start(self, t: float) -> None:
        self.trace.rebase(t)
        super()._start(t)
        switch_steps = np.floor((SWITCH_MM - self.trace.base_mm) * STEPS_PER_MM + 1e-6).astype(int)
        self.harness.send_request(f"L {switch_steps[0]} {switch_steps[1]}")

    def _report(self, words: list[str]) -> None:
        """``P <cycle> <x> <y>``: the step counters at the end of a run."""
        t = self._time(int(words[1]))
        moved_before = self.trace.commanded_mm(self.now_s)
        self.trace.record(t, (int(words[2]), int(words[3])))
        z_steps = int(words[4]) if len(words) > 4 else 0  # grbl's Z: no motor, but the firmware is busy
        if not np.array_equal(moved_before, self.trace.commanded_mm(t)) or z_steps != self._z_steps:
            self.keep_active(t + 0.1)  # moving: keep the physics (and the answers) in small steps
        self._z_steps = z_steps
        self._apply_slip(t)

    def _apply_slip(self, t: float) -> None:
        when = self.stage_faults.missed_steps_at_s
        if not self._slipped and when is not None and t >= when:
            self.trace.slip(when, self.stage_faults.missed_steps_mm)
            self._slipped = True

    def _answer(self, words: list[str]) -> str:
        """``A <cycle> <axis> <x> <y>``: what the AS5600 of that axis reads."""
        if words[0] != "A":
            return super()._answer(words)
        t, axis = self._time(int(words[1])), int(words[2])
        self.trace.record(t, (int(words[3]), int(words[4])))
        self._apply_slip(t)
        faults = self.stage_faults
        if axis == 0 and faults.encoder_bus_at_s is not None and t >= faults.encoder_bus_at_s:
            return "nack"
        status = AS5600_MAGNET_DETECTED
        if axis == 1 and faults.encoder_magnet_at_s is not None and t >= faults.encoder_magnet_at_s:
            status = 0
        turns = self.trace.pulley_mm(t)[axis] / MM_PER_TURN
        return f"{status} {int(round(turns * AS5600_COUNTS_PER_TURN)) % AS5600_COUNTS_PER_TURN}"
