"""The report's bookkeeping on a fake study: table, clear refusals, target in a new artifact."""

import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest

from whiskercal.artifacts import h5io
from whiskercal.artifacts.calibration import Target, read_calibration
from whiskercal.artifacts.plane_study import StudyWriter, read_study
from whiskercal.study.artifact_target import write_target
from whiskercal.study.config import PlaneGeometry
from whiskercal.study.figures import write_figures
from whiskercal.study.report import IncompleteStudyError, build_report
from study_fakes import FakeCalibration, fake_config as _config, fake_rig, run_on_clients

FIXTURES = Path(__file__).parents[1] / "fixtures"


@pytest.fixture(scope="module")
def fake_study(tmp_path_factory):
    tmp_path = tmp_path_factory.mktemp("study")
    config = _config(tmp_path, "[safety]\nhome = false\n")
    config["trials"]["depths_mm"] = [5.0, 10.0, 15.0, 20.0]
    rig, stage, sensor = fake_rig(config)
    run_on_clients(stage, sensor, config, StudyWriter(tmp_path / "study.h5", config, "fake"))
    return tmp_path / "study.h5", PlaneGeometry.from_config(config)


def test_estimates_on_the_plane_pass_and_a_target_is_chosen(fake_study):
    path, geometry = fake_study
    report = build_report(path, FakeCalibration(geometry))
    assert [row.depth_mm for row in report.rows] == [5.0, 10.0, 15.0, 20.0]
    for row in report.rows:
        # stream noise 5 µT over 250 µT/mm -> 0.02 mm; sub-0.1 mm error against the plane
        assert row.raw_mean_mm < 0.1 and not row.failing, row.reasons
        assert row.contact_fraction > 0.95
    assert report.choice is not None and report.choice.depth_mm in (10.0, 15.0)
    assert report.choice.z_uT == pytest.approx(
        next(r.median_z_uT for r in report.rows if r.depth_mm == report.choice.depth_mm))


def test_z_beyond_the_calibration_is_counted_and_fails_the_trial(fake_study):
    path, geometry = fake_study
    report = build_report(path, FakeCalibration(geometry, z_limit_uT=4500.0))
    deepest = report.rows[-1]
    assert report.unmapped[20.0] > 0 and report.unmapped[5.0] == 0
    assert deepest.failing


def test_missing_trials_are_named_in_a_clear_refusal(tmp_path, fake_study):
    path, geometry = fake_study
    partial = tmp_path / "partial.h5"
    partial.write_bytes(path.read_bytes())
    with h5py.File(partial, "r+") as handle:
        del handle["trials/depth_15.00mm"]
    with pytest.raises(IncompleteStudyError, match=r"lacks the trials at 15 mm \(3 of 4 done\)"):
        build_report(partial, FakeCalibration(geometry))
    report = build_report(partial, FakeCalibration(geometry), allow_missing=True)
    missing = next(row for row in report.rows if row.depth_mm == 15.0)
    assert missing.failing and missing.reasons == ["missing from the study file"]
    assert report.choice is None or report.choice.depth_mm not in (10.0, 15.0, 20.0)


def test_a_trial_cut_short_is_flagged(tmp_path, fake_study):
    path, geometry = fake_study
    short = tmp_path / "short.h5"
    short.write_bytes(path.read_bytes())
    with h5py.File(short, "r+") as handle:
        handle["trials/depth_10.00mm"].attrs["travel_mm"] = 80.0
    report = build_report(short, FakeCalibration(geometry))
    row = next(row for row in report.rows if row.depth_mm == 10.0)
    assert row.failing and row.reasons[0].startswith("cut short: slid 10.0 of 80 mm")


def test_target_goes_into_a_new_artifact_version(tmp_path, fake_study):
    path, geometry = fake_study
    report = build_report(path, FakeCalibration(geometry))
    calibration = shutil.copyfile(FIXTURES / "calibration-1.0.0.h5", tmp_path / "CAL.h5")
    before = calibration.read_bytes()
    out = write_target(calibration, tmp_path / "out" / "CAL-target.h5", report.choice,
                       read_study(path).sha256)
    assert calibration.read_bytes() == before  # the input version is never changed
    stored = read_calibration(out)
    assert stored.target == Target(report.choice.z_uT, report.choice.depth_mm, report.choice.rule,
                                   report.choice.reason, h5io.sha256_file(path))
    assert stored.schema_version == "1.1.0" and stored.target_z_uT == report.choice.z_uT
    assert stored.inputs == {"raw_grid": read_calibration(calibration).inputs["raw_grid"],
                             "plane_study": h5io.sha256_file(path),
                             "calibration": h5io.sha256_file(calibration)}
    with h5py.File(out) as handle:
        assert handle["target/z_uT"].attrs["units"] == "µT"


def test_figures_are_written(tmp_path, fake_study):
    path, geometry = fake_study
    report = build_report(path, FakeCalibration(geometry))
    figures = write_figures(report.series, report.rows, tmp_path)
    assert [f.name for f in figures] == ["errors.png", "estimates.png", "z_over_time.png"]
    assert all(f.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" for f in figures)


def test_a_trial_without_contact_is_flagged_not_a_traceback(tmp_path, fake_study):
    path, geometry = fake_study
    lost = tmp_path / "lost.h5"
    lost.write_bytes(path.read_bytes())
    with h5py.File(lost, "r+") as handle:
        static = handle["header/baseline_field_uT"][()]
        field = handle["trials/depth_15.00mm/stream/field_uT"]
        field[...] = np.tile(static, (field.shape[0], 1))  # the plane never touched the whisker
    report = build_report(lost, FakeCalibration(geometry))
    row = next(row for row in report.rows if row.depth_mm == 15.0)
    assert row.failing and row.reasons[0].startswith("no contact (0 samples")
    assert row.contact_fraction == 0.0 and np.isnan(row.median_z_uT)
    assert report.choice is None and "no trial qualifies" in report.no_target


class _CountermeasuredCalibration(FakeCalibration):
    """The fake calibration, its tracker asked for counter-measures, recording what it reads."""

    def tracker(self, out_of_range="nan", rezero=False, creep=None):
        self.asked, self.read = (rezero, creep), []
        inner, read = super().tracker(out_of_range), self.read

        class Recording:
            def update(self, z_uT, axial_uT=None):
                read.append(z_uT)
                return inner.update(z_uT)

        return Recording()


def test_countermeasures_read_each_trial_from_its_start_at_rest_and_keep_the_slide(fake_study):
    from whiskercal.artifacts.plane_study import PHASE_SLIDE
    from whiskercal.study.localize import Countermeasures
    from whiskercal.study.report import trial_series

    path, geometry = fake_study
    study = read_study(path)
    trial = study.trials[0]
    calibration = _CountermeasuredCalibration(geometry)
    plain, _ = trial_series(study, trial, FakeCalibration(geometry), 300.0)
    series, _ = trial_series(study, trial, calibration, 300.0,
                             countermeasures=Countermeasures(rezero=True, creep=(0.05, 3.0)))
    slide = np.flatnonzero(trial.stream["phase"] == PHASE_SLIDE)
    assert calibration.asked == (True, (0.05, 3.0))
    assert len(calibration.read) == slide[-1] + 1 > slide.size  # from the stream's first sample
    assert abs(calibration.read[0]) < 300.0  # at rest, out of contact: a re-zeroed rest needs it
    assert series.raw_tip_mm.shape == plain.raw_tip_mm.shape == (slide.size, 2)
    np.testing.assert_array_equal(series.raw_tip_mm, plain.raw_tip_mm)  # the fake's tips are z's
