"""Contact localization anywhere on the shaft: z plus the known motion since contact began.

The calibration grid is the measurement model of a point contact on the shaft: the rod's
centre at p (whisker frame, mm) gives z = f(p). When the object that touches the shaft moves by a
known displacement d(t) relative to the sensor after contact began (from the stage or the
robot), the contact slides along the shaft and z follows f at the moved position:

    z(t) = f(p0 + d(t)) + noise,

with p0, the object's position when contact began, the only unknown (two numbers). The localizer
is a batch least squares over every sample since contact began (decimated to a bounded number,
so a sample costs the same however long the contact lasts), solved by Gauss-Newton on the
calibrated surface from a coarse search along the undeflected whisker; a soft prior says that
contact began on the straight, undeflected whisker (y0 = 0; the calibrated surface is over
contact points, ``whiskercal.model.calibrate.correct_for_rod``). Its
covariance is the Gauss-Newton one, scaled by the residual when the model fits worse than the
noise says.

It says it cannot localize yet (``LocalizerState.localized`` False with a reason) while the
travel since contact is too short, z is still in the noise, the covariance is too wide, or a
second, distant p0 explains the data nearly as well.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# Reasons a sample's estimate is withheld (``LocalizerState.reason``).
REASON_OK = ""
REASON_NO_CONTACT = "no contact"
REASON_TRAVEL = "too little travel since contact"
REASON_SIGNAL = "z still in the noise"
REASON_WIDE = "uncertainty too wide"
REASON_AMBIGUOUS = "two contact points explain z alike"


@dataclass(frozen=True)
class ShaftParams:
    """Settings of the shaft localizer (mm, µT).

    ``noise_uT`` is the per-sample noise plus the surface's own misfit (added in quadrature by
    the caller); ``systematic_uT`` the misfit's part, which does not average out over samples
    (it widens the covariance, not the fit's weights); ``start_y_mm`` where contact begins across the whisker (0: on the straight,
    undeflected whisker; the calibrated surface is over contact points, the grid's rod centres
    moved one rod radius onto the shaft); ``search_x_mm`` the range of the coarse search along
    the whisker for the first contact; ``prior_y_sd_mm`` how far from ``start_y_mm`` contact may
    begin; ``max_points`` bounds the batch;
    ``min_travel_mm``, ``min_signal`` (in units of ``noise_uT``), ``max_sd_mm`` and
    ``ambiguity_chi2`` decide when an estimate is given.
    """

    noise_uT: float = 15.0
    systematic_uT: float = 0.0
    misfit_length_mm: float = 3.0
    min_fit_uT: float = 0.0
    start_y_mm: float = 0.0
    search_x_mm: tuple[float, float] = (10.0, 80.0)
    search_step_mm: float = 1.0
    prior_y_sd_mm: float = 0.5
    max_points: int = 96
    iterations: int = 2
    research_every: int = 16
    min_travel_mm: float = 3.0
    min_signal: float = 10.0
    max_sd_mm: float = 0.5
    ambiguity_chi2: float = 9.0
    ambiguity_mm: float = 2.0
    rival_iterations: int = 3


@dataclass(frozen=True)
class LocalizerState:
    """One sample's result (mm, whisker frame).

    ``contact_mm`` is the contact point on the shaft now (p0 + d), ``sd_mm`` the standard deviations
    of p0 along x and y, ``travel_mm`` the path length moved since contact began. NaN and
    ``localized`` False (with ``reason``) until an estimate is given.
    """

    localized: bool
    reason: str
    contact_mm: np.ndarray
    sd_mm: np.ndarray
    travel_mm: float
    rms_residual: float


class MotionSinceContact:
    """The object's position relative to the sensor since contact began: its displacement (mm)
    and the length of its path (mm). Any constant offset of the positions cancels."""

    def __init__(self) -> None:
        self.origin: np.ndarray | None = None
        self.last: np.ndarray | None = None
        self.travel_mm = 0.0

    def add(self, position_mm) -> np.ndarray:
        """Take the next position; return the displacement since the first (mm)."""
        position = np.asarray(position_mm, float)
        if self.origin is None:
            self.origin = self.last = position
        self.travel_mm += float(np.hypot(*(position - self.last)))
        self.last = position
        return position - self.origin

    @property
    def displacement_mm(self) -> np.ndarray | None:
        """Displacement of the latest position from the first (None before any)."""
        return None if self.origin is None else self.last - self.origin


class _Batch:
    """Samples since contact began, decimated by doubling the stride when full."""

    def __init__(self, capacity: int) -> None:
        self.capacity = capacity
        self.d = np.empty((capacity, 2))
        self.z = np.empty(capacity)
        self.n = 0
        self.stride = 1
        self.seen = 0

    def add(self, d_mm: np.ndarray, z_uT: float) -> None:
        self.seen += 1
        if (self.seen - 1) % self.stride:
            return
        if self.n == self.capacity:
            keep = slice(0, self.n, 2)
            count = len(range(0, self.n, 2))
            self.d[:count], self.z[:count] = self.d[keep].copy(), self.z[keep].copy()
            self.n, self.stride = count, self.stride * 2
            if (self.seen - 1) % self.stride:
                return
        self.d[self.n], self.z[self.n] = d_mm, z_uT
        self.n += 1


class ShaftLocalizer:
    """Streaming contact localization on the shaft (module docstring).

    ``surface`` is anything with ``__call__(points (..., 2)) -> z`` and ``gradient(points) ->
    (..., 2)``: the calibration's :class:`~whiskercal.model.surface.Surface`.
    """

    def __init__(self, surface, params: ShaftParams = ShaftParams()) -> None:
        self.surface, self.params = surface, params
        x0, x1 = params.search_x_mm
        self._search = np.column_stack([np.arange(x0, x1 + 1e-9, params.search_step_mm),
                                        np.full(int(np.floor((x1 - x0) / params.search_step_mm
                                                             + 1e-9)) + 1, params.start_y_mm)])
        self.reset()

    def reset(self) -> None:
        """Forget the contact: the next ``update`` begins a new one."""
        self._batch = _Batch(self.params.max_points)
        self._motion = MotionSinceContact()
        self._peak = 0.0
        self._p0 = None
        self._cov = self._cov_noise = None
        self._rms = np.nan
        self._ambiguous = True

    def update(self, z_uT: float, position_mm) -> LocalizerState:
        """One sample in contact: z (µT) and the object's position relative to the sensor (mm,
        whisker frame; any constant offset, only its change since contact began counts)."""
        d = self._motion.add(position_mm)
        if abs(z_uT) >= self.params.min_fit_uT:
            self._batch.add(d, z_uT)
        self._peak = max(self._peak, abs(z_uT))
        self._solve()
        return self._state(d)

    def _solve(self) -> None:
        batch = self._batch
        if batch.n < 3:
            return
        if self._p0 is None or batch.seen % self.params.research_every == 0:
            self._p0 = self._coarse_search()
        for _ in range(self.params.iterations):
            self._p0, self._cov, self._rms = self._gauss_newton_step(self._p0)

    def _cost(self, candidates: np.ndarray, stride: int = 1) -> np.ndarray:
        """Chi² (data plus prior) of each candidate p0 (m, 2) against every ``stride``-th sample
        of the batch (scaled back to the whole batch)."""
        batch, params = self._batch, self.params
        d, z = batch.d[: batch.n: stride], batch.z[: batch.n: stride]
        points = candidates[:, None, :] + d[None, :, :]
        residual = (z - self.surface(points)) / params.noise_uT
        residual *= np.sqrt(batch.n / len(z))
        prior = ((candidates[:, 1] - params.start_y_mm) / params.prior_y_sd_mm) ** 2
        return np.sum(residual * residual, axis=1) + prior

    def _coarse_search(self) -> np.ndarray:
        """The best p0 on the search line, and whether a distant one explains z nearly as well."""
        # a third of the batch is plenty to rank 1 mm-spaced candidates, at a third of the cost
        cost = self._cost(self._search, stride=3)
        best = int(np.argmin(cost))
        far = np.abs(self._search[:, 0] - self._search[best, 0]) > self.params.ambiguity_mm
        # a rival basin only counts when it is a local minimum of its own, not the best's slope
        rival = _best_distinct_minimum(cost, far)
        self._rival, self._rival_ok = np.inf, False
        if rival is not None:
            p_rival, rival_cost = self._refined(self._search[rival].copy())
            # a rival that slides into the best's basin is the best's slope after all
            if abs(p_rival[0] - self._search[best, 0]) > self.params.ambiguity_mm:
                self._rival, self._rival_ok = rival_cost, True
        return self._search[best].copy()

    def _gauss_newton(self, p0: np.ndarray):
        """One Gauss-Newton step from p0 on the batch: (new p0, information, jacobian, prior's
        row, RMS residual in noise units), or None when the information is singular."""
        batch, params = self._batch, self.params
        points = p0 + batch.d[: batch.n]
        residual = (batch.z[: batch.n] - self.surface(points)) / params.noise_uT
        jacobian = self.surface.gradient(points) / params.noise_uT
        prior_j = np.array([0.0, 1.0 / params.prior_y_sd_mm])
        prior_r = (params.start_y_mm - p0[1]) / params.prior_y_sd_mm
        information = jacobian.T @ jacobian + np.outer(prior_j, prior_j)
        gradient = jacobian.T @ residual + prior_j * prior_r
        try:
            step = np.linalg.solve(information, gradient)
        except np.linalg.LinAlgError:
            return None
        step_norm = float(np.hypot(*step))
        if step_norm > 5.0:  # a trust region: the surface is only locally quadratic
            step *= 5.0 / step_norm
        rms = float(np.sqrt(np.mean(residual * residual)))
        return p0 + step, information, jacobian, prior_j, rms

    def _gauss_newton_step(self, p0: np.ndarray):
        solved = self._gauss_newton(p0)
        if solved is None:
            self._cov_noise = None
            return p0, None, np.nan
        p_next, information, jacobian, prior_j, rms = solved
        covariance = np.linalg.inv(information) * max(1.0, rms * rms)
        self._cov_noise = covariance
        return p_next, covariance + self._systematic_covariance(jacobian, prior_j), rms

    def _refined(self, p0: np.ndarray) -> tuple[np.ndarray, float]:
        """The best p0 near a candidate and its chi²: the candidate after the solver's own steps
        (a rival on the search line is judged at its best start across the whisker, not at y0)."""
        for _ in range(self.params.rival_iterations):
            solved = self._gauss_newton(p0)
            if solved is None:
                break
            p0 = solved[0]
        return p0, float(self._cost(p0[None, :])[0])

    def _systematic_covariance(self, jacobian: np.ndarray, prior_j: np.ndarray) -> np.ndarray:
        """The covariance the surface's own misfit leaves: it repeats from sample to sample
        rather than averaging out, so it counts as one sample's worth of information (mm²)."""
        systematic = self.params.systematic_uT
        if systematic <= 0.0:
            return np.zeros((2, 2))
        noise = self.params.noise_uT
        mean_information = (jacobian.T @ jacobian) * (noise * noise) / len(jacobian)
        prior = np.outer(prior_j, prior_j) * (systematic * systematic)
        # the misfit changes over a few millimetres of the surface: each such stretch of travel
        # adds about one independent sample of it
        independent = 1.0 + self._motion.travel_mm / self.params.misfit_length_mm
        return np.linalg.inv(mean_information + prior) * (systematic * systematic) / independent

    def rough(self) -> tuple[np.ndarray, float] | None:
        """The current best contact point (mm) and its widest standard deviation (mm) from the
        noise alone, even while the estimate is withheld: enough to tell a contact near the root
        from one at the tip (the surface's systematic misfit, a fraction of a millimetre, does
        not matter against that), never a localization. None before the first solve."""
        if self._cov is None or self._motion.origin is None:
            return None
        sd = float(np.sqrt(np.max(np.linalg.eigvalsh(self._cov_noise))))
        return self._p0 + self._motion.displacement_mm, sd

    def _withheld_reason(self) -> str:
        params = self.params
        if self._cov is None:
            return REASON_SIGNAL
        if self._motion.travel_mm < params.min_travel_mm:
            return REASON_TRAVEL
        if self._peak < params.min_signal * params.noise_uT:
            return REASON_SIGNAL
        if np.sqrt(np.max(np.linalg.eigvalsh(self._cov))) > params.max_sd_mm:
            return REASON_WIDE
        best = float(self._cost(self._p0[None, :])[0])
        if self._rival_ok and self._rival - best < params.ambiguity_chi2 * max(1.0, self._rms ** 2):
            return REASON_AMBIGUOUS
        return REASON_OK

    def _state(self, d: np.ndarray) -> LocalizerState:
        reason = self._withheld_reason()
        if reason:
            nan2 = np.full(2, np.nan)
            return LocalizerState(False, reason, nan2, nan2, self._motion.travel_mm, self._rms)
        return LocalizerState(True, REASON_OK, self._p0 + d, np.sqrt(np.diag(self._cov)),
                              self._motion.travel_mm, self._rms)


def _best_distinct_minimum(cost: np.ndarray, far: np.ndarray) -> int | None:
    """The index of the lowest local minimum of the search line away from the best (None when
    there is none)."""
    inner = np.flatnonzero(far[1:-1]) + 1
    if inner.size == 0:
        return None
    local = inner[(cost[inner] <= cost[inner - 1]) & (cost[inner] <= cost[inner + 1])]
    return int(local[np.argmin(cost[local])]) if local.size else None

