"""An artifact whose lookup runs past the extrapolation limit (schema 1.2, written with
``whiskercal fit --allow-extrapolation`` from a twin grid cut at 70 mm reach): the marks load,
and the runtime refuses or flags those z."""

from pathlib import Path

import numpy as np
import pytest

from whiskercal import runtime
from whiskercal.artifacts.calibration import read_calibration, write_calibration
from whiskercal.model.errors import ZOutOfRangeError

FIXTURE = Path(__file__).parents[1] / "fixtures" / "calibration-1.2.0-extrapolated.h5"


@pytest.fixture(scope="module")
def data():
    return read_calibration(FIXTURE)


def test_the_marks_load(data):
    assert data.schema_version == "1.2.0" and data.extrapolated
    low, high = data.trusted_z_uT
    assert data.lookup_z_uT[0] <= low < high < data.lookup_z_uT[-1]
    assert data.max_extension_mm == 9.5
    assert data.lookup_extension_mm.shape == data.lookup_z_uT.shape
    assert data.lookup_extension_mm.max() > data.max_extension_mm
    assert any("stops short of the tip" in w for w in data.metrics["warnings"])


def test_round_trip_keeps_the_marks(data, tmp_path):
    back = read_calibration(write_calibration(tmp_path / "again.h5", data))
    assert back.extrapolated and back.trusted_z_uT == data.trusted_z_uT
    np.testing.assert_array_equal(back.lookup_extension_mm, data.lookup_extension_mm)
    assert back.metrics["warnings"] == data.metrics["warnings"]


def test_runtime_refuses_the_extrapolated_range(data):
    calibration = runtime.load(FIXTURE)
    low, high = data.trusted_z_uT
    assert calibration.z_range_uT == (low, high)
    inside, beyond = (low + high) / 2, (high + data.lookup_z_uT[-1]) / 2
    calibration.tip(inside)
    with pytest.raises(ZOutOfRangeError, match="trusted range"):
        calibration.tip(beyond)
    assert np.all(np.isnan(calibration.tip(np.array([beyond]), out_of_range="nan")))
    tracker = calibration.tracker(out_of_range="nan")
    assert tracker.update(inside).raw_tip_mm is not None
    state = tracker.update(beyond)
    assert state.contact and state.raw_tip_mm is None and not state.extrapolated


def test_runtime_flags_the_extrapolated_range_when_allowed(data):
    calibration = runtime.load(FIXTURE, allow_extrapolated=True)
    low, high = data.trusted_z_uT
    beyond = (high + data.lookup_z_uT[-1]) / 2
    np.testing.assert_array_equal(calibration.extrapolated([low, (low + high) / 2, beyond]),
                                  [False, False, True])
    tracker = calibration.tracker()
    assert not tracker.update((low + high) / 2).extrapolated
    flagged = tracker.update(beyond)
    assert flagged.extrapolated and flagged.raw_tip_mm is not None


def test_artifacts_before_1_2_trust_their_whole_range():
    older = read_calibration(Path(__file__).parents[1] / "fixtures" / "calibration-1.0.0.h5")
    assert not older.extrapolated and older.max_extension_mm is None
    assert older.trusted_range_uT() == (older.lookup_z_uT[0], older.lookup_z_uT[-1])
    assert not runtime.Calibration(older).extrapolated(older.lookup_z_uT[3])
