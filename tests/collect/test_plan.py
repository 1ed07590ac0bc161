"""Grid plans, frames, path and time estimates, configuration loading."""

from __future__ import annotations

import numpy as np
import pytest

from whiskercal.collect.config import load_config
from whiskercal.collect.estimate import limit_problems, plan_summary, trapezoid_time_s
from whiskercal.collect.plan import angle_floor_deg, build_plan, stage_to_whisker, whisker_to_stage
from whiskercal.errors import UsageError


@pytest.fixture(scope="module")
def plan():
    return build_plan(load_config())


def test_default_plan_is_180_lattice_points_inside_both_bands(plan):
    grid = plan.config.grid
    points = plan.rod_center_mm[:plan.sweep_from]  # the tip sweep follows (test_tip_sweep.py)
    assert len(points) == 180 and len(np.unique(points, axis=0)) == 180
    np.testing.assert_allclose(points / 3.0, np.round(points / 3.0), atol=1e-12)
    reach = np.hypot(*points.T)
    angle = np.degrees(np.arctan2(points[:, 1], points[:, 0]))
    assert reach.min() >= grid.reach_min_mm and reach.max() <= grid.reach_max_mm
    assert np.all(angle >= angle_floor_deg(grid, reach)) and angle.max() <= grid.angle_max_deg
    # one side of the whisker's forward direction: never to its left
    assert np.all(points[:, 1] <= 0.0)


def test_band_edges_are_clear_of_lattice_points(plan):
    """No lattice point sits within rounding of a band edge, so the count is robust."""
    grid = plan.config.grid
    steps = np.arange(-30, 31) * 3.0
    x, y = (a.ravel() for a in np.meshgrid(steps, steps))
    reach, angle = np.hypot(x, y), np.degrees(np.arctan2(y, x))
    assert np.min(np.abs(reach - grid.reach_min_mm)) > 0.15
    assert np.min(np.abs(reach - grid.reach_max_mm)) > 0.15
    in_reach = (reach >= grid.reach_min_mm) & (reach <= grid.reach_max_mm)
    assert np.min(np.abs(angle - angle_floor_deg(grid, reach))[in_reach]) > 0.3


def test_angle_floor_tapers_from_near_to_far(plan):
    grid = plan.config.grid
    floor = angle_floor_deg(grid, [grid.reach_min_mm, grid.reach_max_mm])
    np.testing.assert_allclose(floor, [grid.angle_min_near_deg, grid.angle_min_far_deg])


def test_points_go_column_by_column_each_descending(plan):
    x, y = plan.rod_center_mm[:plan.sweep_from].T
    assert np.all(np.diff(x) >= 0)
    same_column = np.diff(x) == 0
    assert np.all(np.diff(y)[same_column] < 0)


def test_path_approaches_every_point_in_minus_y_and_crosses_above_the_whisker(plan):
    moves = plan.path()
    targets = {tuple(p) for p in plan.rod_center_mm}
    arrivals = [m for m in moves if tuple(m.end_mm) in targets]
    assert len(arrivals) == len(plan) == 208
    for move in arrivals:
        assert move.start_mm[0] == move.end_mm[0] and move.start_mm[1] > move.end_mm[1]
        assert move.purpose == "approach"
    safe_y = plan.config.approach.safe_y_mm
    sweep = {tuple(p) for p in plan.rod_center_mm[plan.sweep_from:]}
    clear_x = plan.config.rig.whisker_reach_mm + plan.config.rig.rod_radius_mm
    for move in moves:
        if tuple(move.start_mm) in sweep and move.end_mm[0] == clear_x:
            continue  # leaving a tip-sweep point outward past the tip, below it
        if move.start_mm[0] != move.end_mm[0]:  # crossing in x: rod above the whisker
            assert move.start_mm[1] == move.end_mm[1] >= safe_y
    # column changes all finish moving in +x (backlash taken up the same way)
    finals = [m for m in moves if m.end_mm[0] != m.start_mm[0] and tuple(m.end_mm) not in targets]
    assert all(m.end_mm[0] > m.start_mm[0] for m in finals if m.end_mm[0] in plan.rod_center_mm[:, 0])


def test_frames_round_trip_and_rotate():
    points = np.array([[10.0, -3.0], [63.0, -42.0]])
    stage = whisker_to_stage(points, (60.0, 120.0), 90.0)
    np.testing.assert_allclose(stage[0], [63.0, 130.0])
    np.testing.assert_allclose(stage_to_whisker(stage, (60.0, 120.0), 90.0), points)


def test_trapezoid_time_matches_the_profile():
    # 10 mm at 600 mm/min (10 mm/s), 200 mm/s²: ramps 0.05 s each over 0.25 mm each
    assert trapezoid_time_s(10.0, 600.0, 200.0) == pytest.approx(0.05 * 2 + 9.5 / 10.0)
    # 0.1 mm never reaches the feed: triangle, 2 sqrt(d / a)
    assert trapezoid_time_s(0.1, 600.0, 200.0) == pytest.approx(2 * np.sqrt(0.1 / 200.0))
    assert trapezoid_time_s(0.0, 600.0, 200.0) == 0.0


def test_summary_counts_dwell_and_moves(plan):
    summary = plan_summary(plan)
    acq = plan.config.acquisition
    dwell = len(plan) * (acq.settle_s + acq.samples_per_point / 300) + 2 * (acq.settle_s + acq.baseline_samples / 300)
    assert summary["estimated_stage_time_s"] == pytest.approx(summary["estimated_move_time_s"] + dwell)
    assert summary["limits_ok"]
    half = plan_summary(plan, start_index=90)
    assert half["points_to_take"] == len(plan) - 90 and half["estimated_stage_time_s"] < summary["estimated_stage_time_s"]


def test_limits_catch_a_small_travel(plan):
    problems = limit_problems(plan, (100.0, 100.0), 1.0)
    assert problems and "outside the travel" in problems[0]


def test_bands_that_give_another_count_are_refused():
    config = load_config().replace(grid={"reach_max_mm": 50.5})
    with pytest.raises(UsageError, match=r"give \d+ points, not the expected 180"):
        build_plan(config)


def test_config_refuses_wrong_types_and_bad_values(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("[acquisition]\nsamples_per_point = 2.5\n")
    with pytest.raises(UsageError, match=r"\[acquisition\] samples_per_point: must be an integer >= 1, not 2.5$"):
        load_config(bad)
    with pytest.raises(UsageError, match="safe_y_mm must exceed the rod radius"):
        load_config().replace(approach={"safe_y_mm": 1.0})
    with pytest.raises(UsageError, match="no such config file"):
        load_config(tmp_path / "missing.toml")
