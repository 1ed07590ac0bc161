"""The shipped sensors: identity, and the default's realism against the real sensor."""

from dataclasses import replace

import numpy as np
import pytest

from whiskercal.collect.config import load_config as load_collect_config
from whiskercal.collect.plan import lattice_points
from whiskercal.errors import UsageError
from whiskercal.study.config import load_config as load_study_config
from whiskercal.twin.physics.contacts import solve_rod
from whiskercal.twin.physics.magnet import field_uT, interpolation_error_uT
from whiskercal.twin.physics.magnetometer import is_saturated, to_counts, to_uT
from whiskercal.twin.params import DEFAULT_SENSOR, SECOND_SENSOR, SensorParams, sensor_by_id
from whiskercal.twin.physics.plane import solve_plane
from whiskercal.twin.physics.obstacles import plane_for_depth
from whiskercal.twin.truth import static_field_uT, tip_contact_sweep


def test_sensors_are_found_by_id_and_unknown_ids_are_refused():
    assert sensor_by_id(DEFAULT_SENSOR.sensor_id) is DEFAULT_SENSOR
    assert sensor_by_id(SECOND_SENSOR.sensor_id) is SECOND_SENSOR
    with pytest.raises(UsageError, match="known sensors"):
        sensor_by_id("no-such-sensor")


def test_sensor_needs_an_id():
    with pytest.raises(UsageError):
        SensorParams(sensor_id=" ")


def test_sensor_params_are_immutable_and_hashable():
    assert hash(DEFAULT_SENSOR) == hash(replace(DEFAULT_SENSOR))
    with pytest.raises(AttributeError):
        DEFAULT_SENSOR.sensor_id = "other"


def test_second_sensor_is_a_different_build():
    assert SECOND_SENSOR.whisker.length_mm == 60.0
    default_whisker = DEFAULT_SENSOR.whisker
    assert SECOND_SENSOR.whisker.root_rotational_stiffness_n_mm_per_rad > default_whisker.root_rotational_stiffness_n_mm_per_rad
    assert SECOND_SENSOR.magnet != DEFAULT_SENSOR.magnet
    assert SECOND_SENSOR.sensor_id != DEFAULT_SENSOR.sensor_id


def test_default_static_y_reading_is_like_the_real_sensor():
    # The real sensor at rest: Y mean 1160.5 µT (reference numbers).
    assert static_field_uT(DEFAULT_SENSOR)[1] == pytest.approx(1160.5, abs=15.0)


def test_default_noise_at_rest_is_like_the_real_sensor():
    meter = DEFAULT_SENSOR.magnetometer
    rest = np.tile(static_field_uT(DEFAULT_SENSOR), (6000, 1))
    readings = to_uT(to_counts(rest, meter, np.random.default_rng(2024)), meter)
    assert 5.0 < readings[:, 1].std() < 6.2
    assert readings[:, 1].mean() == pytest.approx(1160.5, abs=15.0)


def test_default_settings_fit_the_sample_rate():
    meter = DEFAULT_SENSOR.magnetometer
    assert (meter.gain, meter.res, meter.osr, meter.filt, meter.rate_hz) == (5, 2, 0, 2, 300.0)
    assert meter.fits_rate()


@pytest.mark.parametrize("sensor", [DEFAULT_SENSOR, SECOND_SENSOR], ids=lambda s: s.sensor_id)
def test_no_axis_saturates_over_the_tip_contact_range(sensor):
    sweep = tip_contact_sweep(sensor.whisker, 41)
    field = field_uT(sensor.magnet, sweep.root_rotation_rad, sweep.root_shift_mm)
    assert not is_saturated(to_counts(field, sensor.magnetometer, None), sensor.magnetometer).any()


@pytest.mark.parametrize("sensor", [DEFAULT_SENSOR, SECOND_SENSOR], ids=lambda s: s.sensor_id)
def test_shipped_magnets_interpolate_well_below_the_noise(sensor):
    assert interpolation_error_uT(sensor.magnet, n_poses=2000, seed=3).max() < 0.5


def _grid_and_study_fields_uT(sensor) -> np.ndarray:
    """Noise-free field (n, 3) at every default calibration-grid point and study depth, µT."""
    grid = load_collect_config()
    poses = [solve_rod(sensor.whisker, point, grid.rig.rod_radius_mm) for point in lattice_points(grid.grid)]
    depths_mm = load_study_config()["trials"]["depths_mm"]
    poses += [solve_plane(sensor.whisker, plane_for_depth(sensor.whisker, float(d))) for d in depths_mm]
    rotation = np.array([pose.root_rotation_rad for pose in poses])
    shift = np.array([pose.root_shift_mm for pose in poses])
    return field_uT(sensor.magnet, rotation, shift)


@pytest.mark.parametrize("sensor", [DEFAULT_SENSOR, SECOND_SENSOR], ids=lambda s: s.sensor_id)
def test_every_axis_keeps_a_quarter_of_its_range_over_grid_and_study(sensor):
    # The whole calibration grid (the rod near the root shifts the suspension: Z peaks there)
    # and every study depth, at the default settings, with room for build tolerances.
    fields = _grid_and_study_fields_uT(sensor) + np.asarray(sensor.magnetometer.offset_uT)
    peak = np.abs(fields).max(axis=0)
    assert np.all(peak < 0.75 * sensor.magnetometer.full_scale_uT()), peak


def test_default_quantization_is_well_below_the_noise():
    meter = DEFAULT_SENSOR.magnetometer
    quantization_uT = meter.lsb_uT() / np.sqrt(12)  # RMS of rounding to whole counts
    assert np.all(quantization_uT < 0.1 * meter.effective_noise_uT())
