"""The study's tangential label on a weak build, against where the twin says the contact was.

stiff-root-75mm reads about 50 µT per mm of depth: its tip sticks and slips on the plane as it is
pushed in, and z wanders about its course. The kink test once read that wander as a change of
contact and labelled tip contacts at 20-40 mm tangential. The twin records the contact point of
every sample: at the tip in tip contact, on the shaft short of it once tangential.
"""

from pathlib import Path

import numpy as np
import pytest

from short_study import short_study
from twin_calibration import run_twin_study, write_twin_calibration
from whiskercal import runtime
from whiskercal.artifacts.plane_study import PHASE_SLIDE, read_study
from whiskercal.study.report import build_report
from whiskercal.twin.sensor_file import resolve_sensor

SENSOR_FILE = Path(__file__).resolve().parents[2] / "sensors" / "stiff-root-75mm.toml"

STUDY = short_study([5, 10, 15, 20, 25, 30, 35, 40, 45])


@pytest.fixture(scope="module")
def weak_study(tmp_path_factory):
    folder = tmp_path_factory.mktemp("weak")
    calibration = write_twin_calibration(folder / "CAL.h5", resolve_sensor(str(SENSOR_FILE)))
    path, _config, _world = run_twin_study(folder, STUDY, "study-weak-labels", 7,
                                           sensor=str(SENSOR_FILE))
    return read_study(path), build_report(path, runtime.load(calibration))


def _contact_short_of_tip_mm(trial) -> np.ndarray:
    """How far (mm) the twin's contact point lies from its true tip, per slide sample."""
    slide = trial.stream["phase"] == PHASE_SLIDE
    return np.linalg.norm(trial.truth["contact_mm"][slide] - trial.truth["tip_mm"][slide], axis=1)


@pytest.mark.slow  # the nine-trial study on the twin, about 5 s
def test_tip_contacts_are_not_labelled_tangential_and_the_tangential_one_is(weak_study):
    study, report = weak_study
    for row in report.rows:
        trial = next(t for t in study.trials if t.depth_mm == row.depth_mm)
        short_mm = _contact_short_of_tip_mm(trial)
        if np.all(short_mm < 1e-6):         # the twin touched the plane with the tip throughout
            assert not row.tangential, (row.depth_mm, row.reasons)
        else:                               # ... or with the shaft, well short of the tip
            assert row.depth_mm == 45.0 and np.min(short_mm) > 1.0, row.depth_mm
            assert row.tangential, row.reasons
    assert sum(row.tangential for row in report.rows) == 1
