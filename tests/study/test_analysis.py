"""The study's analysis on synthetic streams whose true answer is known by construction."""

import numpy as np
import pytest

from whiskercal.study.analysis import (
    Criteria, TrialSeries, analyse_study, analyse_trial, distance_to_line_mm)
from whiskercal.study.detect import (contact_onset_mm, detect_kink, detect_slips, monotone_breaks,
                                     stiffening_breaks)

NORMAL = np.array([np.cos(np.radians(20)), np.sin(np.radians(20))])
DIRECTION = np.array([NORMAL[1], -NORMAL[0]])


def _series(depth_mm, n=900, noise_mm=0.1, off_plane_mm=0.0, z_uT=-5000.0, seed=0, contact=None):
    """Estimates scattered about a plane line by a known noise, plus a known offset off it."""
    rng = np.random.default_rng(seed)
    point = np.array([78.0, 0.0]) - depth_mm * NORMAL
    along = np.linspace(-10, 10, n)
    on_line = point + along[:, None] * DIRECTION
    raw = on_line + rng.normal(0, noise_mm, (n, 2)) + off_plane_mm * NORMAL
    z = z_uT + rng.normal(0, 6.0, n)
    contact = np.ones(n, bool) if contact is None else contact
    return TrialSeries(depth_mm=depth_mm, t_s=np.arange(n) / 300, z_uT=z, contact=contact,
                       raw_tip_mm=raw, filtered_tip_mm=raw.copy(),
                       plane_point_mm=np.tile(point, (n, 1)), plane_normal=np.tile(NORMAL, (n, 1)),
                       true_tip_mm=on_line, true_kind=np.array(["tip"] * n))


def test_distance_to_line_is_the_perpendicular_distance():
    points = np.array([[3.0, 1.5], [-2.0, -4.0], [np.nan, 0.0]])
    distance = distance_to_line_mm(points, np.array([0.0, 0.0]), np.array([0.0, 1.0]))
    assert distance[:2] == pytest.approx([1.5, 4.0])
    assert np.isnan(distance[2])


def test_error_statistics_match_the_noise_put_in():
    metrics = analyse_trial(_series(20.0, n=20000, noise_mm=0.2))
    # |N(0, s)| has mean s*sqrt(2/pi) and std s*sqrt(1 - 2/pi)
    assert metrics.raw_mean_mm == pytest.approx(0.2 * np.sqrt(2 / np.pi), rel=0.03)
    assert metrics.raw_std_mm == pytest.approx(0.2 * np.sqrt(1 - 2 / np.pi), rel=0.03)
    assert metrics.true_raw_mean_mm == pytest.approx(0.2 * np.sqrt(np.pi / 2), rel=0.03)
    assert not metrics.failing and metrics.n_slips == 0


def test_estimates_off_the_plane_flag_tangential_contact():
    metrics = analyse_trial(_series(45.0, off_plane_mm=4.0))
    assert metrics.tangential and metrics.failing
    assert any("tangential" in reason for reason in metrics.reasons)


def test_slips_are_found_where_z_jumps_and_nowhere_else():
    rng = np.random.default_rng(1)
    z = -6000 + np.cumsum(rng.normal(0, 8, 3000))
    z[1200:] -= 900.0
    z[2500:] += 600.0
    slips = detect_slips(z, np.ones(z.size, bool))
    assert slips.tolist() == [1200, 2500]


def test_losing_contact_is_not_a_slip():
    z = np.r_[np.zeros(100), np.full(100, -3000.0)]
    contact = np.abs(z) > 300
    assert detect_slips(z, contact).size == 0


def test_a_trial_without_contact_fails_with_a_clear_reason():
    series = _series(5.0, contact=np.zeros(900, bool))
    metrics = analyse_trial(series)
    assert metrics.failing and "no contact" in metrics.reasons[0]
    assert np.isnan(metrics.raw_mean_mm)


def test_monotone_breaks_flag_the_depth_where_z_stops_growing():
    depths = np.array([5, 10, 15, 20, 25.0])
    median_z = np.array([-1000, -2000, -3000, -2500, -3500.0])
    assert monotone_breaks(depths, median_z).tolist() == [False, False, False, True, False]
    assert monotone_breaks(depths[::-1], median_z[::-1]).tolist() == [False, True, False, False, False]


def test_study_rows_are_sorted_and_monotone_break_fails_a_trial():
    trials = [_series(d, z_uT=-200.0 * d, seed=int(d)) for d in (5, 10, 15, 20)]
    trials.append(_series(25.0, z_uT=-3000.0, seed=25))
    rows = analyse_study(trials[::-1], Criteria())
    assert [row.depth_mm for row in rows] == [5, 10, 15, 20, 25]
    assert [row.failing for row in rows] == [False, False, False, False, True]


def test_a_slide_cut_short_fails_with_a_clear_reason():
    series = _series(15.0)
    series.slid_mm, series.planned_travel_mm = 31.0, 80.0
    metrics = analyse_trial(series)
    assert metrics.failing and metrics.reasons[0] == "cut short: slid 31.0 of 80 mm"


def _push_in(kink_at_mm=None, slope_after=-380.0, seed=3):
    """A concave z(depth) like a tip contact's (slope -330 µT/mm falling to -170), 300 Hz noise."""
    rng = np.random.default_rng(seed)
    depth = np.linspace(0, 45, 45 * 60)
    z = -330 * depth + 1.8 * depth ** 2
    if kink_at_mm is not None:
        past = depth > kink_at_mm
        z[past] = z[past][0] + slope_after * (depth[past] - kink_at_mm)
    return depth, z + rng.normal(0, 5.6, depth.size)


def test_a_smooth_push_in_has_no_kink():
    assert np.isnan(detect_kink(*_push_in()))


@pytest.mark.parametrize("slope_after", [-380.0, -20.0, 150.0])  # stiffer, stalled, falling back
def test_a_kink_in_the_push_in_is_found_where_it_is(slope_after):
    depth = detect_kink(*_push_in(kink_at_mm=41.0, slope_after=slope_after))
    assert 41.0 <= depth <= 41.0 + 2 * 1.25


@pytest.mark.parametrize("depth_mm", [0.0, 5.0])
def test_a_push_in_at_one_depth_has_no_kink(depth_mm):
    """All samples at the same depth (a stalled stage): no slope to judge, so NaN, not a crash."""
    z = np.linspace(0.0, -100.0, 50)
    assert np.isnan(detect_kink(np.full(50, depth_mm), z))


def test_sparse_noisy_push_in_is_not_a_kink():
    rng = np.random.default_rng(5)
    depth = np.linspace(0, 45, 200)  # 0.2 mm a sample
    z = -330 * depth + 1.8 * depth ** 2 + rng.normal(0, 40.0, depth.size)
    assert np.isnan(detect_kink(depth, z))


def _sawtooth(period, jump_uT, n=1500, seed=4):
    """Stick-slip: z creeps one way while stuck and jumps back at each slip, plus 6 µT noise."""
    rng = np.random.default_rng(seed)
    phase = np.arange(n) % period
    z = -8000.0 + jump_uT * phase / period + rng.normal(0, 6.0, n)
    return z, np.flatnonzero(phase == 0)[1:]


@pytest.mark.parametrize("period, jump_uT", [(30, 120.0), (10, 150.0)])
def test_stick_slip_jumps_are_found_against_the_creep(period, jump_uT):
    z, slips = _sawtooth(period, jump_uT)
    assert detect_slips(z, np.ones(z.size, bool)).tolist() == slips.tolist()


def test_a_steady_creep_with_noise_is_not_a_slip():
    rng = np.random.default_rng(5)
    z = -8000.0 + 3.0 * np.arange(3000) + rng.normal(0, 6.0, 3000)
    assert detect_slips(z, np.ones(z.size, bool)).size == 0


# median z per depth of a tip contact on the twin (concave: it grows ever more slowly)
TIP_DEPTHS = np.array([5, 10, 15, 20, 25, 30, 35, 40.0])
TIP_Z = np.array([-1870, -3108, -4216, -5206, -6140, -7028, -7884, -8709.0])


def test_z_growing_ever_more_slowly_with_depth_is_tip_contact():
    assert not stiffening_breaks(TIP_DEPTHS, TIP_Z).any()


def test_z_growing_faster_again_flags_tangential_from_there_on():
    depths = np.r_[TIP_DEPTHS, 45.0, 50.0]
    median_z = np.r_[TIP_Z, -9569.0, -10300.0]   # 172 µT/mm after 165 µT/mm: stiffer
    assert stiffening_breaks(depths, median_z).tolist() == [False] * 8 + [True, True]
    order = np.random.default_rng(2).permutation(depths.size)
    assert stiffening_breaks(depths[order], median_z[order]).tolist() == (order >= 8).tolist()


def test_a_stiffening_trial_is_reported_tangential():
    trials = [_series(d, z_uT=z, seed=int(d)) for d, z in zip(TIP_DEPTHS, TIP_Z)]
    trials.append(_series(45.0, z_uT=-9569.0, seed=45))
    rows = analyse_study(trials, Criteria())
    assert [row.tangential for row in rows] == [False] * 8 + [True]
    assert rows[-1].failing and any("stiffened" in reason and reason.startswith("tangential")
                                    for reason in rows[-1].reasons)
    assert not any(row.failing for row in rows[:-1])


def _contact_search(onset_mm, gain_uT_per_mm, threshold_uT=300.0, step_mm=0.1, noise_uT=1.5,
                    seed=3):
    """The steps of a contact search up to the first past the threshold: z grows from the onset,
    ever more slowly (concave, as a tip contact does), plus the noise of a step's mean."""
    rng = np.random.default_rng(seed)
    distance = np.arange(1, 400) * step_mm
    depth = np.clip(distance - onset_mm, 0.0, None)
    z = -(gain_uT_per_mm * depth - 0.006 * gain_uT_per_mm * depth ** 2) \
        + rng.normal(0.0, noise_uT, distance.size)
    last = int(np.argmax(np.abs(z) > threshold_uT))
    return distance[:last + 1], z[:last + 1], noise_uT


@pytest.mark.parametrize("gain_uT_per_mm", [330.0, 50.0])
def test_the_contact_onset_is_where_z_leaves_zero_not_where_it_passes_the_threshold(
        gain_uT_per_mm):
    distance, z, noise = _contact_search(5.0, gain_uT_per_mm)
    assert distance[-1] - 5.0 > 300.0 / gain_uT_per_mm - 0.1  # the threshold step: 1 to 6 mm late
    assert contact_onset_mm(distance, z, noise) == pytest.approx(5.0, abs=0.1)


def test_a_contact_search_without_two_steps_in_contact_keeps_the_threshold_step():
    distance, z = np.array([0.1, 0.2, 0.3]), np.array([0.5, -1.0, -400.0])
    assert contact_onset_mm(distance, z, 1.0) == 0.3


def _weak_push_in(seed, gain_uT_per_mm=50.0, wander_uT=10.0):
    """A tip contact's push-in on a weak build (long-110mm reads ~50 µT/mm): z wanders about its
    smooth course as the tip sticks and slips (10 µT RMS over mm, as on the twin), plus 5.6 µT
    noise, 0.1 mm a sample."""
    rng = np.random.default_rng(seed)
    depth = np.arange(0.0, 25.0, 0.1)
    smooth = np.convolve(rng.normal(0.0, 1.0, depth.size + 20), np.ones(20) / 20, "valid")
    wander = wander_uT * smooth[:depth.size] / smooth[:depth.size].std()
    z = -gain_uT_per_mm * depth + 0.3 * depth ** 2 + wander + rng.normal(0.0, 5.6, depth.size)
    return depth, z


def test_a_weak_builds_tip_contact_wandering_with_stick_slip_is_rarely_a_kink():
    # the slope's own noise guard alone flagged 34 of these 40 tip contacts as tangential
    flagged = sum(np.isfinite(detect_kink(*_weak_push_in(seed))) for seed in range(40))
    assert flagged <= 2


def test_a_weak_builds_slope_doubling_is_still_a_kink():
    found = 0
    for seed in range(40):
        depth, z = _weak_push_in(seed)
        z = z - 60.0 * np.clip(depth - 18.0, 0.0, None)  # the shaft meets the plane at 18 mm
        found += abs(detect_kink(depth, z) - 18.0) <= 1.5
    assert found >= 30


def test_the_last_window_of_a_push_in_cannot_kink_alone():
    """A change of contact lasts: a deviation in the push-in's final window (where the stage
    stops) has no next window to confirm it; one a window earlier does."""
    assert np.isnan(detect_kink(*_push_in(kink_at_mm=44.0, slope_after=150.0)))
    assert 43.0 <= detect_kink(*_push_in(kink_at_mm=43.0, slope_after=150.0)) <= 43.0 + 2 * 1.25
