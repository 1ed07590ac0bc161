"""The acquisition loop against small fakes of the documented client API."""

from __future__ import annotations

import os

import h5py
import numpy as np
import pytest

from collect_fakes import STATIC_Y_UT, FakeSensor, FakeStage, FakeWorld
from whiskercal.artifacts.raw_grid import read_raw_grid
from whiskercal.collect.config import load_config
from whiskercal.collect.journal import journal_path
from whiskercal.collect.plan import build_plan
from whiskercal.rig.overload import OverloadError
from whiskercal.collect.run import collect
from whiskercal.errors import DeviceError, UsageError


def small_plan(**sections):
    """A plan of a dozen or so points (reach 30..35 mm) with short dwells: the loop, quickly
    (the tip sweep off unless asked for: test_tip_sweep.py runs it)."""
    sections.setdefault("sweep", {"enabled": False})
    config = load_config().replace(
        grid={"reach_min_mm": 30.0, "reach_max_mm": 35.0, "expected_points": 0},
        acquisition={"samples_per_point": 6, "settle_s": 0.02, "baseline_samples": 30},
        **sections)
    return build_plan(config)


N_SMALL = len(small_plan())


def run(tmp_path, world=None, plan=None, encoder=True, resume=False, **kwargs):
    world = world or FakeWorld()
    plan = plan or small_plan()
    stage, sensor = FakeStage(world, encoder=encoder), FakeSensor(world)
    summary = collect(None, None, tmp_path / "raw.h5", plan, resume=resume,
                      stage_client=stage, sensor_client=sensor, **kwargs)
    return summary, stage, sensor


def test_full_run_records_every_point_once_with_z_against_truth(tmp_path):
    plan = small_plan()
    summary, stage, sensor = run(tmp_path, plan=plan)
    assert summary.complete and summary.points == len(plan) == N_SMALL
    assert 10 <= N_SMALL <= 20
    grid = read_raw_grid(tmp_path / "raw.h5")
    assert grid.complete and sorted(grid.plan_index) == list(range(len(plan)))
    # the fake's noise-free z at each true position is the truth the measurement must match
    assert grid.truth is not None
    np.testing.assert_allclose(grid.z_uT, grid.truth["z_uT"], atol=4.0)
    assert np.ptp(grid.z_uT) > 1000.0  # the grid really bends the whisker
    np.testing.assert_allclose(grid.rod_center_mm, plan.rod_center_mm, atol=1e-9)
    assert sensor.configured == {"rate_hz": 300, "gain": 5, "res": 2, "osr": 0, "filt": 2}
    assert stage.commands[0] == "$H"
    assert not journal_path(tmp_path / "raw.h5").exists()
    assert summary.stage_time_s > 0 and summary.baseline_drift_uT is not None


def test_every_point_is_approached_moving_in_minus_y(tmp_path):
    summary, stage, _ = run(tmp_path)
    targets = [tuple(map(float, (c.split()[1][1:], c.split()[2][1:])))
               for c in stage.commands if c.startswith("G1")]
    plan_stage = {tuple(p) for p in np.round(small_plan().stage_mm, 3)}
    for before, target in zip(targets, targets[1:]):
        if target in plan_stage:
            assert target[1] < before[1] and target[0] == before[0], (before, target)


def test_drift_is_removed_by_the_before_and_after_baselines(tmp_path):
    world = FakeWorld(drift_uT_per_s=2.0)
    summary, _, _ = run(tmp_path, world=world)
    grid = read_raw_grid(tmp_path / "raw.h5")
    assert summary.baseline_drift_uT > 20.0
    np.testing.assert_allclose(grid.z_uT, grid.truth["z_uT"], atol=5.0)


def test_stock_grbl_stage_uses_commanded_positions(tmp_path):
    run(tmp_path, encoder=False)
    grid = read_raw_grid(tmp_path / "raw.h5")
    assert np.isnan(grid.encoder_mm).all()
    np.testing.assert_allclose(grid.rod_center_mm, small_plan().rod_center_mm)


def test_dropped_and_corrupt_frames_are_counted_per_point(tmp_path):
    world = FakeWorld(bad_frames_every_reads=5)
    summary, _, sensor = run(tmp_path, world=world)
    with h5py.File(tmp_path / "raw.h5") as handle:
        dropped = handle["points/dropped"][()]
        corrupt = handle["points/corrupt"][()]
    bad_reads = sensor.reads // 5
    assert summary.dropped == summary.corrupt == bad_reads > 0
    # reads after the last point (parking, the after-baseline) belong to no point
    assert 0 < dropped.sum() <= bad_reads and corrupt.sum() == dropped.sum()


def test_missed_steps_stop_the_run_with_the_encoder_message(tmp_path):
    world = FakeWorld(missed_steps_after_moves=8)
    with pytest.raises(DeviceError, match="encoder and step positions disagree by 0.80 mm") as info:
        run(tmp_path, world=world)
    assert "points saved" in str(info.value) and "--resume" in str(info.value)
    grid = read_raw_grid(tmp_path / "raw.h5")
    assert 0 < len(grid) < N_SMALL


def test_the_encoder_alarm_stops_the_run_with_the_encoder_message(tmp_path):
    world = FakeWorld(encoder_alarm_after_moves=8)
    with pytest.raises(DeviceError, match=r"disagree at point \d+ \(ALARM:100\)"):
        run(tmp_path, world=world)
    assert len(read_raw_grid(tmp_path / "raw.h5")) > 0


def test_overload_guard_backs_off_and_keeps_points(tmp_path):
    plan = small_plan(safety={"overload_z_uT": 7500.0, "on_overload": "stop"})
    with pytest.raises(OverloadError, match="over the safe limit of 7500 µT") as info:
        _, stage, _ = run(tmp_path, plan=plan)
    grid = read_raw_grid(tmp_path / "raw.h5")
    assert np.all(np.abs(grid.z_uT) < 7500.0) and len(grid) > 0
    assert "points saved" in str(info.value)


def test_overload_guard_lifts_the_rod_above_the_whisker(tmp_path):
    world = FakeWorld()
    plan = small_plan(safety={"overload_z_uT": 7500.0, "on_overload": "stop"})
    stage, sensor = FakeStage(world), FakeSensor(world)
    with pytest.raises(OverloadError):
        collect(None, None, tmp_path / "raw.h5", plan, stage_client=stage, sensor_client=sensor)
    assert plan.to_whisker(stage.true_mm)[1] >= plan.config.approach.safe_y_mm - 1e-9
    assert world.z_uT(stage.true_mm) == 0.0


def test_by_default_an_overload_ends_its_column_and_the_run_goes_on(tmp_path):
    plan = small_plan(safety={"overload_z_uT": 7500.0})
    summary, stage, _ = run(tmp_path, plan=plan)
    grid = read_raw_grid(tmp_path / "raw.h5")
    assert grid.complete and 0 < summary.beyond_guard < len(plan)
    assert len(grid) + summary.beyond_guard == len(plan)
    assert np.all(np.abs(grid.z_uT) < 7500.0)
    assert any("beyond the overload guard" in w for w in summary.warnings)
    # what was skipped is the deep end of columns: above every skipped point of a column, the
    # points taken; below the first skipped one, none
    taken = set(grid.plan_index.tolist())
    points = plan.rod_center_mm
    for index in set(range(len(plan))) - taken:
        below = np.isclose(points[:, 0], points[index, 0]) & (points[:, 1] < points[index, 1])
        assert not (set(np.flatnonzero(below).tolist()) & taken)


def test_disconnect_saves_points_and_resume_completes_each_once(tmp_path):
    world = FakeWorld(disconnect_after_reads=1000)
    with pytest.raises(DeviceError, match="disconnected"):
        run(tmp_path, world=world)
    partial = read_raw_grid(tmp_path / "raw.h5")
    assert 0 < len(partial) < N_SMALL
    world.disconnect_after_reads = None
    summary, _, _ = run(tmp_path, world=world, resume=True)
    grid = read_raw_grid(tmp_path / "raw.h5")
    assert summary.complete and summary.taken_this_run == N_SMALL - len(partial)
    assert sorted(grid.plan_index) == list(range(N_SMALL))
    np.testing.assert_array_equal(grid.plan_index[:len(partial)], partial.plan_index)
    assert np.all(np.diff(grid.t_mid_s) > 0)  # device time continues across the resume
    np.testing.assert_allclose(grid.z_uT, grid.truth["z_uT"], atol=4.0)


def test_stop_request_ends_after_the_current_point_and_resumes(tmp_path):
    calls = {"n": 0}

    def stop_after_three():
        calls["n"] += 1
        return calls["n"] >= 3

    summary, _, _ = run(tmp_path, stop_requested=stop_after_three)
    assert summary.stopped and not summary.complete and summary.points == 3
    assert len(read_raw_grid(tmp_path / "raw.h5")) == 3
    summary, _, _ = run(tmp_path, resume=True)
    assert summary.complete and summary.points == N_SMALL and summary.taken_this_run == N_SMALL - 3


def test_an_existing_output_is_not_overwritten(tmp_path):
    run(tmp_path)
    with pytest.raises(UsageError, match="already exists"):
        run(tmp_path)
    with pytest.raises(UsageError, match="already complete"):
        run(tmp_path, resume=True)


def test_force_replaces_a_finished_dataset_whole_and_never_a_partial_run(tmp_path):
    out = tmp_path / "raw.h5"
    run(tmp_path)
    before = out.read_bytes()
    keep = tmp_path / "kept.h5"
    os.link(out, keep)  # a name sharing the old file keeps the old bytes
    summary, _, _ = run(tmp_path, force=True)
    assert summary.complete and summary.points == N_SMALL
    assert read_raw_grid(out).complete and keep.read_bytes() == before
    assert os.stat(out).st_ino != os.stat(keep).st_ino  # a new file, not the old one rewritten
    assert sorted(p.name for p in tmp_path.iterdir()) == ["kept.h5", "raw.h5"]  # no scratch left
    with pytest.raises(UsageError, match="--resume continues .* give one"):
        run(tmp_path, resume=True, force=True)
    calls = {"n": 0}

    def stop_after_two():
        calls["n"] += 1
        return calls["n"] >= 2

    out.unlink()
    assert run(tmp_path, stop_requested=stop_after_two)[0].stopped
    partial = out.read_bytes()
    with pytest.raises(UsageError, match="interrupted run .* continue it with --resume"):
        run(tmp_path, force=True)
    journal_path(out).unlink()  # its journal gone, the file alone is still a partial run
    with pytest.raises(UsageError, match="partial raw dataset: continue it with --resume"):
        run(tmp_path, force=True)
    assert out.read_bytes() == partial


def test_a_journal_alone_is_named_as_an_interrupted_run(tmp_path):
    # a run killed before its HDF5 file was written leaves only the journal
    journal_path(tmp_path / "raw.h5").write_bytes(b"")
    with pytest.raises(UsageError) as refused:
        run(tmp_path)
    message = str(refused.value)
    assert "already exists" not in message
    assert "journal of an interrupted run" in message
    assert "--resume" in message and "delete the journal to discard it" in message


def test_an_unhomed_stage_is_refused_when_homing_is_off(tmp_path):
    plan = small_plan(motion={"home": False})
    with pytest.raises(DeviceError, match="not homed"):
        run(tmp_path, plan=plan)


def test_static_reading_is_the_fake_offset(tmp_path):
    run(tmp_path)
    grid = read_raw_grid(tmp_path / "raw.h5")
    assert abs(grid.baseline_before_uT[1] - STATIC_Y_UT) < 2.0


def test_an_output_in_a_missing_directory_is_one_clear_error(tmp_path):
    with pytest.raises(UsageError, match="no such directory"):
        run(tmp_path / "missing")


def test_the_step_count_places_the_rod_where_the_encoder_agrees_else_the_encoder():
    from whiskercal.collect.loop import STEP_COUNT_AGREES_MM, rod_position_mm

    step = np.array([10.0125, 5.0])
    within = step + [0.5 * STEP_COUNT_AGREES_MM, -0.5 * STEP_COUNT_AGREES_MM]
    np.testing.assert_array_equal(rod_position_mm(step, within), step)
    slipped = step + [0.0, 3.0 * STEP_COUNT_AGREES_MM]  # lost steps the encoder saw
    np.testing.assert_array_equal(rod_position_mm(step, slipped), slipped)
    np.testing.assert_array_equal(rod_position_mm(step, [np.nan, np.nan]), step)  # no encoder
