"""bench calibration-time: how its per-plan rows judge a plan against the full plan, the
settle after a stop, and one quick session through collect and fit."""

from __future__ import annotations

import math

import numpy as np
import pytest

from whiskercal.bench import calibration_time as bench
from whiskercal.twin.params import DEFAULT_SENSOR


def _session(plan, seed=1, rmse=0.01, held=0.02, estimate=0.01, seconds=50.0, build="b"):
    return {"build": build, "plan": plan, "seed": seed, "points": 40, "points_time_s": seconds,
            "tip_curve_rmse_mm": rmse, "tip_curve_max_mm": 2 * rmse,
            "realistic_held": {"rmse_mm": held}, "estimated_tip_error_mm": estimate,
            "tip_model": "mechanics-yz"}


def _quick_row(*quick_sessions):
    full = [_session("full", seed=1, seconds=370.0), _session("full", seed=2, rmse=0.012,
                                                              seconds=372.0)]
    rows = bench.plan_rows(full + list(quick_sessions))
    return next(r for r in rows if r["plan"] == "quick")


def test_a_plan_within_the_margin_of_the_full_plan_meets_the_goal():
    row = _quick_row(_session("quick", rmse=0.015, estimate=0.015),
                     _session("quick", seed=2, rmse=0.02, estimate=0.02))
    assert row["worst_rmse_mm"] == 0.02 and math.isclose(row["rmse_over_full_mm"], 0.008)
    assert row["meets_goal"] and row["sessions"] == 2


@pytest.mark.parametrize("quick, why", [
    (_session("quick", rmse=0.03, estimate=0.03), "tip curve 0.018 mm over the full plan's"),
    (_session("quick", held=0.04), "realistic contacts 0.02 mm over"),
    (_session("quick", seconds=61.0), "over 60 s of stage time"),
    (_session("quick", rmse=0.02, estimate=0.005), "the truth 4x the estimate"),
    ({"build": "b", "plan": "quick", "seed": 1, "refused": "UsageError: ..."}, "refused"),
])
def test_a_plan_misses_the_goal_on_any_one_bound(quick, why):
    assert not _quick_row(quick)["meets_goal"], why


def test_an_estimate_below_the_truth_within_the_honesty_factor_is_as_honest_as_today():
    row = _quick_row(_session("quick", rmse=0.018, estimate=0.01))
    assert math.isclose(row["worst_truth_over_estimate"], 1.8) and row["as_honest_as_full"]
    # where the full plan's own estimate is further below its truth, that ratio is today's
    full = [_session("full", rmse=0.03, estimate=0.01), _session("quick", rmse=0.025,
                                                                  estimate=0.01)]
    assert [r["as_honest_as_full"] for r in bench.plan_rows(full)] == [True, True]


def test_the_underestimate_counts_only_an_estimate_below_the_truth():
    assert bench.underestimate_mm(_session("quick", rmse=0.02, estimate=0.05)) == 0.0
    assert math.isclose(bench.underestimate_mm(_session("quick", rmse=0.05, estimate=0.02)), 0.03)
    assert bench.underestimate_mm({"refused": "no"}) == math.inf
    # a fit that could not estimate its error is not honest whatever its truth
    unestimated = _session("quick", estimate=math.nan)
    assert bench.underestimate_mm(unestimated) == math.inf
    assert bench.truth_over_estimate(unestimated) == math.inf


@pytest.mark.slow
def test_the_settle_after_a_stop_is_the_averaged_readings_ring_down():
    row = bench.settle_after_stop(DEFAULT_SENSOR, 25.0, samples=30)
    sigma = DEFAULT_SENSOR.magnetometer.noise_uT_rms[1]
    assert math.isclose(row["averaged_noise_uT"], sigma / math.sqrt(30))
    assert 0.0 <= row["settle_s"] < 1.0 and np.isfinite(row["stop_error_uT"])
    # a single sample's noise is a looser bound: it is met no later
    assert bench.settle_after_stop(DEFAULT_SENSOR, 25.0, samples=1)["settle_s"] <= 1.0


@pytest.mark.slow
def test_a_quick_session_on_the_twin_ships_a_finite_tip_model():
    """The quick plan through collect (dynamics on) and fit on a fresh twin session: a model
    ships, its error vs the twin's truth and its estimate are finite, the run's points time is
    the run's own."""
    from whiskercal.bench.sessions import session_row
    from whiskercal.collect.plans import QUICK

    row = session_row(DEFAULT_SENSOR, 3, QUICK, bench.DYNAMICS_MODES)
    assert "refused" not in row, row
    assert math.isfinite(row["tip_curve_rmse_mm"]) and math.isfinite(row["tip_curve_max_mm"])
    assert math.isfinite(row["estimated_tip_error_mm"])
    assert math.isfinite(row["realistic_held"]["rmse_mm"])
    assert 0 < row["points_time_s"] < row["stage_time_s"]
