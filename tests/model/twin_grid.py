"""Raw calibration grids generated straight from the twin's physics, for fast, honest model tests.

Each rod position on the paper's lattice (3 mm, reach 12.5..65 mm, angle -44.5..0 deg, 180
points) goes through ``mechanics.solve_rod`` (warm-started along each column, as the stage
visits them), then ``truth.z_of_equilibrium`` plus seeded Gaussian noise of the averaged reading.
No serial protocol, no stage: what is tested here is the model, not the acquisition.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from whiskercal.collect.config import GridConfig
from whiskercal.collect.plan import lattice_points, visiting_order
from whiskercal.twin import mechanics, truth
from whiskercal.twin.params import DEFAULT_SENSOR, SensorParams

PAPER_GRID = GridConfig(step_mm=3.0, reach_min_mm=12.5, reach_max_mm=65.0, angle_min_deg=-44.5,
                        angle_max_deg=0.0, expected_points=180)
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
def _noise_free(sensor: SensorParams, rod_radius_mm: float, grid: GridConfig = PAPER_GRID):
    points = lattice_points(grid)
    points = points[visiting_order(points)]
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


def write_raw_grid(path, grid: TwinGrid, n_samples: int = 30, field_std_uT: float = 5.6,
                   with_truth: bool = True, static_y_uT: float = 1160.0):
    """Write ``grid`` as a raw dataset with ``RawGridWriter`` (the twin's truth under /truth)."""
    from whiskercal.collect.dataset import Baseline, PointRecord, RawGridWriter, RawHeader

    header = RawHeader(plan_stage_mm=grid.rod_center_mm + 100.0,
                       plan_rod_center_mm=grid.rod_center_mm,
                       config={"rig": {"rod_radius_mm": grid.rod_radius_mm}},
                       sensor_id=grid.sensor.sensor_id, rod_radius_mm=grid.rod_radius_mm)
    writer = RawGridWriter.create(path, header)
    baseline = Baseline(np.array([0.0, static_y_uT, 0.0]), np.full(3, field_std_uT), 0.0)
    writer.set_baseline("before", baseline)
    for k, center in enumerate(grid.rod_center_mm):
        field = np.array([0.0, static_y_uT + grid.z_uT[k], 0.0])
        point = PointRecord(k, center + 100.0, center + 100.0, center, field,
                            np.full(3, field_std_uT), n_samples, 1.0 + k, 1.1 + k)
        truth = {"contact_mm": grid.contact_mm[k], "tip_mm": grid.tip_mm[k],
                 "kind": str(grid.kind[k]), "z_uT": grid.z_true_uT[k]} if with_truth else None
        writer.append_point(point, truth=truth)
    writer.set_baseline("after", Baseline(baseline.field_uT, baseline.std_uT, 1.0 + len(grid.z_uT)))
    writer.mark_complete()
    writer.close()
    return path
