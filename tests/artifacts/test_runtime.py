"""whiskercal.runtime: load, tip(z) with its out-of-range policies, the streaming tracker."""

import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest

from analytic import rigid_tip_mm
from whiskercal import runtime
from whiskercal.errors import ArtifactError
from whiskercal.model.errors import ModelError, ZOutOfRangeError

FIXTURE = Path(__file__).parents[1] / "fixtures" / "calibration-1.0.0.h5"


@pytest.fixture(scope="module")
def calibration():
    return runtime.load(FIXTURE)


def test_tip_scalar_and_array(calibration):
    low, high = calibration.z_range_uT
    z = np.linspace(low, high, 9)
    tips = calibration.tip(z)
    assert tips.shape == (9, 2)
    np.testing.assert_allclose(calibration.tip(float(z[3])), tips[3], atol=1e-12)
    expected = np.array([rigid_tip_mm(v, 78.0) for v in z])
    assert np.max(np.linalg.norm(tips - expected, axis=1)) < 0.05  # fitted on noisy data


def test_out_of_range_policies(calibration):
    low, high = calibration.z_range_uT
    with pytest.raises(ZOutOfRangeError, match="outside the calibrated range"):
        calibration.tip(low - 10.0)
    assert np.all(np.isnan(calibration.tip(low - 10.0, out_of_range="nan")))
    np.testing.assert_allclose(calibration.tip(low - 10.0, out_of_range="clip"),
                               calibration.tip(low))
    with pytest.raises(ModelError):
        calibration.tip(low, out_of_range="extrapolate")


def test_tracker_detects_contact_filters_and_resets(calibration):
    tracker = calibration.tracker()
    z_contact = float(np.mean(calibration.z_range_uT))
    assert tracker.update(0.0).contact is False
    first = tracker.update(z_contact)
    assert first.contact and first.raw_tip_mm is not None
    np.testing.assert_allclose(first.filtered_tip_mm, first.raw_tip_mm)  # x0 = first estimate
    rng = np.random.default_rng(11)
    states = [tracker.update(z_contact + rng.normal(0.0, 40.0)) for _ in range(200)]
    filtered = np.array([s.filtered_tip_mm for s in states[50:]])
    raw = np.array([s.raw_tip_mm for s in states[50:]])
    assert np.all(filtered.std(axis=0) < 0.5 * raw.std(axis=0))
    released = tracker.update(-50.0)
    assert released.contact is False and released.filtered_tip_mm is None
    again = tracker.update(z_contact)
    np.testing.assert_allclose(again.filtered_tip_mm, again.raw_tip_mm)  # a new contact, a new x0


def test_tracker_out_of_range_raises_but_goes_on(calibration):
    low, _ = calibration.z_range_uT
    tracker = calibration.tracker()
    tracker.update(low + 100.0)
    with pytest.raises(ZOutOfRangeError):
        tracker.update(low - 500.0)
    assert tracker.update(low + 100.0).contact
    quiet = calibration.tracker(out_of_range="nan")
    quiet.update(low + 100.0)
    state = quiet.update(low - 500.0)
    assert state.contact and state.raw_tip_mm is None and state.filtered_tip_mm is not None
    assert state.out_of_range == -1


def test_clip_policy_gives_the_edge_tip_and_flags_the_side(calibration):
    low, high = calibration.z_range_uT
    tracker = calibration.tracker(out_of_range="clip")
    inside = tracker.update(low + 100.0)
    assert inside.out_of_range == 0
    below = tracker.update(low - 500.0)
    assert below.out_of_range == -1
    np.testing.assert_array_equal(below.raw_tip_mm, calibration.tip(low))
    if high < -calibration.collision_params.threshold_uT:  # above the range yet in contact
        above = tracker.update(high + 0.5 * (-calibration.collision_params.threshold_uT - high))
        assert above.out_of_range == 1
        np.testing.assert_array_equal(above.raw_tip_mm, calibration.tip(high))


@pytest.mark.parametrize("policy", ["clip", "nan"])
def test_streaming_policies_never_raise_on_any_float(calibration, policy):
    low, _ = calibration.z_range_uT
    tracker = calibration.tracker(out_of_range=policy)
    for z in (low + 100.0, float("nan"), float("inf"), -float("inf"), -1e300, 1e300, low - 1.0,
              0.0, float("nan"), low * 10):
        state = tracker.update(z)
        assert state.filtered_tip_mm is None or np.all(np.isfinite(state.filtered_tip_mm))


def test_target_is_none_until_a_study_writes_one(calibration, tmp_path):
    assert calibration.target_z_uT is None
    path = tmp_path / "with-target.h5"
    shutil.copy(FIXTURE, path)
    with h5py.File(path, "r+") as handle:
        group = handle.create_group("target")
        group.create_dataset("z_uT", data=-5000.0).attrs["units"] = "µT"
        handle.attrs["schema_version"] = "1.1.0"
    assert runtime.load(path).target_z_uT == -5000.0


def test_trace_on_the_stored_surface_agrees_with_the_lookup(calibration):
    z = float(calibration.data.lookup_z_uT[7])
    np.testing.assert_allclose(calibration.trace(z), calibration.data.lookup_tip_mm[7], atol=1e-6)


def test_missing_file_is_an_artifact_error(tmp_path):
    with pytest.raises(ArtifactError, match="no such file"):
        runtime.load(tmp_path / "none.h5")
