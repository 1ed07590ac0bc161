"""The replay track's schema: the shipped fixture loads, a 1.0 file (before the world frame)
reads with those columns NaN, and another schema or a later major version is refused."""

from pathlib import Path

import h5py
import numpy as np
import pytest

from whiskercal.artifacts.replay_track import ADDED_IN_1_1, COLUMNS, read_track, write_track
from whiskercal.errors import ArtifactError

FIXTURE = Path(__file__).parents[1] / "fixtures" / "replay_track-1.1.0.h5"


def test_the_shipped_fixture_loads_with_every_column_and_unit():
    track = read_track(FIXTURE)
    assert track.schema_version == "1.1.0" and set(track.columns) == set(COLUMNS)
    np.testing.assert_allclose(track.columns["world_x_mm"][:2], [100.0, 100.0 + 8.0 / 300.0])
    with h5py.File(FIXTURE) as handle:
        assert {name: handle["track"][name].attrs["units"] for name in COLUMNS} == \
            {name: units for name, (units, _) in COLUMNS.items()}


def _written(tmp_path, n=5):
    columns = {name: np.arange(n, dtype=float) for name in COLUMNS}
    return write_track(tmp_path / "t.h5", columns, {"samples": n}, "s", {}, {})


def test_a_1_0_file_reads_with_the_world_columns_nan(tmp_path):
    path = _written(tmp_path)
    with h5py.File(path, "r+") as handle:
        handle.attrs["schema_version"] = "1.0.0"
        for name in ADDED_IN_1_1:
            del handle["track"][name]
    track = read_track(path)
    assert np.all(np.isnan(track.columns["world_y_mm"])) and len(track.columns["world_y_mm"]) == 5
    np.testing.assert_array_equal(track.columns["z_uT"], np.arange(5.0))


@pytest.mark.parametrize("attribute, value, message", [
    ("schema_version", "2.0.0", "schema version 2.0.0 is not supported"),
    ("schema", "whiskercal.contour_run", "not a whiskercal.replay_track file"),
])
def test_another_schema_or_major_version_is_refused(tmp_path, attribute, value, message):
    path = _written(tmp_path)
    with h5py.File(path, "r+") as handle:
        handle.attrs[attribute] = value
    with pytest.raises(ArtifactError, match=message):
        read_track(path)


def test_columns_of_unequal_length_are_refused(tmp_path):
    path = _written(tmp_path)
    with h5py.File(path, "r+") as handle:
        del handle["track"]["t_s"]
        handle["track"]["t_s"] = np.arange(4.0)
    with pytest.raises(ArtifactError, match="differ in length"):
        read_track(path)
