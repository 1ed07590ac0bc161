"""`whiskercal twin cantilever` and `whiskercal twin validate`."""

import json
import math

import pytest
from click.testing import CliRunner

from whiskercal.cli import cli


def run(*args):
    return CliRunner().invoke(cli, list(args), catch_exceptions=False)


def test_cantilever_json_against_the_published_table():
    result = run("twin", "cantilever", "--alpha", "2", "--json")
    assert result.exit_code == 0
    payload = json.loads(result.output)
    assert set(payload) == {"alpha", "x", "y"}
    assert payload["alpha"] == 2.0
    # Bisshopp & Drucker: alpha = 2 -> y/L = 0.49346, 1 - x/L = 0.16064
    assert payload["y"] == pytest.approx(0.49346, abs=1e-5)
    assert payload["x"] == pytest.approx(1 - 0.16064, abs=1e-5)


def test_cantilever_text_follows_beam_theory_for_small_loads():
    result = run("twin", "cantilever", "--alpha", "0.003")
    assert result.exit_code == 0
    assert result.output.startswith("alpha = 0.003: tip x/L = ")
    y = float(result.output.strip().rsplit("=", 1)[1])
    assert y == pytest.approx(0.001, rel=1e-4)


def test_cantilever_out_of_range_is_one_line_and_exit_2():
    result = CliRunner().invoke(cli, ["twin", "cantilever", "--alpha", "-1"])
    assert result.exit_code == 2
    assert result.output.strip().splitlines() == ["error: alpha must be in [0, 50], got -1.0."]


def test_validate_passes_and_reports_every_check():
    result = run("twin", "validate", "--json")
    assert result.exit_code == 0
    payload = json.loads(result.output)
    assert payload["ok"] is True
    names = [check["name"] for check in payload["checks"]]
    assert any("Bisshopp-Drucker" in name for name in names)
    assert any("rigidly" in name for name in names)
    assert sum("equilibrium residual" in name for name in names) == 5
    assert any("sticking" in name for name in names) and any("sliding" in name for name in names)
    assert all(check["value"] <= check["limit"] for check in payload["checks"])


def test_validate_fails_when_a_check_fails(monkeypatch):
    from whiskercal.twin.validation import checks as validation

    failing = validation.Check("a check that fails", 2.0, 1.0)
    monkeypatch.setattr(validation, "run_all", lambda: [failing])
    result = CliRunner().invoke(cli, ["twin", "validate"])
    assert result.exit_code == 1
    assert "FAIL" in result.output
    assert "error: 1 of 1 mechanics checks failed." in result.output


def test_twin_group_lists_its_commands():
    result = run("twin", "--help")
    assert "cantilever" in result.output and "validate" in result.output


def test_plane_study_json_finds_the_switch_to_tangential():
    result = run("twin", "plane-study", "--depths", "30,40,50", "--json")
    assert result.exit_code == 0
    payload = json.loads(result.output)
    kinds = [row["kind"] for row in payload["depths"]]
    assert kinds == ["tip", "tip", "tangential"]
    assert payload["tangential_onset_mm"] == 50.0
    # deeper pushes turn the root further
    rotations = [row["root_rotation_deg"] for row in payload["depths"]]
    assert rotations[0] > rotations[1] > rotations[2]


def test_plane_study_softer_root_slips_later():
    stiff = json.loads(run("twin", "plane-study", "--depths", "46", "--json").output)
    soft = json.loads(run("twin", "plane-study", "--depths", "46", "--k-rot", "0.5",
                          "--json").output)
    assert stiff["depths"][0]["kind"] == "tangential"
    assert soft["depths"][0]["kind"] == "tip"


def test_plane_study_bad_depths_are_one_line():
    result = CliRunner().invoke(cli, ["twin", "plane-study", "--depths", "a,b"])
    assert result.exit_code == 2
    expected = "error: --depths must be numbers separated by commas, got 'a,b'."
    assert result.output.strip() == expected


def test_validate_reports_the_stick_slip_checks():
    payload = json.loads(run("twin", "validate", "--json").output)
    stick_slip = [c for c in payload["checks"] if c["name"].startswith("stick-slip")]
    assert len(stick_slip) == 3
    assert all(c["value"] <= c["limit"] for c in stick_slip)
    events = int(stick_slip[0]["detail"].split()[0])
    assert events >= 10  # a 10 mm slide at 20 mm depth slips many times


def test_stick_slip_check_fails_when_a_slip_does_not_come_to_rest(monkeypatch):
    # a twin whose slips stop on the kinetic edge instead of at the rest ratio must fail
    from whiskercal.twin.physics import plane as plane_module
    from whiskercal.twin.validation import checks as validation

    def slip_to_kinetic_edge(ratio_start, ratio_stuck, plane):
        return math.copysign(plane.mu_kinetic, ratio_stuck), 1

    monkeypatch.setattr(plane_module, "slips_within_step", slip_to_kinetic_edge)
    checks = {c.name: c for c in validation.check_stick_slip(n_steps=600)}
    rest = checks["stick-slip: after each slip |Ft|/Fn sits at the rest ratio"]
    assert not rest.ok
    assert rest.value > 0.05  # mu_k sits 0.072 above the default rest ratio

