"""The model's former silent failures, each now detected: a coarse fixed step, a grid that stops
short of the tip, an under-fitting surface. Known surfaces and seeded twin grids."""

from dataclasses import replace

import numpy as np
import pytest

from analytic import bent_tip_mm, bent_z, paper_grid_mm, rigid_z
from twin_grid import twin_grid
from whiskercal.model import trace as trace_module
from whiskercal.model.calibrate import MAX_EXTENSION_MM, CalibrationOptions, calibrate
from whiskercal.model.diagnostics import (UNDERFIT_FACTOR, UNDERFIT_SHIFT_MM, expected_noise_uT,
                                          underfit_warning)
from whiskercal.model.uncertainty import TIP_SPREAD_WARN_MM
from whiskercal.model.errors import ExtrapolationLimitError, TraceDriftError, ZOutOfRangeError
from whiskercal.model.surface import fit_surface
from whiskercal.model.trace import Domain, LevelSetProblem, drift_tolerance_mm, trace_paper
from whiskercal.twin import truth
from whiskercal.twin.params import DEFAULT_SENSOR

LENGTH_MM = 78.0
WIDE_GRID = paper_grid_mm(reach=(12.5, 90.0), angle_deg=(-50.0, 5.0))


@pytest.fixture(scope="module")
def bent():
    surface, _ = fit_surface(WIDE_GRID, bent_z(WIDE_GRID), 6, "polar")
    z = bent_z(WIDE_GRID)
    return LevelSetProblem(surface, Domain.from_points(WIDE_GRID, 1.0), LENGTH_MM,
                           (float(z.min()), float(z.max())), 26.0)


# --- 1. the paper's fixed step -------------------------------------------------------------

def test_a_coarse_fixed_step_raises_with_its_step_and_drift(bent):
    with pytest.raises(TraceDriftError, match=r"with a 20 mm step drifted [0-9.]+ mm off the level "
                                              r"set \(tolerance 0.6 mm"):
        trace_paper(bent, -3000.0, 20.0)


def test_without_the_check_the_coarse_step_would_return_a_wrong_tip(bent, monkeypatch):
    monkeypatch.setattr(trace_module, "DRIFT_FRACTION_OF_STEP", np.inf)
    wrong = trace_paper(bent, -3000.0, 20.0).tip_mm
    # over ten times the 0.04 mm bound that the passing steps meet (below)
    assert np.linalg.norm(wrong - bent_tip_mm(-3000.0, LENGTH_MM, 26.0)) > 10 * 0.04


@pytest.mark.parametrize("step_mm", [0.1, 1.0, 5.0])
def test_steps_within_the_tolerance_pass_and_stay_accurate(bent, step_mm):
    tip = trace_paper(bent, -3000.0, step_mm).tip_mm
    assert np.linalg.norm(tip - bent_tip_mm(-3000.0, LENGTH_MM, 26.0)) < 0.04


def test_drift_tolerance_scales_with_the_step():
    assert drift_tolerance_mm(10.0) == pytest.approx(10 * drift_tolerance_mm(1.0))
    assert drift_tolerance_mm(0.0) > 0.0  # round-off at a vanishing step is not drift


# --- 2. a grid that stops short of the tip --------------------------------------------------

@pytest.fixture(scope="module")
def grid():
    return twin_grid(noise_uT=1.0, seed=4)


def cut(grid, reach_mm: float, **options):
    keep = np.hypot(*grid.rod_center_mm.T) <= reach_mm
    return calibrate(grid.rod_center_mm[keep], grid.z_uT[keep], grid.rod_radius_mm,
                     CalibrationOptions(trace_length_mm=DEFAULT_SENSOR.whisker.reach_mm, **options),
                     np.ones(int(keep.sum())))


def truth_error_mm(lookup, low: float, high: float) -> np.ndarray:
    z, tips = truth.tip_curve(DEFAULT_SENSOR)
    inside = (z >= low) & (z <= high)
    return np.linalg.norm(lookup(z[inside]) - tips[inside], axis=1)


def test_the_default_grid_stays_within_the_extension_limit(grid):
    calibration = cut(grid, 100.0)
    report = calibration.lookup_report
    assert not calibration.extrapolated
    assert 0.0 < report.max_extension_mm <= MAX_EXTENSION_MM
    assert report.knot_extension_mm.shape == calibration.lookup.z_knots_uT.shape
    assert calibration.trusted_z_uT == (calibration.lookup.z_min_uT, calibration.lookup.z_max_uT)


def test_a_short_grid_is_refused_with_the_extension_it_needs(grid):
    with pytest.raises(ExtrapolationLimitError,
                       match=r"stops short of the tip: .* up to 1\d\.\d mm straight past the grid's "
                             r"far edge, more than the 9.5 mm"):
        cut(grid, 65.0)


def test_what_the_limit_refuses_was_wrong(grid):
    # written anyway, the 60 mm grid's tips are off by more than the paper's 2 mm bound
    calibration = cut(grid, 60.0, allow_extrapolation=True)
    assert calibration.extrapolated and calibration.trusted_z_uT is None
    full = calibration.lookup
    assert truth_error_mm(full, full.z_min_uT, full.z_max_uT).max() > 2.0


def test_allowed_extrapolation_marks_the_range_and_the_lookup_refuses_it(grid):
    calibration = cut(grid, 70.0, allow_extrapolation=True)
    low, high = calibration.trusted_z_uT
    knots = calibration.lookup.z_knots_uT
    assert calibration.extrapolated and knots[0] <= low < high < knots[-1]
    assert any("stops short of the tip" in w for w in calibration.warnings)
    calibration.lookup((low + high) / 2)
    with pytest.raises(ZOutOfRangeError, match="outside the trusted range"):
        calibration.lookup(high + 1.0)
    # the trusted end is where the capped trace just manages
    capped = replace(calibration.problem, tip_extension_mm=MAX_EXTENSION_MM)
    assert trace_module.trace_fast(capped, low).extension_mm <= MAX_EXTENSION_MM


# --- 3. under-fitting ------------------------------------------------------------------------

def test_underfit_warning_names_the_numbers():
    assert underfit_warning(0.99 * UNDERFIT_FACTOR, 1.0, 0.25, 5) is None
    # far above the noise, but the level sets move by less than the shift that matters
    assert underfit_warning(40.0, 2.0, 0.9 * UNDERFIT_SHIFT_MM, 5) is None
    message = underfit_warning(40.0, 2.0, 0.25, 5)
    assert "CV RMSE 40.0 µT is 20.0 times the 2.00 µT noise" in message and "0.250 mm" in message
    assert "a higher degree" in message
    assert "the highest" in underfit_warning(40.0, 2.0, 0.25, 8)
    assert underfit_warning(40.0, float("nan"), 0.25, 5) is None
    assert expected_noise_uT(np.array([3.0, 4.0])) == pytest.approx(np.sqrt(12.5))


@pytest.mark.parametrize("degree, warned", [(1, True), (5, False)])
def test_calibrate_warns_when_the_surface_underfits_the_noise(degree, warned):
    points = paper_grid_mm()
    noise_uT = 1.0
    z = rigid_z(points) + np.random.default_rng(3).normal(0.0, noise_uT, len(points))
    calibration = calibrate(points, z, 0.0, CalibrationOptions(degree=degree, trace_length_mm=70.0),
                            np.full(len(points), noise_uT))
    assert calibration.expected_noise_uT == pytest.approx(noise_uT)
    ratio = calibration.fit.cv_rmse_uT / noise_uT
    assert (ratio > UNDERFIT_FACTOR and calibration.cv_level_set_shift_mm > UNDERFIT_SHIFT_MM) == warned
    assert any("under-fits" in w for w in calibration.warnings) == warned


# --- 4. the same input gives the same calibration ---------------------------------------------

def test_calibrating_the_same_grid_twice_is_bit_identical(grid):
    first, second = cut(grid, 100.0), cut(replace(grid), 100.0)
    assert first.lookup.z_knots_uT.tobytes() == second.lookup.z_knots_uT.tobytes()
    assert first.lookup.tips_mm.tobytes() == second.lookup.tips_mm.tobytes()
    assert first.surface.coefficients.tobytes() == second.surface.coefficients.tobytes()


# --- 6. scatter: a surface that fits noisy data as well as it can, tips still off ------------

def test_scatter_warning_when_the_redrawn_surfaces_move_the_tips():
    points = paper_grid_mm()
    rng = np.random.default_rng(11)
    options = CalibrationOptions(degree=5, trace_length_mm=70.0)
    clean = calibrate(points, rigid_z(points) + rng.normal(0.0, 1.0, len(points)), 0.0, options)
    noisy = calibrate(points, rigid_z(points) + rng.normal(0.0, 300.0, len(points)), 0.0, options)
    assert clean.tip_spread_mm < 0.1 and not any("scatter" in w for w in clean.warnings)
    assert noisy.tip_spread_mm > TIP_SPREAD_WARN_MM
    assert any("scatter" in w and f"{noisy.tip_spread_mm:.2f} mm" in w for w in noisy.warnings)
    # seeded: the same grid gives the same spread
    assert calibrate(points, rigid_z(points), 0.0, options).tip_spread_mm == \
        calibrate(points, rigid_z(points), 0.0, options).tip_spread_mm
