"""MLX90393 facts the host needs: µT per count, conversion time, the I2C exchange.

Sources: the MLX90393 datasheet's tables as carried by the Adafruit_MLX90393 driver
(``mlx90393_lsb_lookup``, ``mlx90393_tconv``), HALLCONF 0xC. Sensitivity is the RES 0 column per
GAIN_SEL (the driver's "5x" is GAIN_SEL 0, "1x" GAIN_SEL 7), doubled for each RES step as the
datasheet states (the driver's higher-RES columns are the same values rounded to 1e-3). The twin's
magnetometer uses the same facts; tests/rig/test_mlx90393.py checks that the two agree.
"""

from __future__ import annotations

import numpy as np

# [GAIN_SEL][X/Y, Z] µT/LSB at RES 0.
_LSB_RES0_UT = np.array([
    [0.751, 1.210], [0.601, 0.968], [0.451, 0.726], [0.376, 0.605],
    [0.300, 0.484], [0.250, 0.403], [0.200, 0.323], [0.150, 0.242],
])

# [DIG_FILT][OSR] three-axis conversion time, ms.
_CONVERSION_MS = np.array([
    [1.27, 1.84, 3.00, 5.30],
    [1.46, 2.23, 3.76, 6.84],
    [1.84, 3.00, 5.30, 9.91],
    [2.61, 4.53, 8.37, 16.05],
    [4.15, 7.60, 14.52, 28.34],
    [7.22, 13.75, 26.80, 52.92],
    [13.36, 26.04, 51.38, 102.07],
    [25.65, 50.61, 100.53, 200.37],
])

# The firmware's SM + RM exchange on a 400 kHz I2C bus (about 135 bit times plus the Wire
# library's gaps) comes on top of the conversion within each sample period.
I2C_EXCHANGE_MS = 0.36


def lsb_uT(gain: int, res: int) -> np.ndarray:
    """µT per count for the (x, y, z) axes at a GAIN_SEL (0..7) and RES (0..3), shape (3,)."""
    xy, z = _LSB_RES0_UT[gain] * 2**res
    return np.array([xy, xy, z])


def conversion_time_ms(osr: int, filt: int) -> float:
    """Time of one three-axis conversion in ms for an OSR (0..3) and DIG_FILT (0..7)."""
    return float(_CONVERSION_MS[filt, osr])


def sample_time_ms(osr: int, filt: int) -> float:
    """Conversion plus the I2C exchange: the least sample period these settings allow, ms."""
    return conversion_time_ms(osr, filt) + I2C_EXCHANGE_MS
