"""``bench --only error-budget``: contour error with the twin's nuisances, with and without their
counter-measures; the goal's verdict; the quick form's JSON."""

import json
import math

import pytest
from click.testing import CliRunner

from whiskercal.bench.error_budget import GOAL_MM, goal, level_of, mount_of
from whiskercal.bench.mount_cal import NOMINAL
from whiskercal.mount import Mount
from whiskercal.cli import cli

ROW_KEYS = {"nuisance", "level", "countermeasure", "case", "mean_error_mm"}


def _row(case, nuisance, on, error, coverage=1.0):
    return {"case": case, "nuisance": nuisance, "countermeasure_on": on, "mean_error_mm": error,
            "coverage": coverage}


def test_the_goal_names_the_nuisance_that_sets_a_failing_case():
    rows = [_row("octagon", "all", True, 0.45), _row("octagon", "all", False, 3.0),
            _row("octagon", "drift", True, 0.02), _row("octagon", "viscoelastic", True, 0.41),
            _row("octagon", "robot", True, math.nan),  # lost the surface: the worst of all
            _row("cylinder", "all", True, 0.2), _row("cylinder", "drift", True, 0.05)]
    verdict = goal(rows)
    assert verdict["octagon"]["met"] is False and verdict["octagon"]["set_by"] == "robot"
    assert verdict["cylinder"] == {"all_mean_error_mm": 0.2, "goal_mm": GOAL_MM, "met": True,
                                   "set_by": None, "alone_mean_error_mm": {"drift": 0.05}}


def test_a_miss_run_without_each_nuisance_is_set_by_the_one_whose_absence_helps_most():
    # alone, viscoelastic errs most; together, the case meets the goal only without contact
    rows = [_row("octagon", "all", True, 0.68), _row("octagon", "contact", True, 0.17),
            _row("octagon", "viscoelastic", True, 0.21),
            _row("octagon", "all but contact", True, 0.12),
            _row("octagon", "all but viscoelastic", True, 0.55),
            _row("octagon", "all but robot", True, math.nan)]  # lost the surface: no help
    verdict = goal(rows)["octagon"]
    assert verdict["set_by"] == "contact" and verdict["met"] is False
    assert verdict["alone_mean_error_mm"] == {"contact": 0.17, "viscoelastic": 0.21}
    assert verdict["without_mean_error_mm"]["viscoelastic"] == 0.55


def test_all_but_one_keeps_every_other_nuisance_realistic():
    from whiskercal.twin.nuisances import REALISTIC, Nuisances

    without_contact = level_of("all but contact")
    assert without_contact.contact == Nuisances().contact
    assert without_contact.replace(contact=REALISTIC.contact) == REALISTIC
    assert level_of("all but mount") == REALISTIC  # the mount is the loop's, not the sensor's
    fitted = Mount(NOMINAL.x_mm + 1.0, NOMINAL.y_mm - 0.5, NOMINAL.yaw_deg + 2.0)
    mounts = {"fitted": fitted, "true": NOMINAL}
    assert mount_of("all but mount", True, mounts) is None
    assert mount_of("all but drift", True, mounts) == (fitted, (-1.0, 0.5, -2.0))


def test_every_realistic_level_says_where_it_comes_from():
    from whiskercal.twin.nuisances import REALISTIC, SOURCES

    keys = {f"{table}.{key}" for table, values in REALISTIC.to_dict().items() for key in values}
    assert keys == set(SOURCES) and all(SOURCES.values())


@pytest.mark.slow
def test_the_quick_bench_writes_its_rows_chart_and_verdict(tmp_path):
    result = CliRunner().invoke(cli, ["bench", "--quick", "--only", "error-budget", "--out",
                                      str(tmp_path), "--json"], catch_exceptions=False)
    assert result.exit_code == 0, result.output
    found = json.loads((tmp_path / "error-budget.json").read_text())
    rows = found["rows"]
    assert {(r["nuisance"], r["countermeasure_on"]) for r in rows} == {
        ("none", False), ("none", True), ("all", False), ("all", True)}
    for row in rows:
        assert ROW_KEYS <= set(row) and row["case"] in ("cylinder", "plane 20 mm")
    for case in ("cylinder", "plane 20 mm"):  # the plane study's one quick depth passes
        baseline = next(r for r in rows if r["case"] == case and r["nuisance"] == "none"
                        and not r["countermeasure_on"])
        assert 0.0 < baseline["mean_error_mm"] < 1.0  # against the truth, no alignment
    assert {(r["speed_mm_s"], r["rate_hz"]) for r in found["speed_rate_rows"]} == {
        (8.0, 30.0), (8.0, 300.0)}
    assert set(found["goal"]) == {"cylinder", "plane 20 mm"} and found["goal"]["cylinder"]["goal_mm"] == GOAL_MM
    assert found["levels"]["robot"]["rate_hz"] == 30.0 and found["sources"]["robot.rate_hz"]
    assert (tmp_path / "error-budget.png").read_bytes().startswith(b"\x89PNG")
