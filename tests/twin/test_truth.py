"""Ground truth: z of poses, the tip-contact curve and its inverse."""

import numpy as np
import pytest

from whiskercal.errors import UsageError
from whiskercal.twin.physics import mechanics
from whiskercal.twin.physics.magnet import field_uT
from whiskercal.twin.params import DEFAULT_SENSOR, SECOND_SENSOR
from whiskercal.twin.truth import (
    TIP_ROD_RADIUS_MM,
    static_field_uT,
    tip_contact_sweep,
    tip_curve,
    true_tip,
    z_of_equilibrium,
    z_of_pose,
)

# The characterized model the authors ran on their robot (reference/README.md): raw Y (µT) ->
# tip (mm).
# A realism target for the twin's defaults only.
AUTHORS_RAW_Y_UT = np.array([0.0, -1000.0, -3000.0, -5000.0, -7000.0, -8760.0, -10000.0])
AUTHORS_REST_RAW_Y_UT = 447.0
AUTHORS_TIP_MM = np.array([
    [77.81, -3.39], [77.02, -10.64], [73.69, -23.44], [68.67, -34.36],
    [61.98, -43.97], [54.43, -50.82], [48.02, -53.57],
])


def test_z_is_zero_at_rest_and_the_y_change_elsewhere():
    assert z_of_pose(DEFAULT_SENSOR, 0.0, [0.0, 0.0]) == pytest.approx(0.0, abs=1e-9)
    pose_field = field_uT(DEFAULT_SENSOR.magnet, -0.1, [0.02, -0.03])
    expected = pose_field[1] - static_field_uT(DEFAULT_SENSOR)[1]
    assert z_of_pose(DEFAULT_SENSOR, -0.1, [0.02, -0.03]) == pytest.approx(expected, rel=1e-12)
    assert z_of_pose(DEFAULT_SENSOR, np.zeros(5), np.zeros((5, 2))).shape == (5,)


def test_contact_pushing_to_minus_y_reads_negative():
    equilibrium = mechanics.solve_rod(DEFAULT_SENSOR.whisker, (50.0, -8.0), 1.5)
    assert equilibrium.kind == "shaft" and equilibrium.root_rotation_rad < 0
    z = z_of_equilibrium(DEFAULT_SENSOR, equilibrium)
    assert z < -300.0
    assert z == pytest.approx(z_of_pose(DEFAULT_SENSOR, equilibrium.root_rotation_rad, equilibrium.root_shift_mm))


def test_tip_curve_starts_undeflected_and_z_falls_monotonically():
    z, tip = tip_curve(DEFAULT_SENSOR, 81)
    assert z.shape == (81,) and tip.shape == (81, 2)
    assert z[0] == pytest.approx(0.0, abs=1e-9)
    np.testing.assert_allclose(tip[0], [DEFAULT_SENSOR.whisker.reach_mm, 0.0])
    assert np.all(np.diff(z) < 0)
    # The default's curve covers the paper's working range with room (target -8760 µT).
    assert z[-1] < -12000.0


def test_each_sweep_sample_is_a_frictionless_contact_at_the_tip():
    whisker = DEFAULT_SENSOR.whisker
    sweep = tip_contact_sweep(whisker, 81)
    for i in (10, 40, 80):
        # Solved afresh along the rod's approach, independently of the sweep's warm starts.
        again = mechanics.solve_rod(whisker, sweep.rod_center_mm[i], TIP_ROD_RADIUS_MM)
        np.testing.assert_allclose(again.tip_mm, sweep.tip_mm[i], atol=1e-4)
        assert again.contact_arc_mm == pytest.approx(whisker.length_mm, abs=1e-3)
        # The rod touches the very tip, pushing perpendicular to the wire there.
        assert np.linalg.norm(sweep.rod_center_mm[i] - again.tip_mm) == pytest.approx(TIP_ROD_RADIUS_MM, abs=1e-4)
        shape = again.shape_mm(400)
        tangent = (shape[-1] - shape[-2]) / np.linalg.norm(shape[-1] - shape[-2])
        assert abs(tangent @ again.force_n) < 1e-3 * np.linalg.norm(again.force_n)
        assert np.arctan2(tangent[1], tangent[0]) == pytest.approx(sweep.tip_slope_rad[i], abs=1e-6)


def test_true_tip_passes_through_the_curve_and_interpolates_between():
    z, tip = tip_curve(DEFAULT_SENSOR, 81)
    np.testing.assert_allclose(true_tip(DEFAULT_SENSOR, z[1:-1], n=81), tip[1:-1], atol=1e-9)
    dense_z, dense_tip = tip_curve(DEFAULT_SENSOR, 161)
    # Every second sample of the denser curve falls between the coarse curve's samples.
    between = true_tip(DEFAULT_SENSOR, dense_z[1:-1:2], n=81)
    assert np.abs(between - dense_tip[1:-1:2]).max() < 0.05


@pytest.mark.parametrize("bad", [10.0, -1e6, np.nan])
def test_true_tip_refuses_z_outside_the_curve(bad):
    with pytest.raises(UsageError, match="range"):
        true_tip(DEFAULT_SENSOR, [-1000.0, bad])


def test_second_sensor_has_its_own_invertible_curve():
    z, tip = tip_curve(SECOND_SENSOR, 41)
    assert np.all(np.diff(z) < 0)
    np.testing.assert_allclose(tip[0], [SECOND_SENSOR.whisker.reach_mm, 0.0])
    middle = 0.5 * z[-1]
    assert true_tip(SECOND_SENSOR, middle, n=41)[1] < 0


def test_default_tip_curve_lies_within_1_2_mm_of_the_authors_model_on_its_raw_footing():
    # The model's input is the raw Y reading, its undeflected point at raw +447 µT: the twin's z
    # from rest is compared at raw - 447 µT (docs/twin.md).
    z_uT = AUTHORS_RAW_Y_UT - AUTHORS_REST_RAW_Y_UT
    distance = np.linalg.norm(true_tip(DEFAULT_SENSOR, z_uT) - AUTHORS_TIP_MM, axis=1)
    assert distance.max() < 1.2
    assert np.sqrt(np.mean(distance**2)) < 0.75


def test_a_coarse_sweep_lands_on_the_same_equilibria_as_a_dense_one():
    coarse = tip_contact_sweep(DEFAULT_SENSOR.whisker, 11)
    dense = tip_contact_sweep(DEFAULT_SENSOR.whisker, 81)
    np.testing.assert_allclose(coarse.tip_mm, dense.tip_mm[::8], atol=1e-5)
    np.testing.assert_allclose(coarse.root_rotation_rad, dense.root_rotation_rad[::8], atol=1e-8)


def test_tip_curve_needs_a_few_samples():
    with pytest.raises(UsageError, match="at least 4"):
        tip_curve(DEFAULT_SENSOR, 3)


def _soft_sensor():
    from pathlib import Path

    from whiskercal.twin.sensor_file import load_sensor

    return load_sensor(Path(__file__).resolve().parents[2] / "sensors" / "short-45mm-soft.toml")


def test_a_soft_suspension_has_a_truth_up_to_where_its_tip_contact_holds():
    # k_θ·L/EI about 1: the wire swings round its root before its tip turns 1.9 rad
    from whiskercal.twin.truth import MAX_TIP_SLOPE_RAD

    soft = _soft_sensor()
    sweep = tip_contact_sweep(soft.whisker, 41)
    assert 1.0 < abs(sweep.tip_slope_rad[-1]) < MAX_TIP_SLOPE_RAD
    assert np.all(np.diff(np.abs(sweep.tip_slope_rad)) > 0)
    z, tips = tip_curve(soft, 41)
    assert z.shape == (41,) and np.all(np.isfinite(tips))
    # the inverse holds over the first branch, up to where z folds back, and refuses past it
    fold = int(np.argmin(z))
    assert 3 < fold < 40
    for k in (1, fold // 2, fold - 1):
        assert true_tip(soft, z[k], n=41) == pytest.approx(tips[k], abs=1e-6)
    with pytest.raises(UsageError, match="range"):
        true_tip(soft, z[fold] - 100.0, n=41)


def _default_with_softer_root(factor: float):
    """The default sensor with its root ``factor`` times less stiff against turning, built the
    way a sensor file is (k_θ 6.0 -> 0.6 N·mm/rad for factor 10)."""
    from whiskercal.twin.sensor_file import sensor_from_dict, sensor_to_dict

    data = sensor_to_dict(DEFAULT_SENSOR)
    data["sensor_id"] = f"default-root-softer-{factor:g}x"
    data["whisker"]["root_rotational_stiffness_n_mm_per_rad"] /= factor
    return sensor_from_dict(data, "test")


def test_a_root_ten_times_softer_has_a_truth_up_to_its_fold():
    # the rod that holds tip contact would have had to stand at the clamp (x < 3 mm)
    soft = _default_with_softer_root(10.0)
    z, tips = tip_curve(soft, 81)
    assert np.all(np.isfinite(z)) and np.all(np.isfinite(tips))
    fold = int(np.argmin(z))
    assert 3 < fold < 80 and np.all(np.diff(z[:fold + 1]) < 0)
    for k in (1, fold // 2, fold):
        assert true_tip(soft, z[k], n=81) == pytest.approx(tips[k], abs=1e-6)
