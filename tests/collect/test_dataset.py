"""The raw dataset schema, its writer and reader, and the journal-backed checkpoint."""

from __future__ import annotations

import h5py
import numpy as np
import pytest

from whiskercal.collect.checkpoint import Checkpoint
from whiskercal.collect.dataset import (SCHEMA, Baseline, PointRecord, RawGridWriter, RawHeader,
                                        StreamChunk, read_raw_grid)
from whiskercal.collect.journal import decode_line, encode_line, journal_path, replay
from whiskercal.errors import ArtifactError, UsageError


def make_header(n_plan: int = 6, config: dict | None = None) -> RawHeader:
    rod = np.column_stack([np.arange(n_plan) * 3.0 + 20.0, -np.arange(n_plan) * 3.0])
    return RawHeader(plan_stage_mm=rod + [50.0, 100.0], plan_rod_center_mm=rod,
                     config=config or {"grid": {"step_mm": 3.0}}, sensor_id="twin-1",
                     rod_radius_mm=1.5)


def make_point(index: int, y_uT: float, t_s: float) -> PointRecord:
    rod = np.array([20.0 + 3 * index, -3.0 * index])
    return PointRecord(plan_index=index, commanded_mm=rod + [50, 100], encoder_mm=rod + [50, 100],
                       rod_center_mm=rod, field_mean_uT=np.array([1.0, y_uT, 3.0]),
                       field_std_uT=np.array([5.0, 6.0, 7.0]), n_samples=30,
                       t_start_s=t_s, t_end_s=t_s + 0.1, dropped=index % 2, corrupt=0)


def make_stream(point: int, n: int = 4) -> StreamChunk:
    return StreamChunk(seq=np.arange(n), t_s=np.arange(n) / 300.0,
                       counts=np.full((n, 3), point, np.int16), status=np.zeros(n, np.uint8),
                       point=np.full(n, point))


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


def test_journal_drops_a_torn_or_corrupt_tail(tmp_path):
    line = encode_line({"type": "header", "a": [1.5, float("nan")]})
    assert decode_line(line)["a"][0] == 1.5
    assert decode_line(line[:-3] + b"\n") is None
    path = tmp_path / "j"
    path.write_bytes(line + encode_line({"n": 2}) + b"0000dead {\"n\":3}\n" + encode_line({"n": 4}))
    records = replay(path)
    assert [r.get("n") for r in records] == [None, 2]
    assert path.read_bytes() == line + encode_line({"n": 2})


def _checkpoint_with_points(path, indices):
    checkpoint = Checkpoint.start(path, make_header())
    checkpoint.set_baseline("before", Baseline(np.array([0, 1000.0, 0]), np.ones(3), 0.0))
    for index in indices:
        checkpoint.add_point(make_point(index, -1000.0 * index, 1.0 + index), make_stream(index),
                             truth={"z_uT": -1000.0 * index})
    return checkpoint


def test_resume_rebuilds_a_destroyed_h5_from_the_journal(tmp_path):
    path = tmp_path / "raw.h5"
    _checkpoint_with_points(path, [0, 1, 2]).close()
    path.write_bytes(b"\x89HDF garbage left by a killed writer")
    resumed = Checkpoint.resume(path, make_header())
    assert resumed.taken == {0, 1, 2}
    resumed.add_point(make_point(3, -3000.0, 4.0))
    with pytest.raises(ValueError, match="already recorded"):
        resumed.add_point(make_point(1, 0.0, 5.0))
    resumed.close()
    grid = read_raw_grid(path)
    assert grid.plan_index.tolist() == [0, 1, 2, 3]
    np.testing.assert_allclose(grid.z_uT, [-1000, -2000, -3000, -4000])


def test_resume_refuses_a_different_plan_or_config(tmp_path):
    path = tmp_path / "raw.h5"
    _checkpoint_with_points(path, [0]).close()
    with pytest.raises(UsageError, match="different plan or configuration"):
        Checkpoint.resume(path, make_header(config={"grid": {"step_mm": 2.0}}))
    with pytest.raises(UsageError, match="nothing to resume"):
        Checkpoint.resume(tmp_path / "other.h5", make_header())


def test_resume_from_the_h5_alone_and_finish_removes_the_journal(tmp_path):
    path = tmp_path / "raw.h5"
    _checkpoint_with_points(path, [0, 1]).close()
    journal_path(path).unlink()
    resumed = Checkpoint.resume(path, make_header())
    assert resumed.taken == {0, 1}
    resumed.add_point(make_point(2, 0.0, 3.0))
    resumed.set_baseline("after", Baseline(np.array([0, 1000.0, 0]), np.ones(3), 9.0))
    resumed.finish()
    assert not journal_path(path).exists()
    grid = read_raw_grid(path)
    assert grid.complete and grid.plan_index.tolist() == [0, 1, 2]
    # the resumed point had no truth: its row is NaN, never misaligned
    np.testing.assert_array_equal(grid.truth["z_uT"], [0.0, -1000.0, np.nan])


def test_resume_recovers_from_an_h5_cut_anywhere_and_a_torn_journal_line(tmp_path):
    rng = np.random.default_rng(11)
    path = tmp_path / "raw.h5"
    _checkpoint_with_points(path, [0, 1, 2, 3]).close()
    intact = path.read_bytes()
    with open(journal_path(path), "ab") as handle:
        handle.write(b'1234abcd {"type":"point","plan_index":4')  # killed mid-line
    for cut in rng.integers(0, len(intact), size=5):
        path.write_bytes(intact[:cut])
        resumed = Checkpoint.resume(path, make_header())
        assert resumed.taken == {0, 1, 2, 3}
        resumed.close()
        assert read_raw_grid(path).plan_index.tolist() == [0, 1, 2, 3]
