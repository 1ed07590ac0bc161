"""A small grid collected through whisker_nano.hex on simavr gives what the Python sensor board
gives with the same seed: the same points, z within the sensor noise, no frame lost."""

import uuid

import numpy as np
import pytest

from avr_emulation import emulation_or_skip

from fast_collect import FAST_MOTION
from whiskercal.artifacts.raw_grid import read_raw_grid
from whiskercal.collect.config import load_config
from whiskercal.collect.plan import build_plan
from whiskercal.collect.run import collect

# Short dwell and fast moves as in tests/collect/test_sim.py; the sensor at its 300 Hz default.
SMALL_GRID = FAST_MOTION + """
[grid]
reach_min_mm = 45
reach_max_mm = 52
expected_points = 0
"""


def _collect(tmp_path, plan, sensor_query: str, stage_query: str = ""):
    name = f"avrgrid{uuid.uuid4().hex[:8]}"
    out = tmp_path / f"raw{uuid.uuid4().hex[:6]}.h5"
    sensor = f"sim://{name}/sensor" + (f"?{sensor_query}" if sensor_query else "")
    stage = f"sim://{name}/stage?seed=11" + (f"&{stage_query}" if stage_query else "")
    summary = collect(stage, sensor, out, plan)
    return summary, read_raw_grid(out)


def _plan(tmp_path):
    config_path = tmp_path / "collect.toml"
    config_path.write_text(SMALL_GRID)
    config = load_config(config_path)
    assert config.sensor.rate_hz == 300
    return build_plan(config)


@pytest.mark.slow
def test_small_grid_through_the_emulated_sensor_matches_the_python_board(tmp_path):
    emulation_or_skip("sensor")
    plan = _plan(tmp_path)
    _, python = _collect(tmp_path, plan, "")
    summary, avr = _collect(tmp_path, plan, "firmware=avr")
    assert summary.complete and summary.dropped == 0 and summary.corrupt == 0
    assert len(avr) == len(plan) >= 20
    np.testing.assert_array_equal(avr.plan_index, python.plan_index)
    assert np.abs(avr.z_uT - python.z_uT).max() <= 20.0  # z is already baseline-relative
    # and against the ground truth, as tests/collect/test_sim.py checks the Python board
    assert np.abs(avr.z_uT - avr.truth["z_uT"]).max() <= 20.0


@pytest.mark.slow
def test_small_grid_through_both_emulated_boards_matches_the_python_boards(tmp_path):
    # the acceptance run: stage_stepper.hex homes and moves the carriage, whisker_nano.hex samples
    emulation_or_skip("stage")
    emulation_or_skip("sensor")
    plan = _plan(tmp_path)
    _, python = _collect(tmp_path, plan, "")
    summary, avr = _collect(tmp_path, plan, "firmware=avr", "firmware=avr")
    assert summary.complete and summary.dropped == 0 and summary.corrupt == 0
    np.testing.assert_array_equal(avr.plan_index, python.plan_index)
    assert np.abs(avr.z_uT - python.z_uT).max() <= 20.0
    assert np.abs(avr.z_uT - avr.truth["z_uT"]).max() <= 20.0
    # the encoders (read by the firmware) see the carriage the step counters moved
    np.testing.assert_allclose(avr.rod_center_mm, avr.truth["rod_center_mm"], atol=0.05)
