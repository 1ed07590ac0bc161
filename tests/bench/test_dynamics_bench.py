"""``bench --only dynamics``: the release's ring-down against the first mode's envelope, the
slide's error against its speed and start, the quick form's JSON and chart."""

import json
import math

import numpy as np
import pytest
from click.testing import CliRunner

from whiskercal.bench import dynamics
from whiskercal.cli import cli
from whiskercal.twin.params import DEFAULT_SENSOR
from whiskercal.twin.physics.dynamics import modes


def test_a_trapezoid_ends_where_it_should_and_an_abrupt_move_runs_at_its_speed():
    times = np.linspace(0.0, 3.0, 3001)
    for distance, speed, accel in ((10.0, 5.0, 200.0), (0.01, 50.0, 200.0), (10.0, 5.0, math.inf)):
        x, end = dynamics.travelled_mm(times, distance, speed, accel)
        assert x[-1] == pytest.approx(distance) and np.all(np.diff(x) >= -1e-12)
        assert np.max(np.diff(x) / np.diff(times)) <= speed * (1 + 1e-9)
    x, end = dynamics.travelled_mm(times, 10.0, 5.0, math.inf)
    assert end == pytest.approx(2.0) and x[1000] == pytest.approx(5.0)


def test_the_release_rings_down_within_the_first_modes_envelope():
    found = modes(DEFAULT_SENSOR.whisker, 2)
    release = dynamics.release(DEFAULT_SENSOR, found)
    assert release["held_kind"] != "free" and abs(release["held_z_uT"]) > 100 * release["noise_uT"]
    assert 0.8 * release["envelope_s"] < release["ring_down_s"] < 1.1 * release["envelope_s"]


def test_a_slide_started_at_once_errs_in_proportion_to_its_speed_and_less_when_it_accelerates():
    found = modes(DEFAULT_SENSOR.whisker, 2)
    path = dynamics.slide_path(DEFAULT_SENSOR.whisker)
    slow, fast = (dynamics.slide(DEFAULT_SENSOR, found, path, v) for v in (2.0, 10.0))
    assert 4.0 < fast["max_error_uT"] / slow["max_error_uT"] < 6.0
    gentle = dynamics.slide(DEFAULT_SENSOR, found, path, 10.0, dynamics.STAGE_ACCEL_MM_S2)
    assert gentle["max_error_uT"] < 0.5 * fast["max_error_uT"]


@pytest.mark.slow
def test_the_quick_bench_writes_its_rows_and_chart(tmp_path):
    result = CliRunner().invoke(cli, ["bench", "--quick", "--only", "dynamics", "--out",
                                      str(tmp_path), "--json"], catch_exceptions=False)
    assert result.exit_code == 0, result.output
    found = json.loads((tmp_path / "dynamics.json").read_text())
    assert [row["build"] for row in found["rows"]] == ["twin-paper-75mm", "twin-short-60mm"]
    for row in found["rows"]:
        assert row["first_mode_hz"] < row["second_mode_hz"] and row["ring_down_s"] > 0
        assert set(row["error_uT"]) == set(dynamics.STARTS)
    assert (tmp_path / "dynamics.png").read_bytes().startswith(b"\x89PNG")
