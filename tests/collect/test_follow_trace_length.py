"""Defaults that follow the build: the collect grid and the study's depths from the trace length."""

import pytest

from whiskercal.collect.config import load_config
from whiskercal.collect.plan import build_plan
from whiskercal.study.config import load_config as load_study_config


def _collect(tmp_path, text):
    path = tmp_path / "collect.toml"
    path.write_text(text)
    return load_config(path)


def test_the_default_build_keeps_the_papers_180_points(tmp_path):
    config = _collect(tmp_path, "[rig]\ntrace_length_mm = 78.0\n")
    assert build_plan(config).sweep_from == 180 and config.grid.reach_max_mm == 71.75


@pytest.mark.parametrize("length_mm", [48.0, 63.0, 123.0])
def test_another_trace_length_scales_the_reach_band_and_the_clear_reach(tmp_path, length_mm):
    config = _collect(tmp_path, f"[rig]\ntrace_length_mm = {length_mm}\n")
    factor = length_mm / 78.0
    assert config.grid.reach_min_mm == pytest.approx(22.5 * factor, abs=0.01)
    assert config.grid.reach_max_mm == pytest.approx(71.75 * factor, abs=0.01)
    assert config.grid.reach_max_mm < length_mm - 3.0  # the rod never slips off the tip
    assert config.rig.whisker_reach_mm == length_mm + 2.0
    assert config.grid.expected_points == 0 and len(build_plan(config)) > 40


def test_keys_the_file_gives_win_over_the_scaled_ones(tmp_path):
    config = _collect(tmp_path, "[rig]\ntrace_length_mm = 63.0\nwhisker_reach_mm = 70.0\n"
                                "[grid]\nreach_max_mm = 50.0\n")
    assert config.rig.whisker_reach_mm == 70.0 and config.grid.reach_max_mm == 50.0
    assert config.grid.reach_min_mm == pytest.approx(22.5 * 63 / 78, abs=0.01)


def test_the_study_depths_and_slide_follow_the_tip_reach(tmp_path):
    path = tmp_path / "study.toml"
    path.write_text("[geometry]\ntip_reach_mm = 48.0\n")
    trials = load_study_config(path)["trials"]
    assert trials["depths_mm"][0] == 3.0 and trials["depths_mm"][-1] == 27.5
    assert len(trials["depths_mm"]) == 9
    assert trials["slide_start_mm"] == -trials["travel_mm"] / 2 == pytest.approx(-24.6)
    path.write_text("[geometry]\ntip_reach_mm = 48.0\n[trials]\ndepths_mm = [4.0, 8.0]\n")
    assert load_study_config(path)["trials"]["depths_mm"] == [4.0, 8.0]
