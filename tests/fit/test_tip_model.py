"""``fit --tip-model``: the mechanics-informed model on the recorded grid, against the twin's truth;
and what ``fit`` ships without options (the tip model ``auto`` chooses and the (Y, Z) table)."""

import json
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from whiskercal.artifacts.calibration import read_calibration
from whiskercal.artifacts.raw_grid import read_raw_grid
from whiskercal.cli import cli
from whiskercal.fit import FitOptions, fit

DATA = Path(__file__).resolve().parents[2] / "data"
RECORDED = DATA / "twin-paper-75mm" / "raw_grid.h5"
SHORT = DATA / "twin-short-60mm" / "raw_grid.h5"


@pytest.fixture(scope="module")
def raw():
    return read_raw_grid(RECORDED)


@pytest.mark.slow
def test_auto_ships_the_mechanics_on_the_default_grid_within_the_goal(raw):
    result = fit(raw, FitOptions(tip_model="auto", field_table=False))
    assert result.metrics["tip_model"] == "mechanics"
    # issue 13's goal on the default sensor: 0.15 mm RMS (the level set gives 0.44 mm)
    assert result.metrics["lookup_vs_truth_rmse_mm"] <= 0.15
    estimate = result.metrics["estimated_tip_error_mm"]
    assert result.metrics["lookup_vs_truth_rmse_mm"] <= estimate <= 0.25
    assert not any("tip error" in w for w in result.warnings)
    low, high = result.metrics["one_to_one_z_uT"]
    assert low < result.calibration.lookup.z_min_uT < result.calibration.lookup.z_max_uT <= high


@pytest.mark.slow
def test_the_level_set_estimates_its_error_and_warns_of_it(raw):
    result = fit(raw, FitOptions(tip_model="level-set", field_table=False))
    assert result.metrics["tip_model"] == "level-set"
    true_rms = result.metrics["lookup_vs_truth_rmse_mm"]
    assert true_rms > 0.3  # the level set's intrinsic error on a frictionless tip contact
    estimate = result.metrics["estimated_tip_error_mm"]
    assert 0.8 * true_rms < estimate < 1.5 * true_rms
    assert any("exceeds 0.25 mm" in w for w in result.warnings)


def test_an_unknown_tip_model_is_one_line(tmp_path):
    result = CliRunner().invoke(cli, ["fit", str(RECORDED), "--out", str(tmp_path / "c.h5"),
                                      "--tip-model", "spline"])
    assert result.exit_code == 2 and "spline" in result.output


@pytest.mark.slow
def test_fit_without_options_ships_the_mechanics_and_the_field_table(tmp_path):
    # the default calibration, end to end through the command (twin-short-60mm: the smaller
    # recorded grid, a 30-40 s fit with the table)
    out = tmp_path / "c.h5"
    result = CliRunner().invoke(cli, ["fit", str(SHORT), "--out", str(out), "--json"])
    assert result.exit_code == 0, result.output
    summary = json.loads(result.stdout)
    assert summary["tip_model"] == "mechanics"  # what auto chose: the grid identifies it
    assert 0 < summary["estimated_tip_error_mm"] <= 0.25
    assert summary["field_table_written"] is True
    assert 0 < summary["field_table_estimated_tip_error_mm"] <= 0.25
    table = read_calibration(out).field_table
    assert table is not None and np.isfinite(table["tip_mm"]).any()
