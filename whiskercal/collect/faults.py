"""Faults a run can survive but must not pass over in silence: frame loss, nothing touched.

- Frames lost on the sensor link (sequence gaps: dropped; CRC failures: corrupt) cost samples,
  never wrong values, but above a fraction (``[safety] max_frame_loss``, default 1 %) the link
  or the host is failing and the run says so.
- A grid in which no point deflected the whisker beyond its own noise (no object in the scene,
  the rod missing, the whisker out of reach) is no calibration data at all: the run keeps the
  file but fails with one line.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from whiskercal.errors import DeviceError

# A point touches when its |z| exceeds this many per-sample noise sigmas; the grid's touched points
# deflect by hundreds to thousands of µT against a few µT of noise, free points stay within ~1.
TOUCH_SIGMAS = 8.0


class NothingTouchedError(DeviceError):
    """No point of a grid deflected the whisker beyond its noise."""


def frame_loss(kept: int, dropped: int, corrupt: int) -> float:
    """Fraction of the frames the sensor sent that were lost (dropped or corrupt)."""
    lost = int(dropped) + int(corrupt)
    return lost / (int(kept) + lost) if kept + lost > 0 else 0.0


def frame_loss_warning(kept: int, dropped: int, corrupt: int, limit: float) -> str | None:
    """One line when the lost fraction exceeds ``limit``, else None."""
    lost = frame_loss(kept, dropped, corrupt)
    if lost <= limit:
        return None
    return (f"{100 * lost:.1f} % of the sensor frames were lost ({dropped} dropped, {corrupt} "
            f"corrupt, {kept} received; limit {100 * limit:g} %, [safety] max_frame_loss): check "
            "the cable, the port and the host's load")


def check_touched(z_uT: np.ndarray, z_std_uT: np.ndarray, where: str) -> None:
    """Raise :class:`NothingTouchedError` when no point's |z| rises above its noise."""
    z, std = np.asarray(z_uT, float), np.asarray(z_std_uT, float)
    if len(z) == 0:
        return
    noise_uT = max(float(np.median(std)), 1e-9)
    if np.any(np.abs(z) > TOUCH_SIGMAS * noise_uT):
        return
    raise NothingTouchedError(
        f"{where}: nothing was touched: no point's |z| exceeds {TOUCH_SIGMAS:g} x the noise "
        f"({np.max(np.abs(z)):.1f} µT at most, noise {noise_uT:.1f} µT per sample); check that the "
        "rod is mounted and the whisker is within reach of the grid")
