"""The runtime's (Y, Z) -> tip table: a regular grid of tips read bilinearly, NaN outside.

Built by ``whiskercal.mechfit.tables.field_tip_table`` from the fitted mechanics and magnet
map (docs/calibration.md), stored in the calibration artifact's ``/field_table``, evaluated here
in plain floats (a few microseconds a sample).
"""

from __future__ import annotations

import math

import numpy as np


class FieldTipTable:
    """(Y, Z) µT -> tip (mm) on a regular grid, bilinear (the corners with a tip, at the edge
    of the tip-load family); NaN outside it.

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
        self._bands = [_answered_band(self.z_uT, row) for row in self.tips_mm[..., 0]]

    def tip_scalar(self, y_uT: float, z_uT: float) -> tuple[float, float]:
        """One tip (x, y) mm in plain floats; NaN outside the table and where no corner of the
        reading's cell has a tip.

        At the edge of the tip loads, where some corners have none, the others' bilinear
        weights are renormalized: a reading there lies within a cell of tabulated loads, and
        their tips are far closer than the frictionless z lookup the runtime would fall back
        to (a soft build's deepest plane contacts lie beyond the lookup's curve altogether).
        """
        fy, fz = (y_uT - self._y0) / self._dy, (z_uT - self._z0) / self._dz
        # compared before any int(): NaN and ±inf fail the comparison and get no tip
        if not (0.0 <= fy < self._ny - 1 and 0.0 <= fz < self._nz - 1):
            return math.nan, math.nan
        i, j = int(fy), int(fz)
        ty, tz = fy - i, fz - j
        a, b, c, d = self._rows[i][j], self._rows[i + 1][j], self._rows[i][j + 1], self._rows[i + 1][j + 1]
        w00, w10, w01, w11 = (1 - ty) * (1 - tz), ty * (1 - tz), (1 - ty) * tz, ty * tz
        x = w00 * a[0] + w10 * b[0] + w01 * c[0] + w11 * d[0]
        if x == x:
            return x, w00 * a[1] + w10 * b[1] + w01 * c[1] + w11 * d[1]
        return _edge_tip(((a, w00), (b, w10), (c, w01), (d, w11)))

    def beyond_loads(self, y_uT: float, z_uT: float) -> int:
        """-1 or +1 where Y lies within the table's span but Z more than one cell below or
        above every tip the table answers at that Y: a load past any the model tabulated (a
        soft root turned past where Y folds back), which the z lookup, placing Y on the
        frictionless tip curve, would put tens of millimetres off (docs/calibration.md);
        0 elsewhere, NaN included."""
        i = (y_uT - self._y0) / self._dy
        if not 0.0 <= i < self._ny - 1:
            return 0
        bands = [b for b in self._bands[int(i):int(i) + 2] if b is not None]
        if not bands:
            return 0
        low, high = min(b[0] for b in bands), max(b[1] for b in bands)
        return -1 if z_uT < low - self._dz else 1 if z_uT > high + self._dz else 0

    def __call__(self, y_uT, z_uT) -> np.ndarray:
        """Tips (..., 2) mm for arrays of Y and Z (µT)."""
        y, z = np.broadcast_arrays(np.asarray(y_uT, float), np.asarray(z_uT, float))
        out = np.array([self.tip_scalar(a, b) for a, b in zip(y.ravel(), z.ravel())])
        return out.reshape(y.shape + (2,))


def _edge_tip(corners) -> tuple[float, float]:
    """The bilinear weights of a cell's corners that have a tip, renormalized (equal where
    those weights are all zero: the reading sits on a corner without one); NaN where none do."""
    kept = [(tip, weight) for tip, weight in corners if tip[0] == tip[0]]
    if not kept:
        return math.nan, math.nan
    total = sum(weight for _, weight in kept)
    if total <= 0.0:
        kept, total = [(tip, 1.0) for tip, _ in kept], float(len(kept))
    return (sum(tip[0] * w for tip, w in kept) / total, sum(tip[1] * w for tip, w in kept) / total)


def _answered_band(z_axis: np.ndarray, row: np.ndarray) -> tuple[float, float] | None:
    """The lowest and highest Z (µT) a table row answers, None where it answers none."""
    answered = z_axis[np.isfinite(row)]
    return (float(answered[0]), float(answered[-1])) if len(answered) else None
