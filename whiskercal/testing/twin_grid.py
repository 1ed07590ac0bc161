"""Calibration grids generated straight from the twin's physics, and the twin's true tips.

The comparisons measure models, not acquisition: each rod position of the default collect plan
goes through ``mechanics.solve_rod`` (warm-started down each column, as the stage visits them) and
``truth.z_of_equilibrium`` gives its noise-free z. Measurement noise is added by the caller, either
as the averaged reading's Gaussian error or sample by sample through the magnetometer model.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, replace

import numpy as np

from whiskercal.collect.config import GridConfig, load_config
from whiskercal.collect.plan import lattice_points, visiting_order
from whiskercal.fit.options import FitOptions
from whiskercal.fit.truth import true_tips_in_range
from whiskercal.model.calibrate import Calibration, calibrate
from whiskercal.twin.physics import mechanics
from whiskercal.twin import truth
from whiskercal.twin.params import DEFAULT_SENSOR, SensorParams

ROD_RADIUS_MM = 1.5
# 5.6 µT per sample averaged over the default 30 samples per point (docs/bench.md, collection)
AVERAGED_NOISE_UT = 1.0
TRUTH_SAMPLES = 161


@dataclass(frozen=True)
class SimulatedGrid:
    """Rod centres (n, 2) mm in visiting order, noise-free z (n,) µT, contact kinds, the sensor,
    and the true contact points and tips (n, 2) mm."""

    rod_center_mm: np.ndarray
    z_true_uT: np.ndarray
    kind: np.ndarray
    sensor: SensorParams
    rod_radius_mm: float
    contact_mm: np.ndarray | None = None
    tip_mm: np.ndarray | None = None


def default_grid_config() -> GridConfig:
    """The grid bands of ``whiskercal collect``'s default configuration."""
    return load_config().grid


def simulate_grid(sensor: SensorParams = DEFAULT_SENSOR, grid: GridConfig | None = None,
                  rod_radius_mm: float = ROD_RADIUS_MM) -> SimulatedGrid:
    """Noise-free z at every point of a grid plan (cached per sensor, grid and rod)."""
    # one cache entry however the arguments are spelt: simulate_grid() and
    # simulate_grid(DEFAULT_SENSOR, None, 1.5) are the same few seconds of mechanics
    return _simulate_grid(sensor, grid, float(rod_radius_mm))


@functools.lru_cache(maxsize=16)
def _simulate_grid(sensor: SensorParams, grid: GridConfig | None,
                   rod_radius_mm: float) -> SimulatedGrid:
    points = lattice_points(grid or default_grid_config())
    points = points[visiting_order(points)]
    z, kinds, contacts, tips, previous, column = [], [], [], [], None, None
    for center in points:
        if center[0] != column:
            previous, column = None, center[0]  # a new column starts from the free whisker
        equilibrium = mechanics.solve_rod(sensor.whisker, center, rod_radius_mm, previous=previous)
        previous = equilibrium if equilibrium.kind != "free" else None
        z.append(truth.z_of_equilibrium(sensor, equilibrium))
        kinds.append(equilibrium.kind)
        contacts.append(equilibrium.contact_mm)
        tips.append(equilibrium.tip_mm)
    return SimulatedGrid(points, np.asarray(z), np.asarray(kinds), sensor, float(rod_radius_mm),
                         np.asarray(contacts), np.asarray(tips))


def noisy_z(grid: SimulatedGrid, noise_uT: float = AVERAGED_NOISE_UT, seed: int = 0) -> np.ndarray:
    """The grid's z (µT) with seeded Gaussian noise of the averaged reading."""
    return grid.z_true_uT + np.random.default_rng(seed).normal(0.0, noise_uT, grid.z_true_uT.shape)


@dataclass(frozen=True)
class RawLike:
    """The parts of a raw grid the fit reads (``fit.run.calibrate_grid``, ``fit.tip_model``):
    rod centres (n, 2) mm, z (n,) µT, standard errors (n,) µT, the rod, the tip sweep's mask."""

    rod_center_mm: np.ndarray
    z_uT: np.ndarray
    rod_radius_mm: float
    z_sem_uT: np.ndarray
    sweep: np.ndarray

    def without_sweep(self) -> "RawLike":
        """The grid's own points (what the level set is fitted to)."""
        keep = ~self.sweep
        return RawLike(self.rod_center_mm[keep], self.z_uT[keep], self.rod_radius_mm,
                       self.z_sem_uT[keep], self.sweep[keep])


def raw_like(rod_center_mm: np.ndarray, z_uT: np.ndarray, noise_uT: float,
             rod_radius_mm: float, sweep: np.ndarray | None = None) -> RawLike:
    """A simulated grid (and tip sweep, ``sweep`` marking its points) as the fit reads a raw
    grid, each point's mean z with a standard error of ``noise_uT``."""
    z_uT = np.asarray(z_uT, float)
    mask = np.zeros(len(z_uT), bool) if sweep is None else np.asarray(sweep, bool)
    return RawLike(np.asarray(rod_center_mm, float), z_uT, float(rod_radius_mm),
                   np.full(len(z_uT), float(noise_uT)), mask)


def calibrate_grid(grid: SimulatedGrid, z_uT: np.ndarray | None = None, **options) -> Calibration:
    """Calibrate a simulated grid with the model options of the fit stage's defaults (``options``,
    :class:`~whiskercal.model.calibrate.CalibrationOptions` fields, override them)."""
    base = FitOptions().calibration_options(trace_length_mm=grid.sensor.whisker.reach_mm)
    z_uT = noisy_z(grid) if z_uT is None else z_uT
    return calibrate(grid.rod_center_mm, z_uT, grid.rod_radius_mm, replace(base, **options))


def truth_curve(sensor: SensorParams = DEFAULT_SENSOR, n: int = TRUTH_SAMPLES):
    """The twin's noise-free z (n,) µT against the true tip (n, 2) mm for tip contact."""
    return truth.tip_curve(sensor, n)


def truth_points(sensor: SensorParams, z_low_uT: float, z_high_uT: float,
                 n: int = TRUTH_SAMPLES) -> tuple[np.ndarray, np.ndarray]:
    """The tip-curve samples whose z lies in [low, high] µT: (z (m,), true tips (m, 2) mm), as
    the fit stage compares its lookup with them."""
    return true_tips_in_range(sensor, z_low_uT, z_high_uT, n)


def tip_error_mm(estimated_mm: np.ndarray, true_mm: np.ndarray) -> dict:
    """RMSE and largest Euclidean distance (mm) between estimated and true tips."""
    distance = np.linalg.norm(np.asarray(estimated_mm) - np.asarray(true_mm), axis=-1)
    finite = distance[np.isfinite(distance)]
    if finite.size == 0:
        return {"rmse_mm": float("nan"), "max_mm": float("nan"), "n": 0}
    return {"rmse_mm": float(np.sqrt(np.mean(finite ** 2))), "max_mm": float(finite.max()),
            "n": int(finite.size)}
