"""The report's summary leads with what shipped, in words and units, then the evidence."""

import html
import math
import re
from dataclasses import replace

import numpy as np
import pytest

from whiskercal.artifacts.calibration import read_calibration
from whiskercal.report import outcome
from whiskercal.report.build import build_html


@pytest.fixture(scope="module")
def fitted(twin_files):
    return read_calibration(twin_files[1])


def _summary_section(page: str) -> str:
    return re.search(r"<h2>Summary</h2>(.*?)</section>", page, re.S).group(1)


def test_the_summary_leads_with_what_shipped_then_the_evidence(twin_files, fitted):
    summary = html.unescape(_summary_section(build_html(twin_files[1], twin_files[0])))
    m = fitted.metrics
    order = [summary.index(words) for words in (
        "tip model", "(Y, Z) table", "collision threshold", "Warnings fit gave", "Evidence",
        "surface fit residual, RMS (µT)")]
    assert order == sorted(order)
    assert f"{m['tip_model']}: {outcome.TIP_MODEL_WORDS[m['tip_model']]}; estimated tip error " \
        f"{m['estimated_tip_error_mm']:.3f} mm RMS" in summary
    assert f"{m['r2']:.6f}" in summary
    assert "not fitted (fit --no-field-table)" in summary  # the fixture's fit
    assert f"{fitted.collision['threshold_uT']:.0f} µT from the static reading" in summary
    assert "whiskercal.runtime.load(...).tracker()" in summary
    for warning in m["warnings"]:
        assert warning in summary
    assert "rmse_uT" not in summary and "lookup_holdout_rmse_mm" not in summary


def test_a_written_table_is_said_with_its_estimates(fitted):
    metrics = {**fitted.metrics, "field_table_estimated_tip_error_mm": 0.2,
               "field_table_held_estimated_tip_error_mm": 0.1}
    table = {"y_uT": np.zeros(2), "axial_uT": np.zeros(2), "tip_mm": np.zeros((2, 2, 2))}
    line = outcome.table_line(replace(fitted, metrics=metrics, field_table=table))
    assert line.startswith("written")
    assert "0.200 mm RMS for one reading, 0.100 mm RMS for a held contact" in line


def test_a_withheld_table_names_the_loads_followed_instead(fitted):
    metrics = {**fitted.metrics, "field_table_estimated_tip_error_mm": 0.9,
               "field_table_held_estimated_tip_error_mm": 0.7,
               "load_branches_estimated_tip_error_mm": 0.3}
    withheld = replace(fitted, metrics=metrics, field_table=None, load_branches=None)
    assert outcome.table_line(withheld).startswith("withheld (")
    assert "loads are followed" not in outcome.table_line(withheld)
    followed = replace(withheld, load_branches={"fields_uT": np.zeros((1, 2))})
    assert "loads are followed through each contact from rest, estimated tip error 0.300 mm" \
        in outcome.table_line(followed)


def test_the_threshold_says_why_it_has_its_value(fitted):
    given = {**fitted.metrics, "collision_threshold_source": "given",
             "collision_tip_motion_mm": math.nan}
    line = outcome.threshold_line(replace(fitted, metrics=given))
    assert "given with fit --threshold-uT" in line and "tip has moved" not in line
    chosen = {**fitted.metrics, "collision_threshold_source": "tip motion",
              "collision_tip_motion_mm": 3.0}
    assert "a frictionless tip has moved 3.0 mm" in outcome.threshold_line(
        replace(fitted, metrics=chosen))


def test_no_warnings_reads_none(fitted):
    quiet = replace(fitted, metrics={**fitted.metrics, "warnings": []})
    assert outcome.warnings_lines(quiet) == ["none"]
