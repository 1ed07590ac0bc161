"""The raw dataset schema (whiskercal.raw_grid): its writer and its reader."""

from __future__ import annotations

import h5py
import numpy as np
import pytest

from whiskercal.artifacts.raw_grid import (SCHEMA, Baseline, RawGridWriter, read_plan_fingerprint,
                                           read_raw_grid)
from whiskercal.errors import ArtifactError

from rawfile import make_header, make_point, make_stream


def test_writer_and_reader_round_trip_with_drift_corrected_z(tmp_path):
    path = tmp_path / "raw.h5"
    writer = RawGridWriter.create(path, make_header())
    writer.set_baseline("before", Baseline(np.array([0, 1000.0, 0]), np.ones(3), t_s=0.0))
    for index, t_s in enumerate([10.0, 20.0]):
        writer.append_point(make_point(index, -2000.0, t_s), make_stream(index),
                            truth={"tip_mm": [70.0, -index], "kind": "shaft", "z_uT": -3000.0})
    # the static reading drifted by +100 µT over 40 s: z is relative to the drifting baseline
    writer.set_baseline("after", Baseline(np.array([0, 1100.0, 0]), np.ones(3), t_s=40.0))
    writer.mark_complete()
    writer.close()
    grid = read_raw_grid(path)
    expected_static = 1000.0 + 100.0 * np.array([10.05, 20.05]) / 40.0
    np.testing.assert_allclose(grid.z_uT, -2000.0 - expected_static)
    np.testing.assert_allclose(grid.z_std_uT, [6.0, 6.0])
    assert grid.complete and grid.sensor_id == "twin-1" and grid.rod_radius_mm == 1.5
    assert grid.truth["kind"].tolist() == ["shaft", "shaft"]
    np.testing.assert_allclose(grid.truth["tip_mm"], [[70, 0], [70, -1]])
    assert grid.config == {"grid": {"step_mm": 3.0}} and len(grid.sha256) == 64
    with h5py.File(path) as handle:
        assert handle.attrs["schema"] == SCHEMA
        assert handle["stream/counts"].shape == (8, 3)
        for name, dataset in _datasets(handle):
            assert "units" in dataset.attrs, name


def _datasets(handle):
    found = []
    handle.visititems(lambda name, obj: found.append((name, obj))
                      if isinstance(obj, h5py.Dataset) else None)
    return found


def test_without_after_baseline_z_uses_before(tmp_path):
    path = tmp_path / "raw.h5"
    writer = RawGridWriter.create(path, make_header())
    writer.set_baseline("before", Baseline(np.array([0, 1000.0, 0]), np.ones(3), t_s=0.0))
    writer.append_point(make_point(0, 500.0, 5.0))
    writer.close()
    grid = read_raw_grid(path)
    np.testing.assert_allclose(grid.z_uT, [-500.0])
    assert not grid.complete and grid.truth is None


def test_reader_refuses_other_schema_and_future_major(tmp_path):
    path = tmp_path / "raw.h5"
    RawGridWriter.create(path, make_header()).close()
    with h5py.File(path, "a") as handle:
        handle.attrs["schema_version"] = "2.0.0"
    with pytest.raises(ArtifactError, match="version 2.0.0 is not supported"):
        read_raw_grid(path)
    with pytest.raises(ArtifactError, match="no such file"):
        read_raw_grid(tmp_path / "missing.h5")
    with h5py.File(path, "a") as handle:
        handle.attrs["schema"] = "whiskercal.plane_study"
    with pytest.raises(ArtifactError, match="not a whiskercal.raw_grid file"):
        read_raw_grid(path)


def test_the_stream_is_read_when_asked_with_every_point_column_and_baseline(tmp_path):
    path = tmp_path / "raw.h5"
    writer = RawGridWriter.create(path, make_header())
    writer.set_baseline("before", Baseline(np.array([0, 1000.0, 0]), np.full(3, 2.0), t_s=0.5))
    writer.append_stream(make_stream(-1, n=3))
    writer.append_point(make_point(0, -2000.0, 10.0), make_stream(0))
    writer.close()
    assert read_raw_grid(path).stream is None  # most of a file: only on request
    grid = read_raw_grid(path, stream=True)
    assert grid.stream.point.tolist() == [-1] * 3 + [0] * 4
    assert grid.stream.counts.dtype == np.int16 and grid.stream.counts.shape == (7, 3)
    point = make_point(0, -2000.0, 10.0)
    np.testing.assert_array_equal(grid.field_std_uT, [point.field_std_uT])
    assert (grid.t_start_s.tolist(), grid.t_end_s.tolist()) == ([10.0], [10.1])
    assert (grid.dropped.tolist(), grid.corrupt.tolist()) == ([0], [0])
    assert grid.baseline_after is None
    np.testing.assert_array_equal(grid.baseline_before.std_uT, [2.0, 2.0, 2.0])
    assert grid.baseline_before.t_s == 0.5 and grid.baseline_after_uT is None
    assert grid.plan_fingerprint == make_header().fingerprint == read_plan_fingerprint(path)


def test_the_plan_fingerprint_of_a_file_that_does_not_open_is_none(tmp_path):
    path = tmp_path / "raw.h5"
    path.write_bytes(b"\x89HDF garbage left by a killed writer")
    assert read_plan_fingerprint(path) is None
    assert read_plan_fingerprint(tmp_path / "missing.h5") is None
