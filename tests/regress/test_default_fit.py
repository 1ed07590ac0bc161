"""The default fit in ``regress``: its quantities, their tolerance classes, and the golden files
that carry them."""

import json
import math
from pathlib import Path

import numpy as np
import pytest

from whiskercal.regress.default_fit import (TABLE_STRIDE, Z_SAMPLES, _table_quantities,
                                            table_within_goal)
from whiskercal.regress.golden import DEFAULT_PIPELINE, Golden
from whiskercal.regress.runner import _pipeline
from whiskercal.regress.tolerances import (EXACT, MODEL_TIP, MODEL_TIP_MAX, MODEL_Z, TABLE_AXIS,
                                           TABLE_SHARE, TABLE_TIP, tolerance_for)

DATA = Path(__file__).resolve().parents[2] / "data"
DATASETS = ("twin-long-110mm", "twin-paper-75mm", "twin-short-60mm")


def _table(fill=True):
    """A 25 x 13 table over Y -100..0 and Z -60..60 µT whose tip x is Y + Z (mm), so a
    bilinear read is exact; ``fill`` False empties its first two Z columns (-60, -50 µT)."""
    y, axial = np.linspace(-100.0, 0.0, 25), np.linspace(-60.0, 60.0, 13)
    tips = np.stack(np.broadcast_arrays(y[:, None] + axial[None, :], np.zeros((1, 13))), -1)
    tips = tips.astype(float).copy()
    if not fill:
        tips[:, :2] = np.nan
    return {"y_uT": y, "axial_uT": axial, "tip_mm": tips}


def test_the_table_is_read_at_fixed_fields_whatever_its_z_axis():
    found = _table_quantities(_table(), (-40.0, 40.0))
    assert [k for k in found if k.startswith("default") or k.startswith("table.y_uT")] == [
        "table.y_uT[000]", "table.y_uT[012]", "table.y_uT[024]"]
    assert TABLE_STRIDE == 12 and Z_SAMPLES == 11
    # Y -50 µT (row 12), Z sample 5 of -40..40 (0 µT): the bilinear read, tip x = Y + Z
    assert found["table.tip_x_mm[012,05]"] == pytest.approx(-50.0)
    assert found["table.tip_x_mm[012,00]"] == pytest.approx(-90.0)
    assert found["table.axial_uT.first"] == -60.0 and found["table.axial_uT.last"] == 60.0
    assert found["table.answered_share"] == 1.0
    # the first and last Y rows lie on the table's edge: left out
    assert math.isnan(found["table.tip_x_mm[000,05]"]) and math.isnan(
        found["table.tip_x_mm[024,05]"])


def test_a_field_within_a_cell_of_the_loads_edge_is_left_out():
    found = _table_quantities(_table(fill=False), (-40.0, 40.0))
    # Z -40 and -32 µT lie in the cell next to the emptied columns' cells, -24 µT one further
    assert math.isnan(found["table.tip_x_mm[012,00]"]) and math.isnan(
        found["table.tip_x_mm[012,01]"])
    assert found["table.tip_x_mm[012,02]"] == pytest.approx(-50.0 - 24.0)
    assert found["table.answered_share"] == 11 / 13


@pytest.mark.parametrize("estimate_mm, within", [(0.04, True), (0.25, True), (0.43, False),
                                                 (math.nan, False), (None, False)])
def test_only_a_table_the_fit_estimates_within_the_goal_has_its_tips_checked(estimate_mm, within):
    metrics = {} if estimate_mm is None else {"field_table_estimated_tip_error_mm": estimate_mm}
    assert table_within_goal(metrics) is within


@pytest.mark.parametrize("name, tolerance", [
    ("default.fit.tip_model", EXACT), ("default.fit.field_table_written", EXACT),
    ("default.fit.load_branches_written", EXACT), ("default.fit.tip_error_warned", EXACT),
    ("default.fit.lookup_vs_truth_points", EXACT), ("default.lookup.kind", EXACT),
    ("default.fit.lookup_vs_truth_rmse_mm", MODEL_TIP), ("default.lookup.tip_x_mm[03]", MODEL_TIP),
    ("default.fit.lookup_vs_truth_max_mm", MODEL_TIP_MAX), ("default.lookup.z_uT[19]", MODEL_Z),
    ("default.table.axial_uT.last", TABLE_AXIS), ("default.table.within_goal", EXACT),
    ("default.table.tip_y_mm[012,04]", TABLE_TIP), ("default.table.answered_share", TABLE_SHARE),
    ("lookup.tip_x_mm[03]", tolerance_for("lookup.tip_x_mm[03]")),  # the level set's unchanged
])
def test_each_default_quantity_has_the_class_of_what_the_fit_guarantees(name, tolerance):
    assert tolerance_for(name) is tolerance


def test_the_classes_leave_a_change_of_model_outside_and_the_arithmetics_moves_inside():
    # the widest moves measured over the arithmetic variants pass; a fall to the level set's
    # 0.44 mm, or a table tip moved by a third of the goal, does not
    assert MODEL_TIP.allows(0.0462, 0.0462 - 0.026) and not MODEL_TIP.allows(0.0462, 0.44)
    assert MODEL_TIP_MAX.allows(0.123, 0.123 - 0.097) and not MODEL_TIP_MAX.allows(0.123, 0.5)
    assert TABLE_TIP.allows(70.0, 70.042) and not TABLE_TIP.allows(70.0, 70.09)
    # a field at the loads' edge left out on one side passes; the coverage is table_share's
    assert TABLE_TIP.allows(50.37, float("nan")) and TABLE_TIP.allows(float("nan"), 50.37)
    assert not MODEL_TIP.allows(0.0439, float("nan"))
    assert TABLE_SHARE.allows(0.64, 0.6435) and not TABLE_SHARE.allows(0.64, 0.60)


def test_an_update_gives_an_older_golden_file_the_default_fit_and_a_check_keeps_its_own():
    old = Golden({}, {}, pipeline={"fit_args": ["--degree", "4"], "margin_weight_mm": 0.2,
                                   "why": "old"})
    updated = _pipeline(old, update=True)
    assert updated["fit_args"] == ["--degree", "4"] and updated["margin_weight_mm"] == 0.2
    assert updated["default_fit_args"] == DEFAULT_PIPELINE["default_fit_args"]
    assert updated["why"] == DEFAULT_PIPELINE["why"]
    assert _pipeline(old, update=False) is old.pipeline


@pytest.mark.parametrize("dataset", DATASETS)
def test_every_recorded_golden_file_regresses_the_default_fit(dataset):
    document = json.loads((DATA / dataset / "golden.json").read_text(encoding="utf-8"))
    assert document["pipeline"]["default_fit_args"] == DEFAULT_PIPELINE["default_fit_args"]
    quantities = document["quantities"]
    assert quantities["default.fit.tip_model"]["value"] in ("mechanics", "mechanics-yz",
                                                            "level-set")
    tips = [k for k in quantities if k.startswith("default.lookup.tip_")]
    assert len(tips) == 40 and all(quantities[k]["tolerance"] == "model_tip" for k in tips)
    within = quantities["default.table.within_goal"]["value"]
    table_tips = [k for k in quantities if k.startswith("default.table.tip_")]
    assert len(table_tips) == (2 * 11 * Z_SAMPLES if within else 0)
    assert {"model_tip", "model_tip_max", "model_z"} <= set(document["tolerance_classes"])
