"""Finding datasets, refusing missing or corrupt ones, golden files, and compact copies."""

import json
import os
import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest

from whiskercal.artifacts.raw_grid import read_raw_grid
from whiskercal.errors import ArtifactError, UsageError
from whiskercal.regress.golden import Dataset, check_inputs, find_datasets, read_golden
from whiskercal.regress.pack import compact_copy

DATA = Path(__file__).resolve().parents[2] / "data"
SHORT = DATA / "twin-short-60mm"


def test_the_recorded_datasets_are_found():
    names = [d.name for d in find_datasets(DATA)]
    assert names == ["twin-long-110mm", "twin-paper-75mm", "twin-short-60mm"]
    assert [d.name for d in find_datasets(SHORT)] == ["twin-short-60mm"]


def test_a_missing_or_empty_data_directory_is_refused(tmp_path):
    with pytest.raises(UsageError, match="no such directory"):
        find_datasets(tmp_path / "nothing")
    with pytest.raises(UsageError, match="no dataset directories"):
        find_datasets(tmp_path)


def test_a_missing_study_file_is_named(tmp_path):
    (tmp_path / "partial").mkdir()
    shutil.copy(SHORT / "raw_grid.h5", tmp_path / "partial" / "raw_grid.h5")
    with pytest.raises(ArtifactError, match="partial: missing plane_study.h5"):
        check_inputs(Dataset(tmp_path / "partial"))


def test_a_corrupt_file_is_named(tmp_path):
    shutil.copytree(SHORT, tmp_path / "broken")
    raw = tmp_path / "broken" / "raw_grid.h5"
    raw.write_bytes(raw.read_bytes()[:4096])  # truncated, as by an interrupted copy
    with pytest.raises(ArtifactError, match="broken: raw_grid.h5 is unreadable"):
        check_inputs(Dataset(tmp_path / "broken"))


def test_a_golden_file_that_is_not_json_or_missing_is_refused(tmp_path):
    (tmp_path / "d").mkdir()
    dataset = Dataset(tmp_path / "d")
    with pytest.raises(ArtifactError, match="no golden.json.*--update"):
        read_golden(dataset)
    assert read_golden(dataset, required=False) is None
    dataset.golden_path.write_text("{not json", encoding="utf-8")
    with pytest.raises(ArtifactError, match="not a valid golden results file"):
        read_golden(dataset)
    dataset.golden_path.write_text(json.dumps({"schema": "other"}), encoding="utf-8")
    with pytest.raises(ArtifactError, match="not a whiskercal.golden file"):
        read_golden(dataset)


def test_every_golden_quantity_states_a_known_tolerance_with_its_reason():
    for dataset in find_datasets(DATA):
        golden = read_golden(dataset)
        document = json.loads(dataset.golden_path.read_text(encoding="utf-8"))
        assert len(golden.quantities) > 100
        for name, tolerance in golden.classes.items():
            assert document["tolerance_classes"][tolerance]["why"], name


def test_compact_copy_keeps_measurements_exact_and_truth_to_float32(tmp_path):
    copy = compact_copy(SHORT / "raw_grid.h5", tmp_path / "copy.h5")
    with h5py.File(SHORT / "raw_grid.h5") as original, h5py.File(copy) as compact:
        assert dict(original.attrs) == dict(compact.attrs)
        np.testing.assert_array_equal(original["stream/counts"][()], compact["stream/counts"][()])
        np.testing.assert_array_equal(original["points/field_mean_uT"][()],
                                      compact["points/field_mean_uT"][()])
        assert compact["stream/counts"].compression == "gzip"
        assert compact["points/field_mean_uT"].attrs["units"] == "µT"
    assert read_raw_grid(copy).z_uT.shape == read_raw_grid(SHORT / "raw_grid.h5").z_uT.shape


def test_compact_copy_refuses_to_overwrite_its_source(tmp_path):
    shutil.copy(SHORT / "raw_grid.h5", tmp_path / "raw.h5")
    with pytest.raises(UsageError, match="is the input"):
        compact_copy(tmp_path / "raw.h5", tmp_path / "raw.h5")
    os.link(tmp_path / "raw.h5", tmp_path / "linked.h5")
    with pytest.raises(UsageError, match="is the input"):
        compact_copy(tmp_path / "raw.h5", tmp_path / "linked.h5")
