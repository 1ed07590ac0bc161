"""Named collection plans: the full plan is the defaults, quick is a layer the user's file
still overrides, scaled with the build; the points time adds up; a bad name is one line."""

from __future__ import annotations

import json
import uuid

import numpy as np
import pytest
from click.testing import CliRunner

from whiskercal.cli import cli
from whiskercal.collect.config import load_config
from whiskercal.collect.estimate import plan_summary, points_time_s
from whiskercal.collect.plan import build_plan
from whiskercal.collect.plans import PLANS, QUICK, named_plan
from whiskercal.collect.run import collect
from whiskercal.errors import UsageError

from fast_collect import FAST, SMALL_BAND


def _file(tmp_path, text: str, name: str = "collect.toml"):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_the_full_plan_is_the_defaults_unchanged():
    assert load_config(plan="full") == load_config()
    assert len(build_plan(load_config(plan="full"))) == 208


def test_quick_sets_its_lattice_sweep_settle_and_feeds():
    config = load_config(plan="quick")
    assert config.grid.step_mm == QUICK.step_mm and config.grid.expected_points == 0
    assert config.sweep.angles == QUICK.sweep_angles
    assert tuple(config.sweep.offsets_mm) == QUICK.sweep_offsets_mm
    assert config.sweep.angle_last_deg == QUICK.sweep_angle_last_deg
    assert config.acquisition.settle_s == QUICK.settle_s
    assert config.motion.approach_feed_mm_min == QUICK.approach_feed_mm_min
    # what the plan leaves alone stays the default's
    default = load_config()
    assert config.grid.reach_max_mm == default.grid.reach_max_mm
    assert config.acquisition.samples_per_point == default.acquisition.samples_per_point
    plan = build_plan(config)
    assert plan.sweep_count == QUICK.sweep_angles and len(plan) < len(build_plan(default)) / 4


def test_quick_scales_with_the_trace_length_as_the_bands_do(tmp_path):
    short = load_config(_file(tmp_path, "[rig]\ntrace_length_mm = 63.0\n"), "quick")
    long = load_config(_file(tmp_path, "[rig]\ntrace_length_mm = 113.0\n", "long.toml"), "quick")
    assert short.grid.step_mm == pytest.approx(QUICK.step_mm * 63.0 / 78.0, abs=1e-3)
    assert long.grid.step_mm == pytest.approx(QUICK.step_mm * 113.0 / 78.0, abs=1e-3)
    # the same lattice scaled: the same points but for rounding at the bands' edges
    counts = [build_plan(c).sweep_from for c in (short, load_config(plan="quick"), long)]
    assert max(counts) - min(counts) <= 2, counts


def test_a_users_file_overrides_the_plan(tmp_path):
    config = load_config(_file(tmp_path, "[acquisition]\nsettle_s = 0.25\n"), "quick")
    assert config.acquisition.settle_s == 0.25 and config.grid.step_mm == QUICK.step_mm


def test_an_unknown_plan_is_refused_naming_the_plans():
    with pytest.raises(UsageError, match=r"unknown plan 'nonsense'; choose from full, quick"):
        load_config(plan="nonsense")
    assert named_plan("quick") is QUICK and set(PLANS) == {"full", "quick"}


def test_points_time_counts_each_points_settle_once():
    config = load_config(plan="quick")
    plan = build_plan(config)
    longer = build_plan(config.replace(acquisition={"settle_s": config.acquisition.settle_s + 0.5}))
    assert points_time_s(longer) - points_time_s(plan) == pytest.approx(0.5 * len(plan))
    summary = plan_summary(plan)
    # the baselines, the homing move and the way back to the park position are left out
    assert 0 < summary["estimated_points_time_s"] < summary["estimated_stage_time_s"]
    assert points_time_s(plan, start_index=len(plan)) == 0.0


def test_dry_run_names_the_plan_and_its_points_time():
    result = CliRunner().invoke(cli, ["collect", "--dry-run", "--json", "--plan", "quick"],
                                catch_exceptions=False)
    assert result.exit_code == 0, result.output
    summary = json.loads(result.output)
    assert summary["points"] == len(build_plan(load_config(plan="quick")))
    assert summary["estimated_points_time_s"] == pytest.approx(
        points_time_s(build_plan(load_config(plan="quick"))))


def test_a_run_reports_its_points_time_on_the_sensor_clock(tmp_path):
    from whiskercal.artifacts.raw_grid import read_raw_grid

    name = f"p{uuid.uuid4().hex[:10]}"
    out = tmp_path / "raw.h5"
    # a handful of points of the small band
    band = SMALL_BAND.replace("reach_max_mm = 56.5", "reach_max_mm = 48.5")
    plan = build_plan(load_config(_file(tmp_path, FAST + band)))
    assert 2 <= len(plan) <= 15
    summary = collect(f"sim://{name}/stage", f"sim://{name}/sensor", out, plan)
    grid = read_raw_grid(out)
    assert summary.complete and summary.points == len(plan)
    # from the rod leaving the baseline: longer than the points' own span, shorter than the
    # session (homing and both baselines in it)
    span = float(np.max(grid.t_end_s) - np.min(grid.t_start_s))
    assert span < summary.points_time_s < summary.stage_time_s
