"""Tolerance classes and the comparison of recomputed quantities with golden values."""

import math

import pytest

from whiskercal.regress.compare import compare
from whiskercal.regress.tolerances import EXACT, ESTIMATE, LEAST_SQUARES, tolerance_for


def test_tolerance_allows_within_and_refuses_beyond_its_bound():
    assert ESTIMATE.allows(0.25, 0.25 + 0.9e-6)
    assert not ESTIMATE.allows(0.25, 0.25 + 1.1e-6)
    # Relative part: 1e-7 of 14 µT is 1.4e-6 µT (plus the 1e-9 absolute part).
    assert LEAST_SQUARES.allows(14.0, 14.0 + 1.3e-6)
    assert not LEAST_SQUARES.allows(14.0, 14.0 + 1.6e-6)
    assert EXACT.allows(3.0, 3.0) and not EXACT.allows(3.0, 3.0 + 1e-15)


def test_nan_matches_only_nan():
    assert ESTIMATE.allows(math.nan, math.nan)
    assert not ESTIMATE.allows(math.nan, 0.0)
    assert not ESTIMATE.allows(0.0, math.nan)


@pytest.mark.parametrize("name, expected", [
    ("fit.r2", "r_squared"), ("fit.rmse_uT", "least_squares"), ("fit.degree", "exact"),
    ("lookup.tip_x_mm[03]", "trace"), ("lookup.z_uT[19]", "lookup_range"),
    ("study.trial[20mm].filtered_mean_mm", "estimate"), ("study.trial[5mm].median_z_uT", "measured"),
    ("study.trial[45mm].failing", "exact"), ("study.target.depth_mm", "exact"),
    ("study.target.scores_mm[20mm]", "score"), ("runtime.tip_y_mm_at_target", "trace"),
])
def test_quantity_names_map_to_their_classes(name, expected):
    assert tolerance_for(name).name == expected


def test_compare_names_moved_added_and_removed_quantities():
    golden = {"fit.rmse_uT": 14.0, "study.target.depth_mm": 20.0, "lookup.kind": "cubic",
              "gone": 1}
    classes = {"fit.rmse_uT": "least_squares", "study.target.depth_mm": "exact",
               "lookup.kind": "exact", "gone": "exact"}
    new = {"fit.rmse_uT": 14.5, "study.target.depth_mm": 20.0, "lookup.kind": "pchip", "new": 2}
    changes = {c.name: c for c in compare(golden, classes, new)}
    assert set(changes) == {"fit.rmse_uT", "lookup.kind", "gone", "new"}
    assert changes["fit.rmse_uT"].kind == "moved"
    assert changes["fit.rmse_uT"].difference == pytest.approx(0.5)
    assert "moved +0.5" in changes["fit.rmse_uT"].describe()
    assert changes["gone"].kind == "removed" and changes["new"].kind == "added"


def test_null_golden_stands_for_nan_and_flags_compare_exactly():
    golden = {"a": None, "b": False, "c": [45.0]}
    classes = {"a": "estimate", "b": "exact", "c": "exact"}
    assert compare(golden, classes, {"a": math.nan, "b": False, "c": [45.0]}) == []
    moved = compare(golden, classes, {"a": 0.1, "b": True, "c": [40.0, 45.0]})
    assert [c.name for c in moved] == ["a", "b", "c"]
