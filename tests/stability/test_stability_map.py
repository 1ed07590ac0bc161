"""The stability map: each method pushed past its working range, and how the failure shows.

Everything is seeded; each test pins a detection (an exception, a status or an analysis flag)
or, where a method cannot see its own failure, pins that the map reports it as silent.
"""

import json

import numpy as np
import pytest
from click.testing import CliRunner

from whiskercal.bench import stability
from whiskercal.bench.stability_scenes import plane_slip_probe, stiffness_ratio_probe
from whiskercal.testing.twin_grid import calibrate_grid, noisy_z, simulate_grid
from whiskercal.cli import cli


@pytest.fixture(scope="module")
def grid():
    return simulate_grid()


@pytest.fixture(scope="module")
def calibration(grid):
    return calibrate_grid(grid, noisy_z(grid, seed=0))


def _statuses(entries):
    return [e["status"] for e in entries]


def test_z_beyond_the_calibrated_range_raises_in_every_method(calibration, grid):
    result = stability.z_range_probe(calibration, grid.sensor, n=9)
    low, high = result["data_range_uT"]
    for name in ("fast", "paper 1e-2 mm", "lookup"):
        for entry in result[name]["entries"]:
            if not low <= entry["setting"] <= high:
                assert entry["status"] == "ZOutOfRangeError", (name, entry)
    # inside the range every method returns a tip near the twin's truth
    inside = [e for e in result["fast"]["entries"] if e["status"] == "ok"]
    assert len(inside) >= 5
    assert np.median([e["error_vs_truth_mm"] for e in inside]) < 1.0


def test_traces_leaving_the_grid_are_reported_as_domain_exits(calibration, grid):
    result = stability.z_range_probe(calibration, grid.sensor, n=25)
    assert result["fast"]["statuses"].get("DomainExitError", 0) >= 1
    assert result["paper 1e-2 mm"]["statuses"].get("DomainExitError", 0) >= 1


def test_a_ridge_of_zero_gradient_stops_the_trace(grid):
    result = stability.vanishing_gradient_probe(grid, n=5)
    statuses = _statuses(result["entries"])
    assert statuses[0] == "VanishingGradientError"  # z exactly on the ridge
    assert statuses[-1] == "ok"                      # far enough off it the level set is fine


def test_paper_trace_at_a_coarse_step_is_refused_not_silent(calibration, grid):
    # 20 mm steps used to return tips 12 mm off without an error (docs/bench.md); the drift off
    # the level set now gives them away
    result = stability.paper_step_probe(calibration, grid.sensor, (0.1, 3.0, 20.0), n_z=2)
    by_step = {}
    for entry in result["entries"]:
        by_step.setdefault(entry["setting"], []).append(entry)
    assert [e["status"] for e in by_step[0.1]] == ["ok", "ok"]
    assert all(e["status"] == "TraceDriftError" for e in by_step[20.0])
    for entry in result["entries"]:
        if entry["status"] == "ok":
            assert entry["error_vs_reference_mm"] < 0.2  # what passes the drift check is close
    assert result["silent_failures"] == 0
    assert result["detected"] == result["statuses"]["TraceDriftError"] >= 2
    summary = stability._detections(result)
    assert summary["detected_by"]["TraceDriftError"] == result["detected"]
    assert summary["silent"] == 0


def test_a_grid_cut_short_of_the_tip_is_refused(grid):
    # the straight extension past the grid used to bridge the whole gap (reach 60 mm: 2.5 mm
    # RMS, 50 mm: 6.6 mm, silently); now no tip may lie more than 9.5 mm past the grid
    result = stability.domain_probe(grid, (71.75, 60.0, 50.0))
    full, *short = result["entries"]
    assert full["status"] == "ok" and full["error_vs_truth_mm"] < 0.5
    assert [e["status"] for e in short] == ["ExtrapolationLimitError"] * 2
    assert result["silent_failures"] == 0
    assert result["detected"] == 2


def test_noisy_grids_are_reported_by_the_fits_scatter_warning(grid):
    result = stability.noise_probe(grid, (1.0, 300.0))
    quiet, loud = result["entries"]
    assert loud["cv_rmse_uT"] > 5 * quiet["cv_rmse_uT"]
    assert loud["max_error_vs_truth_mm"] > stability.SILENT_LIMIT_MM  # the tips really are off
    assert quiet["status"] == "ok" and quiet["tip_spread_mm"] < 0.1
    assert loud["status"] == "ScatterWarning" and loud["tip_spread_mm"] > 0.5
    assert result["silent_failures"] == 0 and result["detected"] == 1


def test_kalman_survives_degenerate_windows_and_damps_an_outlier():
    cases = {c["case"]: c for c in stability.kalman_probe()}
    assert all(c["finite"] for c in cases.values())
    assert cases["identical tips (singular R)"]["state_error_mm"] < 1e-9
    assert cases["NaN raw tips"]["first_output_none"]
    assert cases["50 mm outlier after 40 tips"]["outlier_pull_mm"] < 0.5
    assert cases["window of 1 (no covariance)"]["status"] == "ModelError"


def test_slip_into_tangential_contact_is_flagged_by_the_study_analysis(calibration, grid):
    result = plane_slip_probe(calibration, grid.sensor, (20.0, 50.0), quick=True)
    shallow, deep = result["entries"]
    assert shallow["true_tangential_fraction"] == 0.0 and not shallow["flagged_tangential"]
    assert deep["true_tangential_fraction"] > 0.5
    assert deep["flagged_tangential"] and deep["failing"]


@pytest.mark.slow
def test_level_set_tip_breaks_down_for_a_stiff_suspension():
    result = stiffness_ratio_probe((1.0, 3.0))
    default, stiff = result["entries"]
    assert default["status"] == "ok" and default["error_vs_truth_mm"] < 1.0
    assert stiff["setting"] == pytest.approx(3 * result["default_ratio"])
    # the fit's own tip-error estimate sees the breakdown: warned, not silent
    assert stiff["status"] == "tip error warned" and not stiff["silent"]
    assert stiff["error_vs_truth_mm"] > 2.0
    assert 0.5 * stiff["error_vs_truth_mm"] < stiff["estimated_tip_error_mm"] \
        < 2 * stiff["error_vs_truth_mm"]
    assert result["valid_ratio_range"] == [default["setting"], default["setting"]]
    limit = result["documented_limit"]
    assert limit["kind"] == "documented limit" and limit["detected_at_runtime"] is True
    assert limit["valid_ratio_range"] == result["valid_ratio_range"]
    assert stiff["documented_limit"] and not default["documented_limit"]


@pytest.mark.slow
def test_bench_only_stability_writes_the_map(tmp_path):
    result = CliRunner().invoke(cli, ["bench", "--quick", "--only", "stability", "--out",
                                      str(tmp_path)], catch_exceptions=False)
    assert result.exit_code == 0, result.output
    payload = json.loads((tmp_path / "stability.json").read_text())
    assert set(payload["probes"]) == {"z_range", "domain", "vanishing_gradient", "paper_step",
                                      "noise", "kalman", "plane_slip", "stiffness_ratio"}
    assert (tmp_path / "stability.png").read_bytes().startswith(b"\x89PNG")
    detections = payload["supports"]["detections"]
    assert detections["paper_step"]["detected_by"] == {"TraceDriftError": 1}
    assert detections["domain"]["detected_by"] == {"ExtrapolationLimitError": 1}
    assert detections["paper_step"]["silent"] == detections["domain"]["silent"] == 0
    limits = payload["supports"]["documented_limits"]
    assert limits["stiffness_ratio"]["detected_at_runtime"] is True
    assert detections["stiffness_ratio"]["silent"] == 0
