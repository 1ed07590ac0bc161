"""The calibration artifact: round trip, shipped fixtures, refusals."""

import shutil
from dataclasses import fields
from pathlib import Path

import h5py
import numpy as np
import pytest

from analytic import paper_grid_mm, rigid_tip_mm, rigid_z
from whiskercal.artifacts.calibration import (SCHEMA, CalibrationData, data_from_calibration,
                                              read_calibration, surface_of, write_calibration)
from whiskercal.errors import ArtifactError
from whiskercal.model.calibrate import CalibrationOptions, calibrate
from whiskercal.model.collision import CollisionParams
from whiskercal.model.kalman import KalmanParams

FIXTURES = Path(__file__).parents[1] / "fixtures"


@pytest.fixture(scope="module")
def calibration():
    points = paper_grid_mm()
    # 70 mm: the lattice reaches 65 mm, so the tips lie within the 9.5 mm extrapolation limit
    return calibrate(points, rigid_z(points), 0.0, CalibrationOptions(degree=4, trace_length_mm=70.0))


@pytest.fixture(scope="module")
def data(calibration):
    return data_from_calibration(
        calibration, sensor_id="analytic", rod_radius_mm=0.0, tracer="fast",
        kalman=KalmanParams(), collision=CollisionParams(), metrics={"rmse_uT": 1.5, "r2": 0.99,
        "degrees": np.arange(1, 4), "by_kind": {"cubic": 1e-4}},
        truth={"z_uT": np.array([-1.0, -2.0]), "error_mm": np.array([0.1, 0.2])},
        inputs={"raw_grid": "ab" * 32}, config={"options": {"degree": 4}})


def test_round_trip_keeps_every_field(tmp_path, data):
    path = write_calibration(tmp_path / "cal.h5", data)
    back = read_calibration(path)
    for item in fields(CalibrationData):
        if item.name in ("created", "whiskercal_version", "metrics", "truth"):
            continue
        original, loaded = getattr(data, item.name), getattr(back, item.name)
        if isinstance(original, np.ndarray):
            np.testing.assert_array_equal(loaded, original)
        else:
            assert loaded == original, item.name
    assert back.metrics["rmse_uT"] == 1.5 and back.metrics["by_kind"] == {"cubic": 1e-4}
    np.testing.assert_array_equal(back.truth["error_mm"], [0.1, 0.2])
    assert back.created and back.whiskercal_version
    probe = np.array([[40.0, -12.0]])
    np.testing.assert_allclose(surface_of(back)(probe), surface_of(data)(probe), rtol=1e-15)


def test_every_dataset_has_units_and_provenance(tmp_path, data):
    path = write_calibration(tmp_path / "cal.h5", data)
    with h5py.File(path) as handle:
        for key in ("schema", "schema_version", "created", "whiskercal_version", "sensor_id",
                    "inputs_sha256", "config"):
            assert key in handle.attrs
        assert handle.attrs["schema"] == SCHEMA
        missing = []
        handle.visititems(lambda name, item: missing.append(name)
                          if isinstance(item, h5py.Dataset) and "units" not in item.attrs else None)
        assert missing == []


@pytest.mark.parametrize("name", ["calibration-1.0.0.h5", "calibration-1.1.0-target.h5"])
def test_shipped_fixtures_still_load(name):
    data = read_calibration(FIXTURES / name)
    assert data.schema_version.startswith("1.")
    assert data.sensor_id == "analytic-rigid"
    # the fixtures were fitted on the rigid-whisker surface: the lookup still finds its tips
    z = float(np.mean(data.lookup_z_uT[[4, 5]]))
    from whiskercal.artifacts.calibration import lookup_of
    np.testing.assert_allclose(lookup_of(data)(z), rigid_tip_mm(z, 78.0), atol=0.05)
    assert (data.target_z_uT is not None) == ("target" in name)


def test_unknown_major_version_is_refused(tmp_path):
    path = tmp_path / "future.h5"
    shutil.copy(FIXTURES / "calibration-1.0.0.h5", path)
    with h5py.File(path, "r+") as handle:
        handle.attrs["schema_version"] = "2.0.0"
    with pytest.raises(ArtifactError, match="schema version 2.0.0 is not supported"):
        read_calibration(path)


def test_other_schemas_and_broken_files_are_refused(tmp_path):
    path = tmp_path / "cal.h5"
    shutil.copy(FIXTURES / "calibration-1.0.0.h5", path)
    with h5py.File(path, "r+") as handle:
        del handle["lookup"]
    with pytest.raises(ArtifactError, match="incomplete calibration artifact"):
        read_calibration(path)
    with h5py.File(path, "r+") as handle:
        handle.attrs["schema"] = "whiskercal.raw_grid"
    with pytest.raises(ArtifactError, match="not a whiskercal.calibration file"):
        read_calibration(path)
    (tmp_path / "junk.h5").write_bytes(b"not hdf5")
    with pytest.raises(ArtifactError, match="not an HDF5 file"):
        read_calibration(tmp_path / "junk.h5")


def test_an_unwritable_destination_is_an_artifact_error(tmp_path, data):
    (tmp_path / "file").write_bytes(b"")
    with pytest.raises(ArtifactError, match="cannot write the calibration artifact"):
        write_calibration(tmp_path / "file" / "cal.h5", data)


def test_validation_catches_inconsistent_content(tmp_path):
    path = tmp_path / "cal.h5"
    shutil.copy(FIXTURES / "calibration-1.0.0.h5", path)
    with h5py.File(path, "r+") as handle:
        z = handle["lookup/z_uT"][()]
        handle["lookup/z_uT"][...] = z[::-1]
    with pytest.raises(ArtifactError, match="increasing lookup z"):
        read_calibration(path)


def test_a_target_on_a_1_2_artifact_ships_as_1_3_and_loads():
    # calibration-1.3.0-target.h5: the study's target writer applied to the 1.2.0 fixture
    from whiskercal import runtime

    data = read_calibration(FIXTURES / "calibration-1.3.0-target.h5")
    older = read_calibration(FIXTURES / "calibration-1.2.0-extrapolated.h5")
    assert (older.schema_version, data.schema_version) == ("1.2.0", "1.3.0")
    np.testing.assert_array_equal(data.lookup_z_uT, older.lookup_z_uT)
    loaded = runtime.load(FIXTURES / "calibration-1.3.0-target.h5")
    assert loaded.target_z_uT == pytest.approx(data.target_z_uT)
    assert loaded.trusted_z_range_uT == runtime.load(FIXTURES / "calibration-1.2.0-extrapolated.h5").trusted_z_range_uT
    assert np.all(np.isfinite(loaded.tip(loaded.target_z_uT)))
