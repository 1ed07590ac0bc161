"""The target rule: never next to a failing depth, lowest score wins, clear refusal otherwise."""

import numpy as np
import pytest

from whiskercal.study.analysis import TrialMetrics
from whiskercal.errors import UsageError
from whiskercal.study.target import NoTargetError, choose_target


def _row(depth, mean, std, failing=False, median_z=None):
    return TrialMetrics(depth_mm=depth, n_samples=100, contact_fraction=1.0,
                        median_z_uT=-200.0 * depth if median_z is None else median_z,
                        raw_mean_mm=mean, raw_std_mm=std, filtered_mean_mm=mean,
                        filtered_std_mm=std, off_plane_fraction=0.0, n_slips=0, failing=failing)


def test_the_best_trial_next_to_a_failure_is_not_chosen():
    rows = [_row(d, 0.5, 0.1) for d in range(5, 40, 5)]
    rows.append(_row(40, 0.05, 0.01))            # most accurate, but next to the failing 45
    rows.append(_row(45, 5.0, 3.0, failing=True))
    choice = choose_target(rows)
    assert choice.depth_mm not in (40, 45)
    assert 40 not in choice.scores_mm and 45 not in choice.scores_mm


def test_lowest_score_wins_and_its_median_z_is_the_target():
    rows = [_row(5, 0.01, 0.0), _row(10, 0.3, 0.05), _row(15, 0.2, 0.3), _row(20, 0.01, 0.0)]
    choice = choose_target(rows)  # the ends are best but never eligible: untested room beyond
    # scores: 10 mm -> 0.3 + 0.1 = 0.4, 15 mm -> 0.2 + 0.6 = 0.8 (no failures: no margin penalty)
    assert choice.depth_mm == 10 and choice.z_uT == -2000.0
    assert choice.scores_mm[15] == pytest.approx(0.8)
    assert np.isinf(choice.margin_mm)


def test_margin_penalty_prefers_the_depth_farther_from_failure():
    rows = [_row(5, 1.0, 0.0, failing=True), _row(10, 0.3, 0.0), _row(15, 0.3, 0.0),
            _row(20, 0.3, 0.0), _row(25, 0.3, 0.0), _row(30, 0.3, 0.0)]
    # penalties 0.5, 0.33, 0.25 mm: further apart than the tie
    choice = choose_target(rows, margin_weight_mm=1.0)
    assert choice.depth_mm == 25 and choice.margin_mm == 20
    assert set(choice.scores_mm) == {15, 20, 25}
    assert choice.scores_mm[15] == pytest.approx(0.3 + 1.0 * 5 / 10)


def test_among_near_tied_scores_the_shallowest_depth_wins():
    # 35 mm scores lowest, but 10-35 mm lie within the 0.05 mm tie: the shallowest of them wins
    scores = {10: 0.018, 15: 0.022, 20: 0.023, 25: 0.020, 30: 0.015, 35: 0.014, 40: 0.021}
    rows = [_row(5, 0.01, 0.0), *(_row(d, s, 0.0) for d, s in scores.items()), _row(45, 0.03, 0.0)]
    choice = choose_target(rows)
    assert choice.depth_mm == 10 and choice.z_uT == -2000.0
    assert "shallowest of 7" in choice.reason
    assert choose_target(rows, tie_mm=0.0).depth_mm == 35


def test_a_score_just_past_the_tie_does_not_win_by_being_shallower():
    rows = [_row(5, 0.0, 0.0), _row(10, 0.11, 0.0), _row(15, 0.05, 0.0), _row(20, 0.0, 0.0)]
    choice = choose_target(rows, tie_mm=0.05)
    assert choice.depth_mm == 15 and "lowest score" in choice.reason


def test_a_negative_tie_is_refused():
    with pytest.raises(UsageError, match="tie"):
        choose_target([_row(d, 0.1, 0.0) for d in (5, 10, 15)], tie_mm=-0.01)


def test_no_eligible_trial_is_a_clear_error():
    rows = [_row(5, 0.3, 0.1), _row(10, 0.3, 0.1), _row(15, 3.0, 1.0, failing=True),
            _row(20, 0.3, 0.1), _row(25, 0.3, 0.1)]
    with pytest.raises(NoTargetError, match="no trial qualifies"):
        choose_target(rows)
