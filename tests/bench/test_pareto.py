"""Pareto fronts and charts."""

import numpy as np
import pytest

from whiskercal.bench.pareto import draw_pareto, front_rows, pareto_mask
from whiskercal.bench.runner import add_time_ratios
from whiskercal.errors import UsageError

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def test_front_keeps_exactly_the_non_dominated_points():
    time_s = [1.0, 2.0, 3.0, 2.0, 0.5, np.nan]
    error = [5.0, 1.0, 0.5, 2.0, 9.0, 0.1]
    # (2, 2) is dominated by (2, 1); the NaN row can never be on the front
    assert pareto_mask(time_s, error).tolist() == [True, True, True, False, True, False]


def test_a_duplicate_point_does_not_dominate_itself():
    assert pareto_mask([1.0, 1.0], [2.0, 2.0]).tolist() == [True, True]


def test_front_rows_are_sorted_fastest_first():
    rows = [{"t": 3.0, "e": 0.1}, {"t": 1.0, "e": 1.0}, {"t": 2.0, "e": 2.0}]
    assert [r["t"] for r in front_rows(rows, "t", "e")] == [1.0, 3.0]


def test_time_ratios_are_relative_to_the_fastest_row():
    rows = [{"t": 2e-6}, {"t": 1e-3}, {"t": 4e-6}]
    add_time_ratios(rows, "t")
    assert [r["time_ratio_to_fastest"] for r in rows] == pytest.approx([1.0, 500.0, 2.0])


def test_chart_is_a_png_with_panels_and_a_default(tmp_path):
    rows = [{"case": c, "engine": e, "t": t, "err": err, "default": e == "a" and t == 1e-3}
            for c in ("one", "two") for e, t, err in (("a", 1e-3, 0.1), ("a", 1e-2, 0.01),
                                                      ("b", 1e-4, 0.5))]
    spec = {"x": "t", "y": "err", "series": ["engine"], "panel": "case", "label": "engine"}
    path = draw_pareto(rows, spec, tmp_path / "chart.png", title="test")
    content = path.read_bytes()
    assert content.startswith(PNG_SIGNATURE)
    # two panels side by side: the image is wider than one panel's 5.5 inch at 110 dpi
    width = int.from_bytes(content[16:20], "big")
    assert width > 2 * 5.5 * 110 * 0.9


def test_nothing_finite_to_chart_is_refused(tmp_path):
    with pytest.raises(UsageError, match="nothing to chart"):
        draw_pareto([{"t": np.nan, "e": 1.0}], {"x": "t", "y": "e"}, tmp_path / "x.png")
