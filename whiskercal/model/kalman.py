"""The paper's constant-state Kalman filter for the tip position (mm), robust to degenerate windows.

Predict: x stays, P += Q. Update with the raw tip from the lookup, with R the covariance of the
last N raw tips. A window of identical tips has a singular covariance, and one of fewer than two
tips has none: R's eigenvalues are floored at ``r_floor_mm2``, and a window of fewer than two tips
either skips the update or uses ``r_prior_mm2``. A non-finite raw tip is ignored. The state is never
NaN.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np

from whiskercal.model.errors import ModelError


@dataclass(frozen=True)
class KalmanParams:
    """Filter settings (mm²; the paper's values by default).

    Attributes
    ----------
    q_mm2 : float
        Process noise Q = q·I per sample (paper: 1e-5).
    p0_mm2 : float
        Initial covariance P0 = p0·I (paper: 10).
    window : int
        N, the raw tips whose covariance is R (the authors' code: 10).
    r_floor_mm2 : float
        Smallest eigenvalue allowed in R; keeps a window of identical tips from making K = I.
    r_prior_mm2 : float or None
        R = r_prior·I while the window holds fewer than two tips; None skips those updates.
    """

    q_mm2: float = 1e-5
    p0_mm2: float = 10.0
    window: int = 10
    r_floor_mm2: float = 1e-6
    r_prior_mm2: float | None = None

    def __post_init__(self) -> None:
        if not (self.q_mm2 >= 0 and self.p0_mm2 > 0 and self.r_floor_mm2 > 0 and self.window >= 2):
            raise ModelError("Kalman settings need q >= 0, p0 > 0, r_floor > 0 and window >= 2")
        if self.r_prior_mm2 is not None and not self.r_prior_mm2 > 0:
            raise ModelError("the Kalman R prior must be positive (or None)")


def window_covariance(tips_mm: np.ndarray, floor_mm2: float) -> np.ndarray:
    """Sample covariance (2, 2) of raw tips (n >= 2, 2) with eigenvalues floored at ``floor_mm2``."""
    covariance = np.cov(np.asarray(tips_mm, float), rowvar=False)
    eigenvalues, vectors = np.linalg.eigh(covariance)
    return (vectors * np.maximum(eigenvalues, floor_mm2)) @ vectors.T


class ConstantStateKalman:
    """Streaming filter: :meth:`update` one raw tip at a time; :meth:`reset` when contact ends."""

    def __init__(self, params: KalmanParams | None = None) -> None:
        self.params = params or KalmanParams()
        self.reset()

    def reset(self) -> None:
        """Forget the state: the next finite raw tip becomes x0."""
        self.state_mm: np.ndarray | None = None
        self.covariance_mm2 = self.params.p0_mm2 * np.eye(2)
        self._window: deque = deque(maxlen=self.params.window)

    def update(self, raw_tip_mm) -> np.ndarray | None:
        """Feed one raw tip (2,) mm; return the filtered tip (None before the first finite one)."""
        raw = np.asarray(raw_tip_mm, float)
        if not np.all(np.isfinite(raw)):
            return None if self.state_mm is None else self.state_mm.copy()
        self._window.append(raw)
        if self.state_mm is None:
            self.state_mm = raw.copy()  # x0 = the first estimate at collision
            return self.state_mm.copy()
        self.covariance_mm2 = self.covariance_mm2 + self.params.q_mm2 * np.eye(2)
        noise = self._measurement_noise()
        if noise is not None:
            gain = self.covariance_mm2 @ np.linalg.inv(self.covariance_mm2 + noise)
            self.state_mm = self.state_mm + gain @ (raw - self.state_mm)
            self.covariance_mm2 = (np.eye(2) - gain) @ self.covariance_mm2
        return self.state_mm.copy()

    def _measurement_noise(self) -> np.ndarray | None:
        if len(self._window) >= 2:
            return window_covariance(np.array(self._window), self.params.r_floor_mm2)
        if self.params.r_prior_mm2 is None:
            return None
        return self.params.r_prior_mm2 * np.eye(2)


def filter_batch(raw_tips_mm: np.ndarray, params: KalmanParams | None = None) -> np.ndarray:
    """Filter a whole contact's raw tips (n, 2) mm; rows before the first finite tip are NaN."""
    kalman = ConstantStateKalman(params)
    out = np.full((len(raw_tips_mm), 2), np.nan)
    for k, raw in enumerate(np.asarray(raw_tips_mm, float)):
        filtered = kalman.update(raw)
        if filtered is not None:
            out[k] = filtered
    return out
