"""The journal-backed checkpoint of a collection run: torn journals, lost files, resume."""

from __future__ import annotations

import numpy as np
import pytest

from whiskercal.artifacts.raw_grid import POINT_FIELDS, Baseline, read_raw_grid
from whiskercal.collect.checkpoint import Checkpoint, recorded_fingerprint
from whiskercal.collect.journal import decode_line, encode_line, journal_path, replay
from whiskercal.errors import UsageError

from rawfile import make_header, make_point, make_stream


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
    recorded = read_raw_grid(path, stream=True)
    resumed = Checkpoint.resume(path, make_header())
    assert resumed.taken == {0, 1}
    resumed.add_point(make_point(2, 0.0, 3.0))
    resumed.set_baseline("after", Baseline(np.array([0, 1000.0, 0]), np.ones(3), 9.0))
    resumed.finish()
    assert not journal_path(path).exists()
    grid = read_raw_grid(path, stream=True)
    assert grid.complete and grid.plan_index.tolist() == [0, 1, 2]
    # the resumed point had no truth: its row is NaN, never misaligned
    np.testing.assert_array_equal(grid.truth["z_uT"], [0.0, -1000.0, np.nan])
    # the file rebuilt from itself kept every recorded value, samples and baseline spread too
    for name in POINT_FIELDS:
        np.testing.assert_array_equal(getattr(grid, name)[:2], getattr(recorded, name))
    assert grid.stream.point.tolist() == [0] * 4 + [1] * 4
    np.testing.assert_array_equal(grid.stream.counts, recorded.stream.counts)
    np.testing.assert_array_equal(grid.baseline_before.std_uT, np.ones(3))
    assert grid.plan_fingerprint == make_header().fingerprint


def test_the_recorded_fingerprint_comes_from_the_journal_else_the_file(tmp_path):
    path = tmp_path / "raw.h5"
    _checkpoint_with_points(path, [0]).close()
    assert recorded_fingerprint(path) == make_header().fingerprint
    journal_path(path).unlink()
    assert recorded_fingerprint(path) == make_header().fingerprint
    path.write_bytes(b"\x89HDF garbage left by a killed writer")
    with pytest.raises(UsageError, match="nothing to resume"):
        recorded_fingerprint(path)


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
