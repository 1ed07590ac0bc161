"""Write a raw calibration dataset from arrays with the collect package's own writer."""

from __future__ import annotations

import numpy as np

from whiskercal.collect.dataset import Baseline, PointRecord, RawGridWriter, RawHeader


def write_raw_grid(path, rod_center_mm, z_uT, rod_radius_mm: float, sensor_id: str,
                   truth: list[dict] | None = None, n_samples: int = 30,
                   field_std_uT: float = 5.6, static_y_uT: float = 1160.0, config=None):
    """A complete raw grid: static baselines before and after, one point per row (mm, µT)."""
    rod_center_mm = np.asarray(rod_center_mm, float)
    header = RawHeader(plan_stage_mm=rod_center_mm + 100.0, plan_rod_center_mm=rod_center_mm,
                       config=config or {"rig": {"rod_radius_mm": rod_radius_mm}},
                       sensor_id=sensor_id, rod_radius_mm=rod_radius_mm)
    writer = RawGridWriter.create(path, header)
    baseline = Baseline(np.array([0.0, static_y_uT, 0.0]), np.full(3, field_std_uT), 0.0)
    writer.set_baseline("before", baseline)
    for k, center in enumerate(rod_center_mm):
        field = np.array([0.0, static_y_uT + z_uT[k], 0.0])
        point = PointRecord(k, center + 100.0, center + 100.0, center, field,
                            np.full(3, field_std_uT), n_samples, 1.0 + k, 1.1 + k)
        writer.append_point(point, truth=None if truth is None else truth[k])
    writer.set_baseline("after", Baseline(baseline.field_uT, baseline.std_uT,
                                          1.0 + len(rod_center_mm)))
    writer.mark_complete()
    writer.close()
    return path
