"""The run loop's logic against fake clients: search, trials, checkpoint and resume, safety."""

import numpy as np
import pytest

from whiskercal.artifacts.plane_study import PHASE_SLIDE, StudyWriter, read_study
from whiskercal.errors import DeviceError, UsageError
from whiskercal.study.config import PlaneGeometry
from whiskercal.rig.overload import OverloadError
from whiskercal.study.run import NoContactError

from study_fakes import fake_config as _config, fake_rig, run_on_clients


def _run(tmp_path, config, resume=False, force=False, **rig_options):
    rig, stage, sensor = fake_rig(config, **rig_options)
    writer = StudyWriter(tmp_path / "study.h5", config, "fake-sensor", resume=resume, force=force)
    return rig, run_on_clients(stage, sensor, config, writer)


def test_every_trial_is_recorded_at_its_depth(tmp_path):
    config = _config(tmp_path)
    rig, summary = _run(tmp_path, config)
    assert summary.complete and summary.trials_done == [5.0, 10.0, 15.0]
    study = read_study(tmp_path / "study.h5")
    geometry = PlaneGeometry.from_config(config)
    contact = study.header["first_contact_stage_mm"]
    # the fake's z passes -300 µT 1.2 mm past the true contact (the search steps 0.5 mm): depth 0
    # is where z leaves zero, not that step
    depth_at_contact = geometry.depth_of_stage_mm(contact, geometry.contact_guess_stage_mm())[0]
    assert abs(depth_at_contact) < 0.05
    for trial in study.trials:
        slide = trial.stream["phase"] == PHASE_SLIDE
        z = trial.stream["field_uT"][slide, 1] - study.header["baseline_field_uT"][1]
        expected = -250.0 * (trial.depth_mm + depth_at_contact)
        assert np.median(z) == pytest.approx(expected, abs=3.0)
        # the slide covers the configured travel along the plane
        positions = trial.stage["enc_mm"][trial.stage["phase"] == PHASE_SLIDE]
        assert np.linalg.norm(positions[-1] - positions[0]) == pytest.approx(10.0, abs=0.5)


def test_resume_does_only_the_missing_trials(tmp_path):
    config = _config(tmp_path)
    with pytest.raises(DeviceError, match="vanished"):
        _run(tmp_path, config, fail_after_s=18.0)
    done_before = read_study(tmp_path / "study.h5")
    assert 0 < len(done_before.trials) < 3 and not done_before.complete
    _, summary = _run(tmp_path, config, resume=True)
    assert summary.trials_skipped == [t.depth_mm for t in done_before.trials]
    study = read_study(tmp_path / "study.h5")
    assert study.complete and [t.depth_mm for t in study.trials] == [5.0, 10.0, 15.0]
    assert study.missing_depths() == []


def test_resume_with_another_config_is_refused(tmp_path):
    config = _config(tmp_path)
    _run(tmp_path, config)
    other = _config(tmp_path, "[safety]\noverload_uT = 9000.0\n")
    with pytest.raises(UsageError, match="another configuration"):
        StudyWriter(tmp_path / "study.h5", other, "fake-sensor", resume=True)
    with pytest.raises(UsageError, match="already exists: pass --force to replace it, or --resume"):
        StudyWriter(tmp_path / "study.h5", config, "fake-sensor")
    with pytest.raises(UsageError, match="nothing to resume"):
        StudyWriter(tmp_path / "other.h5", config, "fake-sensor", resume=True)


def test_force_replaces_a_finished_study_whole_and_never_a_partial_one(tmp_path):
    import os

    config = _config(tmp_path)
    _run(tmp_path, config)
    out = tmp_path / "study.h5"
    os.link(out, tmp_path / "kept.h5")
    before = out.read_bytes()
    _, summary = _run(tmp_path, config, force=True)
    assert summary.complete and summary.trials_done == [5.0, 10.0, 15.0]
    assert (tmp_path / "kept.h5").read_bytes() == before  # the old file replaced, not rewritten
    assert os.stat(out).st_ino != os.stat(tmp_path / "kept.h5").st_ino
    with pytest.raises(UsageError, match="give one"):
        StudyWriter(out, config, "fake-sensor", resume=True, force=True)
    out.unlink()
    with pytest.raises(DeviceError, match="vanished"):
        _run(tmp_path, config, fail_after_s=18.0)
    partial = out.read_bytes()
    with pytest.raises(UsageError, match="partial study: continue it with --resume"):
        _run(tmp_path, config, force=True)
    assert out.read_bytes() == partial


def test_no_contact_is_a_clear_error(tmp_path):
    config = _config(tmp_path, "search_max_mm = 3.0\n")
    config["contact"]["search_start_mm"] = 10.0
    with pytest.raises(NoContactError, match="did not touch the whisker within 3 mm"):
        _run(tmp_path, config)


def test_overload_guard_stops_the_run(tmp_path):
    # -250 µT/mm: the trial at 10 mm reaches -2500 µT
    config = _config(tmp_path, "[safety]\noverload_uT = 2400.0\n")
    rig, stage, sensor = fake_rig(config)
    writer = StudyWriter(tmp_path / "study.h5", config, "fake-sensor")
    with pytest.raises(OverloadError, match="over the safe limit of 2400"):
        run_on_clients(stage, sensor, config, writer)
    assert [t.depth_mm for t in read_study(tmp_path / "study.h5").trials] == [5.0]
    assert rig.z_uT(rig.position) == 0.0  # backed off clear of the whisker


def test_waypoints_outside_the_travel_are_refused_before_any_trial(tmp_path):
    config = _config(tmp_path, "[geometry]\nwhisker_origin_stage_mm = [150.0, 100.0]\n")
    with pytest.raises(UsageError, match="outside its travel"):
        _run(tmp_path, config)
    assert read_study(tmp_path / "study.h5").trials == []


def test_ctrl_c_stops_the_stage_and_keeps_finished_trials(tmp_path):
    config = _config(tmp_path)
    rig, stage, sensor = fake_rig(config)
    resets = []
    stage.reset = lambda: resets.append(rig.time_s)
    real_read = sensor.read
    writer = StudyWriter(tmp_path / "study.h5", config, "fake-sensor")
    real_add, added, reads_since = writer.add_trial, [], []

    def add_trial(record):
        real_add(record)
        added.append(record.depth_mm)
        reads_since.clear()

    def interrupted_read(n, timeout_s=1.0):
        reads_since.append(n)
        if len(added) == 1 and len(reads_since) > 50:
            raise KeyboardInterrupt  # in the middle of the second trial
        return real_read(n, timeout_s)

    writer.add_trial, sensor.read = add_trial, interrupted_read
    with pytest.raises(KeyboardInterrupt):
        run_on_clients(stage, sensor, config, writer)
    assert resets  # the move in progress was stopped
    study = read_study(tmp_path / "study.h5")
    assert [t.depth_mm for t in study.trials] == [5.0] and study.missing_depths() == [10.0, 15.0]
