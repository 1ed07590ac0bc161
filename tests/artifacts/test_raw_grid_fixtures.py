"""Every raw dataset schema version that shipped must still load (fixtures in tests/fixtures/)."""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
import pytest

from whiskercal.artifacts.raw_grid import SCHEMA_VERSION, read_raw_grid

FIXTURES = sorted((Path(__file__).parents[1] / "fixtures").glob("raw_grid_v*.h5"))


def test_there_is_a_fixture_for_the_current_schema():
    assert any(path.name == f"raw_grid_v{SCHEMA_VERSION}.h5" for path in FIXTURES)


@pytest.mark.parametrize("path", FIXTURES, ids=lambda p: p.name)
def test_fixture_loads_whole_and_consistent(path):
    grid = read_raw_grid(path)
    assert grid.complete and len(grid) == len(grid.plan_stage_mm) > 0
    assert sorted(grid.plan_index) == list(range(len(grid.plan_stage_mm)))
    assert grid.rod_center_mm.shape == (len(grid), 2) and grid.z_uT.shape == (len(grid),)
    assert np.all(grid.n_samples > 0) and grid.rod_radius_mm > 0 and grid.sensor_id
    error = grid.z_uT - grid.truth["z_uT"]
    sigma = np.median(grid.z_std_uT) * np.sqrt(1 / grid.n_samples
                                               + 1 / grid.config["acquisition"]["baseline_samples"])
    assert np.all(np.abs(error) < 5 * sigma)
    with h5py.File(path) as handle:
        for key in ("schema", "schema_version", "created", "whiskercal_version", "sensor_id",
                    "inputs_sha256", "config", "rod_radius_mm", "complete"):
            assert key in handle.attrs, key
        missing = []
        handle.visititems(lambda name, obj: missing.append(name)
                          if isinstance(obj, h5py.Dataset) and "units" not in obj.attrs else None)
        assert missing == []


def test_a_file_before_the_tip_sweep_has_none_and_the_current_one_marks_its_own():
    old = read_raw_grid(Path(__file__).parents[1] / "fixtures" / "raw_grid_v1.0.0.h5")
    assert not old.sweep.any() and old.without_sweep() is old
    new = read_raw_grid(Path(__file__).parents[1] / "fixtures" / "raw_grid_v1.1.0.h5")
    first = new.config["plan"]["tip_sweep"]["first_index"]
    assert new.sweep.sum() == new.config["plan"]["tip_sweep"]["points"] == 4
    np.testing.assert_array_equal(new.sweep, new.plan_index >= first)
    grid = new.without_sweep()
    assert len(grid) == first and set(grid.truth["kind"]) == {"shaft"}
