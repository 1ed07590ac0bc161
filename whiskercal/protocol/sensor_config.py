"""The sensor board's settings, as both the host client and the twin's virtual board read them."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from whiskercal.protocol.mlx90393 import lsb_uT


@dataclass(frozen=True)
class SensorConfig:
    """The board's settings: sample rate in Hz and the MLX90393's GAIN_SEL, RES, OSR, DIG_FILT."""

    rate_hz: int = 300
    gain: int = 5
    res: int = 2
    osr: int = 0
    filt: int = 2

    @property
    def lsb_uT(self) -> np.ndarray:
        """µT per count on (x, y, z)."""
        return lsb_uT(self.gain, self.res)
