"""Calibration sessions through collect (bench.sessions): the builds drawn, and how a session's
row is judged."""

from __future__ import annotations

import math

import numpy as np
import pytest

from whiskercal.bench import sessions
from whiskercal.testing.fields import stiffness_ratio
from whiskercal.twin.params import DEFAULT_SENSOR


def test_builds_are_drawn_over_the_whole_span_and_again_the_same_from_the_seed():
    builds = sessions.draw_builds(30, seed=3)
    assert [b.whisker for b in builds] == [b.whisker for b in sessions.draw_builds(30, seed=3)]
    lengths = np.array([b.whisker.length_mm for b in builds])
    diameters = np.array([b.whisker.diameter_mm for b in builds])
    ratios = np.array([stiffness_ratio(b.whisker) for b in builds])
    assert lengths.min() >= 45.0 and lengths.max() <= 130.0
    assert diameters.min() >= 0.15 and diameters.max() <= 0.40
    # the drawn k_theta*L/EI is kept to the rounding of k_theta (four decimals, N mm/rad)
    assert ratios.min() >= 0.99 and ratios.max() <= 80.5
    # log-uniform: both decades are drawn from
    assert (ratios < 9.0).any() and (ratios > 9.0).any()
    assert len({b.sensor_id for b in builds}) == 30


def _row(build="drawn-00", rmse=0.1, worst=0.3, held=0.2, estimate=0.1, seed=1):
    return {"build": build, "seed": seed, "stiffness_ratio": 5.0, "tip_model": "mechanics-yz",
            "tip_curve_rmse_mm": rmse, "tip_curve_max_mm": worst,
            "realistic_held": {"rmse_mm": held}, "estimated_tip_error_mm": estimate,
            "honest": rmse <= sessions.HONEST_FACTOR * estimate}


@pytest.mark.parametrize("row, meets", [
    (_row(), True),
    (_row(rmse=0.3), False),                       # the tip curve's RMS
    (_row(worst=0.6), False),                      # its max
    (_row(held=0.35), False),                      # realistic contacts held
    (_row(rmse=0.2, estimate=0.05), False),        # an estimate 4x below the truth
    ({"build": "drawn-00", "seed": 1, "refused": "UsageError: ..."}, False),
    (_row(build=DEFAULT_SENSOR.sensor_id, rmse=0.06, estimate=0.06), False),  # the default's 0.05
])
def test_a_session_meets_the_goal_only_within_every_bound_with_an_honest_estimate(row, meets):
    assert sessions.meets_goal(row) is meets


def test_each_build_reports_its_worst_seed_and_spread():
    rows = [_row(seed=1, rmse=0.05), _row(seed=2, rmse=0.2), _row(seed=3, rmse=0.1),
            _row(seed=4, held=0.9),
            {"build": "drawn-01", "seed": 1, "stiffness_ratio": 2.0, "refused": "no"}]
    first, second = sessions.per_build(rows)
    assert first["worst_seed"] == 2 and math.isclose(first["spread_mm"], 0.15)
    assert first["missing_goal"] == [4] and first["sessions"] == 4
    assert second["refused"] == [1] and second["missing_goal"] == [1]
    assert second["worst_rmse_mm"] == math.inf
    # a refusal misses the goal and says so; a calibration shipped off it does not
    assert first["shipped_off_goal"] == [4] and second["shipped_off_goal"] == []
    summary = sessions.summary(rows)
    assert summary["missing_goal"] == ["drawn-00 seed 4", "drawn-01 seed 1"]
    assert summary["shipped_off_goal"] == ["drawn-00 seed 4"]


@pytest.mark.slow
def test_a_session_of_the_default_sensor_ships_the_joint_fit_and_knows_its_error():
    """One fresh session through collect and fit: the suspension is identified (no fall back to
    the level set), and the estimate is not below the truth by more than its honesty factor."""
    row = sessions.session_row(DEFAULT_SENSOR, seed=2)
    assert "refused" not in row, row
    assert row["tip_model"] != "level-set", row["warnings"]
    assert row["honest"], (row["tip_curve_rmse_mm"], row["estimated_tip_error_mm"])
