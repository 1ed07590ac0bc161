"""Where the sensor sits on the robot: the sensor's base frame in the end-effector frame.

A mount file is TOML with one ``[mount]`` table::

    [mount]
    x_mm = 12.0     # the base frame's origin along the end effector's x axis, mm
    y_mm = -3.5     # ... along its y axis, mm
    yaw_deg = 90.0  # the base frame's x axis (the undeflected whisker) from the end effector's x, deg

The end effector's pose in the world is (x mm, y mm, heading rad); the sensor's base frame
(the whisker frame of docs/architecture.md) is that pose composed with the mount. A point the
runtime gives in the base frame reaches the world through :meth:`Mount.to_world`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from whiskercal.errors import UsageError
from whiskercal.tomlconfig import read_toml
from whiskercal.typedconfig import Table, number, validate

MOUNT_KEYS = ("x_mm", "y_mm", "yaw_deg")
MAX_OFFSET_MM = 2000.0
"""A mount farther than this from the end effector is a unit error (metres read as mm), not a
mount."""


@dataclass(frozen=True)
class Mount:
    """The sensor's base frame in the end-effector frame: offset (mm) and yaw (deg)."""

    x_mm: float = 0.0
    y_mm: float = 0.0
    yaw_deg: float = 0.0

    def base_pose(self, effector_pose) -> np.ndarray:
        """The base frame's world pose(s), (..., 3) as (x mm, y mm, heading rad), from the end
        effector's world pose(s) of the same shape."""
        pose = np.asarray(effector_pose, dtype=float)
        heading = pose[..., 2]
        cos, sin = np.cos(heading), np.sin(heading)
        x = pose[..., 0] + cos * self.x_mm - sin * self.y_mm
        y = pose[..., 1] + sin * self.x_mm + cos * self.y_mm
        return np.stack([x, y, heading + math.radians(self.yaw_deg)], axis=-1)

    def effector_velocity(self, effector_pose, base_velocity_mm_s, turn_rad_s: float) -> np.ndarray:
        """The end effector's world velocity (mm/s) that moves the base frame at
        ``base_velocity_mm_s`` while both turn at ``turn_rad_s``: v_e = v_b - ω × (base - effector)."""
        effector = np.asarray(effector_pose, dtype=float)
        lever = self.base_pose(effector)[:2] - effector[:2]
        return np.asarray(base_velocity_mm_s, float) - turn_rad_s * np.array([-lever[1], lever[0]])

    def offset_by(self, error) -> "Mount":
        """This mount moved by ``error`` (dx mm, dy mm, dyaw deg), key by key: where a sensor
        drawn at this mount really sits when it is off by that much."""
        dx, dy, dyaw = (float(value) for value in error)
        return Mount(self.x_mm + dx, self.y_mm + dy, self.yaw_deg + dyaw)

    def as_dict(self) -> dict:
        """The mount as its file's keys (JSON-able)."""
        return {key: float(getattr(self, key)) for key in MOUNT_KEYS}

    def to_world(self, effector_pose, points_mm) -> np.ndarray:
        """Points (..., 2) in the sensor's base frame, mm, to the world frame, each with the end
        effector's pose (..., 3) at its sample."""
        return base_to_world(self.base_pose(effector_pose), points_mm)


MAX_ERROR_MM, MAX_ERROR_DEG = 50.0, 45.0
"""The largest mount error (offset from the drawing) the twin carries a sensor at: far more
than a real mount is off by, far less than a frame or unit mistake."""


def parse_mount_error(text: str, where: str = "--mount-error") -> tuple[float, float, float]:
    """``DX,DY,DEG`` (mm, mm, degrees) as a tuple, each finite and within
    :data:`MAX_ERROR_MM` / :data:`MAX_ERROR_DEG`; one UsageError line otherwise."""
    from whiskercal.checks import number

    cells = str(text).split(",")
    if len(cells) != 3:
        raise UsageError(f"{where} must be DX,DY,DEG (mm, mm, degrees), not {text!r}")
    dx, dy = (number(cell, f"{where} {axis}", low=-MAX_ERROR_MM, high=MAX_ERROR_MM, unit="mm")
              for axis, cell in zip(("dx", "dy"), cells))
    return dx, dy, number(cells[2], f"{where} deg", low=-MAX_ERROR_DEG, high=MAX_ERROR_DEG)


def base_to_world(base_pose, points_mm) -> np.ndarray:
    """Points (..., 2) in a base frame whose world pose is ``base_pose`` (..., 3), to the world."""
    base = np.asarray(base_pose, dtype=float)
    points = np.asarray(points_mm, dtype=float)
    cos, sin = np.cos(base[..., 2]), np.sin(base[..., 2])
    x = base[..., 0] + cos * points[..., 0] - sin * points[..., 1]
    y = base[..., 1] + sin * points[..., 0] + cos * points[..., 1]
    return np.stack([x, y], axis=-1)


class _MountTable(Table):
    x_mm: number(ge=-MAX_OFFSET_MM, le=MAX_OFFSET_MM) = 0.0
    y_mm: number(ge=-MAX_OFFSET_MM, le=MAX_OFFSET_MM) = 0.0
    yaw_deg: number(ge=-360.0, le=360.0) = 0.0


class _MountFile(Table):
    mount: _MountTable


def read_mount(path: str | Path) -> Mount:
    """The ``[mount]`` table of a TOML file; a missing table, an unknown key or a value that is
    not a finite number within :data:`MAX_OFFSET_MM` (or ±360°) is one error naming the key."""
    data = read_toml(path)
    if not isinstance(data.get("mount"), dict):
        raise UsageError(f"{path}: no [mount] table (keys {', '.join(MOUNT_KEYS)})")
    table = validate(_MountFile, data, str(path)).mount
    return Mount(**{key: getattr(table, key) for key in MOUNT_KEYS})


def mount_text(mount: Mount, comment: str = "") -> str:
    """``mount`` as a mount file's text (the format :func:`read_mount` reads)."""
    lines = [f"# {line}" for line in comment.splitlines()] + ["[mount]"]
    lines += [f"{key} = {float(getattr(mount, key))!r}" for key in MOUNT_KEYS]
    return "\n".join(lines) + "\n"


def write_mount(path: str | Path, mount: Mount, comment: str = "") -> None:
    """Write ``mount`` as a mount file (the format :func:`read_mount` reads)."""
    Path(path).write_text(mount_text(mount, comment), encoding="utf-8")
