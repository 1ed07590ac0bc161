"""The tip-accuracy bench's pure parts: the chart keys, the per-method goal summary, the lookup
timings and the run's assembly (``measure_build`` replaced: no grid simulated)."""

import numpy as np
import pytest

from whiskercal.bench import tip_accuracy


def _row(build, method, rmse_mm=0.1, max_mm=0.3, coverage=1.0, realistic_mm=0.2):
    return {"build": build, "method": method,
            "tip_curve": {"rmse_mm": rmse_mm, "max_mm": max_mm, "coverage": coverage},
            "realistic_rmse_mm": realistic_mm}


def test_the_summary_counts_only_builds_meeting_every_part_of_the_goal():
    rows = [_row("a", "level-set"), _row("b", "level-set", rmse_mm=0.26),
            _row("c", "level-set", max_mm=0.51), _row("d", "level-set", coverage=0.94),
            _row("e", "level-set", realistic_mm=0.31),
            {"build": "f", "method": "level-set", "error": "UsageError: no fit"},
            _row("a", "magnet-yz", realistic_mm=0.1)]
    summary = tip_accuracy._summary(rows)
    assert set(summary) == set(tip_accuracy.CANDIDATES)
    assert summary["level-set"] == {"builds": 6, "meeting_tip_goal": ["a", "e"],
                                    "meeting_realistic_goal": ["a", "b", "c", "d"]}
    assert summary["magnet-yz"]["meeting_realistic_goal"] == ["a"]
    assert summary["mechanics-y"] == {"builds": 0, "meeting_tip_goal": [],
                                      "meeting_realistic_goal": []}


def test_chart_keys_chart_the_table_where_a_candidate_has_one():
    with_table = {"build": "b", "tip_curve": {"rmse_mm": 0.2}, "lookup_s": 1e-6, "table_s": 3e-6,
                  "realistic": {"y_only": {"rmse_mm": 0.5},
                                "y_and_z_sample_noise": {"rmse_mm": 0.25}}}
    tip_accuracy._chart_keys(with_table)
    assert (with_table["error_vs_truth_mm"], with_table["realistic_rmse_mm"],
            with_table["runtime_s"], with_table["label"]) == (0.2, 0.25, 3e-6, "b")
    lookup_only = {"build": "c", "tip_curve": {"rmse_mm": 0.3}, "lookup_s": 1e-6,
                   "realistic": {"y_only": {"rmse_mm": 0.5}}}
    tip_accuracy._chart_keys(lookup_only)
    assert (lookup_only["realistic_rmse_mm"], lookup_only["runtime_s"]) == (0.5, 1e-6)


class _Lookup:
    z_min_uT, z_max_uT = -1000.0, -200.0

    def __init__(self):
        self.asked = []

    def tip_scalar(self, *args):
        self.asked.append(args)
        return np.zeros(2)


def test_speeds_time_the_lookup_mid_range_and_the_table_at_its_mean():
    lookup, table = _Lookup(), _Lookup()
    table.y_uT, table.z_uT = np.array([-100.0, 300.0]), np.array([-800.0, -400.0])
    speeds = tip_accuracy._speeds({"lookup": lookup, "table": table})
    assert set(speeds) == {"lookup_s", "table_s"} and all(v > 0 for v in speeds.values())
    assert set(lookup.asked) == {(-600.0,)} and set(table.asked) == {(100.0, -600.0)}
    assert set(tip_accuracy._speeds({"lookup": _Lookup()})) == {"lookup_s"}


def test_the_quick_run_measures_the_default_build_and_charts_only_fitted_rows(monkeypatch):
    asked = []

    def measure_build(sensor, candidates, seed, say):
        asked.append((sensor.sensor_id, candidates, seed))
        fitted = _row(sensor.sensor_id, "level-set") | {
            "lookup_s": 1e-6, "realistic": {"y_only": {"rmse_mm": 0.2}}}
        return [fitted, {"build": sensor.sensor_id, "method": "magnet-yz", "error": "UsageError: no fit"}]

    monkeypatch.setattr(tip_accuracy, "measure_build", measure_build)
    monkeypatch.setattr(tip_accuracy, "machine_info", lambda: {})
    result = tip_accuracy.run(quick=True, seed=7)
    assert asked == [(tip_accuracy.DEFAULT_SENSOR.sensor_id,
                      ("level-set", "mechanics-y", "magnet-yz"), 7)]
    fitted, failed = result["rows"]
    assert fitted["error_vs_truth_mm"] == 0.1 and "error_vs_truth_mm" not in failed
    assert result["supports"]["level-set"]["meeting_tip_goal"] == [fitted["build"]]
    assert result["setup"]["builds"] == [tip_accuracy.DEFAULT_SENSOR.sensor_id]
    for key in ("pareto", "pareto_realistic", "pareto_lookup"):
        assert result[key]["series"] == ["method"]

