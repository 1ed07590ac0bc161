"""The runtime tracker's per-sample cost: what a robot pays for each magnetometer sample.

A calibration is fitted on the analytic curved-level-set grid of ``model_speed`` (no data files
needed), and its :meth:`~whiskercal.runtime.Calibration.tracker` is timed per call without
contact, in contact inside the calibrated range, and in contact past it under the streaming
"clip" policy; then a whole seeded stream goes through :func:`whiskercal.replay.replay`, whose
per-sample cost includes collecting the track. The budget is the sensor's period at 300 Hz
(3.3 ms), and within it 1 ms; ``within_1ms`` records whether the slowest path kept to it.
"""

from __future__ import annotations

import numpy as np

from whiskercal.artifacts.calibration import data_from_calibration
from whiskercal.bench.model_speed import _bent_z, _grid_mm
from whiskercal.bench.timing import per_call_s
from whiskercal.model.calibrate import CalibrationOptions, calibrate
from whiskercal.model.collision import CollisionParams
from whiskercal.model.kalman import KalmanParams
from whiskercal.replay import ReplayOptions, Stream, replay
from whiskercal.runtime import Calibration

BUDGET_US = 1000.0


def analytic_calibration() -> Calibration:
    """A runtime calibration of the analytic grid (trace length 78 mm, rod radius 0)."""
    points = _grid_mm(reach=(12.5, 90.0), angle_deg=(-70.0, 0.0))
    model = calibrate(points, _bent_z(points), 0.0,
                      CalibrationOptions(trace_length_mm=78.0, correct_rod_radius=False,
                                         allow_extrapolation=True))
    data = data_from_calibration(model, sensor_id="analytic", rod_radius_mm=0.0, tracer="fast",
                                 kalman=KalmanParams(), collision=CollisionParams(), metrics={})
    return Calibration(data, allow_extrapolated=True)


def per_sample_us(calibration: Calibration, repeats: int = 5) -> dict[str, float]:
    """Median time (µs) of one ``Tracker.update`` per path."""
    low, high = calibration.z_range_uT
    inside = 0.5 * (low + high)
    timings = {}
    for name, z in (("free", 0.0), ("contact_in_range", inside), ("contact_clipped", low - 500.0)):
        tracker = calibration.tracker("clip")
        tracker.update(inside)
        timings[name] = per_call_s(lambda z=z: tracker.update(z), repeats=repeats) * 1e6
    return timings


def replay_stream_us(calibration: Calibration, n: int, seed: int = 0) -> dict[str, float]:
    """A seeded stream of n samples (presses past the range, 45 µT noise) through ``replay``."""
    rng = np.random.default_rng(seed)
    low = calibration.z_range_uT[0]
    phase = np.linspace(0.0, 12 * np.pi, n)
    z = np.minimum(0.0, 1.2 * low * np.sin(phase)) + rng.normal(0.0, 45.0, n)
    result = replay(Stream(np.arange(n) / 300.0, 1000.0 + z, "bench"), calibration,
                    ReplayOptions(rest=1000.0))
    return {"samples": n, **result.counts(), "per_sample_us": result.per_sample_us}


def run(quick: bool = False, progress=None) -> dict:
    """Per-call tracker costs and a replayed stream's cost per sample, JSON-able."""
    calibration = analytic_calibration()
    timings = per_sample_us(calibration, repeats=3 if quick else 7)
    stream = replay_stream_us(calibration, 5_000 if quick else 50_000)
    slowest = max(max(timings.values()), stream["per_sample_us"])
    return {"tracker_update_us": timings, "replay": stream, "budget_us": BUDGET_US,
            "within_1ms": bool(slowest < BUDGET_US),
            "supports": {"out_of_range_default": "clip",
                         "slowest_per_sample_us": slowest,
                         "rule": "every sample through the tracker well under 1 ms "
                                 "(the sensor's period at 300 Hz is 3.3 ms)"}}
