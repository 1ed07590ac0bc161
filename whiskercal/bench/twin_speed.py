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
    from whiskercal.twin.physics import mechanics

    whisker = mechanics.WhiskerParams()
    mechanics.solve_plane(whisker, mechanics.plane_for_depth(whisker, 20.0))
    return time.perf_counter() - start


def cold_solves(n_rods: int = 60) -> dict:
    """Median time of single solves without history: rod, plane, octagon."""
    from whiskercal.twin.physics import mechanics as m

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
    from whiskercal.twin.physics import mechanics as m

    whisker, previous, durations = m.WhiskerParams(), None, []
    for y in np.linspace(-0.5, -30.0, n_steps):
        previous, seconds = _timed(lambda y=y: m.solve_rod(whisker, (60.0, y), 1.5, previous))
        durations.append(seconds)
    return {"warm_rod_median_ms": _median_ms(durations)}


def _field_function():
    """The default magnet's field (µT) per equilibrium, as the simulated world evaluates it."""
    from whiskercal.twin.physics.magnet import field_uT
    from whiskercal.twin.params import DEFAULT_SENSOR

    magnet = DEFAULT_SENSOR.magnet
    return lambda eq: field_uT(magnet, eq.root_rotation_rad, eq.root_shift_mm)


def study_scene(with_field: bool = True) -> dict:
    """The 9-depth flat-plane study, sample by sample; elapsed time against real time."""
    from whiskercal.twin.physics import mechanics as m

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


def _plane_waypoints_stage_mm(world, depth_mm: float, slide_mm: float,
                              retract_mm: float = 10.0) -> dict:
    """Stage targets of one trial: retracted at the slide start, pushed in, slid, retracted."""
    fixture = world.config.fixture
    normal = np.array([math.cos(fixture.normal_rad), math.sin(fixture.normal_rad)])
    tangent = fixture.tangent()
    tip = np.array([world.sensor.whisker.reach_mm, 0.0])
    half = 0.5 * slide_mm * tangent

    def at(depth: float, along: np.ndarray) -> np.ndarray:
        return world.stage_target_for(tip + depth * normal + along)

    return {"start": at(-retract_mm, -half), "pushed": at(depth_mm, -half),
            "slid": at(depth_mm, half), "end": at(-retract_mm, half)}


def _move(stage, sensor, target_mm, speed_mm_s: float, chunk: int) -> int:
    """G1 to a stage target while reading the sensor between status polls; samples read."""
    stage.move_to(float(target_mm[0]), float(target_mm[1]), 60.0 * speed_mm_s)
    samples = [0]

    def on_poll(status) -> None:
        if not status.idle:
            samples[0] += len(sensor.read(chunk, timeout_s=1.0))
        samples[0] += len(sensor.read_available())

    stage.wait_idle(600.0, on_poll=on_poll)
    return samples[0]


def world_study_scene(depths_mm=STUDY_DEPTHS_MM, travel_mm: float = STUDY_TRAVEL_MM,
                      name: str = "bench-plane") -> dict:
    """The flat-plane scene end to end: a ``sim://NAME/stage?scene=plane`` world driven by the
    rig's clients (G1 moves, ``?`` polls every 20 ms, the 300 Hz stream read between polls),
    per depth a push-in at 5 mm/s, a slide of `travel_mm` at 10 mm/s and a retract.

    Returns the simulated, wall and process CPU times of the slides alone and of everything (s),
    the ratios simulated/wall (the "x real time") and simulated/CPU (what the machine's other
    load does not change), samples read and solver failures.
    """
    from whiskercal.rig import SensorClient, StageClient
    from whiskercal.twin.devices import simport
    from whiskercal.twin.world import drop_world

    stage_port = simport.Serial(f"sim://{name}/stage?scene=plane&seed={SEED % 1000}", timeout=1.0)
    sensor_port = simport.Serial(f"sim://{name}/sensor", timeout=1.0)
    stage, sensor, world = StageClient(stage_port), SensorClient(sensor_port), sensor_port.world
    chunk = int(SAMPLE_RATE_HZ * 0.02)
    try:
        stage.home()
        sensor.configure(rate_hz=int(SAMPLE_RATE_HZ))
        sensor.start()
        slide_sim = slide_wall = slide_cpu = 0.0
        samples = 0
        wall_start, cpu_start, sim_start = time.perf_counter(), time.process_time(), world.now_s
        for depth in depths_mm:
            points = _plane_waypoints_stage_mm(world, float(depth), travel_mm)
            samples += _move(stage, sensor, points["start"], 40.0, chunk)
            samples += _move(stage, sensor, points["pushed"], 5.0, chunk)
            tick, cpu_tick, sim_tick = time.perf_counter(), time.process_time(), world.now_s
            samples += _move(stage, sensor, points["slid"], STUDY_SPEED_MM_S, chunk)
            slide_wall += time.perf_counter() - tick
            slide_cpu += time.process_time() - cpu_tick
            slide_sim += world.now_s - sim_tick
            samples += _move(stage, sensor, points["end"], 40.0, chunk)
        total_wall, total_sim = time.perf_counter() - wall_start, world.now_s - sim_start
        total_cpu = time.process_time() - cpu_start
        sensor.stop()
    finally:
        stage_port.close()
        sensor_port.close()
        drop_world(name)
    return {"world_slides_simulated_s": slide_sim, "world_slides_wall_s": slide_wall,
            "world_slides_realtime_factor": slide_sim / slide_wall,
            "world_slides_cpu_s": slide_cpu, "world_slides_cpu_factor": slide_sim / slide_cpu,
            "world_total_simulated_s": total_sim, "world_total_wall_s": total_wall,
            "world_total_realtime_factor": total_sim / total_wall,
            "world_total_cpu_s": total_cpu, "world_total_cpu_factor": total_sim / total_cpu,
            "world_samples": samples, "world_solver_failures": world.solver_failures}


def run() -> dict:
    """Every measurement above, in one JSON-able dict (times in ms or s as named)."""
    results = {"first_solve_s": first_solve_s()}
    results.update(cold_solves())
    results.update(warm_rod_path())
    results.update(study_scene())
    results.update(world_study_scene())
    return results


if __name__ == "__main__":  # pragma: no cover
    import json

    print(json.dumps(run(), indent=2))
