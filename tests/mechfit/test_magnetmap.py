"""The multipole magnet pose map: its own form recovered, and its extrapolation off the grid.

Measured with seed 0 (docs/calibration.md): fitted to the default twin's grid on its true poses,
the map errs 0.5 / 0.5 µT RMS (Y / Z) on the true poses of plane contacts with friction, where
the degree-3 polynomial fitted to the same grid is off by orders of magnitude more.
"""

import numpy as np
from numpy.polynomial import legendre

from whiskercal.testing.fields import (NOISE_UT, ROD_RADIUS_MM, STAGE_OFFSET_MM,
                                       pose_fields_of_poses, realistic_pose_contacts,
                                       simulate_fields, true_suspension)
from whiskercal.mechfit.fieldmap import fit_pose_map
from whiskercal.mechfit.forward import pose_of, rod_equilibria
from whiskercal.mechfit.magnetmap import (MagnetPoseMap, fit_magnet_map, multipole_basis,
                                          relative_basis)
from whiskercal.twin.params import DEFAULT_SENSOR


def test_the_map_is_zero_at_rest_and_recovers_its_own_form():
    rng = np.random.default_rng(0)
    geometry = np.array([-4.0, 0.05, 0.02, -6.4, 0.15, 0.1, 0.04])
    strengths = np.array([-2e5, 3e4, -1e4, 2e3])
    truth = MagnetPoseMap(geometry, strengths)
    assert np.allclose(truth(np.zeros(3)), 0.0)
    grid = np.column_stack([rng.uniform(-0.2, 0.0, 150), rng.uniform(-0.3, 0.0, 150),
                            rng.uniform(-0.4, 0.0, 150)])
    fitted, residual = fit_magnet_map(grid, truth(grid))
    elsewhere = np.column_stack([rng.uniform(-0.15, 0.0, 50), rng.uniform(-0.15, 0.0, 50),
                                 rng.uniform(-0.05, 0.1, 50)])
    assert np.abs(residual).max() < 1e-3 * np.abs(truth(grid)).max()
    assert np.abs(fitted(elsewhere) - truth(elsewhere)).max() < 1e-2 * np.abs(truth(grid)).max()


def test_the_basis_is_finite_away_from_the_source():
    basis = relative_basis(np.array([-4.0, 0.0, 0.0, -6.5, 0.0, 0.05, 0.0]),
                           np.array([[-0.1, -0.05, 0.02]]))
    assert basis.shape == (1, 4, 2) and np.all(np.isfinite(basis))


def test_on_the_twin_the_map_extrapolates_to_plane_contacts():
    grid = simulate_fields(DEFAULT_SENSOR, seed=0)
    # the twin's poses, each rod where it sat (off its recorded place by the stage's offset)
    rods = grid.rod_center_mm + np.array(STAGE_OFFSET_MM)
    equilibria = rod_equilibria(true_suspension(DEFAULT_SENSOR), rods, ROD_RADIUS_MM)
    poses = np.array([pose_of(e) for e in equilibria])
    contacts = realistic_pose_contacts(DEFAULT_SENSOR, (grid.fields_uT[:, 0].min(), 0.0))
    truth = pose_fields_of_poses(DEFAULT_SENSOR, contacts)
    weights = 1.0 / np.array(NOISE_UT)
    magnet, _ = fit_magnet_map(poses, grid.fields_uT, weights)
    polynomial, _ = fit_pose_map(poses, grid.fields_uT, weights=weights)
    magnet_rms = np.sqrt(np.mean((magnet(contacts) - truth) ** 2, axis=0))
    polynomial_rms = np.sqrt(np.mean((polynomial(contacts) - truth) ** 2, axis=0))
    assert len(contacts) > 100
    assert np.all(magnet_rms < 5.0)  # µT; the noise of one sample is 5.6 / 9.0
    assert np.all(polynomial_rms > 10 * magnet_rms)


def test_the_rest_basis_kept_for_a_geometry_is_the_one_computed_afresh():
    # the geometry is read by value: an array changed in place after a call is a new geometry
    geometry = np.array([-4.0, 0.05, 0.02, -6.4, 0.15, 0.1, 0.04])
    poses = np.random.default_rng(1).uniform(-0.2, 0.0, (20, 3))
    for _ in range(2):
        fresh = multipole_basis(geometry, poses) - multipole_basis(geometry, np.zeros(3))
        assert np.array_equal(relative_basis(geometry, poses), fresh)
        geometry[0] -= 0.5
    assert not np.array_equal(relative_basis(geometry, poses), fresh)


def _potential_field(geometry, pose, order, step_mm=1e-5):
    """-grad of P_l(u·r̂)/r^(l+1) at the sensing point by central differences, in the chip's
    (Y, Z) axes: the basis's definition, evaluated apart from its compiled loop."""
    cx, cy, axis, sx, sy, sw, tilt = geometry
    rotation, shift = pose[0], pose[1:]
    turn = np.array([[np.cos(rotation), -np.sin(rotation)], [np.sin(rotation), np.cos(rotation)]])
    center = np.append(turn @ [cx, cy] + shift, 0.0)
    u = np.array([np.cos(rotation + axis), np.sin(rotation + axis), 0.0])
    coefficients = np.eye(order + 1)[order]

    def potential(point):
        r = point - center
        distance = np.linalg.norm(r)
        return legendre.legval(u @ r / distance, coefficients) / distance ** (order + 1)

    point = np.array([sx, sy, sw])
    gradient = np.array([(potential(point + step) - potential(point - step)) / (2 * step_mm)
                         for step in np.eye(3) * step_mm])
    chip = np.array([[np.sin(tilt), np.cos(tilt), 0.0], [np.cos(tilt), -np.sin(tilt), 0.0]])
    return chip @ -gradient


def test_the_basis_is_the_multipoles_field_for_every_order_and_pose():
    rng = np.random.default_rng(2)
    orders = (1, 2, 3, 4, 5, 6)
    for _ in range(20):
        geometry = np.array([-4.0, 0.05, 0.02, -6.4, 0.15, 0.1, 0.04]) + rng.normal(0, 0.3, 7)
        poses = rng.normal(0.0, [0.05, 0.3, 0.3], (5, 3))
        basis = multipole_basis(geometry, poses, orders)
        for pose, fields in zip(poses, basis):
            for order, field in zip(orders, fields):
                expected = _potential_field(geometry, pose, order)
                # central differences of a smooth potential at 1e-5 mm, a few mm from its
                # source: good to about 1e-8 of the field; the loop's rounding is 1e-14
                assert np.allclose(field, expected, rtol=1e-6, atol=1e-6 * np.abs(expected).max())
    assert multipole_basis(geometry, np.zeros((2, 5, 3)), orders).shape == (2, 5, 6, 2)
