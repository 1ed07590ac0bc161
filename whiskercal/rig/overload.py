"""The overload guard of every run that bends the whisker (collect, the flat-plane study).

A reading is no measurement when an axis sits at an end of its output range (saturated), and the
whisker is at risk when the deflection |z| passes a safe limit. Either stops the run; the caller
then backs the rod or plane off.
"""

from __future__ import annotations

import numpy as np

from whiskercal.errors import DeviceError
from whiskercal.protocol.codes import SensorStatus

# Samples whose axes are not a measurement at all; the guard skips them.
INVALID_STATUS = int(SensorStatus.NO_SENSOR | SensorStatus.MLX_ERROR)
_SATURATED = int(SensorStatus.SATURATED)
# Highest |count| an axis holds per RES once the board has removed the RES 2/3 offsets
# (MLX90393 datasheet: 16-bit output; RES 3 leaves 15 bits). The default settings keep every
# axis inside its range at rest and over the whole grid and study (docs/firmware.md), so a
# saturated axis, Z as much as Y, means the reading is no measurement of the whisker.
COUNT_LIMIT = {0: 32767, 1: 32767, 2: 32767, 3: 16383}
_AXES = "XYZ"
SENSOR_AXIS_Y = 1
"""The deflection measurement z is the sensor's Y axis (docs/architecture.md)."""


class OverloadError(DeviceError):
    """The whisker is bent past the safe deflection, or the sensor saturated; the run stopped."""


def valid_samples(status) -> np.ndarray:
    """Mask of the samples whose axes are a measurement."""
    return (np.asarray(status).astype(int) & INVALID_STATUS) == 0


def saturated_axes(counts, status, res: int) -> str:
    """Names of the axes ("Y", "XZ", ...) at an end of their output range in a valid sample.

    A sample whose SATURATED status bit is set without any axis at the limit (a board that
    judges the raw word differently) gives "?", so that it is never taken as unsaturated.
    """
    valid = valid_samples(status)
    limit = COUNT_LIMIT[res]
    counts = np.asarray(counts)[valid]
    at_end = (counts >= limit) | (counts < -limit)
    axes = "".join(name for name, hit in zip(_AXES, at_end.any(axis=0)) if hit)
    flagged = bool(np.any(np.asarray(status)[valid].astype(int) & _SATURATED))
    return axes or ("?" if flagged else "")


def describe_axes(axes: str) -> str:
    """``saturated_axes``'s answer in words: "the sensor's Z axis", "the sensor's X and Z axes"."""
    if axes == "?":
        return "one of the sensor's axes"
    if len(axes) == 1:
        return f"the sensor's {axes} axis"
    return f"the sensor's {', '.join(axes[:-1])} and {axes[-1]} axes"


def check_overload(field_uT, counts, status, *, res: int, static_y_uT: float, limit_uT: float,
                   moved: str = "rod") -> None:
    """Raise ``OverloadError`` when any axis saturates or a valid sample's |z| passes ``limit_uT``.

    ``field_uT`` (n, 3) µT, ``counts`` (n, 3), ``status`` (n,); ``moved`` names what the caller
    backs off ("rod", "plane") in the message.
    """
    if not len(status):
        return
    axes = saturated_axes(counts, status, res)
    if axes:
        raise OverloadError(f"overload guard: {describe_axes(axes)} saturated, so the reading "
                            f"is no measurement; the {moved} was backed off")
    z_uT = np.asarray(field_uT)[valid_samples(status), SENSOR_AXIS_Y] - static_y_uT
    worst = float(np.max(np.abs(z_uT))) if len(z_uT) else 0.0
    if worst > limit_uT:
        raise OverloadError(f"overload guard: |z| reached {worst:.0f} µT, over the safe limit of "
                            f"{limit_uT:.0f} µT; the {moved} was backed off")
