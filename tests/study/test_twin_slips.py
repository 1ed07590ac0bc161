"""The study's slip detector on the twin's stick-slip: a slow slide resolves every slip."""

import numpy as np
import pytest

from short_study import short_study
from twin_calibration import run_twin_study
from whiskercal import runtime
from whiskercal.artifacts.plane_study import PHASE_SLIDE, read_study
from whiskercal.study.report import build_report
from whiskercal.study.truth import match_rows

# One trial at the paper's 40 mm, slid at 1 mm/s: the twin's sawtooth (period ~0.1 mm at this
# depth) spans ~30 samples at 300 Hz. At the study's 10 mm/s it spans ~3 and is not resolved.
SLOW_SLIDE = short_study([40.0], travel_mm=3.0, slide="speed_mm_s = 1.0\n")


@pytest.fixture(scope="module")
def slow_study(tmp_path_factory):
    path, _config, world = run_twin_study(tmp_path_factory.mktemp("slips"), SLOW_SLIDE, "study-slips", 13)
    return path, world


def test_the_detector_finds_the_twins_slips(slow_study, twin_calibration):
    path, world = slow_study
    row = build_report(path, runtime.load(twin_calibration)).rows[0]
    trial = read_study(path).trials[0]
    slide_t_s = trial.stream["t_s"][trial.stream["phase"] == PHASE_SLIDE]
    truth = world.truth.arrays()
    rows = match_rows(truth["t_s"], slide_t_s, 0.5 / 300.0)
    assert np.all(rows >= 0)
    true_slips = np.flatnonzero(truth["slips"][rows] > 0)
    steady = true_slips[true_slips > 100]          # the push-in's friction state settles first
    assert steady.size >= 15                          # ~3 mm of sawtooth
    found = np.asarray(row.slip_indices)
    # every true slip found at its sample, and nothing else reported
    assert np.isin(steady, found).mean() >= 0.9
    assert np.isin(found, true_slips).all()
    assert not row.failing, row.reasons
