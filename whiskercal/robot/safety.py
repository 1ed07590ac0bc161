"""The limits every command to a real robot passes: speed and turn rate (clipped), a workspace
box for the end effector (leaving it stops the run), and the watchdog's time (no pose or no
sample for that long stops the run). Each is checked where the command is made
(``RosbridgeRobot.command``) and where samples are waited for (the run's loop)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from whiskercal import checks
from whiskercal.errors import UsageError
from whiskercal.robot.errors import WorkspaceError


@dataclass(frozen=True)
class Safety:
    """speed_mm_s: the end effector's largest speed; turn_rad_s: its largest turn rate;
    box_mm: (x_min, x_max, y_min, y_max) of the end effector in the pose topic's frame, mm
    (None: no box); watchdog_s: the longest wait for a pose or a sample."""

    speed_mm_s: float = 20.0
    turn_rad_s: float = 0.5
    box_mm: tuple[float, float, float, float] | None = None
    watchdog_s: float = 0.2

    def __post_init__(self) -> None:
        checks.positive(self.speed_mm_s, "--max-speed", unit="mm/s")
        checks.positive(self.turn_rad_s, "--max-turn", unit="rad/s")
        checks.positive(self.watchdog_s, "--watchdog-ms", unit="s")
        if self.box_mm is not None:
            x0, x1, y0, y1 = (checks.number(v, "--box", unit="mm") for v in self.box_mm)
            if not (x0 < x1 and y0 < y1):
                raise UsageError(f"--box must be X_MIN,X_MAX,Y_MIN,Y_MAX with each min below its "
                                 f"max, not {','.join(f'{v:g}' for v in self.box_mm)}")

    def clip(self, velocity_mm_s, turn_rad_s: float) -> tuple[np.ndarray, float, bool]:
        """The command within the speed and turn limits (the velocity scaled down along its
        direction), and whether anything was cut."""
        velocity = np.asarray(velocity_mm_s, float)
        speed = float(np.hypot(*velocity))
        turn = float(np.clip(turn_rad_s, -self.turn_rad_s, self.turn_rad_s))
        cut = turn != turn_rad_s or speed > self.speed_mm_s
        if speed > self.speed_mm_s:
            velocity = velocity * (self.speed_mm_s / speed)
        if not (np.all(np.isfinite(velocity)) and math.isfinite(turn)):
            raise ValueError(f"a command that is not a number: {velocity}, {turn}")
        return velocity, turn, cut

    def check_inside(self, effector_pose) -> None:
        """WorkspaceError when the end effector's position is outside the box."""
        if self.box_mm is None:
            return
        x, y = float(effector_pose[0]), float(effector_pose[1])
        x0, x1, y0, y1 = self.box_mm
        if not (x0 <= x <= x1 and y0 <= y <= y1):
            raise WorkspaceError(f"the end effector at ({x:.1f}, {y:.1f}) mm left the workspace "
                                 f"box x {x0:g}..{x1:g}, y {y0:g}..{y1:g} mm: stopped")


def parse_box(text: str | None) -> tuple[float, float, float, float] | None:
    """``X_MIN,X_MAX,Y_MIN,Y_MAX`` (mm) as numbers; None for None."""
    if text is None:
        return None
    parts = text.split(",")
    if len(parts) != 4:
        raise UsageError(f"--box must be X_MIN,X_MAX,Y_MIN,Y_MAX in mm, not {text!r}")
    return tuple(checks.number(part, "--box", unit="mm") for part in parts)
