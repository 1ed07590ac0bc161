"""Mechanics of the two-axis stage: trapezoidal moves, steps, encoders, backlash, faults.

Three positions per axis, all in mm:

- the **commanded** position follows the motion plan (what the step counters say, in the
  stage's physical coordinates where the homing switches sit at ``-pulloff``);
- the **pulley** position is where the motor shaft really is: commanded plus missed steps, or
  frozen during a stall. The AS5600 encoders sit on the motor shafts and measure this one;
- the **carriage** position (where the touch rod or fixture really is) follows the pulley
  through the belt's backlash, a dead band of ``backlash_mm``: the carriage is dragged only
  when the pulley moves past the band's edge. Approaching a point from one side cancels it.

Machine coordinates (``MPos``) are physical coordinates minus ``home_offset_mm``: unknown
until homing, which sets machine zero at the pulled-off switch position.

Nothing here knows about bytes or serial lines; ``virtual_stage`` speaks the protocol.
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass, field

import numpy as np

# grbl's settings plus whiskercal's 200..202 (docs/protocol.md); 24/25/27 are grbl's homing
# feed, seek rate (mm/min) and pull-off distance (mm) at grbl's own defaults.
DEFAULT_SETTINGS: dict[int, float] = {
    20: 1, 22: 1, 24: 25.0, 25: 500.0, 27: 1.0,
    100: 80.0, 101: 80.0, 110: 3000.0, 111: 3000.0, 120: 200.0, 121: 200.0,
    130: 200.0, 131: 200.0, 200: 1, 201: 40.0, 202: 0.5,
}
WHISKERCAL_SETTINGS = (200, 201, 202)
AS5600_COUNTS_PER_TURN = 4096
ENCODER_CHECK_PERIOD_S = 0.01
_MAX_HISTORY = 256


def trapezoid_phases(distance_mm: float, v_start: float, v_max: float,
                     accel: float) -> list[tuple[float, float, float]]:
    """Phases ``(duration s, start speed mm/s, acceleration mm/s²)`` that cover ``distance_mm``.

    Accelerate from ``v_start`` to at most ``v_max``, cruise, and decelerate to rest at the
    end (grbl plans every move like this when the queue holds one move at a time).
    """
    if distance_mm <= 0:
        return []
    v_peak = min(v_max, math.sqrt(accel * distance_mm + v_start**2 / 2))
    v_peak = max(v_peak, v_start)
    accel_mm = (v_peak**2 - v_start**2) / (2 * accel)
    decel_mm = v_peak**2 / (2 * accel)
    cruise_mm = max(distance_mm - accel_mm - decel_mm, 0.0)
    phases = [((v_peak - v_start) / accel, v_start, accel), (cruise_mm / v_peak, v_peak, 0.0),
              (v_peak / accel, v_peak, -accel)]
    return [p for p in phases if p[0] > 0]


@dataclass
class Segment:
    """One straight move (or a dwell when ``length_mm`` is 0) of the commanded position."""

    start_mm: np.ndarray
    direction: np.ndarray
    length_mm: float
    phases: list
    dwell_s: float = 0.0
    t0: float | None = None
    cut_s: float = math.inf  # a hold or an alarm stops the profile here
    carriage_start_mm: np.ndarray | None = None

    @property
    def duration_s(self) -> float:
        """How long the segment runs (s), up to a hold or alarm that cut it."""
        return min(sum(p[0] for p in self.phases) + self.dwell_s, self.cut_s - (self.t0 or 0.0))

    @property
    def t_end(self) -> float:
        """When the segment ends (s)."""
        return self.t0 + self.duration_s

    def progress(self, t: float) -> tuple[float, float]:
        """Distance travelled (mm) and speed (mm/s) at time ``t``."""
        elapsed = min(max(t - self.t0, 0.0), self.cut_s - self.t0)
        done = 0.0
        for duration, v0, a in self.phases:
            if elapsed <= duration:
                return done + v0 * elapsed + a * elapsed**2 / 2, v0 + a * elapsed
            done += v0 * duration + a * duration**2 / 2
            elapsed -= duration
        return min(done, self.length_mm), 0.0

    def position(self, t: float) -> np.ndarray:
        """Commanded position at time ``t`` (mm)."""
        return self.start_mm + self.direction * self.progress(t)[0]


@dataclass
class StageFaults:
    """Faults to inject (simulated times in s; ``None`` = never).

    ``missed_steps_mm`` is how far the pulleys fall behind the step counters, along the
    current (or last) direction of motion, at ``missed_steps_at_s``; a stall freezes the
    pulleys from ``stall_at_s`` until homing.
    """

    missed_steps_at_s: float | None = None
    missed_steps_mm: float = 1.0
    stall_at_s: float | None = None
    encoder_magnet_at_s: float | None = None
    encoder_bus_at_s: float | None = None


@dataclass
class StageMechanics:
    """The stage's motion plan and the positions it produces over simulated time.

    Parameters
    ----------
    start_mm
        Physical position of the carriage at power-up (machine zero is there until homing).
    backlash_mm
        Dead band of the belt drive per axis.
    settings
        ``$N`` values (defaults: :data:`DEFAULT_SETTINGS`).
    """

    start_mm: tuple[float, float] = (120.0, 150.0)
    backlash_mm: float = 0.02
    settings: dict = field(default_factory=lambda: dict(DEFAULT_SETTINGS))
    faults: StageFaults = field(default_factory=StageFaults)

    def __post_init__(self) -> None:
        start = np.asarray(self.start_mm, dtype=float)
        self.home_offset_mm = start.copy()
        self._timeline: list[Segment] = []  # started segments, in time order
        self._t0s: list[float] = []
        self.queue: list[Segment] = []  # planned, not started
        self._rest_mm = start.copy()  # commanded position when nothing moves
        self._rest_carriage_mm = start.copy()
        self._slips: list[tuple[float, np.ndarray]] = []
        self._stall: tuple[float, np.ndarray, float] | None = None  # from, pulley, until
        self.paused = False

    # -- planning ---------------------------------------------------------------------------
    def planned_end_mm(self) -> np.ndarray:
        """Commanded physical position after everything queued has run."""
        if self.queue:
            last = self.queue[-1]
            return last.start_mm + last.direction * last.length_mm
        if self._timeline and self._timeline[-1].t0 is not None:
            return self._timeline[-1].position(math.inf)
        return self._rest_mm.copy()

    def limits(self, target_mm: np.ndarray) -> tuple[float, float]:
        """Speed (mm/s) and acceleration (mm/s²) a move along ``target - planned end`` may use."""
        delta = target_mm - self.planned_end_mm()
        length = float(np.hypot(*delta))
        unit = np.abs(delta / length) if length > 0 else np.array([1.0, 1.0])
        rates = np.array([self.settings[110], self.settings[111]]) / 60.0
        accels = np.array([self.settings[120], self.settings[121]])
        active = unit > 1e-12
        return float(np.min(rates[active] / unit[active])), float(np.min(accels[active] / unit[active]))

    def quantize_machine_mm(self, machine_mm: np.ndarray) -> np.ndarray:
        """A machine position rounded to whole motor steps ($100/$101)."""
        steps_per_mm = np.array([self.settings[100], self.settings[101]])
        return np.round(np.asarray(machine_mm, float) * steps_per_mm) / steps_per_mm

    def queue_move(self, machine_target_mm, feed_mm_min: float | None, now_s: float) -> None:
        """Plan a linear move to a machine position at a feed rate (None: the maximum rate)."""
        target = self.quantize_machine_mm(machine_target_mm) + self.home_offset_mm
        self._queue_physical(target, feed_mm_min, now_s)

    def _queue_physical(self, target_mm: np.ndarray, feed_mm_min: float | None, now_s: float,
                        start_mm: np.ndarray | None = None) -> None:
        start = self.planned_end_mm() if start_mm is None else start_mm
        delta = target_mm - start
        length = float(np.hypot(*delta))
        v_max, accel = self.limits(target_mm)
        if feed_mm_min is not None:
            v_max = min(v_max, feed_mm_min / 60.0)
        direction = delta / length if length > 0 else np.zeros(2)
        self._enqueue(Segment(start, direction, length, trapezoid_phases(length, 0.0, v_max, accel)), now_s)

    def queue_dwell(self, seconds: float, now_s: float) -> None:
        """Plan a pause of ``seconds`` s behind the queued moves."""
        self._enqueue(Segment(self.planned_end_mm(), np.zeros(2), 0.0, [], dwell_s=seconds), now_s)

    def _enqueue(self, segment: Segment, now_s: float) -> None:
        self.queue.append(segment)
        self._start_next(now_s)

    def _start_next(self, now_s: float) -> None:
        if self.paused or not self.queue or self.active(now_s) is not None:
            return
        segment = self.queue.pop(0)
        segment.t0 = now_s
        segment.carriage_start_mm = self.carriage_mm(now_s)
        self._timeline.append(segment)
        self._t0s.append(now_s)
        if len(self._timeline) > _MAX_HISTORY:
            del self._timeline[0], self._t0s[0]

    def active(self, t: float) -> Segment | None:
        """The segment running at time ``t`` (None when standing still)."""
        if self._timeline and self._timeline[-1].t_end > t:
            return self._timeline[-1]
        return None

    def active_end_s(self) -> float:
        """When the most recently started segment ends (s); 0 before any motion."""
        return self._timeline[-1].t_end if self._timeline else 0.0

    def advance_to(self, t: float) -> None:
        """Start queued segments back to back up to time ``t``."""
        while self.queue and not self.paused and self._timeline:
            start = self._timeline[-1].t_end
            if start > t:
                return
            self._start_next(start)

    def busy(self, t: float) -> bool:
        """True while a segment runs or moves wait in the queue."""
        return self.active(t) is not None or bool(self.queue)

    # -- stopping ---------------------------------------------------------------------------
    def stop_now(self, t: float, flush: bool = True) -> None:
        """Stop the commanded position at once (reset, alarm): cut the running segment."""
        segment = self.active(t)
        if segment is not None:
            segment.cut_s = t
        if flush:
            self.queue.clear()
        self.paused = False

    def hold(self, t: float) -> float:
        """Feed hold: decelerate to rest; the rest of the move waits for :meth:`resume`.

        Returns the time (s) at which the stage stands still.
        """
        segment = self.active(t)
        self.paused = True
        if segment is None or segment.length_mm == 0:
            return t
        done, speed = segment.progress(t)
        target = segment.start_mm + segment.direction * segment.length_mm
        segment.cut_s = t
        _, accel = self.limits(target)
        stop_mm = min(speed**2 / (2 * accel), segment.length_mm - done)
        decel = Segment(segment.position(t), segment.direction, stop_mm,
                        trapezoid_phases(stop_mm, speed, speed, accel), t0=t,
                        carriage_start_mm=self.carriage_mm(t))
        self._timeline.append(decel)
        self._t0s.append(t)
        rest = target - decel.position(math.inf)
        remaining = float(np.hypot(*rest))
        if remaining > 1e-9:
            v_max, accel = self.limits(target)
            v_max = min(v_max, max(p[1] for p in segment.phases))
            self.queue.insert(0, Segment(decel.position(math.inf), rest / remaining, remaining,
                                         trapezoid_phases(remaining, 0.0, v_max, accel)))
        return decel.t_end

    def resume(self, t: float) -> None:
        """Cycle start after a hold."""
        self.paused = False
        self._start_next(t)

    # -- positions --------------------------------------------------------------------------
    def commanded_mm(self, t: float) -> np.ndarray:
        """Commanded physical position at time ``t`` (mm)."""
        index = bisect.bisect_right(self._t0s, t) - 1
        if index < 0:
            return self._timeline[0].start_mm.copy() if self._timeline else self._rest_mm.copy()
        return self._timeline[index].position(t)

    def path_length_mm(self, t0: float, t1: float) -> float:
        """Distance the commanded position travels between times ``t0`` and ``t1`` (mm)."""
        total = 0.0
        for segment in reversed(self._timeline):
            if segment.t_end <= t0:
                break
            if segment.t0 < t1 and segment.length_mm > 0:
                total += segment.progress(min(t1, segment.t_end))[0] - segment.progress(max(t0, segment.t0))[0]
        return total

    def slip_mm(self, t: float) -> np.ndarray:
        """Missed steps accumulated by time ``t`` (pulley minus commanded), mm."""
        total = np.zeros(2)
        for when, amount in self._slips:
            if when <= t:
                total += amount
        return total

    def add_slip(self, t: float, amount_mm) -> None:
        """The pulleys slip by ``amount_mm`` at time ``t`` without the step counters knowing."""
        self._slips.append((t, np.asarray(amount_mm, dtype=float)))
        self._slips.sort(key=lambda slip: slip[0])

    def miss_steps(self, t: float, distance_mm: float) -> None:
        """The motors lose ``distance_mm`` of steps at time ``t``, against the direction of
        motion (the last one when standing still; +x before any motion)."""
        index = bisect.bisect_right(self._t0s, t) - 1
        moving = [s for s in self._timeline[:index + 1] if s.length_mm > 0]
        direction = moving[-1].direction if moving else np.array([1.0, 0.0])
        self.add_slip(t, -distance_mm * direction)

    def stall(self, t: float) -> None:
        """Freeze the pulleys from time ``t`` on (until homing)."""
        self._stall = (t, self.pulley_mm(t), math.inf)

    def pulley_mm(self, t: float) -> np.ndarray:
        """Where the motor shafts really are (physical, mm)."""
        if self._stall is not None and self._stall[0] <= t < self._stall[2]:
            return self._stall[1].copy()
        return self.commanded_mm(t) + self.slip_mm(t)

    def carriage_mm(self, t: float) -> np.ndarray:
        """Where the carriage (and what rides on it) really is, after backlash (physical, mm)."""
        index = bisect.bisect_right(self._t0s, t) - 1
        half = self.backlash_mm / 2
        pulley = self.pulley_mm(t)
        if index < 0:
            return np.clip(self._rest_carriage_mm, pulley - half, pulley + half)
        # within one straight segment each axis moves one way, so dragging through the dead
        # band is a clip of the carriage position the segment started with
        return np.clip(self._timeline[index].carriage_start_mm, pulley - half, pulley + half)

    def machine_mm(self, t: float) -> np.ndarray:
        """``MPos``: the step counters in machine coordinates, whole steps (mm)."""
        return self.quantize_machine_mm(self.commanded_mm(t) - self.home_offset_mm)

    def encoder_mm(self, t: float) -> np.ndarray:
        """``Enc``: the AS5600 reading of each pulley in machine coordinates, mm."""
        step = self.settings[201] / AS5600_COUNTS_PER_TURN
        return np.round((self.pulley_mm(t) - self.home_offset_mm) / step) * step

    def speed_mm_min(self, t: float) -> float:
        """Commanded feed at time ``t``, mm/min."""
        segment = self.active(t)
        return 0.0 if segment is None or segment.length_mm == 0 else segment.progress(t)[1] * 60.0

    # -- homing -----------------------------------------------------------------------------
    def plan_homing(self, t: float) -> float:
        """Plan the homing cycle from time ``t`` (X, then Y); return when it ends (s)."""
        pulley = self.pulley_mm(t)
        self.stop_now(t)
        if self._stall is not None:
            self._stall = (self._stall[0], self._stall[1], t)
        # the step counters take over the pulleys' true position: homing re-references both
        self.add_slip(t, -self.slip_mm(t))
        pulloff = self.settings[27]
        seek, feed = self.settings[25], self.settings[24]
        targets = ((np.array([-pulloff, pulley[1]]), seek), (np.array([0.0, pulley[1]]), feed),
                   (np.array([0.0, -pulloff]), seek), (np.zeros(2), feed))
        for index, (target, rate) in enumerate(targets):
            self._queue_physical(target, rate, t, pulley if index == 0 else None)
        return t + sum(s.duration_s for s in self.queue) + (
            self._timeline[-1].t_end - t if self.active(t) else 0.0)

    def finish_homing(self, homed_machine_mm=(0.0, 0.0)) -> None:
        """Homing ended at the pulled-off switch position (physical 0), which becomes machine
        ``homed_machine_mm`` (whiskercal's firmware: machine zero; stock grbl: -$130+$27)."""
        self.home_offset_mm = -np.asarray(homed_machine_mm, float)

    def pins(self, t: float) -> str:
        """Limit switches pressed at time ``t`` (``Pn:`` letters)."""
        carriage = self.carriage_mm(t)
        switch = -self.settings[27] + 1e-6
        return "".join(axis for axis, value in zip("XY", carriage) if value <= switch)
