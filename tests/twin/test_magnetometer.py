"""The MLX90393 model: sensitivity, conversion time, quantization, range, noise."""

import numpy as np
import pytest

from whiskercal.errors import UsageError
from whiskercal.twin.physics.magnetometer import (
    MagnetometerParams,
    averaged_conversions,
    conversion_time_ms,
    count_range,
    is_saturated,
    lsb_uT,
    to_counts,
    to_uT,
)

DEFAULT = MagnetometerParams()


def test_sensitivity_table_and_the_default_settings():
    np.testing.assert_allclose(lsb_uT(7, 0), [0.150, 0.150, 0.242])
    np.testing.assert_allclose(lsb_uT(5, 0), [0.250, 0.250, 0.403])
    # default GAIN_SEL 5, RES 2 (docs/protocol.md)
    np.testing.assert_allclose(DEFAULT.lsb_uT(), [1.000, 1.000, 1.612])
    np.testing.assert_allclose(DEFAULT.full_scale_uT(), [32767.0, 32767.0, 1.612 * 32767])


@pytest.mark.parametrize("gain", range(8))
def test_each_resolution_step_doubles_the_sensitivity(gain):
    for res in range(1, 4):
        np.testing.assert_allclose(lsb_uT(gain, res), 2 * lsb_uT(gain, res - 1), rtol=1e-12)


def test_lower_gain_select_means_more_microtesla_per_count():
    xy = [lsb_uT(gain, 0)[0] for gain in range(8)]
    assert all(a > b for a, b in zip(xy, xy[1:]))


def test_conversion_time_table_lookups():
    assert conversion_time_ms(0, 0) == pytest.approx(1.27)
    assert conversion_time_ms(0, 2) == pytest.approx(1.84)
    assert conversion_time_ms(3, 3) == pytest.approx(16.05)
    assert conversion_time_ms(1, 1) == pytest.approx(2.23)


def test_conversion_time_grows_with_averaging():
    times = np.array([[conversion_time_ms(osr, filt) for osr in range(4)] for filt in range(8)])
    assert np.all(np.diff(times, axis=0) > 0) and np.all(np.diff(times, axis=1) > 0)


def test_which_settings_fit_300_hz():
    fits = {(osr, filt) for osr in range(4) for filt in range(8) if DEFAULT.with_settings(osr=osr, filt=filt).fits_rate()}
    # (OSR, DIG_FILT): DF0 and DF1 with OSR 0-1, DF2 and DF3 with OSR 0 (reference numbers).
    assert fits == {(0, 0), (1, 0), (0, 1), (1, 1), (0, 2), (0, 3)}
    DEFAULT.check_rate()
    with pytest.raises(UsageError, match="longer than"):
        DEFAULT.with_settings(osr=2, filt=2).check_rate()


@pytest.mark.parametrize("bad", [dict(gain=8), dict(res=-1), dict(osr=4), dict(filt=8), dict(rate_hz=0.0)])
def test_settings_out_of_range_are_refused(bad):
    with pytest.raises(UsageError):
        DEFAULT.with_settings(**bad)


def test_quantization_rounds_to_the_nearest_count():
    params = DEFAULT.with_settings(gain=7, res=0)  # 0.150 / 0.242 µT per count
    field = np.array([[0.074, 0.076, 0.5], [-0.226, 0.0, -0.4]])
    np.testing.assert_array_equal(to_counts(field, params, None), [[0, 1, 2], [-2, 0, -2]])
    counts = to_counts(field, params, None)
    assert counts.dtype == np.int16
    assert np.abs(to_uT(counts, params) - field).max() <= 0.5 * params.lsb_uT().max() + 1e-12


def test_saturation_at_the_end_of_the_output_range():
    res0 = DEFAULT.with_settings(gain=7, res=0)
    # RES 0 at GAIN_SEL 7 holds only about ±4.9 mT on X/Y: the -8760 µT target would clip.
    assert res0.full_scale_uT()[1] == pytest.approx(0.150 * 32767)
    field = np.array([[0.0, -8760.0, 0.0], [0.0, 4000.0, 0.0]])
    counts = to_counts(field, res0, None)
    assert counts[0, 1] == -32768 and is_saturated(counts, res0).tolist() == [True, False]
    # The defaults fit -12 mT on Y and the -34.6 mT the default sensor's Z reaches on the
    # calibration grid, which GAIN_SEL 7 (±31.7 mT on Z at RES 2) clipped.
    deep = to_counts([0.0, -12000.0, -34600.0], DEFAULT, None)
    assert not is_saturated(deep, DEFAULT)
    np.testing.assert_allclose(to_uT(deep, DEFAULT)[1:], [-12000.0, -34600.0], atol=0.81)
    gain7 = DEFAULT.with_settings(gain=7)
    assert is_saturated(to_counts([0.0, -12000.0, -34600.0], gain7, None), gain7)


def test_resolution_three_range_is_half_the_counts():
    assert count_range(3) == (-16384, 16383)
    res3 = DEFAULT.with_settings(gain=7, res=3)  # 1.2 µT per count on Y: 30 mT is 25000 counts
    assert to_counts([0.0, 30000.0, 0.0], res3, None)[1] == 16383


def test_static_offset_is_added():
    params = DEFAULT.with_settings(offset_uT=(30.0, -60.0, 0.0))
    np.testing.assert_allclose(to_uT(to_counts(np.zeros(3), params, None), params), [30.0, -60.0, 0.0], atol=0.31)


def test_noise_rms_matches_the_real_sensor_after_quantization():
    rng = np.random.default_rng(11)
    field = np.tile([0.0, 1160.0, -20000.0], (20000, 1))
    readings = to_uT(to_counts(field, DEFAULT, rng), DEFAULT)
    # The real sensor at rest: Y standard deviation 5.6 µT.
    assert 5.3 < readings[:, 1].std() < 5.9
    assert abs(readings[:, 1].mean() - 1160.0) < 0.2


def test_more_averaging_means_less_noise():
    rng = np.random.default_rng(3)
    quiet = DEFAULT.with_settings(osr=1, filt=3)
    ratio = np.sqrt(averaged_conversions(0, 2) / averaged_conversions(1, 3))
    np.testing.assert_allclose(quiet.effective_noise_uT(), np.asarray(DEFAULT.noise_uT_rms) * ratio)
    readings = to_uT(to_counts(np.zeros((20000, 3)), quiet, rng), quiet)
    assert readings[:, 1].std() < 0.8 * 5.6


def test_same_seed_same_counts_other_seed_other_counts():
    field = np.tile([10.0, 1160.0, -20000.0], (500, 1))
    first = to_counts(field, DEFAULT, np.random.default_rng(5))
    again = to_counts(field, DEFAULT, np.random.default_rng(5))
    other = to_counts(field, DEFAULT, np.random.default_rng(6))
    np.testing.assert_array_equal(first, again)
    assert np.any(first != other)


def test_field_must_have_three_axes():
    with pytest.raises(UsageError, match="length 3"):
        to_counts(np.zeros(2), DEFAULT, None)
