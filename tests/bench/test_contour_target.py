"""``bench --only contour-target``: contour error against the deflection target."""

import json

import pytest
from click.testing import CliRunner

from whiskercal.bench.contour_target import _targets
from whiskercal.cli import cli


def test_the_targets_span_the_range_keep_the_chosen_one_and_list_those_past_the_range():
    run, beyond = _targets(-5011.0, -9539.0, quick=False)
    assert run == [-3000.0, -4000.0, -5000.0, -5011.0, -6000.0, -7000.0, -8000.0, -9000.0]
    assert beyond == [-10000.0, -11000.0, -12000.0]
    run, beyond = _targets(4200.0, 12500.0, quick=True)  # a positive target keeps its sign
    assert run == [4200.0, 8000.0] and beyond == []


@pytest.mark.slow
def test_the_quick_comparison_runs_the_loop_at_each_target_and_draws_the_chart(tmp_path):
    result = CliRunner().invoke(cli, ["bench", "--quick", "--only", "contour-target", "--out",
                                      str(tmp_path), "--json"], catch_exceptions=False)
    assert result.exit_code == 0, result.output
    found = json.loads((tmp_path / "contour-target.json").read_text())
    chosen = found["chosen_target_z_uT"]["z-lookup"]
    assert list(found["chosen_target_z_uT"]) == ["z-lookup"]
    assert [row["target_z_uT"] for row in found["rows"]] == [chosen, -8000.0]
    for row in found["rows"]:  # measured against the twin's outline, no alignment
        assert row["tip_model"] == "z-lookup"  # quick mode skips the minutes-long table fit
        assert row["shape"] == "cylinder" and 0.0 < row["mean_error_mm"] < 1.0
        assert row["control_ms_mean"] > 0.0
    assert found["supports"]["target_z_uT"] == {"z-lookup": chosen}
    assert (tmp_path / "contour-target.png").read_bytes().startswith(b"\x89PNG")


def _row(model, shape, target, error, coverage=1.0):
    return {"tip_model": model, "shape": shape, "target_z_uT": target, "mean_error_mm": error,
            "coverage": coverage, "control_ms_mean": 0.1, "control_ms_max": 1.0}


def test_each_tip_model_gets_its_own_chosen_and_best_target_and_the_chart_draws_both(tmp_path):
    from whiskercal.bench.contour_target import _supports, draw

    rows = [_row("z-lookup", "cylinder", -4000.0, 0.04),
            _row("z-lookup", "cylinder", -5011.0, 0.22),
            _row("yz-table", "cylinder", -3100.0, 0.016),
            _row("yz-table", "cylinder", -4000.0, 0.03, coverage=0.5),  # did not go round
            _row("yz-table", "cylinder", -5011.0, 0.017)]
    chosen = {"z-lookup": -5011.0, "yz-table": -3100.0}
    supports = _supports(rows, chosen)
    assert supports["best_target_z_uT"] == {"z-lookup": {"cylinder": -4000.0},
                                            "yz-table": {"cylinder": -3100.0}}
    assert supports["chosen_mean_error_mm"] == {"z-lookup": {"cylinder": 0.22},
                                                "yz-table": {"cylinder": 0.016}}
    result = {"rows": rows, "chosen_target_z_uT": chosen, "calibrated_range_end_uT": -9539.0}
    assert draw(result, tmp_path / "c.png").read_bytes().startswith(b"\x89PNG")
