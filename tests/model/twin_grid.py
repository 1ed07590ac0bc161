"""Raw calibration grids generated straight from the twin's physics, for fast, honest model tests.

Each rod position of ``whiskercal collect``'s default plan (the paper's 3 mm lattice, reach
22.5..71.75 mm, an angle band tapering from -28.5 to -46 deg, 180 points) goes through ``mechanics.solve_rod`` (warm-started along each column, as the stage
visits them), then ``truth.z_of_equilibrium`` plus seeded Gaussian noise of the averaged reading.
No serial protocol, no stage: what is tested here is the model, not the acquisition.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from whiskercal.twin import mechanics, truth
from whiskercal.twin.params import DEFAULT_SENSOR, SensorParams

from rawfile import write_raw_grid
from whiskercal.collect.config import load_config
from whiskercal.collect.plan import lattice_points, visiting_order

ROD_RADIUS_MM = 1.5


@dataclass(frozen=True)
class TwinGrid:
    """Rod centres (n, 2) mm, measured z (n,) µT, and the twin's truth per point."""

    rod_center_mm: np.ndarray
    z_uT: np.ndarray
    z_true_uT: np.ndarray
    contact_mm: np.ndarray
    tip_mm: np.ndarray
    root_shift_mm: np.ndarray
    kind: np.ndarray
    rod_radius_mm: float
    sensor: SensorParams


@functools.lru_cache(maxsize=4)
def _noise_free(sensor: SensorParams, rod_radius_mm: float):
    points = lattice_points(load_config().grid)
    points = points[visiting_order(points)]  # columns in x, each from +y down
    rows, previous, last_x = [], None, None
    for center in points:
        if center[0] != last_x:
            previous, last_x = None, center[0]  # a new column starts from the free whisker
        eq = mechanics.solve_rod(sensor.whisker, center, rod_radius_mm, previous=previous)
        previous = eq if eq.kind != "free" else None
        rows.append((truth.z_of_equilibrium(sensor, eq), eq.contact_mm, eq.tip_mm,
                     eq.root_shift_mm, eq.kind))
    z, contact, tip, shift, kind = zip(*rows)
    return points, np.array(z), np.array(contact), np.array(tip), np.array(shift), np.array(kind)


def twin_grid(sensor: SensorParams = DEFAULT_SENSOR, rod_radius_mm: float = ROD_RADIUS_MM,
              noise_uT: float = 1.0, seed: int = 0) -> TwinGrid:
    """A 180-point grid with Gaussian measurement noise ``noise_uT`` (µT, seeded)."""
    points, z, contact, tip, shift, kind = _noise_free(sensor, float(rod_radius_mm))
    noisy = z + np.random.default_rng(seed).normal(0.0, noise_uT, z.shape)
    return TwinGrid(points, noisy, z, contact, tip, shift, kind, float(rod_radius_mm), sensor)


def write_twin_raw(path, grid: TwinGrid, with_truth: bool = True):
    """Write ``grid`` as a raw dataset, the twin's truth per point under /truth."""
    truth = None
    if with_truth:
        truth = [{"contact_mm": grid.contact_mm[k], "tip_mm": grid.tip_mm[k],
                  "kind": str(grid.kind[k]), "z_uT": grid.z_true_uT[k]}
                 for k in range(len(grid.z_uT))]
    return write_raw_grid(path, grid.rod_center_mm, grid.z_uT, grid.rod_radius_mm,
                          grid.sensor.sensor_id, truth)
