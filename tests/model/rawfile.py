"""Raw calibration datasets for tests, written with the schema's own writer: a whole grid from
arrays, and the records (header, point, samples) the writer and the checkpoint take."""

from __future__ import annotations

import numpy as np

from whiskercal.artifacts.raw_grid import (Baseline, PointRecord, RawGridWriter, RawHeader,
                                           StreamChunk)


def make_header(n_plan: int = 6, config: dict | None = None) -> RawHeader:
    """A plan of ``n_plan`` rod positions 3 mm apart (mm) and a small configuration."""
    rod = np.column_stack([np.arange(n_plan) * 3.0 + 20.0, -np.arange(n_plan) * 3.0])
    return RawHeader(plan_stage_mm=rod + [50.0, 100.0], plan_rod_center_mm=rod,
                     config=config or {"grid": {"step_mm": 3.0}}, sensor_id="twin-1",
                     rod_radius_mm=1.5)


def make_point(index: int, y_uT: float, t_s: float) -> PointRecord:
    """Planned point ``index`` measured with field Y ``y_uT`` (µT) from device time ``t_s`` (s)."""
    rod = np.array([20.0 + 3 * index, -3.0 * index])
    return PointRecord(plan_index=index, commanded_mm=rod + [50, 100], encoder_mm=rod + [50, 100],
                       rod_center_mm=rod, field_mean_uT=np.array([1.0, y_uT, 3.0]),
                       field_std_uT=np.array([5.0, 6.0, 7.0]), n_samples=30,
                       t_start_s=t_s, t_end_s=t_s + 0.1, dropped=index % 2, corrupt=0)


def make_stream(point: int, n: int = 4) -> StreamChunk:
    """``n`` raw samples (300 Hz) averaged for plan index ``point``, their counts all ``point``."""
    return StreamChunk(seq=np.arange(n), t_s=np.arange(n) / 300.0,
                       counts=np.full((n, 3), point, np.int16), status=np.zeros(n, np.uint8),
                       point=np.full(n, point))


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
