"""The surface fit: exactness on polynomials, gradients, degree choice, refusals."""

import numpy as np
import pytest

from analytic import paper_grid_mm, rigid_z
from whiskercal.model.errors import FitError
from whiskercal.model.surface import choose_degree, fit_surface, to_coordinates

POINTS = paper_grid_mm()


def cubic_xy(p):
    x, y = p[..., 0] / 10.0, p[..., 1] / 10.0
    return 50.0 + 30.0 * x - 20.0 * y + 4.0 * x * y - 3.0 * x ** 2 * y + 0.5 * y ** 3


@pytest.mark.parametrize("coordinates", ["cartesian", "polar"])
def test_reproduces_a_polynomial_in_its_own_variables(coordinates):
    variables = to_coordinates(POINTS, coordinates)
    z = cubic_xy(variables * [1.0, 100.0] if coordinates == "polar" else variables)
    surface, report = fit_surface(POINTS, z, 3, coordinates)
    assert report.rmse_uT < 1e-8 * np.ptp(z)
    assert report.r2 == pytest.approx(1.0, abs=1e-12)
    probe = np.array([[40.0, -10.0], [25.0, -20.0]])
    expected = cubic_xy(to_coordinates(probe, coordinates) * ([1.0, 100.0] if coordinates == "polar" else 1.0))
    np.testing.assert_allclose(surface(probe), expected, rtol=1e-9)


@pytest.mark.parametrize("coordinates", ["cartesian", "polar"])
def test_gradient_matches_finite_differences_and_scalar_path(coordinates):
    surface, _ = fit_surface(POINTS, rigid_z(POINTS), 6, coordinates)
    probe = np.array([[33.0, -12.0], [50.0, -3.0], [20.0, -15.0]])
    h = 1e-5
    numeric = np.stack([(surface(probe + [h, 0]) - surface(probe - [h, 0])) / (2 * h),
                        (surface(probe + [0, h]) - surface(probe - [0, h])) / (2 * h)], axis=-1)
    np.testing.assert_allclose(surface.gradient(probe), numeric, rtol=1e-6)
    for point, value, grad in zip(probe, surface(probe), surface.gradient(probe)):
        f, fx, fy = surface.value_and_gradient(*point)
        assert f == pytest.approx(value, rel=1e-12)
        np.testing.assert_allclose([fx, fy], grad, rtol=1e-10)


def test_polar_fits_the_rigid_whisker_far_better_than_cartesian():
    z = rigid_z(POINTS)
    _, polar = fit_surface(POINTS, z, 5, "polar")
    _, cartesian = fit_surface(POINTS, z, 5, "cartesian")
    assert polar.rmse_uT < 1e-6 * np.ptp(z)  # a cubic in θ: exact
    assert cartesian.rmse_uT > 1e3 * polar.rmse_uT


def test_auto_degree_does_not_model_more_than_the_data_needs():
    rng = np.random.default_rng(7)
    variables = to_coordinates(POINTS, "cartesian")
    z = cubic_xy(variables) + rng.normal(0.0, 0.5, len(POINTS))
    surface, report = fit_surface(POINTS, z, "auto", "cartesian")
    assert surface.degree == 3
    assert report.rmse_uT == pytest.approx(0.5, rel=0.25)  # residuals are the noise
    assert np.isfinite(report.cv_rmse_by_degree).sum() == 8


def test_one_standard_error_rule():
    degrees = np.arange(1, 6)
    cv = np.array([10.0, 3.0, 2.05, 2.0, 2.1])
    se = np.array([1.0, 0.5, 0.1, 0.1, 0.1])
    assert choose_degree(degrees, cv, se) == 3


def test_too_few_points_and_degenerate_grids_are_refused():
    with pytest.raises(FitError, match="needs 21 points"):
        fit_surface(POINTS[:12], rigid_z(POINTS[:12]), 5)
    line = np.column_stack([np.linspace(20, 60, 40), np.zeros(40)])
    with pytest.raises(FitError):
        fit_surface(line, np.arange(40.0), 2, "cartesian")
    with pytest.raises(FitError, match="non-finite"):
        fit_surface(POINTS, np.full(len(POINTS), np.nan), 2)
