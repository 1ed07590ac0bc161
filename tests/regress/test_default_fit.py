"""The default fit in ``regress``: its quantities, their tolerance classes, and the golden files
that carry them."""

import json
import math
from pathlib import Path

import numpy as np
import pytest

from whiskercal.regress.default_fit import TABLE_STRIDE, _table_quantities
from whiskercal.regress.golden import DEFAULT_PIPELINE, Golden
from whiskercal.regress.runner import _pipeline
from whiskercal.regress.tolerances import (EXACT, MODEL_TIP, MODEL_Z, TABLE_AXIS, TABLE_SHARE,
                                           TABLE_TIP, tolerance_for)

DATA = Path(__file__).resolve().parents[2] / "data"
DATASETS = ("twin-long-110mm", "twin-paper-75mm", "twin-short-60mm")


def test_the_table_is_checked_on_a_subgrid_with_its_empty_cells_as_nan():
    y, axial = np.linspace(-100.0, 0.0, 25), np.linspace(-50.0, 50.0, 13)
    tips = np.full((25, 13, 2), np.nan)
    tips[12, 12] = (70.0, -3.0)
    found = _table_quantities({"y_uT": y, "axial_uT": axial, "tip_mm": tips})
    assert [k for k in found if k.startswith("table.y_uT")] == [
        "table.y_uT[000]", "table.y_uT[012]", "table.y_uT[024]"]
    assert found["table.axial_uT[012]"] == 50.0 and TABLE_STRIDE == 12
    assert found["table.tip_x_mm[012,012]"] == 70.0 and found["table.tip_y_mm[012,012]"] == -3.0
    assert math.isnan(found["table.tip_x_mm[000,000]"])
    assert found["table.answered_share"] == 1 / (25 * 13)
    assert _table_quantities(None) == {}


@pytest.mark.parametrize("name, tolerance", [
    ("default.fit.tip_model", EXACT), ("default.fit.field_table_written", EXACT),
    ("default.fit.load_branches_written", EXACT), ("default.fit.tip_error_warned", EXACT),
    ("default.fit.lookup_vs_truth_points", EXACT), ("default.lookup.kind", EXACT),
    ("default.fit.lookup_vs_truth_rmse_mm", MODEL_TIP), ("default.lookup.tip_x_mm[03]", MODEL_TIP),
    ("default.lookup.z_uT[19]", MODEL_Z), ("default.table.axial_uT[012]", TABLE_AXIS),
    ("default.table.tip_y_mm[012,024]", TABLE_TIP), ("default.table.answered_share", TABLE_SHARE),
    ("lookup.tip_x_mm[03]", tolerance_for("lookup.tip_x_mm[03]")),  # the level set's unchanged
])
def test_each_default_quantity_has_the_class_of_what_the_fit_guarantees(name, tolerance):
    assert tolerance_for(name) is tolerance


def test_the_classes_leave_a_change_of_model_outside_and_reordered_sums_inside():
    assert MODEL_TIP.allows(0.0439, 0.0439 + 8.5e-4) and not MODEL_TIP.allows(0.0439, 0.0539)
    assert TABLE_TIP.allows(70.0, 70.069) and not TABLE_TIP.allows(70.0, 70.25)
    # an edge cell emptied or filled passes; the coverage is what table_share holds
    assert TABLE_TIP.allows(50.37, float("nan")) and TABLE_TIP.allows(float("nan"), 50.37)
    assert not MODEL_TIP.allows(0.0439, float("nan"))
    assert TABLE_SHARE.allows(0.64, 0.64 + 1 / 121 ** 2) and not TABLE_SHARE.allows(0.64, 0.60)


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
    assert {"model_tip", "model_z", "table_axis", "table_tip", "table_share"} <= set(
        document["tolerance_classes"])
