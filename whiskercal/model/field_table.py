"""The runtime's (Y, Z) -> tip table: a regular grid of tips read bilinearly, NaN outside.

Built by ``whiskercal.mechfit.tables.field_tip_table`` from the fitted mechanics and magnet
map (docs/calibration.md), stored in the calibration artifact's ``/field_table``, evaluated here
in plain floats (a few microseconds a sample).
"""

from __future__ import annotations

import math

import numpy as np


class FieldTipTable:
    """(Y, Z) µT -> tip (mm) on a regular grid, bilinear; NaN outside the tip-load family.

    Parameters
    ----------
    y_uT, z_uT : ndarray (ny,), (nz,)
        Increasing, evenly spaced axes.
    tips_mm : ndarray (ny, nz, 2)
    """

    def __init__(self, y_uT: np.ndarray, z_uT: np.ndarray, tips_mm: np.ndarray) -> None:
        self.y_uT, self.z_uT = np.asarray(y_uT, float), np.asarray(z_uT, float)
        self.tips_mm = np.asarray(tips_mm, float)
        self._y0, self._z0 = float(self.y_uT[0]), float(self.z_uT[0])
        self._dy = float(self.y_uT[1] - self.y_uT[0])
        self._dz = float(self.z_uT[1] - self.z_uT[0])
        self._ny, self._nz = len(self.y_uT), len(self.z_uT)
        self._rows = self.tips_mm.tolist()

    def tip_scalar(self, y_uT: float, z_uT: float) -> tuple[float, float]:
        """One tip (x, y) mm in plain floats; NaN outside the table."""
        fy, fz = (y_uT - self._y0) / self._dy, (z_uT - self._z0) / self._dz
        i, j = int(math.floor(fy)), int(math.floor(fz))
        if not (0 <= i < self._ny - 1 and 0 <= j < self._nz - 1):
            return math.nan, math.nan
        ty, tz = fy - i, fz - j
        a, b, c, d = self._rows[i][j], self._rows[i + 1][j], self._rows[i][j + 1], self._rows[i + 1][j + 1]
        w00, w10, w01, w11 = (1 - ty) * (1 - tz), ty * (1 - tz), (1 - ty) * tz, ty * tz
        return (w00 * a[0] + w10 * b[0] + w01 * c[0] + w11 * d[0],
                w00 * a[1] + w10 * b[1] + w01 * c[1] + w11 * d[1])

    def __call__(self, y_uT, z_uT) -> np.ndarray:
        """Tips (..., 2) mm for arrays of Y and Z (µT)."""
        y, z = np.broadcast_arrays(np.asarray(y_uT, float), np.asarray(z_uT, float))
        out = np.array([self.tip_scalar(a, b) for a, b in zip(y.ravel(), z.ravel())])
        return out.reshape(y.shape + (2,))
