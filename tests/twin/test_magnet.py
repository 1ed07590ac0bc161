"""The magnet's field: frames, symmetry, the dipole limit and the interpolation table."""

from dataclasses import replace

import magpylib as magpy
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from whiskercal.errors import UsageError
from whiskercal.twin.physics.magnet import (
    FieldGrid,
    MagnetParams,
    dipole_field_uT,
    exact_field_uT,
    field_uT,
    interpolation_error_uT,
)

ALIGNED = MagnetParams(diameter_mm=4.0, height_mm=2.0, polarization_T=-1.3, magnet_center_mm=-2.0, gap_mm=4.0)


def _magpylib_object_field_uT(magnet, rotation, shift):
    """The same field through magpylib's object interface: an independent frame bookkeeping."""
    cylinder = magpy.magnet.Cylinder(
        dimension=(magnet.diameter_mm, magnet.height_mm), polarization=(0.0, 0.0, magnet.polarization_T)
    )
    # The cylinder's own axis (z) lies along the whisker's x, then the suspension turns it.
    cylinder.orientation = Rotation.from_rotvec([0.0, 0.0, rotation]) * Rotation.from_rotvec([0.0, np.pi / 2, 0.0])
    center = magnet.magnet_center_mm * np.array([np.cos(rotation), np.sin(rotation), 0.0])
    cylinder.position = center + np.array([shift[0], shift[1], 0.0])
    field_T = cylinder.getB(magnet.sensor_position_mm())
    return field_T @ magnet.sensor_axes().T * 1e6


@pytest.mark.parametrize("rotation, shift", [(-0.4, (0.1, -0.2)), (0.3, (-0.3, 0.05)), (-1.1, (0.0, 0.0))])
def test_exact_field_matches_magpylib_object_interface(rotation, shift):
    magnet = replace(ALIGNED, sensor_tilt_rad=0.04, sensor_offset_mm=(0.1, -0.2, 0.3))
    expected = _magpylib_object_field_uT(magnet, rotation, shift)
    np.testing.assert_allclose(exact_field_uT(magnet, rotation, shift), expected, rtol=1e-9, atol=1e-6)


def test_undeflected_aligned_magnet_reads_only_on_the_axis():
    field = exact_field_uT(ALIGNED, 0.0, [0.0, 0.0])
    assert abs(field[0]) < 1e-9 and abs(field[1]) < 1e-9
    # North face towards the sensor: the axial field points away from the magnet, down (-Z).
    assert field[2] < -1000.0


def test_misalignment_tilt_leaks_axial_field_into_y_at_rest():
    tilt = -0.05
    field = exact_field_uT(replace(ALIGNED, sensor_tilt_rad=tilt), 0.0, [0.0, 0.0])
    aligned_axial = exact_field_uT(ALIGNED, 0.0, [0.0, 0.0])[2]
    np.testing.assert_allclose(field[1], aligned_axial * np.sin(tilt), rtol=1e-12)
    assert abs(field[0]) < 1e-9


def test_opposite_rotations_give_opposite_y_and_equal_z_without_misalignment():
    rotation = np.linspace(0.05, 1.2, 9)
    plus = exact_field_uT(ALIGNED, rotation, [0.0, 0.0])
    minus = exact_field_uT(ALIGNED, -rotation, [0.0, 0.0])
    np.testing.assert_allclose(minus[:, 1], -plus[:, 1], rtol=1e-12)
    np.testing.assert_allclose(minus[:, 2], plus[:, 2], rtol=1e-12)
    # Contacts turn the root negative; the sensor then reads negative on Y, as the real one does.
    assert np.all(minus[:, 1] < 0)


def _dipole_relative_error(gap_mm):
    magnet = replace(ALIGNED, gap_mm=gap_mm)
    rotation, shift = np.array([0.0, -0.3, -0.8]), np.zeros((3, 2))
    exact, dipole = exact_field_uT(magnet, rotation, shift), dipole_field_uT(magnet, rotation, shift)
    return np.abs(exact - dipole).max() / np.abs(exact).max()


def test_dipole_limit_far_from_the_magnet():
    near, mid, far = (_dipole_relative_error(gap) for gap in (15.0, 30.0, 60.0))
    assert far < 2e-3
    # The leading correction falls as (size / distance)²: doubling the distance quarters it.
    assert near > 3 * mid > 9 * far


def test_dipole_is_a_poor_model_close_to_the_magnet():
    rotation = np.array([0.0, -0.5])
    exact, dipole = exact_field_uT(ALIGNED, rotation, np.zeros((2, 2))), dipole_field_uT(ALIGNED, rotation, np.zeros((2, 2)))
    # At a gap of one magnet diameter the point-dipole picture is off by well over 1 %.
    assert np.abs(exact - dipole).max() > 0.01 * np.abs(exact).max()


def test_interpolated_field_within_half_a_microtesla_of_exact():
    magnet = replace(ALIGNED, sensor_tilt_rad=0.05, sensor_offset_mm=(0.0, 0.1, 0.1))
    assert interpolation_error_uT(magnet, n_poses=3000, seed=7).max() < 0.5


def test_interpolation_error_check_can_fail_on_a_coarse_grid():
    coarse = replace(ALIGNED, grid=FieldGrid(rotation_step_rad=0.2, shift_step_mm=1.0, pad_cells=3))
    assert interpolation_error_uT(coarse, n_poses=500, seed=1).max() > 0.5


def test_poses_outside_the_grid_fall_back_to_the_exact_field():
    rotation = np.array([-0.2, -1.6, 0.0])
    shift = np.array([[0.0, 0.0], [0.0, 0.0], [2.5, -0.4]])
    got = field_uT(ALIGNED, rotation, shift)
    np.testing.assert_allclose(got[1:], exact_field_uT(ALIGNED, rotation[1:], shift[1:]), rtol=1e-12)
    np.testing.assert_allclose(got[0], exact_field_uT(ALIGNED, rotation[0], shift[0]), atol=0.5)


def test_field_broadcasts_poses():
    rotation = np.zeros((4, 5))
    assert field_uT(ALIGNED, rotation, [0.1, 0.0]).shape == (4, 5, 3)
    assert field_uT(ALIGNED, -0.1, np.zeros((2, 2))).shape == (2, 3)
    assert field_uT(ALIGNED, -0.1, [0.0, 0.0]).shape == (3,)


def test_shift_must_have_two_components():
    with pytest.raises(UsageError, match="length 2"):
        field_uT(ALIGNED, 0.0, [0.0, 0.0, 0.0])


@pytest.mark.parametrize("bad", [dict(diameter_mm=0.0), dict(gap_mm=-1.0), dict(polarization_T=np.nan),
                                 dict(sensor_offset_mm=(0.0, 0.0))])
def test_magnet_params_are_validated(bad):
    with pytest.raises(UsageError):
        replace(ALIGNED, **bad)


@pytest.mark.parametrize("bad", [dict(rotation_rad=(0.5, -0.5)), dict(shift_step_mm=0.0), dict(pad_cells=1)])
def test_field_grid_is_validated(bad):
    with pytest.raises(UsageError):
        FieldGrid(**bad)
