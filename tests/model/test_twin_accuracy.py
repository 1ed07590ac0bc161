"""The whole calibration on grids generated from the twin's physics, against the twin's truth.

Measured on the default sensor (docs/model.md has the table): the lookup's error against the
true tips (tip contact) is the level-set method's model error, about 0.5 mm at small deflection
growing to 2 mm and more at the largest; the lookup itself reproduces its traces far better.
"""

import numpy as np
import pytest

from twin_grid import twin_grid
from whiskercal.model.calibrate import CalibrationOptions, calibrate
from whiskercal.twin import truth
from whiskercal.twin.params import DEFAULT_SENSOR


@pytest.fixture(scope="module")
def grid():
    return twin_grid(noise_uT=1.0, seed=4)


def truth_rmse_mm(calibration) -> float:
    z, tips = truth.tip_curve(DEFAULT_SENSOR)
    lookup = calibration.lookup
    inside = (z >= lookup.z_min_uT) & (z <= lookup.z_max_uT)
    assert inside.sum() > 20
    error = np.linalg.norm(lookup(z[inside]) - tips[inside], axis=1)
    return float(np.sqrt(np.mean(error ** 2)))


def fit(grid, **options):
    return calibrate(grid.rod_center_mm, grid.z_uT, grid.rod_radius_mm,
                     CalibrationOptions(degree="auto", trace_length_mm=DEFAULT_SENSOR.whisker.reach_mm,
                                        **options), np.ones(len(grid.z_uT)))


@pytest.fixture(scope="module")
def default_fit(grid):
    """The grid fitted with the default options (the tests below only read it)."""
    return fit(grid)


def test_rod_correction_moves_points_onto_the_shaft(grid, default_fit):
    calibration = default_fit
    true_contact = grid.contact_mm[calibration.used]
    before = np.linalg.norm(grid.rod_center_mm[calibration.used] - true_contact, axis=1)
    after = np.linalg.norm(calibration.contact_points_mm - true_contact, axis=1)
    assert np.allclose(before, grid.rod_radius_mm)
    assert np.mean(after) < 0.5 * grid.rod_radius_mm


def test_lookup_against_the_twins_true_tips(default_fit):
    calibration = default_fit
    rmse = truth_rmse_mm(calibration)
    assert rmse < 0.1 * DEFAULT_SENSOR.whisker.reach_mm
    assert calibration.lookup_report.holdout_rmse_mm < 0.1 * rmse
    assert calibration.fit.r2 > 0.999


def test_rod_correction_and_fitting_the_traced_region_both_pay(grid, default_fit):
    best = truth_rmse_mm(default_fit)
    assert best < truth_rmse_mm(fit(grid, correct_rod_radius=False))
    assert best < truth_rmse_mm(fit(grid, fit_traced_region_only=False))
