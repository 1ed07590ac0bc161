"""A calibration artifact fitted to a grid simulated straight from the twin's physics.

The study judges a calibration against the twin's ground truth; what is under test is the study,
so the calibration is made the fast way: each rod position of the default collect plan goes
through ``mechanics.solve_rod`` (warm-started along each column, as the stage visits them), its
noise-free z gets seeded noise of an averaged reading, and ``model.calibrate`` fits it exactly as
``whiskercal fit`` does. No serial protocol: the study's own tests cover the acquisition.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from whiskercal.artifacts.calibration import data_from_calibration, write_calibration
from whiskercal.model.calibrate import CalibrationOptions, calibrate
from whiskercal.model.collision import CollisionParams
from whiskercal.model.kalman import KalmanParams
from whiskercal.testing.twin_grid import noisy_z, simulate_grid
from whiskercal.twin.params import DEFAULT_SENSOR

ROD_RADIUS_MM = 1.5
AVERAGED_NOISE_UT = 1.0  # 5.6 µT sample noise averaged over ~30 samples per point


def simulated_grid(sensor=DEFAULT_SENSOR, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Rod centres (n, 2) mm and measured z (n,) µT of the default plan on the twin (the
    noise-free grid is ``whiskercal.testing``'s, simulated once per process and sensor)."""
    grid = simulate_grid(sensor, None, ROD_RADIUS_MM)
    return grid.rod_center_mm, noisy_z(grid, AVERAGED_NOISE_UT, seed)


def write_twin_calibration(path: Path, sensor=DEFAULT_SENSOR) -> Path:
    """Fit the simulated grid and write the calibration artifact to ``path``."""
    points, z = simulated_grid(sensor)
    options = CalibrationOptions(trace_length_mm=sensor.whisker.reach_mm)
    calibration = calibrate(points, z, ROD_RADIUS_MM, options)
    data = data_from_calibration(
        calibration, sensor_id=sensor.sensor_id, rod_radius_mm=ROD_RADIUS_MM, tracer=options.tracer,
        kalman=KalmanParams(), collision=CollisionParams(), metrics={},
        inputs={"simulated_grid": "tests/study/twin_calibration.py"}, config={})
    write_calibration(path, data)
    return path


def run_twin_study(folder: Path, config_text: str, world: str, seed: int, sensor: str | None = None):
    """Run a study on a fresh twin plane world through the serial clients; ``sensor``: a
    sensor TOML file for the twin (the default sensor when None).

    Returns the study file, its config and the world (for the ground truth).
    """
    from whiskercal.study.config import load_config
    from whiskercal.artifacts.plane_study import StudyWriter
    from whiskercal.study.run import run_study
    from whiskercal.twin.devices import simport

    (folder / "study.toml").write_text(config_text)
    config = load_config(folder / "study.toml")
    build = "" if sensor is None else f"&sensor={sensor}"
    stage_port = simport.Serial(f"sim://{world}/stage?scene=plane&seed={seed}{build}", timeout=1.0)
    sensor_port = simport.Serial(f"sim://{world}/sensor", timeout=1.0)
    run_study(stage_port, sensor_port, folder / "STUDY.h5", config)
    return folder / "STUDY.h5", config, sensor_port.world
