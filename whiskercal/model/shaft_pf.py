"""A particle filter over the first contact point: the candidate the published work used.

Same measurement model as :mod:`whiskercal.model.shaft` (z = f(p0 + d) on the calibrated
surface), but p0 is carried as weighted particles: each sample multiplies the weights by its
Gaussian likelihood, and when the effective sample size falls below half the particles they are
resampled (systematic) with a small jitter. The estimate is the weighted mean, its spread the
weighted standard deviation. It is charted against the batch Gauss-Newton localizer in
``whiskercal bench`` (``shaft-localizer``); the runtime uses the batch one (docs/shaft.md).
"""

from __future__ import annotations

import numpy as np

from whiskercal.model.shaft import (REASON_OK, REASON_SIGNAL, REASON_TRAVEL, REASON_WIDE,
                                    LocalizerState, MotionSinceContact, ShaftParams)


class ParticleLocalizer:
    """Streaming p0 particle filter with the :class:`~whiskercal.model.shaft.ShaftLocalizer`
    interface (``update``, ``reset``, ``rough``)."""

    def __init__(self, surface, params: ShaftParams = ShaftParams(), particles: int = 1000, inflate: float = 2.0,
                 jitter_mm: float = 0.05, seed: int = 0) -> None:
        self.surface, self.params = surface, params
        self.n, self.jitter_mm, self.seed = int(particles), float(jitter_mm), int(seed)
        self.inflate = float(inflate)  # likelihoods tempered: the surface misfit is not white noise
        self.reset()

    def reset(self) -> None:
        """Forget the contact; particles spread along the undeflected whisker."""
        self._rng = np.random.default_rng(self.seed)
        x0, x1 = self.params.search_x_mm
        self._p = np.column_stack([self._rng.uniform(x0, x1, self.n),
                                   self._rng.normal(self.params.start_y_mm,
                                                    self.params.prior_y_sd_mm, self.n)])
        self._logw = np.zeros(self.n)
        self._motion, self._peak = MotionSinceContact(), 0.0

    def update(self, z_uT: float, position_mm) -> LocalizerState:
        """One sample in contact: z (µT) and the object's position (mm, any constant offset)."""
        d = self._motion.add(position_mm)
        self._peak = max(self._peak, abs(z_uT))
        if abs(z_uT) >= self.params.min_fit_uT:
            residual = (z_uT - self.surface(self._p + d)) / (self.params.noise_uT * self.inflate)
            self._logw -= 0.5 * residual * residual
            self._logw -= self._logw.max()
            self._resample_if_needed()
        return self._state(d)

    def _weights(self) -> np.ndarray:
        w = np.exp(self._logw)
        return w / w.sum()

    def _resample_if_needed(self) -> None:
        w = self._weights()
        if 1.0 / np.sum(w * w) >= 0.5 * self.n:
            return
        positions = (self._rng.random() + np.arange(self.n)) / self.n
        index = np.minimum(np.searchsorted(np.cumsum(w), positions), self.n - 1)
        self._p = self._p[index] + self._rng.normal(0.0, self.jitter_mm, (self.n, 2))
        self._logw = np.zeros(self.n)

    def rough(self):
        """Weighted mean contact point now (mm) and the widest standard deviation (mm)."""
        if self._motion.origin is None:
            return None
        mean, sd = self._moments()
        return mean + self._motion.displacement_mm, float(np.max(sd))

    def _moments(self) -> tuple[np.ndarray, np.ndarray]:
        w = self._weights()
        mean = w @ self._p
        return mean, np.sqrt(w @ (self._p - mean) ** 2)

    def _state(self, d: np.ndarray) -> LocalizerState:
        mean, sd = self._moments()
        params = self.params
        reason = (REASON_TRAVEL if self._motion.travel_mm < params.min_travel_mm else
                  REASON_SIGNAL if self._peak < params.min_signal * params.noise_uT else
                  REASON_WIDE if np.max(sd) > params.max_sd_mm else REASON_OK)
        if reason:
            nan2 = np.full(2, np.nan)
            return LocalizerState(False, reason, nan2, nan2, self._motion.travel_mm, np.nan)
        return LocalizerState(True, REASON_OK, mean + d, sd, self._motion.travel_mm, np.nan)
