"""Files combined with a calibration must belong with it: sensor id, plan and recorded fingerprints."""

import json
import shutil
from pathlib import Path

import h5py
import pytest

from whiskercal.artifacts.cross_check import (PLAN_TOLERANCE_MM, check_report_inputs,
                                              check_study_for_target)
from whiskercal.artifacts.h5io import sha256_file
from whiskercal.errors import UsageError

REPO = Path(__file__).resolve().parents[2]
CAL = REPO / "tests" / "fixtures" / "calibration-1.3.0-target.h5"
RAW = REPO / "data" / "twin-paper-75mm" / "raw_grid.h5"
STUDY = REPO / "data" / "twin-paper-75mm" / "plane_study.h5"
OTHER_STUDY = REPO / "data" / "twin-long-110mm" / "plane_study.h5"


def _calibration_of(tmp_path, raw=RAW, study=STUDY) -> Path:
    """The fixture calibration, recording ``raw`` as its grid and ``study`` as its target's."""
    cal = tmp_path / "cal.h5"
    shutil.copy(CAL, cal)
    with h5py.File(cal, "a") as handle:
        inputs = json.loads(handle.attrs["inputs_sha256"])
        inputs["raw_grid"] = sha256_file(raw)
        handle.attrs["inputs_sha256"] = json.dumps(inputs)
        handle["target"].attrs["study_sha256"] = sha256_file(study)
    return cal


def _study_reaching(tmp_path, reach_mm: float) -> Path:
    study = tmp_path / f"study-{reach_mm:g}.h5"
    shutil.copy(STUDY, study)
    with h5py.File(study, "a") as handle:
        config = json.loads(handle.attrs["config"])
        config["geometry"]["tip_reach_mm"] = reach_mm
        handle.attrs["config"] = json.dumps(config)
    return study


def test_the_files_a_calibration_records_pass(tmp_path):
    cal = _calibration_of(tmp_path)
    assert check_report_inputs(cal, RAW, STUDY) == []
    assert check_study_for_target(cal, STUDY) == []


def test_another_file_in_the_recorded_ones_place_is_refused_or_warned(tmp_path):
    cal = _calibration_of(tmp_path)
    copy = tmp_path / "raw-edited.h5"
    shutil.copy(RAW, copy)
    with h5py.File(copy, "a") as handle:  # one byte of difference is another file
        handle.attrs["created"] = "2030-01-01T00:00:00+00:00"
    with pytest.raises(UsageError, match="is not the one the calibration was fitted from"):
        check_report_inputs(cal, copy)
    other_study = _study_reaching(tmp_path, 78.0)  # the same plan, another file
    with pytest.raises(UsageError, match="given its target by"):
        check_report_inputs(cal, study_path=other_study)
    # a study report writes a new target: the artifact's earlier one may come from any study
    assert check_study_for_target(cal, other_study) == []
    warnings = check_report_inputs(cal, copy, other_study, allow=True)
    assert len(warnings) == 2 and all("SHA-256 differs" in w for w in warnings)


def test_a_plan_for_another_reach_is_refused_past_its_tolerance(tmp_path):
    cal = _calibration_of(tmp_path)
    near = _study_reaching(tmp_path, 78.0 + 0.8 * PLAN_TOLERANCE_MM)
    far = _study_reaching(tmp_path, 78.0 + 2.0 * PLAN_TOLERANCE_MM)
    assert check_study_for_target(cal, near) == []
    with pytest.raises(UsageError, match=r"whisker of 79 mm to its tip, the calibration traces 78 mm"):
        check_study_for_target(cal, far)


def test_another_sensor_is_named_first_and_every_reason_is_warned(tmp_path):
    cal = _calibration_of(tmp_path)
    with pytest.raises(UsageError, match="recorded on sensor 'long-110mm'"):
        check_study_for_target(cal, OTHER_STUDY)
    warnings = check_study_for_target(cal, OTHER_STUDY, allow=True)
    assert "long-110mm" in warnings[0] and "113 mm" in warnings[1]


def test_a_file_of_another_kind_is_refused_by_its_schema_before_any_comparison(tmp_path):
    with pytest.raises(Exception, match="not a whiskercal.raw_grid file"):
        check_report_inputs(CAL, raw_path=STUDY)
