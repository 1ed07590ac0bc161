"""The re-recording bounds: wide only on the stick-slip path, and computed from the sensor."""

import re
from pathlib import Path

import pytest

from whiskercal.regress.golden import Dataset, read_golden
from whiskercal.regress.rerecorded import (compare_rerecorded, lookup_slope_mm_per_uT,
                                           rerecorded_rules, rerecorded_tolerance, z_step_uT)

SHORT = Path(__file__).resolve().parents[2] / "data" / "twin-short-60mm"
GOLDEN = read_golden(Dataset(SHORT)).quantities
Z_STEP = z_step_uT(SHORT / "plane_study.h5")


def _moved(name, by):
    new = dict(GOLDEN)
    new[name] = new[name] + by if isinstance(by, (int, float)) else by
    return [change.name for change in compare_rerecorded(GOLDEN, new, Z_STEP)]


def test_z_comes_in_whole_microtesla_at_the_study_settings():
    assert Z_STEP == 1.0  # GAIN_SEL 5, RES 2: 1.000 µT per count on Y (docs/protocol.md)


def test_the_recorded_results_are_within_their_own_bounds():
    assert compare_rerecorded(GOLDEN, dict(GOLDEN), Z_STEP) == []


@pytest.mark.parametrize("name", ["study.trial[20mm].filtered_mean_mm",
                                  "study.trial[15mm].raw_std_mm", "study.target.score_mm",
                                  "study.passing_mean_filtered_mm"])
def test_slide_statistics_may_move_a_few_micrometres_not_twenty(name):
    assert _moved(name, 0.004) == []
    assert _moved(name, -0.02) == [name]


def test_a_median_z_may_move_two_counts_not_three():
    name = "study.trial[30mm].median_z_uT"
    assert _moved(name, 2 * Z_STEP) == []
    assert _moved(name, 3 * Z_STEP) == [name]


def test_the_runtime_tip_may_move_as_far_as_two_counts_of_target_z_move_it():
    slope = lookup_slope_mm_per_uT(GOLDEN)
    assert 0.007 < slope < 0.009  # mm per µT along this lookup
    bound = rerecorded_tolerance("runtime.tip_x_mm_at_target", rerecorded_rules(Z_STEP, slope))
    assert bound.abs_tol == pytest.approx(2 * Z_STEP * slope)
    assert _moved("runtime.tip_x_mm_at_target", 0.9 * bound.abs_tol) == []
    assert _moved("runtime.tip_y_mm_at_target", 1.5 * bound.abs_tol) == [
        "runtime.tip_y_mm_at_target"]


@pytest.mark.parametrize("name, by", [("fit.rmse_uT", 1e-5), ("lookup.tip_x_mm[05]", 1e-5),
                                      ("study.trial[40mm].kink_depth_mm", 1e-5),
                                      ("study.trial[20mm].slid_mm", 1e-5),
                                      ("study.trial[35mm].unmapped_samples", 1),
                                      ("study.target.depth_mm", 5.0)])
def test_what_has_no_friction_history_keeps_the_regress_bounds(name, by):
    assert _moved(name, by) == [name]


def test_reasons_may_change_their_numbers_not_their_words():
    name = "study.trial[40mm].reasons"
    renumbered = [re.sub(r"\d+", lambda m: str(int(m.group()) + 1), reason) for reason in GOLDEN[name]]
    assert renumbered != GOLDEN[name]
    assert _moved(name, renumbered) == []
    assert _moved(name, GOLDEN[name][:-1]) == [name]
    assert _moved(name, [reason.replace("stiffened", "softened") for reason in GOLDEN[name]]) \
        == [name]
