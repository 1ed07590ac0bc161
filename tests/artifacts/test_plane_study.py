"""The flat-plane study schema (whiskercal.plane_study): its per-trial writer and its reader."""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
import pytest

from whiskercal.artifacts.plane_study import (PHASE_SLIDE, SCHEMA, SCHEMA_VERSION, StudyWriter,
                                              TrialRecord, read_study)
from whiskercal.errors import ArtifactError

# The recorded datasets were written by schema 1.0.0 and must keep loading unchanged.
RECORDED = sorted((Path(__file__).parents[2] / "data").glob("*/plane_study.h5"))
CONFIG = {"trials": {"depths_mm": [5.0, 10.0]}}


def _trial(depth_mm: float, n: int = 6) -> TrialRecord:
    stream = {"seq": np.arange(n), "t_s": np.arange(n) / 300.0,
              "counts": np.full((n, 3), 7, np.int16), "field_uT": np.full((n, 3), -1.5),
              "status": np.zeros(n, np.uint8), "phase": np.full(n, PHASE_SLIDE, np.int8)}
    stage = {"sample_index": np.array([0, 3]), "t_host_s": np.array([0.0, 0.01]),
             "mpos_mm": np.zeros((2, 2)), "enc_mm": np.full((2, 2), np.nan),
             "phase": np.array([PHASE_SLIDE] * 2, np.int8)}
    plane = {"point_mm": np.full((n, 2), 60.0 - depth_mm), "normal": np.tile([-1.0, 0.0], (n, 1))}
    truth = {"tip_mm": np.zeros((n, 2)), "kind": np.array(["tip"] * (n - 1) + ["tangential"])}
    return TrialRecord(depth_mm, stream, stage, plane, {"speed_mm_s": 2.0, "dropped": 0}, truth)


def test_trials_round_trip_with_header_truth_and_units(tmp_path):
    path = tmp_path / "study.h5"
    writer = StudyWriter(path, CONFIG, "twin-1")
    writer.write_header(np.array([0.0, 1160.0, 0.0]), np.ones(3), np.array([100.0, 50.0]), -60.0)
    writer.add_trial(_trial(10.0))
    assert writer.done_depths() == [10.0] and writer.header()["first_contact_z_uT"] == -60.0
    study = read_study(path)
    assert not study.complete and study.missing_depths() == [5.0]
    writer.add_trial(_trial(5.0))
    writer.mark_complete()
    study = read_study(path)
    assert study.complete and [t.depth_mm for t in study.trials] == [5.0, 10.0]
    assert study.config == CONFIG and study.sensor_id == "twin-1" and len(study.sha256) == 64
    trial = study.trials[1]
    np.testing.assert_array_equal(trial.stream["counts"], _trial(10.0).stream["counts"])
    assert trial.truth["kind"].tolist() == ["tip"] * 5 + ["tangential"]
    assert trial.attrs["speed_mm_s"] == 2.0
    with h5py.File(path) as handle:
        assert (handle.attrs["schema"], handle.attrs["schema_version"]) == (SCHEMA, SCHEMA_VERSION)
        missing = []
        handle.visititems(lambda name, obj: missing.append(name)
                          if isinstance(obj, h5py.Dataset) and "units" not in obj.attrs else None)
        assert missing == []


def test_reader_refuses_a_future_major_version(tmp_path):
    path = tmp_path / "study.h5"
    StudyWriter(path, CONFIG, "twin-1")
    with h5py.File(path, "a") as handle:
        handle.attrs["schema_version"] = "2.0.0"
    with pytest.raises(ArtifactError, match="version 2.0.0 is not supported"):
        read_study(path)


@pytest.mark.parametrize("path", RECORDED, ids=lambda p: p.parent.name)
def test_the_recorded_studies_load(path):
    study = read_study(path)
    assert study.complete and study.missing_depths() == [] and study.header
    for trial in study.trials:
        assert len(trial.stream["seq"]) == len(trial.plane["point_mm"]) > 0
