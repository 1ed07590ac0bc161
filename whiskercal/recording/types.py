"""What every reader returns: the field samples of a recording and, where it holds them, poses.

Units: time s (any clock, as recorded; only differences and the poses' clock matter), field µT,
positions mm, heading rad (counter-clockwise from the world's x axis).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from whiskercal.errors import UsageError

FIELD_UNITS = {"T": 1e6, "mT": 1e3, "uT": 1.0, "nT": 1e-3, "G": 100.0}
"""A field unit's size in µT (``--field-unit``)."""
PLAUSIBLE_FIELD_UT = (0.1, 1e5)
"""The median field magnitude a magnetometer next to a magnet can read, µT: below, the numbers
are in a larger unit read as µT (tesla); above, in a smaller one (nT), or a µT field written into
a message whose unit is tesla."""


@dataclass
class Poses:
    """Poses in time order: ``t_s`` (n,) s and ``pose`` (n, 3) as (x mm, y mm, heading rad)."""

    t_s: np.ndarray
    pose: np.ndarray
    source: str

    def __len__(self) -> int:
        return len(self.t_s)


@dataclass
class Recording:
    """Field samples in time order: ``t_s`` (n,) s and ``field_uT``, µT: (n,) the Y axis alone,
    or (n, 3) the X, Y and Z axes (X NaN where the file has none).

    ``recorded_rest_uT`` is the static reading the file itself recorded (a float for Y, (3,) for
    three axes; None for most recordings); ``poses`` the poses the file holds when asked for;
    ``source`` says where the samples came from (file, topic or columns, units).
    """

    t_s: np.ndarray
    field_uT: np.ndarray
    source: str
    recorded_rest_uT: float | np.ndarray | None = None
    poses: Poses | None = None

    def __len__(self) -> int:
        return len(self.t_s)

    @property
    def axes(self) -> int:
        """1 (Y alone) or 3."""
        return 1 if np.ndim(self.field_uT) == 1 else 3

    @property
    def y_uT(self) -> np.ndarray:
        """The Y axis (n,), µT: the deflection axis the calibration's z is read from."""
        return self.field_uT if self.axes == 1 else self.field_uT[:, 1]

    @property
    def axial_uT(self) -> np.ndarray | None:
        """The chip's Z axis (n,), µT, or None for a Y-only recording."""
        return None if self.axes == 1 else self.field_uT[:, 2]


def field_scale(unit: str) -> float:
    """µT per unit of ``unit`` (a key of :data:`FIELD_UNITS`)."""
    if unit not in FIELD_UNITS:
        raise UsageError(f"field unit must be one of {', '.join(FIELD_UNITS)}, not {unit!r}")
    return FIELD_UNITS[unit]


def check_plausible_field(recording: Recording, unit_hint: str) -> None:
    """Refuse a field whose median magnitude no magnetometer beside a magnet reads (a unit
    error); ``unit_hint`` names how the unit was chosen, for the message."""
    field = np.atleast_2d(np.asarray(recording.field_uT, float).T).T
    magnitude = np.sqrt(np.nansum(field ** 2, axis=1))
    median = float(np.median(magnitude)) if len(magnitude) else 0.0
    low, high = PLAUSIBLE_FIELD_UT
    if median < low:
        raise UsageError(f"{recording.source}: the field's median magnitude is {median:.3g} µT, "
                         f"implausibly small ({unit_hint}): is it in tesla? Give --field-unit")
    if median > high:
        raise UsageError(f"{recording.source}: the field's median magnitude is {median:.3g} µT, "
                         f"implausibly large ({unit_hint}): is it in nT, or µT written as tesla? "
                         "Give --field-unit")


def check_times(t_s: np.ndarray, source: str) -> None:
    """Refuse times that are not finite, go back, or never advance."""
    t_s = np.asarray(t_s, float)
    if len(t_s) == 0:
        raise UsageError(f"{source}: no samples")
    if not np.all(np.isfinite(t_s)):
        raise UsageError(f"{source}: a time stamp is not a finite number")
    steps = np.diff(t_s)
    if np.any(steps < 0):
        index = int(np.argmax(steps < 0)) + 1
        raise UsageError(f"{source}: time goes back at sample {index} ({t_s[index]:.6f} s after "
                         f"{t_s[index - 1]:.6f} s)")
    if len(t_s) > 1 and t_s[-1] == t_s[0]:
        raise UsageError(f"{source}: every sample has the same time ({t_s[0]:g}): the time "
                         "column is not a clock")


def implied_rate_hz(t_s: np.ndarray) -> float | None:
    """Samples per second from the median step between samples (None: fewer than 2 samples or
    a median step of 0)."""
    steps = np.diff(np.asarray(t_s, float))
    if len(steps) == 0:
        return None
    median = float(np.median(steps))
    return 1.0 / median if median > 0 else None


RATE_FACTOR = 20.0
"""How far a recording's implied sample rate may lie from the sensor's (either way) before its
time column is taken to be in the wrong unit (milliseconds read as seconds is a factor 1000)."""


def check_rate(t_s: np.ndarray, sensor_rate_hz: float, source: str, time_hint: str = "") -> float:
    """The implied rate (Hz), refused when it lies more than :data:`RATE_FACTOR` from
    ``sensor_rate_hz`` or when most samples share a time stamp."""
    rate = implied_rate_hz(t_s)
    if rate is None:
        if len(t_s) < 2:
            return sensor_rate_hz
        raise UsageError(f"{source}: most samples share their time stamp with the one before "
                         "(median step 0 s): the time column is not the sample clock")
    if not sensor_rate_hz / RATE_FACTOR <= rate <= sensor_rate_hz * RATE_FACTOR:
        span = float(t_s[-1] - t_s[0])
        raise UsageError(f"{source}: {len(t_s)} samples over {span:.6g} s is {rate:.4g} Hz, "
                         f"the sensor samples at {sensor_rate_hz:g} Hz (--rate-hz): the time "
                         f"is in another unit{time_hint}")
    return rate
