"""``bench --only fit-speed``: the fit's wall time against its tip error, for each tip model."""

import json
import math
import time
from pathlib import Path

import pytest
from click.testing import CliRunner

from whiskercal.bench.fit_speed import METHODS, PARETO, _supports
from whiskercal.cli import cli

DATA = Path(__file__).resolve().parents[2] / "data"


def _row(dataset, method, fit_s, rmse):
    return {"dataset": dataset, "method": method, "fit_s": fit_s, "lookup_vs_truth_rmse_mm": rmse}


def test_the_supports_give_the_default_time_as_a_multiple_of_the_level_sets():
    rows = [_row("a", "level-set", 2.0, 0.4), _row("a", "mechanics", 3.0, 0.05),
            _row("a", "auto", 8.0, 0.03)]
    found = _supports(rows)["a"]
    assert found["default_time_ratio_to_level_set"] == 4.0
    assert (found["default_rmse_mm"], found["level_set_rmse_mm"]) == (0.03, 0.4)


def test_the_chart_has_a_panel_per_dataset_and_the_front_of_each(tmp_path):
    from whiskercal.bench.runner import _charts

    rows = [dict(_row(d, m, t, e), tip_model=m, default=m == "auto")
            for d in ("a", "b") for m, t, e in (("level-set", 2.0, 0.4), ("mechanics", 3.0, 0.05),
                                                ("auto", 8.0, 0.03))]
    result = {"rows": rows, "pareto": dict(PARETO)}
    assert _charts("fit-speed", result, tmp_path) == ["fit-speed.png"]
    assert (tmp_path / "fit-speed.png").read_bytes().startswith(b"\x89PNG")
    # no row is both faster and closer than another: all three are on the front
    assert len(result["front"]["pareto"]) == 6
    assert rows[2]["time_ratio_to_fastest"] == 4.0


@pytest.mark.slow
def test_the_quick_comparison_fits_each_tip_model_and_draws_the_chart(tmp_path):
    result = CliRunner().invoke(cli, ["bench", "--quick", "--only", "fit-speed", "--out",
                                      str(tmp_path), "--json"], catch_exceptions=False)
    assert result.exit_code == 0, result.output
    found = json.loads((tmp_path / "fit-speed.json").read_text())
    rows = {row["method"]: row for row in found["rows"]}
    assert list(rows) == list(METHODS)
    golden = json.loads((DATA / "twin-short-60mm" / "golden.json").read_text())["quantities"]
    assert rows["level-set"]["tip_model"] == "level-set"
    assert rows["mechanics"]["tip_model"] == "mechanics"
    # the default's choice is the one the regression pins for this dataset
    assert rows["auto"]["tip_model"] == golden["default.fit.tip_model"]["value"]
    for row in rows.values():
        assert row["fit_s"] > 0.0 and row["cpu_s"] > 0.0 and "level_set" in row["timings_s"]
        assert math.isfinite(row["lookup_vs_truth_rmse_mm"])
    assert "joint_fit" in rows["auto"]["timings_s"]
    assert "joint_fit" not in rows["level-set"]["timings_s"]
    assert (tmp_path / "fit-speed.png").read_bytes().startswith(b"\x89PNG")


def _busy(seconds: float) -> float:
    """Burn this much CPU time (s) in the worker."""
    start = time.process_time()
    while time.process_time() - start < seconds:
        pass
    return time.process_time() - start


def test_the_cpu_time_counts_the_fits_worker_processes(monkeypatch):
    from whiskercal.bench.fit_speed import _cpu_s
    from whiskercal.mechfit import workers

    monkeypatch.setattr(workers, "available_cpus", lambda: 2)
    before = _cpu_s()
    spent = workers.run_side_by_side(_busy, [(0.2,), (0.2,)])
    # the workers' own time, none of it this process's (0.9: the kernel's microsecond rounding)
    assert _cpu_s() - before >= 0.9 * sum(spent) and sum(spent) >= 0.4
