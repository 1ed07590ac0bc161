"""A build described only in a TOML file: the dataset keeps its description, and the fit finds
its truth by it (no shipped sensor has its id)."""

import json
import uuid

import numpy as np
import pytest

from click.testing import CliRunner

from whiskercal.artifacts.raw_grid import read_raw_grid
from whiskercal.cli import cli
from whiskercal.fit.trace_length import twin_sensor
from whiskercal.twin.params import SENSORS
from whiskercal.twin.sensor_file import load_sensor

from fast_collect import FAST

BUILD = """
sensor_id = "lab-build-82mm"
[whisker]
length_mm = 82.0
diameter_mm = 0.27
"""
CONFIG = FAST + """
[rig]
trace_length_mm = 85.0
whisker_reach_mm = 88.0
[grid]
step_mm = 4.0
reach_min_mm = 40.5
reach_max_mm = 80.5
angle_min_near_deg = -20.0
angle_min_far_deg = -40.0
expected_points = 0
"""


def _collect_on_twin(tmp_path, build_text: str, config_text: str, seed: int):
    """``whiskercal collect`` on a new twin world of the build in ``build_text``; the raw file
    and the build's file."""
    build, config = tmp_path / "build.toml", tmp_path / "collect.toml"
    build.write_text(build_text), config.write_text(config_text)
    name = f"t{uuid.uuid4().hex[:10]}"
    raw_path = tmp_path / "raw.h5"
    result = CliRunner().invoke(cli, [
        "collect", "--stage", f"sim://{name}/stage?sensor={build}&seed={seed}",
        "--sensor", f"sim://{name}/sensor", "--config", str(config), "--out", str(raw_path),
        "--json"])
    assert result.exit_code == 0, result.output
    return raw_path, build


@pytest.mark.slow
def test_a_toml_build_is_recorded_whole_and_its_truth_found_by_fit(tmp_path):
    assert "lab-build-82mm" not in SENSORS
    raw_path, build = _collect_on_twin(tmp_path, BUILD, CONFIG, seed=3)
    raw = read_raw_grid(raw_path)
    assert raw.sensor_id == "lab-build-82mm"
    assert twin_sensor(raw) == load_sensor(build)
    fitted = CliRunner().invoke(cli, ["fit", str(raw_path), "--out", str(tmp_path / "cal.h5"),
                                      "--allow-extrapolation", "--no-field-table",
                                      # its quick grid is not one fit vouches for: asked for
                                      "--tip-model", "mechanics", "--json"])
    assert fitted.exit_code == 0, fitted.output
    summary = json.loads(fitted.stdout)
    # measured against the build's own truth: a finite error, no claim of a perfect one
    assert 0 < summary["lookup_vs_truth_rmse_mm"] < 50


SHORT_BUILD = """
sensor_id = "lab-build-45mm"
[whisker]
length_mm = 45.0
"""
ONLY_THE_TRACE_LENGTH = FAST + """
[rig]
trace_length_mm = 48.0
"""


def test_a_config_giving_only_the_trace_length_collects_a_grid_for_that_build(tmp_path):
    raw = read_raw_grid(_collect_on_twin(tmp_path, SHORT_BUILD, ONLY_THE_TRACE_LENGTH, seed=4)[0])
    reach = np.hypot(*raw.rod_center_mm.T)
    # the band scaled from the default's 22.5..71.75 mm for 78 mm: nothing past the tip
    assert reach.min() >= 22.5 * 48 / 78 - 1e-9 and reach.max() <= 71.75 * 48 / 78 + 1e-9
    touched = raw.truth["kind"] == "shaft"
    assert touched.mean() > 0.9  # every point a shaft contact, none slipped off the tip
    assert np.abs(raw.z_uT).max() < 15000.0
