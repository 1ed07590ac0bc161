"""How fast the twin turns a suspension pose into a reading, and what the speed costs in accuracy.

The simulated world evaluates the field once per sample (300 Hz of simulated time), one pose at a
time; the flat-plane study (9 depths, 80 mm at 10 mm/s) is 21 600 samples. This measures, for
`DEFAULT_SENSOR`:

- building the interpolation table (once per magnet and process),
- one pose per call and a batch of poses, interpolated and exact (magpylib), and the dipole model,
- the magnetometer model per sample,
- the interpolation's and the dipole's largest error against the exact field.

`run()` returns JSON-able results; `whiskercal bench` collects them.
"""

from __future__ import annotations

import statistics
import time
from dataclasses import replace

import numpy as np

from whiskercal.twin.physics import magnet as mag
from whiskercal.twin.physics.magnetometer import to_counts
from whiskercal.twin.params import DEFAULT_SENSOR

SEED = 20241121
STUDY_SAMPLES = 9 * 8 * 300  # 9 depths x 8 s (80 mm at 10 mm/s) x 300 Hz


def _per_call_us(call, repeats: int) -> float:
    """Median time of one call, µs (each repeat timed alone)."""
    durations = []
    for _ in range(repeats):
        start = time.perf_counter()
        call()
        durations.append(time.perf_counter() - start)
    return 1e6 * statistics.median(durations)


def _batch_per_pose_us(call, n_poses: int) -> float:
    start = time.perf_counter()
    call()
    return 1e6 * (time.perf_counter() - start) / n_poses


def _working_poses(n: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Poses spread over the tip-contact working range (rad, mm)."""
    return rng.uniform(-0.2, 0.02, n), rng.uniform(-0.2, 0.2, (n, 2))


def _table_build_s(magnet: mag.MagnetParams) -> float:
    # A copy with an equal but distinct grid object would hit the cache; clear it to measure.
    mag._field_table.cache_clear()
    start = time.perf_counter()
    mag.field_uT(magnet, 0.0, [0.0, 0.0])
    return time.perf_counter() - start


def run(n_single: int = 2000, n_batch: int = 20000) -> dict:
    """Time and error of the field evaluation paths for the default sensor.

    Parameters
    ----------
    n_single : int
        Single-pose calls to time.
    n_batch : int
        Poses in the batch timings.

    Returns
    -------
    dict
        Times in µs per pose (and s for the table), errors in µT, and the study's field cost as a
        fraction of its real duration.
    """
    magnet, meter = DEFAULT_SENSOR.magnet, DEFAULT_SENSOR.magnetometer
    rng = np.random.default_rng(SEED)
    table_s = _table_build_s(magnet)
    rotation, shift = _working_poses(n_batch, rng)
    single = _per_call_us(lambda: mag.field_uT(magnet, -0.1, [0.01, -0.02]), n_single)
    single_exact = _per_call_us(lambda: mag.exact_field_uT(magnet, -0.1, [0.01, -0.02]), n_single // 4)
    field = mag.field_uT(magnet, rotation, shift)
    exact = mag.exact_field_uT(magnet, rotation, shift)
    dipole = mag.dipole_field_uT(magnet, rotation, shift)
    meter_us = _per_call_us(lambda: to_counts(field[0], meter, rng), n_single)
    study_s = STUDY_SAMPLES * (single + meter_us) * 1e-6
    return {
        "sensor_id": DEFAULT_SENSOR.sensor_id,
        "table_build_s": table_s,
        "table_nodes": int(mag._field_table(magnet).coefficients[..., 0].size),
        "single_pose_us": {"interpolated": single, "exact": single_exact},
        "batch_per_pose_us": {
            "interpolated": _batch_per_pose_us(lambda: mag.field_uT(magnet, rotation, shift), n_batch),
            "exact": _batch_per_pose_us(lambda: mag.exact_field_uT(magnet, rotation, shift), n_batch),
            "dipole": _batch_per_pose_us(lambda: mag.dipole_field_uT(magnet, rotation, shift), n_batch),
        },
        "magnetometer_per_sample_us": meter_us,
        "max_error_uT": {
            "interpolated_vs_exact_working_range": np.abs(field - exact).max(axis=0).tolist(),
            "interpolated_vs_exact_whole_grid": mag.interpolation_error_uT(magnet, 4000, SEED).tolist(),
            "dipole_vs_exact_working_range": np.abs(dipole - exact).max(axis=0).tolist(),
        },
        "study_field_and_meter_s": study_s,
        "study_real_time_s": STUDY_SAMPLES / 300.0,
    }


def _coarse_grid_error(magnet: mag.MagnetParams, step_rad: float, step_mm: float) -> float:
    """Largest interpolation error (µT) for a coarser table: how much the resolution buys."""
    coarse = replace(magnet, grid=replace(magnet.grid, rotation_step_rad=step_rad, shift_step_mm=step_mm))
    return float(mag.interpolation_error_uT(coarse, 2000, SEED).max())


def resolution_study() -> list[dict]:
    """Interpolation error against table resolution (the Pareto points behind the default grid)."""
    magnet = DEFAULT_SENSOR.magnet
    steps = [(0.04, 0.4), (0.02, 0.2), (0.01, 0.1), (0.005, 0.05)]
    return [{"rotation_step_rad": r, "shift_step_mm": s, "max_error_uT": _coarse_grid_error(magnet, r, s)}
            for r, s in steps]


if __name__ == "__main__":
    import json

    print(json.dumps({"run": run(), "resolution": resolution_study()}, indent=2))
