"""The constant-state Kalman filter, including degenerate windows, and collision detection."""

import numpy as np
import pytest

from whiskercal.model.collision import CollisionDetector, CollisionParams, detect
from whiskercal.model.errors import ModelError
from whiskercal.model.kalman import (ConstantStateKalman, KalmanParams, filter_batch,
                                     floored_covariance_2x2, window_covariance)


def test_filter_reduces_the_spread_of_noisy_tips_around_a_fixed_contact():
    rng = np.random.default_rng(3)
    true_tip = np.array([55.0, -48.0])
    raw = true_tip + rng.normal(0.0, [0.3, 0.15], (600, 2))
    filtered = filter_batch(raw)
    settled = filtered[100:]
    assert np.all(np.isfinite(filtered))
    assert np.all(settled.std(axis=0) < 0.3 * raw.std(axis=0))
    assert np.linalg.norm(settled.mean(axis=0) - true_tip) < 0.05


def test_identical_tips_give_a_floored_covariance_and_no_nan():
    kalman = ConstantStateKalman()
    tip = np.array([60.0, -40.0])
    for _ in range(50):
        out = kalman.update(tip)
    np.testing.assert_allclose(out, tip)
    assert np.all(np.isfinite(kalman.covariance_mm2))
    floored = window_covariance(np.tile(tip, (10, 1)), 1e-6)
    np.testing.assert_allclose(np.linalg.eigvalsh(floored), [1e-6, 1e-6])


def test_first_tip_is_x0_and_a_single_tip_window_skips_the_update():
    kalman = ConstantStateKalman(KalmanParams(window=2))
    np.testing.assert_allclose(kalman.update([10.0, -5.0]), [10.0, -5.0])
    assert kalman.covariance_mm2[0, 0] == pytest.approx(10.0)  # P0, untouched so far
    moved = kalman.update([12.0, -5.0])
    assert 10.0 < moved[0] < 12.0


def test_prior_r_is_used_while_the_window_is_short():
    kalman = ConstantStateKalman(KalmanParams(r_prior_mm2=10.0, window=5))
    kalman.update([0.0, 0.0])
    kalman._window.clear()  # as if the window had been emptied: R comes from the prior
    out = kalman.update([2.0, 0.0])
    assert out[0] == pytest.approx(2.0 * (10.0 + 1e-5) / (20.0 + 1e-5))


def test_non_finite_tips_are_ignored_and_reset_forgets():
    kalman = ConstantStateKalman()
    assert kalman.update([np.nan, 1.0]) is None
    kalman.update([1.0, 1.0])
    np.testing.assert_allclose(kalman.update([np.inf, 0.0]), [1.0, 1.0])
    kalman.reset()
    assert kalman.state_mm is None


def test_streaming_equals_batch():
    rng = np.random.default_rng(5)
    raw = rng.normal(0.0, 1.0, (40, 2))
    raw[7] = np.nan
    kalman = ConstantStateKalman()
    streamed = np.array([kalman.update(r) for r in raw[:7]] + [kalman.update(r) for r in raw[7:]])
    np.testing.assert_allclose(streamed, filter_batch(raw))


def test_bad_settings_are_refused():
    with pytest.raises(ModelError):
        KalmanParams(window=1)
    with pytest.raises(ModelError):
        KalmanParams(r_prior_mm2=0.0)
    with pytest.raises(ModelError):
        CollisionParams(threshold_uT=300.0, release_uT=400.0)


def test_collision_threshold_and_hysteresis():
    z = np.array([0.0, -200.0, -301.0, -250.0, -310.0, -100.0, np.nan, -400.0])
    np.testing.assert_array_equal(detect(z)[:6], [False, False, True, False, True, False])
    with_release = detect(z, CollisionParams(threshold_uT=300.0, release_uT=200.0))
    np.testing.assert_array_equal(with_release, [False, False, True, True, True, False, False, True])
    detector = CollisionDetector()
    streamed = [detector.update(float(v)) for v in z]
    np.testing.assert_array_equal(streamed, detect(z))
    assert detect(np.array([350.0]))[0]  # a departure either way counts


@pytest.mark.parametrize("case", ["random", "identical", "collinear", "isotropic", "tiny"])
def test_plain_float_covariance_equals_the_numpy_reference(case):
    rng = np.random.default_rng(7)
    tips = {"random": rng.normal(50.0, 0.3, (10, 2)),
            "identical": np.tile([55.0, -40.0], (10, 1)),
            "collinear": np.column_stack([np.arange(10.0), 2.0 * np.arange(10.0)]),
            "isotropic": np.array([[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]]),
            "tiny": 50.0 + rng.normal(0.0, 1e-5, (10, 2))}[case]
    a, b, d = floored_covariance_2x2([tuple(t) for t in tips], 1e-6)
    np.testing.assert_allclose([[a, b], [b, d]], window_covariance(tips, 1e-6), rtol=1e-9,
                               atol=1e-15)
