"""Where whiskercal's stage coordinates lie in a grbl 1.1 board's machine coordinates.

whiskercal's stage coordinates have their origin where a homing cycle toward the switches at the
stage's minimum leaves the carriage (the switch position plus grbl's pull-off ``$27``) and run
to the travel ``$130``/``$131`` in +x and +y; whiskercal's own firmware uses exactly these as its
machine coordinates. Stock grbl 1.1 lays out its machine space by its build and settings
(grbl's ``limits_go_home`` and ``system_check_travel_limits``; per axis, with travel T = ``$130``
or ``$131`` and pull-off P = ``$27``):

======================================  ==================  ===================  =============
build, homing direction ``$23``          after ``$H`` MPos   soft-limit box        stage origin
======================================  ==================  ===================  =============
stock, bit set (homes toward minimum)    -T + P              -T .. 0               -T + P
stock, bit clear (homes toward maximum)  -P                  -T .. 0               -T
HOMING_FORCE_SET_ORIGIN, bit set         0                   0 .. T                0
HOMING_FORCE_SET_ORIGIN, bit clear       0                   -T .. 0               -T
homing off (``$22=0``)                   (power-up: 0)       none                  0
======================================  ==================  ===================  =============

An axis homing toward its maximum has no reference at its minimum: its stage origin is the far
end of grbl's workspace. The build option is not in ``$$``; the position right after homing
tells it. :func:`machine_space` gives the mapping, which ``StageClient`` applies to every target
(sent with ``G53``, so no work offset of the user's is touched) and every report.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from whiskercal.errors import DeviceError

HOMING_ENABLE, HOMING_DIR_MASK, HOMING_PULLOFF = 22, 23, 27
TRAVEL = (130, 131)
STEPS_PER_MM = (100, 101)
_DEFAULT_PULLOFF_MM = 1.0  # grbl 1.1's default $27
_STOCK, _FORCE_SET_ORIGIN = "stock", "HOMING_FORCE_SET_ORIGIN"


@dataclass(frozen=True)
class MachineSpace:
    """The mapping of one board: stage = machine - ``origin_mm``; the board's workspace
    (soft-limit box) is ``low_mm``..``high_mm`` in machine coordinates, mm; ``layout`` names it."""

    origin_mm: np.ndarray
    low_mm: np.ndarray
    high_mm: np.ndarray
    layout: str

    def to_machine(self, stage_mm) -> np.ndarray:
        """Stage coordinates (..., 2) mm to the board's machine coordinates, mm."""
        return np.asarray(stage_mm, float) + self.origin_mm

    def to_stage(self, machine_mm) -> np.ndarray:
        """The board's machine coordinates (..., 2) mm to stage coordinates, mm."""
        return np.asarray(machine_mm, float)[..., :2] - self.origin_mm

    @property
    def travel_mm(self) -> tuple[float, float]:
        """How far stage coordinates run from 0 (mm) inside the workspace: 0..travel is safe."""
        high = self.high_mm - self.origin_mm
        return float(high[0]), float(high[1])

    def check(self, machine_mm, where: str) -> None:
        """Refuse a machine target outside the workspace before it is sent: grbl would answer it
        with ALARM:2 and a pause that only a reset ends."""
        target = np.asarray(machine_mm, float)[:2]
        if np.any(target < self.low_mm - 1e-6) or np.any(target > self.high_mm + 1e-6):
            stage = self.to_stage(target)
            raise DeviceError(
                f"stage target ({stage[0]:.3f}, {stage[1]:.3f}) mm (machine "
                f"({target[0]:.3f}, {target[1]:.3f}) mm) on {where} lies outside the board's "
                f"workspace {_box(self.low_mm, self.high_mm)} ({self.layout}); not sent")


def machine_space(settings: dict[int, float], homed_mm=None, here_mm=None) -> MachineSpace:
    """The mapping for a stock grbl 1.1 board with these ``$$`` settings.

    ``homed_mm`` is the machine position (mm) right after ``$H``, which tells a
    HOMING_FORCE_SET_ORIGIN build from a stock one; a homed position that fits neither raises
    DeviceError. Without it (no homing this run) the stock layout is assumed unless the board
    stands where only a HOMING_FORCE_SET_ORIGIN build can (``here_mm`` above 0 on an axis that
    homes toward its minimum): a board standing at 0 fits both, and stock grbl is assumed.
    """
    travel = np.array([float(settings.get(n, 200.0)) for n in TRAVEL])
    if not settings.get(HOMING_ENABLE, 0):
        return MachineSpace(np.zeros(2), np.zeros(2), travel, "homing off: stage origin at power-up")
    toward_min = np.array([bool(int(settings.get(HOMING_DIR_MASK, 0)) & (1 << axis))
                           for axis in range(2)])
    pulloff = float(settings.get(HOMING_PULLOFF, _DEFAULT_PULLOFF_MM))
    if homed_mm is not None:
        layout = _layout(settings, homed_mm, toward_min, travel, pulloff)
    elif here_mm is not None and np.any(toward_min & (np.asarray(here_mm, float)[:2] > 1e-3)):
        layout = _FORCE_SET_ORIGIN
    else:
        layout = _STOCK
    if layout == _FORCE_SET_ORIGIN:
        low, high = np.where(toward_min, 0.0, -travel), np.where(toward_min, travel, 0.0)
        origin = np.where(toward_min, 0.0, -travel)
    else:
        low, high = -travel, np.zeros(2)
        origin = np.where(toward_min, -travel + pulloff, -travel)
    return MachineSpace(origin, low, high, f"{layout} build, $23={int(settings.get(HOMING_DIR_MASK, 0))}")


def _layout(settings: dict[int, float], homed_mm, toward_min: np.ndarray, travel: np.ndarray,
            pulloff: float) -> str:
    """Which build homed the board to ``homed_mm``: stock or HOMING_FORCE_SET_ORIGIN."""
    homed = np.asarray(homed_mm, float)[:2]
    steps = np.array([float(settings.get(n, 0.0)) for n in STEPS_PER_MM])
    tolerance = np.where(steps > 0, 1.5 / np.where(steps > 0, steps, 1.0), 0.0) + 1e-3
    stock = np.where(toward_min, -travel + pulloff, -pulloff)
    if np.all(np.abs(homed - stock) <= tolerance):
        return _STOCK
    if np.all(np.abs(homed) <= tolerance):
        return _FORCE_SET_ORIGIN
    raise DeviceError(
        f"the stage's machine position after homing is {np.round(homed, 3).tolist()} mm, which fits "
        f"neither stock grbl 1.1 ({np.round(stock, 3).tolist()} mm from $23, $130/$131 and $27) nor "
        "a HOMING_FORCE_SET_ORIGIN build (0, 0); check $23, $27, $130/$131 (docs/stage.md)")


def _box(low: np.ndarray, high: np.ndarray) -> str:
    return f"x {low[0]:g}..{high[0]:g}, y {low[1]:g}..{high[1]:g} mm"
