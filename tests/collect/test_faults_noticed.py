"""Faults a collection survives but must report: frame loss above the limit, nothing touched.

Each runs a small band of the grid on the twin (a few dozen points, seconds).
"""

from __future__ import annotations

import json
import uuid
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from whiskercal.artifacts.raw_grid import read_raw_grid
from whiskercal.cli import cli
from whiskercal.collect.config import load_config
from whiskercal.collect.faults import NothingTouchedError, check_touched, frame_loss_warning
from whiskercal.collect.plan import build_plan
from whiskercal.collect.run import collect
from whiskercal.session import EncoderMismatchError
from whiskercal.errors import ArtifactError, UsageError

from fast_collect import FAST

SMALL = FAST + """[grid]
reach_min_mm = 45.5
reach_max_mm = 52.5
angle_min_near_deg = -40.0
angle_min_far_deg = -42.0
expected_points = 0
"""


def _world_urls(stage_query: str) -> tuple[str, str]:
    name = f"f{uuid.uuid4().hex[:10]}"
    return f"sim://{name}/stage?{stage_query}", f"sim://{name}/sensor"


def _plan(tmp_path: Path, extra: str = ""):
    path = tmp_path / "collect.toml"
    path.write_text(SMALL + extra)
    return build_plan(load_config(path))


def test_frame_loss_above_the_limit_warns_with_both_counts(tmp_path):
    stage, sensor = _world_urls("drop=0.03&corrupt=0.01&seed=5")
    summary = collect(stage, sensor, tmp_path / "raw.h5", _plan(tmp_path))
    assert summary.complete and summary.dropped > 0 and summary.corrupt > 0
    assert summary.frame_loss > 0.01
    assert len(summary.warnings) == 1
    assert "dropped" in summary.warnings[0] and "corrupt" in summary.warnings[0]
    grid = read_raw_grid(tmp_path / "raw.h5")
    assert grid.dropped.sum() > 0 and grid.corrupt.sum() > 0  # kept apart per point
    shown = json.loads(CliRunner().invoke(cli, ["inspect", str(tmp_path / "raw.h5"), "--json"]).output)
    assert shown["frames"]["dropped"] == grid.dropped.sum() > shown["frames"]["corrupt"] > 0


@pytest.mark.slow
def test_frame_loss_below_a_raised_limit_and_a_clean_link_do_not_warn(tmp_path):
    stage, sensor = _world_urls("drop=0.03&corrupt=0.01&seed=5")
    raised = collect(stage, sensor, tmp_path / "a.h5",
                     _plan(tmp_path, "[safety]\nmax_frame_loss = 0.5\n"))
    assert raised.frame_loss > 0.01 and raised.warnings == []
    stage, sensor = _world_urls("seed=5")
    clean = collect(stage, sensor, tmp_path / "b.h5", _plan(tmp_path))
    assert clean.frame_loss == 0.0 and clean.warnings == []


def test_a_grid_over_an_empty_scene_fails_saying_nothing_was_touched(tmp_path):
    stage, sensor = _world_urls("scene=none&seed=2")
    with pytest.raises(NothingTouchedError, match="nothing was touched") as info:
        collect(stage, sensor, tmp_path / "raw.h5", _plan(tmp_path))
    assert len(str(info.value).splitlines()) == 1
    assert len(read_raw_grid(tmp_path / "raw.h5")) > 0  # the file is kept for inspection


def test_the_touch_check_passes_one_deflected_point_and_refuses_pure_noise():
    rng = np.random.default_rng(7)
    noise = rng.normal(0.0, 1.0, 40)
    check_touched(np.append(noise, -300.0), np.full(41, 3.0), "x")
    with pytest.raises(NothingTouchedError):
        check_touched(noise, np.full(40, 3.0), "x")


def test_frame_loss_warning_threshold_is_strict_and_the_limit_is_validated(tmp_path):
    assert frame_loss_warning(990, 5, 5, 0.01) is None  # exactly 1 %
    assert "1.1 %" in frame_loss_warning(989, 6, 5, 0.01)
    path = tmp_path / "bad.toml"
    path.write_text("[safety]\nmax_frame_loss = 2.0\n")
    with pytest.raises(UsageError, match="max_frame_loss"):
        load_config(path)


def test_a_torn_dataset_says_truncated_with_its_journal_and_resumes(tmp_path):
    stage, sensor = _world_urls("seed=4")
    out, plan = tmp_path / "raw.h5", _plan(tmp_path)
    taken = []
    partial = collect(stage, sensor, out, plan, stop_requested=lambda: len(taken) >= 6,
                      on_progress=taken.append)
    assert not partial.complete and partial.points == 6
    data = out.read_bytes()
    out.write_bytes(data[:len(data) // 2])  # a crash mid-write leaves the file cut short
    with pytest.raises(ArtifactError) as info:
        read_raw_grid(out)
    message = str(info.value)
    assert len(message.splitlines()) == 1
    assert f"truncated: {len(data) // 2} of {len(data)} bytes" in message
    assert f"its journal holds 6 of {len(plan)} points" in message and "--resume" in message
    inspected = CliRunner().invoke(cli, ["inspect", str(out)])
    assert inspected.exit_code == ArtifactError.exit_code
    assert inspected.output.count("\n") == 1 and f"journal holds 6 of {len(plan)}" in inspected.output
    stage, sensor = _world_urls("seed=4")
    resumed = collect(stage, sensor, out, plan, resume=True)
    grid = read_raw_grid(out)
    assert resumed.complete and grid.complete and sorted(grid.plan_index) == list(range(len(plan)))


def test_a_torn_dataset_without_journal_says_so(tmp_path, small_twin_grid):
    out = tmp_path / "raw.h5"
    out.write_bytes(small_twin_grid[0].read_bytes()[:5000])  # a complete run's file, torn
    with pytest.raises(ArtifactError, match="truncated: 5000 of .* no collection journal"):
        read_raw_grid(out)


# Simulated times (s) at which 1 mm of steps is lost: with this band of the grid, 50.5 and 53.4
# fall while a point's samples are read (after its encoder check), the others during moves.
MISSED_STEPS_AT_S = (44.7, 50.5, 53.4)


@pytest.mark.slow
def test_missed_steps_never_leave_a_point_away_from_where_the_rod_was(tmp_path):
    plan = _plan(tmp_path)
    during_samples = 0
    for when in MISSED_STEPS_AT_S:
        stage, sensor = _world_urls(f"fault=missed_steps@{when}:1.0")
        out = tmp_path / f"raw{when}.h5"
        with pytest.raises(EncoderMismatchError, match="missed steps") as info:
            collect(stage, sensor, out, plan)
        during_samples += "was sampled" in str(info.value)
        grid = read_raw_grid(out)
        error_mm = np.abs(grid.rod_center_mm - grid.truth["rod_center_mm"]).max()
        assert len(grid) > 0 and error_mm < 0.05, (when, error_mm)  # encoder ±0.02 + backlash
    assert during_samples >= 1  # the case that saved a point 1 mm away is exercised
    collect(stage, sensor, out, plan, resume=True)  # homing clears the alarm; the point re-taken
    grid = read_raw_grid(out)
    assert grid.complete and sorted(grid.plan_index) == list(range(len(plan)))
    assert np.abs(grid.rod_center_mm - grid.truth["rod_center_mm"]).max() < 0.05


def test_the_frame_loss_limit_does_not_stop_a_resume(tmp_path):
    from whiskercal.artifacts.raw_grid import plan_fingerprint

    plan = _plan(tmp_path)
    raised = _plan(tmp_path, "[safety]\nmax_frame_loss = 0.2\n")
    config = plan.config.to_dict()
    older = {**config, "safety": {k: v for k, v in config["safety"].items() if k != "max_frame_loss"}}
    assert plan_fingerprint(plan.stage_mm, config) == plan_fingerprint(raised.stage_mm,
                                                                       raised.config.to_dict())
    assert plan_fingerprint(plan.stage_mm, config) == plan_fingerprint(plan.stage_mm, older)
