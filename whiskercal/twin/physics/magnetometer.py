"""The MLX90393 as the twin sees it: field in, raw counts out.

A reading is the field at the chip plus the chip's own offset and white noise, divided by the
sensitivity of the configured GAIN_SEL and RES, rounded to whole counts and clipped to the output
range. Counts are signed, as the sensor firmware delivers them after removing the RES 2/3 output
offsets (docs/protocol.md).

Where the numbers come from
---------------------------
- Sensitivity (µT/LSB, HALLCONF 0xC) at RES 0 per GAIN_SEL: the MLX90393 datasheet table as
  carried by the Adafruit MLX90393 driver (``mlx90393_lsb_lookup``, its RES 0 column). GAIN_SEL 7
  (the driver's "1x") is 0.150 µT/LSB on X/Y and 0.242 on Z. Every RES step doubles it (the
  datasheet's rule; the driver's higher-RES columns repeat it rounded to 1e-3, with one entry,
  GAIN_SEL 1 RES 3 on X/Y, 0.7 % off), so the default GAIN_SEL 5 at RES 2 is 1.000 µT/LSB on
  X/Y and 1.612 on Z (docs/protocol.md; docs/firmware.md says why these defaults).
- Conversion time of a three-axis measurement (ms), rows DIG_FILT 0..7, columns OSR 0..3: the
  datasheet table as carried by the same driver (``mlx90393_tconv``).
- Output range: 16-bit words. RES 0/1 are two's complement; RES 2 is unsigned with zero field at
  32768, so signed counts span -32768..32767; RES 3 has zero field at 16384 and is modelled as
  spanning -16384..16383 (the same field range as RES 2 at twice the step).
- Noise: white, per axis, set so that the default settings reproduce the 5.6 µT standard deviation
  of the real sensor's Y axis at rest (reference numbers). Other OSR/DIG_FILT settings scale it by
  1/sqrt(number of averaged conversions), 2^OSR·(2 + 2^DIG_FILT), as averaging does. It is stated
  in µT at the chip and does not change with GAIN_SEL or RES: those set only the step it is
  rounded to (quantization adds step/sqrt(12) in quadrature, 0.29 µT at the default 1.000 µT).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from whiskercal.errors import UsageError
from whiskercal.protocol import mlx90393

# The sensitivity and conversion-time tables and the I2C exchange time are the host's
# (whiskercal/protocol/mlx90393.py): the twin's chip and the host must convert counts alike.
# Signed count range after the firmware removes the RES 2/3 output offsets, per RES.
_COUNT_RANGE = {0: (-32768, 32767), 1: (-32768, 32767), 2: (-32768, 32767), 3: (-16384, 16383)}

# OSR and DIG_FILT at which ``noise_uT_rms`` is stated (the firmware's defaults).
_NOISE_REFERENCE = (0, 2)


def _check_index(name: str, value: int, high: int) -> None:
    if not (isinstance(value, (int, np.integer)) and 0 <= value <= high):
        raise UsageError(f"{name} must be an integer in 0..{high}, got {value!r}.")


def lsb_uT(gain: int, res: int) -> np.ndarray:
    """Sensitivity of the (X, Y, Z) axes in µT per count for a GAIN_SEL (0..7) and RES (0..3).

    Returns
    -------
    ndarray, shape (3,)
    """
    _check_index("GAIN_SEL", gain, 7)
    _check_index("RES", res, 3)
    return mlx90393.lsb_uT(gain, res)


def conversion_time_ms(osr: int, filt: int) -> float:
    """Duration of one three-axis conversion in ms for an OSR (0..3) and DIG_FILT (0..7)."""
    _check_index("OSR", osr, 3)
    _check_index("DIG_FILT", filt, 7)
    return mlx90393.conversion_time_ms(osr, filt)


def count_range(res: int) -> tuple[int, int]:
    """Lowest and highest signed count the output can hold at a RES (0..3)."""
    _check_index("RES", res, 3)
    return _COUNT_RANGE[res]


def averaged_conversions(osr: int, filt: int) -> int:
    """How many ADC conversions one reading averages: 2^OSR · (2 + 2^DIG_FILT)."""
    return 2**osr * (2 + 2**filt)


@dataclass(frozen=True)
class MagnetometerParams:
    """One MLX90393: its register settings, the sample rate and its imperfections.

    Attributes
    ----------
    gain, res, osr, filt : int
        GAIN_SEL (0..7), RES for all three axes (0..3), OSR (0..3), DIG_FILT (0..7).
    rate_hz : float
        Sample rate the firmware triggers conversions at.
    noise_uT_rms : tuple of 3 float
        White noise RMS per axis (X, Y, Z) in µT at OSR 0 / DIG_FILT 2.
    offset_uT : tuple of 3 float
        Static offset of the chip itself (Hall-plate offset, ambient field), µT.
    """

    gain: int = 5
    res: int = 2
    osr: int = 0
    filt: int = 2
    rate_hz: float = 300.0
    noise_uT_rms: tuple[float, float, float] = (5.6, 5.6, 9.0)
    offset_uT: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        for name, high in (("gain", 7), ("res", 3), ("osr", 3), ("filt", 7)):
            _check_index(name, getattr(self, name), high)
        if not (np.isfinite(self.rate_hz) and self.rate_hz > 0):
            raise UsageError(f"rate_hz must be a positive number, got {self.rate_hz!r}.")
        if min(self.noise_uT_rms) < 0:
            raise UsageError("noise_uT_rms must not be negative.")

    def with_settings(self, **settings) -> "MagnetometerParams":
        """A copy with other register settings or rate (validated), e.g. ``with_settings(osr=1)``."""
        return replace(self, **settings)

    def lsb_uT(self) -> np.ndarray:
        """µT per count of the (X, Y, Z) axes at these settings, shape (3,)."""
        return lsb_uT(self.gain, self.res)

    def conversion_time_ms(self) -> float:
        """Duration of one three-axis conversion at these settings, ms."""
        return conversion_time_ms(self.osr, self.filt)

    def sample_period_ms(self) -> float:
        """Time between samples at ``rate_hz``, ms."""
        return 1000.0 / self.rate_hz

    def sample_time_ms(self) -> float:
        """Conversion plus the I2C exchange that triggers and reads it, ms."""
        return mlx90393.sample_time_ms(self.osr, self.filt)

    def fits_rate(self) -> bool:
        """True when a conversion and its I2C exchange finish within one sample period."""
        return self.sample_time_ms() <= self.sample_period_ms()

    def check_rate(self) -> None:
        """Raise UsageError when the conversion time does not fit the sample period."""
        if not self.fits_rate():
            raise UsageError(
                f"OSR {self.osr} with DIG_FILT {self.filt} takes {self.sample_time_ms():.2f} ms a sample, "
                f"longer than the {self.sample_period_ms():.2f} ms period at {self.rate_hz:g} Hz."
            )

    def effective_noise_uT(self) -> np.ndarray:
        """White noise RMS per axis at these OSR/DIG_FILT settings, µT (3,)."""
        reference = averaged_conversions(*_NOISE_REFERENCE)
        scale = np.sqrt(reference / averaged_conversions(self.osr, self.filt))
        return np.asarray(self.noise_uT_rms, dtype=float) * scale

    def full_scale_uT(self) -> np.ndarray:
        """Largest field magnitude each axis can report before saturating, µT (3,)."""
        low, high = count_range(self.res)
        return self.lsb_uT() * min(-low, high)


def to_counts(field_uT, params: MagnetometerParams, rng: np.random.Generator | None) -> np.ndarray:
    """Raw signed counts the chip reports for a field at the chip.

    Parameters
    ----------
    field_uT : array_like, shape (..., 3)
        Field at the chip in its axes (X, Y, Z), µT.
    params : MagnetometerParams
    rng : numpy.random.Generator or None
        Source of the white noise; None gives noise-free (still quantized, offset) readings.

    Returns
    -------
    ndarray of int16, shape (..., 3)
        Counts clipped to the output range of ``params.res``; see :func:`is_saturated`.
    """
    reading = np.asarray(field_uT, dtype=float)
    if reading.shape[-1:] != (3,):
        raise UsageError(f"field_uT must end in an axis of length 3, got shape {reading.shape}.")
    reading = reading + np.asarray(params.offset_uT)
    if rng is not None:
        reading = reading + rng.standard_normal(reading.shape) * params.effective_noise_uT()
    low, high = count_range(params.res)
    counts = np.clip(np.rint(reading / params.lsb_uT()), low, high)
    return counts.astype(np.int16)


def to_uT(counts, params: MagnetometerParams) -> np.ndarray:
    """Counts (..., 3) back to µT in the sensor's axes at the settings of ``params``."""
    return np.asarray(counts, dtype=float) * params.lsb_uT()


def is_saturated(counts, params: MagnetometerParams) -> np.ndarray:
    """True where any axis of a reading (..., 3) sits at an end of the output range."""
    low, high = count_range(params.res)
    counts = np.asarray(counts)
    return np.any((counts <= low) | (counts >= high), axis=-1)
