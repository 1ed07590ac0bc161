"""Raw calibration grids generated straight from the twin's physics, for fast, honest model tests.

The grid is ``whiskercal.testing.twin_grid``'s: each rod position of ``whiskercal collect``'s
default plan (the paper's 3 mm lattice, 180 points) goes through ``mechanics.solve_rod``
(warm-started along each column, as the stage visits them), then ``truth.z_of_equilibrium`` plus
seeded Gaussian noise of the averaged reading. No serial protocol, no stage: what is tested here
is the model, not the acquisition.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from whiskercal.testing.twin_grid import ROD_RADIUS_MM, noisy_z, simulate_grid
from whiskercal.twin.params import DEFAULT_SENSOR, SensorParams

from rawfile import write_raw_grid


@dataclass(frozen=True)
class TwinGrid:
    """Rod centres (n, 2) mm, measured z (n,) µT, and the twin's truth per point."""

    rod_center_mm: np.ndarray
    z_uT: np.ndarray
    z_true_uT: np.ndarray
    contact_mm: np.ndarray
    tip_mm: np.ndarray
    kind: np.ndarray
    rod_radius_mm: float
    sensor: SensorParams


def twin_grid(sensor: SensorParams = DEFAULT_SENSOR, rod_radius_mm: float = ROD_RADIUS_MM,
              noise_uT: float = 1.0, seed: int = 0) -> TwinGrid:
    """A 180-point grid with Gaussian measurement noise ``noise_uT`` (µT, seeded)."""
    grid = simulate_grid(sensor, None, float(rod_radius_mm))
    return TwinGrid(grid.rod_center_mm, noisy_z(grid, noise_uT, seed), grid.z_true_uT,
                    grid.contact_mm, grid.tip_mm, grid.kind, grid.rod_radius_mm, sensor)


def write_twin_raw(path, grid: TwinGrid, with_truth: bool = True):
    """Write ``grid`` as a raw dataset, the twin's truth per point under /truth."""
    truth = None
    if with_truth:
        truth = [{"contact_mm": grid.contact_mm[k], "tip_mm": grid.tip_mm[k],
                  "kind": str(grid.kind[k]), "z_uT": grid.z_true_uT[k]}
                 for k in range(len(grid.z_uT))]
    return write_raw_grid(path, grid.rod_center_mm, grid.z_uT, grid.rod_radius_mm,
                          grid.sensor.sensor_id, truth)
