"""The study on the twin, judged against the twin's ground truth."""

import json

import numpy as np
import pytest

from whiskercal import runtime
from whiskercal.study.artifact_target import write_target
from whiskercal.artifacts.plane_study import PHASE_SLIDE, read_study
from whiskercal.study.report import build_report


@pytest.fixture(scope="module")
def report(twin_study, twin_calibration):
    path, _ = twin_study
    return build_report(path, runtime.load(twin_calibration))


def _truly_tip(study, depth):
    """True when the twin kept a tip contact during the whole slide of the trial at ``depth``."""
    trial = next(t for t in study.trials if t.depth_mm == depth)
    kinds = trial.truth["kind"][trial.stream["phase"] == PHASE_SLIDE]
    return bool(np.all(kinds == "tip"))


def test_ten_trials_with_truth_and_the_plane_where_the_truth_says(twin_study):
    path, config = twin_study
    study = read_study(path)
    assert study.complete and [t.depth_mm for t in study.trials] == config["trials"]["depths_mm"]
    for trial in study.trials:
        slide = trial.stream["phase"] == PHASE_SLIDE
        assert slide.sum() > 250 and trial.truth is not None
        # the plane's line from the stage encoders and the configured geometry holds the true tip
        # (in tip contact the tip is on the plane; the encoder quantizes to ~0.01 mm)
        if _truly_tip(study, trial.depth_mm):
            offset = (trial.truth["tip_mm"][slide] - trial.plane["point_mm"][slide])
            distance = np.abs(np.sum(offset * trial.plane["normal"][slide], axis=1))
            assert np.max(distance) < 0.05


def test_trials_in_tip_contact_stay_under_2_mm(twin_study, report):
    study = read_study(twin_study[0])
    tip_rows = [row for row in report.rows if _truly_tip(study, row.depth_mm)]
    assert len(tip_rows) >= 7  # 5..35 mm at least: the slip comes near 45.4 mm
    for row in tip_rows:
        assert row.filtered_mean_mm < 2.0 and row.raw_mean_mm < 2.0, row
        assert row.true_filtered_mean_mm < 2.0, row
        assert not row.failing, (row.depth_mm, row.reasons)


def test_slip_into_tangential_contact_is_detected_from_the_data(twin_study, report):
    study = read_study(twin_study[0])
    deepest = report.rows[-1]
    assert deepest.depth_mm == 50.0
    assert deepest.true_tangential_fraction > 0.5        # the twin says it slipped ...
    assert deepest.tangential and deepest.failing        # ... and the data said so too
    assert any("tangential" in reason for reason in deepest.reasons)
    # found twice over: the push-in's kink and |z| growing faster with depth across trials
    assert any("kinked" in reason for reason in deepest.reasons)
    assert any("stiffened" in reason for reason in deepest.reasons)
    for row in report.rows:                               # no false alarm in tip contact
        if _truly_tip(study, row.depth_mm):
            assert not row.tangential, row.depth_mm


def test_the_target_is_not_next_to_a_failing_depth(report):
    depths = [row.depth_mm for row in report.rows]
    failing = {row.depth_mm for row in report.rows if row.failing}
    chosen = depths.index(report.choice.depth_mm)
    assert report.choice.depth_mm not in failing
    assert depths[chosen - 1] not in failing and depths[chosen + 1] not in failing
    assert report.choice.z_uT < -300.0


def test_the_runtime_returns_the_written_target(tmp_path, twin_study, twin_calibration, report):
    assert runtime.load(twin_calibration).target_z_uT is None
    out = write_target(twin_calibration, tmp_path / "CAL-target.h5", report.choice,
                       report.study.sha256)
    loaded = runtime.load(out)
    assert loaded.target_z_uT == pytest.approx(report.choice.z_uT)
    assert json.loads(json.dumps(report.as_dict()))["choice"]["depth_mm"] == report.choice.depth_mm
