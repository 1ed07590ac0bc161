"""The fit stage as a library call (``whiskercal.fit``), without click."""

from __future__ import annotations

import json
import subprocess
import sys
from dataclasses import asdict
from pathlib import Path

import numpy as np
import pytest

from analytic import paper_grid_mm, rigid_z
from rawfile import write_raw_grid
from whiskercal.artifacts.calibration import read_calibration
from whiskercal.artifacts.raw_grid import read_raw_grid
from whiskercal.errors import UsageError
from whiskercal.fit import (FitOptions, compare_with_twin_truth, fit, options_from_args,
                            resolve_trace_length)
from whiskercal.model.errors import ExtrapolationLimitError, FitError, ModelError

ROOT = Path(__file__).resolve().parents[2]
RECORDED = ROOT / "data" / "twin-short-60mm"


def _options(**fields) -> FitOptions:
    """The fit's options for the rigid root's analytic grid: the level set (no suspension to
    fit, so the default refuses the grid, as one test here checks) without the (Y, Z) table:
    these tests are about the rest of the fit, and the table adds 30-60 s to a fit
    (tests/fit/test_tip_model.py tests the default)."""
    return FitOptions(**{"field_table": False, "tip_model": "level-set", **fields})


@pytest.fixture(scope="module")
def rigid_raw(tmp_path_factory):
    """An analytic rigid-whisker grid (no twin truth) with a 70 mm trace length recorded."""
    points = paper_grid_mm()
    z = rigid_z(points) + np.random.default_rng(1).normal(0.0, 1.0, len(points))
    path = tmp_path_factory.mktemp("raw") / "raw.h5"
    write_raw_grid(path, points, z, 0.0, "analytic-rigid",
                   config={"rig": {"rod_radius_mm": 0.0, "trace_length_mm": 70.0}})
    return read_raw_grid(path)


@pytest.fixture(scope="module")
def recorded():
    """The recorded twin grid fitted with its golden file's options, and the golden file."""
    golden = json.loads((RECORDED / "golden.json").read_text(encoding="utf-8"))
    raw = read_raw_grid(RECORDED / "raw_grid.h5")
    # the table enters none of the fit. and lookup. quantities compared here but its own flag
    fit_args = [*golden["pipeline"]["fit_args"], "--no-field-table"]
    return raw, fit(raw, options_from_args(fit_args)), golden


@pytest.mark.slow
def test_the_recorded_grid_fits_to_its_golden_results(recorded):
    from whiskercal.regress.compare import compare
    from whiskercal.regress.pipeline import fit_quantities, lookup_quantities

    _, result, golden = recorded
    data = result.artifact_data()
    new = {**fit_quantities(data), **lookup_quantities(data)}
    assert new.pop("fit.field_table_written") is False  # fitted without the table (above)
    wanted = {name: entry["value"] for name, entry in golden["quantities"].items()
              if name.startswith(("fit.", "lookup.")) and name != "fit.field_table_written"}
    classes = {name: golden["quantities"][name]["tolerance"] for name in wanted}
    assert len(wanted) > 40 and compare(wanted, classes, new) == []


def test_the_result_carries_the_calibration_its_truth_and_provenance(recorded):
    raw, result, _ = recorded
    assert result.sensor_id == raw.sensor_id == "twin-short-60mm"
    assert result.calibration_options.trace_length_mm == raw.config["rig"]["trace_length_mm"]
    assert result.metrics["points_used"] == int(result.calibration.used.sum())
    assert result.metrics["raw_complete"] is True
    assert result.truth is not None and 0 < result.truth.rmse_mm < result.truth.max_mm < 1.0
    assert result.truth.contact_error_corrected_mm < result.truth.contact_error_uncorrected_mm
    assert result.metrics["lookup_vs_truth_rmse_mm"] == result.truth.rmse_mm
    assert result.inputs == {"raw_grid": raw.sha256}
    assert result.config["options"] == asdict(result.calibration_options)
    assert result.config["raw_grid"] == str(RECORDED / "raw_grid.h5")


def test_write_round_trips_through_the_artifact_reader(recorded, tmp_path):
    _, result, _ = recorded
    data = read_calibration(result.write(tmp_path / "cal.h5"))
    assert data.sensor_id == result.sensor_id and data.degree == 5
    assert data.metrics["warnings"] == result.warnings
    assert data.metrics["rmse_uT"] == result.metrics["rmse_uT"]
    np.testing.assert_array_equal(data.lookup_z_uT, result.calibration.lookup.z_knots_uT)
    np.testing.assert_array_equal(data.truth["error_mm"], result.truth.error_mm)
    assert data.collision["threshold_uT"] == 300.0
    assert data.config["options"]["trace_length_mm"] == result.calibration_options.trace_length_mm


def test_a_real_rig_grid_has_no_truth_comparison(rigid_raw):
    result = fit(rigid_raw, _options(samples=8, threshold_uT=250.0))
    assert result.truth is None and compare_with_twin_truth(rigid_raw, result.calibration) is None
    assert not any(name.startswith(("lookup_vs_truth", "contact_error")) for name in result.metrics)
    assert result.artifact_data().truth is None
    assert result.artifact_data().collision["threshold_uT"] == 250.0
    assert len(result.calibration.lookup.z_knots_uT) == 8
    # a rigid root gives the suspension model nothing to fit: the level set, asked for, ships
    # and the fit says its error is unknown
    assert result.metrics["tip_model"] == "level-set"
    assert [w.split(":")[0] for w in result.warnings] == ["the tip error cannot be estimated"]


def test_the_default_fit_refuses_a_grid_no_model_can_estimate_and_says_what_to_change(rigid_raw):
    with pytest.raises(ModelError) as refused:
        fit(rigid_raw, _options(samples=8, tip_model="auto"))
    message = str(refused.value)
    assert message.startswith("no tip model's error can be estimated from this grid")
    assert "[sweep]" in message and "trace_length_mm" in message
    assert "--tip-model level-set" in message


def test_the_default_fit_withholds_a_table_it_cannot_fit_and_still_calibrates(rigid_raw):
    # a rigid root gives the (Y, Z) model nothing to fit either: no table, one warning, and the
    # z lookup asked for ships as it would with --no-field-table
    result = fit(rigid_raw, FitOptions(samples=8, tip_model="level-set"))
    assert result.field_table is None and result.artifact_data().field_table is None
    assert result.metrics["tip_model"] == "level-set"
    assert np.isnan(result.metrics["field_table_estimated_tip_error_mm"])
    withheld = [w for w in result.warnings if w.startswith("no (Y, Z) table written")]
    assert len(withheld) == 1 and "the (Y, Z) model cannot be fitted" in withheld[0]
    assert withheld[0].endswith("the runtime uses the z lookup")


def test_a_grid_with_too_few_contacts_for_the_table_gets_none(tmp_path):
    from whiskercal.fit.field_table import MIN_CONTACTS, fit_field_table

    points = paper_grid_mm()[:MIN_CONTACTS - 1]
    path = write_raw_grid(tmp_path / "raw.h5", points, rigid_z(points), 0.0, "analytic-rigid",
                          config={"rig": {"rod_radius_mm": 0.0, "trace_length_mm": 70.0}})
    table = fit_field_table(read_raw_grid(path), 70.0)
    assert table.table is None and np.isnan(table.metrics["field_table_estimated_tip_error_mm"])
    assert table.warnings == [f"no (Y, Z) table written: it needs at least {MIN_CONTACTS} "
                              f"contacts, the grid has {MIN_CONTACTS - 1}; the runtime uses "
                              "the z lookup"]


def test_options_reach_the_model(rigid_raw):
    result = fit(rigid_raw, _options(degree=3, coordinates="cartesian", interpolant="linear",
                                       trace_length_mm=68.0, rod_correction=False))
    assert (result.calibration.surface.degree, result.calibration.surface.coordinates) == \
        (3, "cartesian")
    assert result.calibration.lookup.kind == "linear"
    assert result.calibration.problem.trace_length_mm == 68.0
    assert not result.calibration_options.correct_rod_radius
    assert result.warnings[0] == ("the trace length 68 mm of --trace-length-mm overrides the "
                                  "70 mm of the raw grid's rig config")


def test_a_grid_short_of_the_tip_is_refused_or_marked(rigid_raw):
    # the grid reaches 65 mm: a 78 mm trace extrapolates about 14 mm past it
    with pytest.raises(ExtrapolationLimitError, match="--allow-extrapolation"):
        fit(rigid_raw, _options(trace_length_mm=78.0))
    marked = fit(rigid_raw, _options(trace_length_mm=78.0, allow_extrapolation=True))
    assert marked.calibration.extrapolated and marked.metrics["extrapolated"] is True
    assert any("stops short of the tip" in warning for warning in marked.warnings)


def test_the_model_refuses_a_degree_out_of_range(rigid_raw):
    with pytest.raises(FitError):
        fit(rigid_raw, _options(degree=9))


def test_an_unknown_sensor_needs_a_trace_length(rigid_raw):
    from dataclasses import replace

    stranger = replace(rigid_raw, sensor_id="bench-sensor-7", config={})
    with pytest.raises(UsageError, match="--trace-length-mm"):
        resolve_trace_length(stranger, None)
    assert resolve_trace_length(stranger, 71.0) == (71.0, [])


@pytest.mark.parametrize("bad", [{"samples": 1}, {"samples": 10_001}, {"coordinates": "spherical"},
                                 {"tracer": "slow"}, {"interpolant": "nearest"},
                                 {"degree": "five"}, {"degree": 5.0}, {"max_extension_mm": -1.0}])
def test_fit_options_refuse_what_the_command_refuses(bad):
    with pytest.raises(UsageError, match=next(iter(bad))):
        FitOptions(**bad)


def test_options_from_command_line_words():
    assert options_from_args([]) == FitOptions()
    words = ["--degree", "auto", "--samples=12", "--coordinates", "cartesian", "--tracer", "paper",
             "--interpolant", "pchip", "--trace-length-mm", "70", "--entry-radius-mm", "25.5",
             "--max-extension-mm", "12", "--allow-extrapolation", "--no-rod-correction",
             "--threshold-uT", "250", "--tip-model", "level-set", "--no-field-table"]
    assert options_from_args(words) == FitOptions(
        degree="auto", samples=12, coordinates="cartesian", tracer="paper", interpolant="pchip",
        trace_length_mm=70.0, entry_radius_mm=25.5, max_extension_mm=12.0,
        allow_extrapolation=True, rod_correction=False, threshold_uT=250.0,
        tip_model="level-set", field_table=False)
    assert options_from_args(["--degree", "4", "--degree", "6"]).degree == 6
    assert options_from_args(["--no-field-table", "--field-table"]).field_table is True


def test_the_default_fit_ships_the_chosen_tip_model_and_the_field_table():
    # the accurate calibration by default: the mechanics where the grid identifies it, and the
    # (Y, Z) table for contacts with friction or at a slant; --no-field-table opts out
    assert (FitOptions().tip_model, FitOptions().field_table) == ("auto", True)
    assert options_from_args(["--no-field-table"]) == FitOptions(field_table=False)
    assert options_from_args(["--field-table"]) == FitOptions()


@pytest.mark.parametrize("words, message", [
    (["--samples", "1"], "samples must be an integer 2..10000"),
    (["--samples", "many"], "--samples must be a number"),
    (["--degree"], "--degree needs a value"),
    (["--degree", "x"], "--degree must be a degree 1..8 or 'auto'"),
    (["--out", "cal.h5"], "no such option of whiskercal fit: --out"),
    (["--allow-extrapolation=yes"], "no such option"),
])
def test_bad_command_line_words_are_usage_errors(words, message):
    with pytest.raises(UsageError, match=message):
        options_from_args(words)


def test_the_word_parser_knows_every_option_of_the_command_and_its_defaults():
    from whiskercal.cli.commands.fit import command
    from whiskercal.fit.args import FLAGS, VALUED

    own = {"raw", "out_path", "as_json", "force"}  # about the command's files, not the fit
    options = [p for p in command.params if p.name not in own]
    assert sorted(o for p in options for o in [*p.opts, *p.secondary_opts]) == \
        sorted([*VALUED, *FLAGS])
    defaults = [word for p in options if not p.is_flag and p.default is not None
                for word in (p.opts[0], str(p.default))]
    assert options_from_args(defaults) == FitOptions()
    on_off = {p.name: p.default for p in options if p.is_flag and p.secondary_opts}
    assert on_off == {"field_table": FitOptions().field_table}


def test_the_fit_stage_imports_without_click():
    code = ("import sys; import whiskercal.fit, whiskercal.regress.pipeline, "
            "whiskercal.report.build, whiskercal.bench.runner; "
            "sys.exit('click' in sys.modules)")
    result = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True,
                            timeout=120)
    assert result.returncode == 0, result.stderr or "click was imported"


def test_fit_on_a_raw_file_without_points_is_one_line(tmp_path):
    from click.testing import CliRunner

    from whiskercal.cli import cli

    path = tmp_path / "empty.h5"
    write_raw_grid(path, np.zeros((0, 2)), np.zeros(0), 0.0, "analytic-rigid",
                   config={"rig": {"rod_radius_mm": 0.0, "trace_length_mm": 70.0}})
    result = CliRunner().invoke(cli, ["fit", str(path), "--out", str(tmp_path / "cal.h5")])
    assert result.exit_code == 2
    assert result.output.strip() == "error: only 0 grid points with contact: too few to calibrate"
    assert not (tmp_path / "cal.h5").exists()


@pytest.mark.parametrize("radius_mm", [35.0, 50.0, 0.0, -3.0])
def test_an_entry_radius_outside_half_the_trace_length_is_refused(rigid_raw, radius_mm):
    # the trace looks for its entry on circles out to half the length (35 mm of 70 mm)
    with pytest.raises(UsageError, match=r"--entry-radius-mm must lie between 0 and half the "
                                         r"trace length \(35 mm\)"):
        fit(rigid_raw, _options(trace_length_mm=70.0, entry_radius_mm=radius_mm))


@pytest.mark.slow
def test_one_untraceable_level_inside_the_range_is_a_warning_not_an_abort(rigid_raw, monkeypatch):
    from whiskercal.model import trace as trace_module
    from whiskercal.model.errors import NonConvergenceError

    clean = fit(rigid_raw, _options(samples=8)).calibration.lookup
    bad = float(clean.z_knots_uT[4])
    original = trace_module.TRACERS["fast"]

    def tracer(problem, z):
        if abs(z - bad) < 1e-9:
            raise NonConvergenceError(f"no convergence at z = {z:.1f} µT")
        return original(problem, z)
    monkeypatch.setitem(trace_module.TRACERS, "fast", tracer)
    result = fit(rigid_raw, _options(samples=8))
    assert np.array_equal(result.calibration.lookup.z_knots_uT, clean.z_knots_uT)
    assert np.max(np.abs(result.calibration.lookup.tips_mm - clean.tips_mm)) < 0.01
    assert [w for w in result.warnings if "could not be traced" in w] == [
        f"the level set at z = {bad:.0f} µT could not be traced (no convergence at z = "
        f"{bad:.1f} µT); skipped: the lookup bridges it from the traced levels beside it"]


def test_the_truth_of_a_soft_suspension_is_its_tip_curves_first_branch():
    # short-45mm-soft: z folds back at about -14,000 µT and rises to about -1,400 µT, so past the
    # fold a second branch of tips, up to 60 mm from the first, shares the lookup's z range
    from whiskercal.fit.truth import true_tips_in_range
    from whiskercal.twin import truth
    from whiskercal.twin.sensor_file import load_sensor

    soft = load_sensor(ROOT / "sensors" / "short-45mm-soft.toml")
    z, tips = true_tips_in_range(soft, -10000.0, -100.0)
    assert z.size > 20 and np.all(np.diff(z) < 0)
    assert np.max(np.abs(tips - truth.true_tip(soft, z))) < 1e-6


def test_the_level_sets_warnings_are_said_of_it_where_another_model_ships():
    from types import SimpleNamespace

    from whiskercal.fit.run import _level_set_warnings

    calibration = SimpleNamespace(warnings=["the surface under-fits: its CV RMSE 9 µT"])
    shipped = _level_set_warnings(calibration, SimpleNamespace(name="level-set"))
    assert shipped == calibration.warnings
    other = _level_set_warnings(calibration, SimpleNamespace(name="mechanics-yz"))
    assert other == ["the level set (not shipped: mechanics-yz ships): the surface under-fits: "
                     "its CV RMSE 9 µT"]
