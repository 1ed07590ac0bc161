"""How fast the twin's mechanics solve: one static solve without history, warm-started solves
along paths, and the flat-plane study scene (9 depths, 80 mm at 10 mm/s, 300 Hz) against real
time, with the magnet's field evaluated at every sample as the simulated world does.

`run()` returns JSON-able results; `whiskercal bench` collects them.
"""

from __future__ import annotations

import math
import statistics
import time
from dataclasses import replace

import numpy as np

STUDY_DEPTHS_MM = tuple(range(5, 50, 5))
STUDY_TRAVEL_MM = 80.0
STUDY_SPEED_MM_S = 10.0
SAMPLE_RATE_HZ = 300.0
SEED = 20241121


def _median_ms(durations_s) -> float:
    return 1e3 * statistics.median(durations_s)


def _timed(call):
    start = time.perf_counter()
    result = call()
    return result, time.perf_counter() - start


def first_solve_s() -> float:
    """Import and the first solve (numba loads its cache, or compiles on a fresh install)."""
    start = time.perf_counter()
    from whiskercal.twin import mechanics

    whisker = mechanics.WhiskerParams()
    mechanics.solve_plane(whisker, mechanics.plane_for_depth(whisker, 20.0))
    return time.perf_counter() - start


def cold_solves(n_rods: int = 60) -> dict:
    """Median time of single solves without history: rod, plane, octagon."""
    from whiskercal.twin import mechanics as m

    whisker, rng = m.WhiskerParams(), np.random.default_rng(SEED)
    centers = np.column_stack([rng.uniform(20.0, 75.0, n_rods), rng.uniform(-30.0, -1.0, n_rods)])
    rods = [_timed(lambda c=c: m.solve_rod(whisker, c, 1.5))[1] for c in centers]
    planes = [_timed(lambda d=d: m.solve_plane(whisker, m.plane_for_depth(whisker, d)))[1]
              for d in STUDY_DEPTHS_MM for _ in range(3)]
    octagon = m.regular_polygon((66.0, 25.0), 30.0, 8, math.pi / 8)
    polygons = [_timed(lambda: m.solve_shape(whisker, octagon))[1] for _ in range(10)]
    return {"cold_rod_median_ms": _median_ms(rods), "cold_rod_max_ms": 1e3 * max(rods),
            "cold_plane_median_ms": _median_ms(planes),
            "cold_octagon_median_ms": _median_ms(polygons)}


def warm_rod_path(n_steps: int = 600) -> dict:
    """A rod moving down across the calibration area, each solve from the previous one."""
    from whiskercal.twin import mechanics as m

    whisker, previous, durations = m.WhiskerParams(), None, []
    for y in np.linspace(-0.5, -30.0, n_steps):
        previous, seconds = _timed(lambda y=y: m.solve_rod(whisker, (60.0, y), 1.5, previous))
        durations.append(seconds)
    return {"warm_rod_median_ms": _median_ms(durations)}


def _field_function():
    """The magnet's field per equilibrium, or None while the magnet model is unavailable."""
    try:
        from whiskercal.twin.magnet import field_uT
        from whiskercal.twin.params import DEFAULT_SENSOR
    except ImportError:
        return None
    magnet = DEFAULT_SENSOR.magnet
    return lambda eq: field_uT(magnet, eq.root_rotation_rad, eq.root_shift_mm)


def study_scene(with_field: bool = True) -> dict:
    """The 9-depth flat-plane study, sample by sample; elapsed time against real time."""
    from whiskercal.twin import mechanics as m

    whisker = m.WhiskerParams()
    field = _field_function() if with_field else None
    step_mm = STUDY_SPEED_MM_S / SAMPLE_RATE_HZ
    n_samples = int(round(STUDY_TRAVEL_MM / step_mm))
    per_step, kinds = [], {}
    start = time.perf_counter()
    for depth in STUDY_DEPTHS_MM:
        plane, previous = m.plane_for_depth(whisker, depth), None
        for i in range(n_samples):
            tick = time.perf_counter()
            plane = replace(plane, slide_mm=plane.motion_sign * i * step_mm)
            previous = m.solve_plane(whisker, plane, previous)
            if field is not None:
                field(previous)
            per_step.append(time.perf_counter() - tick)
            kinds[previous.kind] = kinds.get(previous.kind, 0) + 1
    elapsed = time.perf_counter() - start
    simulated = len(STUDY_DEPTHS_MM) * n_samples / SAMPLE_RATE_HZ
    return {"study_samples": len(per_step), "study_simulated_s": simulated,
            "study_elapsed_s": elapsed, "study_realtime_factor": simulated / elapsed,
            "study_step_median_ms": _median_ms(per_step),
            "study_step_p99_ms": 1e3 * float(np.percentile(per_step, 99)),
            "study_includes_field": field is not None, "study_contact_kinds": kinds}


def run() -> dict:
    """Every measurement above, in one JSON-able dict (times in ms or s as named)."""
    results = {"first_solve_s": first_solve_s()}
    results.update(cold_solves())
    results.update(warm_rod_path())
    results.update(study_scene())
    return results


if __name__ == "__main__":  # pragma: no cover
    import json

    print(json.dumps(run(), indent=2))
