"""The paper's constant-state Kalman filter for the tip position (mm), robust to degenerate windows.

Predict: x stays, P += Q. Update with the raw tip from the lookup, with R the covariance of the
last N raw tips. A window of identical tips has a singular covariance, and one of fewer than two
tips has none: R's eigenvalues are floored at ``r_floor_mm2``, and a window of fewer than two tips
either skips the update or uses ``r_prior_mm2``. A non-finite raw tip is ignored. The state is never
NaN. The per-sample update works on the 2x2 matrices in plain floats (closed forms of the
covariance, its eigenvalue floor and the inverse): numpy's call overhead on 2x2 arrays made the
filter cost hundreds of microseconds a sample; :func:`window_covariance` is the numpy reference.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, replace

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


def floored_covariance_2x2(tips: list[tuple[float, float]], floor_mm2: float
                           ) -> tuple[float, float, float]:
    """:func:`window_covariance` of n >= 2 tips in plain floats: (a, b, d) of [[a, b], [b, d]]."""
    n = len(tips)
    mean_x = sum(t[0] for t in tips) / n
    mean_y = sum(t[1] for t in tips) / n
    a = sum((t[0] - mean_x) ** 2 for t in tips) / (n - 1)
    d = sum((t[1] - mean_y) ** 2 for t in tips) / (n - 1)
    b = sum((t[0] - mean_x) * (t[1] - mean_y) for t in tips) / (n - 1)
    middle, radius = (a + d) / 2, math.hypot((a - d) / 2, b)
    high, low = middle + radius, middle - radius
    if low >= floor_mm2:
        return a, b, d
    if radius == 0.0:  # a multiple of I: one eigenvalue twice
        level = max(middle, floor_mm2)
        return level, 0.0, level
    # C = high·P + low·(I - P) with P = (C - low·I) / (high - low), the projector on `high`
    high_f, low_f = max(high, floor_mm2), floor_mm2
    pa, pb, pd = (a - low) / (2 * radius), b / (2 * radius), (d - low) / (2 * radius)
    return (low_f + (high_f - low_f) * pa, (high_f - low_f) * pb, low_f + (high_f - low_f) * pd)


FILTER_RATE_HZ = 300.0  # the rate the paper's per-sample Q was set at (its sensor's)


def rate_scaled(params: KalmanParams | None, rate_hz: float | None) -> KalmanParams | None:
    """``params`` for a stream at ``rate_hz``: Q·(FILTER_RATE_HZ/rate)², so that the filter's
    lag stays the same in seconds (with Q well below R the steady gain goes as √(Q/R), and a
    sample lasts FILTER_RATE_HZ/rate times longer); ``params`` itself for None or
    FILTER_RATE_HZ. Raises ModelError for a rate that is not a positive number."""
    if rate_hz is None or rate_hz == FILTER_RATE_HZ:
        return params
    if not 0 < rate_hz < math.inf:
        raise ModelError(f"the sample rate must be a positive number of Hz, not {rate_hz!r}")
    params = params or KalmanParams()
    return replace(params, q_mm2=params.q_mm2 * (FILTER_RATE_HZ / rate_hz) ** 2)


class ConstantStateKalman:
    """Streaming filter: :meth:`update` one raw tip at a time; :meth:`reset` when contact ends."""

    def __init__(self, params: KalmanParams | None = None) -> None:
        self.params = params or KalmanParams()
        self.reset()

    def reset(self) -> None:
        """Forget the state: the next finite raw tip becomes x0."""
        self.state_mm: np.ndarray | None = None
        self.covariance_mm2 = self.params.p0_mm2 * np.eye(2)
        self._p = [self.params.p0_mm2, 0.0, self.params.p0_mm2]  # P as (a, b, d)
        self._window: deque = deque(maxlen=self.params.window)

    def update(self, raw_tip_mm) -> np.ndarray | None:
        """Feed one raw tip (2,) mm; return the filtered tip (None before the first finite one)."""
        x, y = (float(v) for v in raw_tip_mm)
        if not (math.isfinite(x) and math.isfinite(y)):
            return None if self.state_mm is None else self.state_mm.copy()
        self._window.append((x, y))
        if self.state_mm is None:
            self.state_mm = np.array([x, y])  # x0 = the first estimate at collision
            self._x = [x, y]
            return self.state_mm.copy()
        q = self.params.q_mm2
        pa, pb, pd = self._p[0] + q, self._p[1], self._p[2] + q
        noise = self._measurement_noise()
        if noise is not None:
            self._x, (pa, pb, pd) = _update_2x2(self._x, (pa, pb, pd), noise, x, y)
        self._p = [pa, pb, pd]
        self.state_mm = np.array(self._x)
        self.covariance_mm2 = np.array([[pa, pb], [pb, pd]])
        return self.state_mm.copy()

    def _measurement_noise(self) -> tuple[float, float, float] | None:
        if len(self._window) >= 2:
            return floored_covariance_2x2(self._window, self.params.r_floor_mm2)
        if self.params.r_prior_mm2 is None:
            return None
        return self.params.r_prior_mm2, 0.0, self.params.r_prior_mm2


def _update_2x2(state, p, r, x: float, y: float):
    """One Kalman update with H = I: K = P (P + R)^-1, x += K (z - x), P = (I - K) P."""
    pa, pb, pd = p
    sa, sb, sd = pa + r[0], pb + r[1], pd + r[2]
    det = sa * sd - sb * sb
    ia, ib, id_ = sd / det, -sb / det, sa / det
    ka, kb = pa * ia + pb * ib, pa * ib + pb * id_   # K row 0
    kc, kd = pb * ia + pd * ib, pb * ib + pd * id_   # K row 1
    ex, ey = x - state[0], y - state[1]
    new_state = [state[0] + ka * ex + kb * ey, state[1] + kc * ex + kd * ey]
    na = (1 - ka) * pa - kb * pb
    nb = (1 - ka) * pb - kb * pd
    nd = -kc * pb + (1 - kd) * pd
    return new_state, (na, nb, nd)


def filter_batch(raw_tips_mm: np.ndarray, params: KalmanParams | None = None) -> np.ndarray:
    """Filter a whole contact's raw tips (n, 2) mm; rows before the first finite tip are NaN."""
    kalman = ConstantStateKalman(params)
    out = np.full((len(raw_tips_mm), 2), np.nan)
    for k, raw in enumerate(np.asarray(raw_tips_mm, float)):
        filtered = kalman.update(raw)
        if filtered is not None:
            out[k] = filtered
    return out
