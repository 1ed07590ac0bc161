"""The (Y, Z) table's truth-free error estimate and the rule that warns or withholds the table.

Synthetic load sets (seeded): a smooth one-to-one map, whose estimate is the noise carried through
its slope, and two branches that give the same fields with tips 10 mm apart (a thin wire bent both
ways), whose estimate must show the branches' distance.
"""

from __future__ import annotations

import numpy as np
import pytest

from whiskercal.fit.field_table import (REFUSE_ESTIMATE_MM, loose_ratios, offset_warnings,
                                        trust_verdict)
from whiskercal.fit.tip_model import WARN_TIP_ERROR_MM
from whiskercal.mechfit.table_error import (HELD_SAMPLES, ambiguity_tip_error_mm,
                                            estimated_tip_error_mm, noise_propagation_mm,
                                            z_lookup_tip_error_mm)
from whiskercal.mechfit.tables import tabulate

NOISE_UT = (5.6, 9.0)  # one sample's Y and Z noise


def _smooth_loads(seed: int = 0, mm_per_uT: float = 0.001):
    """Fields on a 2000 x 2000 µT patch; tips a linear map of them (mm_per_uT mm per µT)."""
    fields = np.random.default_rng(seed).uniform(-2000.0, 0.0, (3000, 2))
    return fields, fields * mm_per_uT


def test_a_smooth_map_is_estimated_at_its_noise_through_its_slope():
    fields, tips = _smooth_loads()
    estimate = ambiguity_tip_error_mm(fields, tips, NOISE_UT)
    # neighbours within twice one sample's noise lie at most 2 |noise| * slope away: 0.021 mm
    assert 0.001 < estimate < 0.0212
    assert trust_verdict(estimate, estimate, (1.0, 1.0)) == (True, [])


def test_two_branches_with_the_same_fields_are_estimated_at_their_distance():
    fields, tips = _smooth_loads()
    other = tips + np.array([10.0, 0.0])  # the same fields, tips 10 mm apart
    estimate = ambiguity_tip_error_mm(np.concatenate([fields, fields]),
                                      np.concatenate([tips, other]), NOISE_UT)
    # half of each load's neighbours lie on the other branch: about 10 / sqrt(2) mm RMS
    assert 6.0 < estimate < 8.0
    write, warnings = trust_verdict(estimate, estimate, (1.0, 1.0))
    assert not write and len(warnings) == 1 and "no (Y, Z) table written" in warnings[0]


def test_the_rule_warns_between_the_goal_and_the_refusal_and_refuses_a_poor_residual():
    between = 0.5 * (WARN_TIP_ERROR_MM + REFUSE_ESTIMATE_MM)  # warned, written
    write, warnings = trust_verdict(between, between / 2, (1.0, 1.0))
    assert write and len(warnings) == 1 and "estimated tip error" in warnings[0]
    write, warnings = trust_verdict(0.05, 0.05, (2.5, 1.0))
    assert not write and "2.5x the noise" in warnings[0]
    assert trust_verdict(float("nan"), float("nan"), (1.0, 1.0))[0] is False


def test_a_suspension_the_grid_does_not_identify_gets_no_table_however_small_its_estimate():
    profile = [{"stiffness_ratio": 14.0, "delta_chi2": 40.0},
               {"stiffness_ratio": 310.0, "delta_chi2": 3.5}]
    assert loose_ratios(profile) == (310.0,)
    write, warnings = trust_verdict(0.05, 0.02, (1.0, 1.0), loose=loose_ratios(profile))
    assert not write and len(warnings) == 1
    assert warnings[0].startswith("no (Y, Z) table written, it cannot be trusted: the grid's Y "
                                  "and Z do not pin the suspension down (k_theta*L/EI 310 fits "
                                  "about as well as the best)")
    assert loose_ratios(profile[:1]) == () and trust_verdict(0.05, 0.02, (1.0, 1.0))[0]


def test_the_held_estimate_decides_and_one_readings_is_warned():
    # one reading past the bound, held within it: noise the runtime's filter averages
    write, warnings = trust_verdict(1.6, 0.28, (1.0, 1.0))
    assert write and len(warnings) == 1
    assert "1.60 mm RMS for one reading, 0.28 mm for a contact held" in warnings[0]
    write, warnings = trust_verdict(1.6, 0.6, (1.0, 1.0))
    assert not write and f"0.60 mm RMS for a contact held {HELD_SAMPLES} samples" in warnings[0]


def test_a_held_contact_shrinks_a_slopes_noise_but_not_two_branches():
    fields, tips = _smooth_loads(mm_per_uT=0.1)  # steep: one reading's noise costs about 1 mm
    y_range = (-2000.0, 0.0)
    smooth = estimated_tip_error_mm(fields, tips, tabulate(fields, tips, y_range), NOISE_UT)
    assert smooth["estimate_mm"] > REFUSE_ESTIMATE_MM
    ratio = smooth["held_estimate_mm"] / smooth["estimate_mm"]
    assert ratio == pytest.approx(1 / np.sqrt(HELD_SAMPLES), rel=0.2)
    both = np.concatenate([fields, fields])
    branches = np.concatenate([tips, tips + np.array([10.0, 0.0])])
    folded = estimated_tip_error_mm(both, branches, tabulate(both, branches, y_range), NOISE_UT)
    assert folded["held_estimate_mm"] > 5.0


def test_the_noise_through_a_linear_tables_slope_is_its_slope_times_the_noise():
    y, z = np.linspace(-2000.0, 0.0, 41), np.linspace(-3000.0, 0.0, 31)
    yy, zz = np.meshgrid(y, z, indexing="ij")
    tips = np.stack([0.002 * yy, 0.001 * zz], axis=-1)  # mm per µT
    tips[:3, :3] = np.nan  # unanswered cells drop out
    expected = np.hypot(0.002 * NOISE_UT[0], 0.001 * NOISE_UT[1])
    assert abs(noise_propagation_mm(y, z, tips, NOISE_UT) - expected) < 1e-9


def test_a_withheld_table_names_what_y_alone_costs_on_its_loads():
    write, warnings = trust_verdict(1.6, 1.6, (1.0, 1.0), 10.6)
    assert not write and len(warnings) == 1
    assert warnings[0].endswith("the runtime uses the z lookup (Y alone errs 10.6 mm RMS on the "
                                "table's loads: expect millimetres on contacts with friction or "
                                "at a slant)")
    assert trust_verdict(1.6, 1.6, (1.0, 1.0))[1][0].endswith("the runtime uses the z lookup")


class _FlatLookup:
    """A z lookup over -100..0 µT that answers the tip (70, -1) mm everywhere."""

    z_min_uT, z_max_uT = -100.0, 0.0

    def __call__(self, z):
        return np.tile([70.0, -1.0], (len(z), 1))


def test_y_alone_on_the_tables_loads_is_measured_where_the_lookup_answers():
    fields = np.array([[-50.0, 0.0], [-50.0, 10.0], [-500.0, 0.0]])
    tips = np.array([[70.0, 0.0], [70.0, -2.0], [0.0, 0.0]])
    # the same Y, two tips 1 mm either side of the lookup's; the third load is outside its range
    assert z_lookup_tip_error_mm(fields, tips, _FlatLookup()) == pytest.approx(1.0)
    assert np.isnan(z_lookup_tip_error_mm(fields[2:], tips[2:], _FlatLookup()))


def test_a_stage_offset_at_the_fits_bound_is_warned_and_a_belts_is_not():
    assert offset_warnings([-0.01, 0.0099]) == []  # half the twin's belt dead band
    warning, = offset_warnings([0.1, -0.027])  # the thin wire's wrong basin (seed 1)
    assert "stage's offset at its bound (+0.100, -0.027 mm" in warning
