"""The plane study's shaft phases on synthetic trials: a flat plane pressed onto the shaft of the
synthetic angle surface, where the contact point is known exactly (no twin, no fit)."""

from pathlib import Path

import numpy as np
import pytest

from shaft_synthetic import AngleSurface

from whiskercal.artifacts.plane_study import Study, TrialRecord
from whiskercal.errors import ArtifactError
from whiskercal.model.shaft import ShaftParams
from whiskercal.runtime_shaft import ONSET_UT, ShaftTracker
from whiskercal.shaftstudy import plane_phases as phases

STATIC_UT = (10.0, 200.0, -30.0)  # the sensor's reading at rest (µT), subtracted from Y
TRACE_MM = 80.0


def _trial(x_mm=45.0, push_mm=8.0, slide_mm=30.0, static_in_attrs=True, scale=1.0, seed=0):
    """The plane (normal +y) pushes the whisker at ``x_mm`` to y = -push_mm while sliding
    ``slide_mm`` along itself; the contact point stays at ``x_mm`` (mm)."""
    y = -np.arange(0.0, push_mm + 0.025, 0.05)
    n = len(y)
    contact = np.column_stack([np.full(n, x_mm), y])
    z = scale * AngleSurface()(contact)
    field = np.tile(STATIC_UT, (n, 1))
    field[:, 1] += z + np.random.default_rng(seed).normal(0.0, 5.0, n)
    point = np.column_stack([7.0 + np.linspace(0.0, slide_mm, n), y + 3.0])
    attrs = {"static_field_uT": np.asarray(STATIC_UT)} if static_in_attrs else {}
    return TrialRecord(depth_mm=push_mm, stream={"field_uT": field}, stage={},
                       plane={"point_mm": point, "normal": np.tile([0.0, 1.0], (n, 1))},
                       attrs=attrs, truth={"contact_mm": contact, "z_uT": z,
                                           "kind": np.where(np.abs(z) > 0, "tangential", "free")})


def _study(trials, baseline=STATIC_UT):
    return Study(Path("plane.h5"), {}, "synthetic", "", True,
                 {"baseline_field_uT": np.asarray(baseline)}, trials)


@pytest.fixture(autouse=True)
def synthetic_tracker(monkeypatch):
    params = ShaftParams(noise_uT=5.0, search_x_mm=(10.0, TRACE_MM))
    monkeypatch.setattr(phases, "shaft_tracker",
                        lambda calibration: ShaftTracker(AngleSurface(), params, TRACE_MM))


def test_a_point_contact_on_the_shaft_is_called_shaft_and_localized():
    trial = _trial()
    row = phases.track_plane_trial(_study([trial]), trial, None)
    assert row.samples_on_shaft == int(np.sum(np.abs(trial.truth["z_uT"]) > ONSET_UT))
    assert row.called_tip == 0.0 and row.called_shaft > 0.9
    assert 0.3 < row.localized_share < 1.0  # withheld until the plane has travelled
    assert row.median_error_mm < 0.3 and row.median_error_mm <= row.p90_error_mm
    assert row.rough_median_error_mm < 0.5


def test_the_planes_slide_along_itself_and_the_static_source_change_nothing():
    study = _study([])
    slid = phases.track_plane_trial(study, _trial(slide_mm=30.0), None)
    assert phases.track_plane_trial(study, _trial(slide_mm=0.0), None) == slid
    # no static reading with the trial: the header's baseline is the one subtracted
    assert phases.track_plane_trial(study, _trial(static_in_attrs=False), None) == slid
    shifted = _study([], baseline=np.add(STATIC_UT, [0.0, 300.0, 0.0]))
    assert phases.track_plane_trial(shifted, _trial(static_in_attrs=False), None) != slid


def test_a_contact_too_weak_to_judge_gives_no_numbers():
    trial = _trial(scale=1e-3)
    row = phases.track_plane_trial(_study([trial]), trial, None)
    assert row.samples_on_shaft == 0
    assert all(np.isnan(v) for k, v in row.as_dict().items() if k not in ("depth_mm", "samples_on_shaft"))


def test_plane_phases_keeps_trials_on_the_shaft_and_refuses_a_study_without_truth(monkeypatch):
    off_shaft = _trial(push_mm=4.0)
    off_shaft.truth["kind"] = np.full(len(off_shaft.truth["z_uT"]), "tip")
    study = _study([off_shaft, _trial()])
    monkeypatch.setattr(phases, "read_study", lambda path: study)
    rows = phases.plane_phases("plane.h5", None)
    assert [row.depth_mm for row in rows] == [8.0]
    study.trials.append(_trial(push_mm=6.0))
    study.trials[-1].truth = None
    with pytest.raises(ArtifactError, match="no twin truth"):
        phases.plane_phases("plane.h5", None)
