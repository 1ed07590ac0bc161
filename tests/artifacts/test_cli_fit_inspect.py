"""``whiskercal fit`` and ``whiskercal inspect``: outputs, JSON, exit codes, one-line errors."""

import json
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from analytic import paper_grid_mm, rigid_z
from rawfile import write_raw_grid
from whiskercal.cli import cli

FIXTURE = Path(__file__).parents[1] / "fixtures" / "calibration-1.0.0.h5"
# These tests are about the rest of the fit, on a rigid root's analytic grid: the level set,
# asked for (no suspension to fit, so the default refuses such a grid: tests/fit/test_fit.py),
# without the (Y, Z) table, which adds 30-60 s to a fit of a sensor's grid
# (tests/fit/test_tip_model.py tests the default, which writes it).
LEVEL_SET = ("--no-field-table", "--tip-model", "level-set")


def run(*args):
    return CliRunner().invoke(cli, list(args), catch_exceptions=False)


@pytest.fixture(scope="module")
def raw_file(tmp_path_factory):
    points = paper_grid_mm()
    z = rigid_z(points) + np.random.default_rng(1).normal(0.0, 1.0, len(points))
    path = tmp_path_factory.mktemp("raw") / "raw.h5"
    return write_raw_grid(path, points, z, 0.0, "analytic-rigid",
                          config={"rig": {"rod_radius_mm": 0.0, "trace_length_mm": 70.0}})


def test_fit_json_summary_and_artifact(raw_file, tmp_path):
    out = tmp_path / "cal.h5"
    result = run("fit", *LEVEL_SET, str(raw_file), "--out", str(out), "--degree", "auto",
                 "--samples", "12", "--json")
    assert result.exit_code == 0, result.output
    summary = json.loads(result.output)
    for key in ("degree", "rmse", "r2", "cv_rmse", "lookup_holdout_rmse_mm", "samples"):
        assert key in summary
    assert summary["samples"] == 12 and 1 <= summary["degree"] <= 8
    assert summary["r2"] > 0.999 and summary["lookup_holdout_rmse_mm"] < 1e-3
    # --no-field-table: the artifact carries no (Y, Z) table and the summary names none
    assert "field_table_written" not in summary and "field_table_estimated_tip_error_mm" not in summary
    from whiskercal.artifacts.calibration import read_calibration

    assert read_calibration(out).field_table is None


def test_fit_text_output(raw_file, tmp_path):
    result = run("fit", *LEVEL_SET, str(raw_file), "--out", str(tmp_path / "cal.h5"))
    assert result.exit_code == 0
    assert result.output.splitlines()[0] == f"wrote {tmp_path / 'cal.h5'}"
    assert "hold-out RMSE" in result.output


def test_fit_needs_a_trace_length_for_an_unknown_sensor(tmp_path):
    points = paper_grid_mm()
    raw = write_raw_grid(tmp_path / "raw.h5", points, rigid_z(points), 0.0, "bench-sensor-7")
    result = CliRunner().invoke(cli, ["fit", str(raw), "--out", str(tmp_path / "c.h5")])
    assert result.exit_code == 2
    assert result.output.count("\n") == 1 and "--trace-length-mm" in result.output


@pytest.mark.parametrize("command", ["fit", "inspect"])
def test_missing_and_corrupt_inputs_end_with_one_line(tmp_path, command):
    junk = tmp_path / "junk.h5"
    junk.write_text("not an hdf5 file")
    for path in (tmp_path / "missing.h5", junk):
        args = [command, str(path)] + (["--out", str(tmp_path / "o.h5")] if command == "fit" else [])
        result = CliRunner().invoke(cli, args)
        assert result.exit_code == 4
        lines = result.output.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("error: ")
        assert not (tmp_path / "o.h5").exists()


def test_fit_refuses_an_artifact_as_input(tmp_path):
    result = CliRunner().invoke(cli, ["fit", str(FIXTURE), "--out", str(tmp_path / "o.h5")])
    assert result.exit_code == 4
    assert "not a whiskercal.raw_grid file" in result.output


def test_inspect_an_artifact(tmp_path):
    result = run("inspect", str(FIXTURE), "--json")
    assert result.exit_code == 0
    summary = json.loads(result.output)
    assert summary["schema"] == "whiskercal.calibration"
    assert summary["schema_version"] == "1.0.0"
    assert summary["kind"] == "calibration"
    assert summary["lookup"]["samples"] == 20
    assert len(summary["inputs_sha256"]["raw_grid"]) == 64
    assert summary["datasets"]["/lookup/tip_mm"] == {"shape": [20, 2], "units": "mm"}
    assert "lookup_holdout_rmse_mm" in summary["metrics"]
    text = run("inspect", str(FIXTURE)).output
    assert "schema               whiskercal.calibration" in text
    assert "/surface/coefficients" in text


def test_inspect_a_raw_grid(raw_file):
    summary = json.loads(run("inspect", str(raw_file), "--json").output)
    assert summary["kind"] == "raw_grid" and summary["points"] == 180
    assert summary["complete"] is True


def test_inspect_refuses_other_hdf5(tmp_path):
    import h5py

    with h5py.File(tmp_path / "other.h5", "w") as handle:
        handle.attrs["schema"] = "someone.else"
    result = CliRunner().invoke(cli, ["inspect", str(tmp_path / "other.h5")])
    assert result.exit_code == 4 and "not a whiskercal calibration artifact" in result.output


@pytest.mark.slow
def test_fit_a_twin_grid_reports_the_lookup_against_truth(tmp_path):
    from twin_grid import twin_grid, write_twin_raw

    raw = write_twin_raw(tmp_path / "twin.h5", twin_grid(noise_uT=1.0, seed=2))
    out = tmp_path / "cal.h5"
    summary = json.loads(run("fit", *LEVEL_SET, str(raw), "--out", str(out), "--degree", "auto",
                             "--json").output)
    assert 0 < summary["lookup_vs_truth_rmse_mm"] <= summary["lookup_vs_truth_max_mm"]
    from whiskercal.artifacts.calibration import read_calibration

    data = read_calibration(out)
    assert data.metrics["contact_error_corrected_mm"] < data.metrics["contact_error_uncorrected_mm"]
    assert data.truth["error_mm"].shape == data.truth["z_uT"].shape
    from whiskercal.twin.params import DEFAULT_SENSOR

    assert data.trace_length_mm == DEFAULT_SENSOR.whisker.reach_mm  # found by the sensor's id


def test_fit_refuses_a_grid_that_stops_short_of_the_tip(tmp_path):
    points = paper_grid_mm()  # reaches 65 mm: a 78 mm trace would extrapolate 14 mm
    raw = write_raw_grid(tmp_path / "raw.h5", points, rigid_z(points), 0.0, "analytic-rigid",
                         config={"rig": {"rod_radius_mm": 0.0, "trace_length_mm": 78.0}})
    out = tmp_path / "cal.h5"
    result = CliRunner().invoke(cli, ["fit", str(raw), "--out", str(out)])
    assert result.exit_code == 2 and not out.exists()
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and "stops short of the tip" in lines[0]
    assert "more than the 9.5 mm" in lines[0] and "--allow-extrapolation" in lines[0]


def test_fit_with_allow_extrapolation_marks_the_range_for_inspect_and_runtime(tmp_path):
    from whiskercal import runtime
    from whiskercal.model.errors import ExtrapolationLimitError

    points = paper_grid_mm()
    raw = write_raw_grid(tmp_path / "raw.h5", points, rigid_z(points), 0.0, "analytic-rigid",
                         config={"rig": {"rod_radius_mm": 0.0, "trace_length_mm": 78.0}})
    out = tmp_path / "cal.h5"
    summary = json.loads(run("fit", *LEVEL_SET, str(raw), "--out", str(out), "--allow-extrapolation",
                             "--json").output)
    assert summary["extrapolated"] and summary["trusted_z_uT"] is None
    assert summary["extension_max_mm"] > summary["extension_limit_mm"] == 9.5
    assert any("stops short of the tip" in w for w in summary["warnings"])
    described = json.loads(run("inspect", str(out), "--json").output)
    assert described["extension"]["extrapolated"] is True
    assert described["extension"]["max_mm"] == pytest.approx(summary["extension_max_mm"])
    assert described["datasets"]["/lookup/extension_mm"]["units"] == "mm"
    with pytest.raises(ExtrapolationLimitError, match="allow_extrapolated=True"):
        runtime.load(out)
    calibration = runtime.load(out, allow_extrapolated=True)
    z = float(np.mean(calibration.z_range_uT))
    assert calibration.extrapolated(z) and calibration.tracker().update(z).extrapolated


def test_fit_a_raised_extension_limit_accepts_the_short_grid(tmp_path):
    points = paper_grid_mm()
    raw = write_raw_grid(tmp_path / "raw.h5", points, rigid_z(points), 0.0, "analytic-rigid",
                         config={"rig": {"rod_radius_mm": 0.0, "trace_length_mm": 78.0}})
    summary = json.loads(run("fit", *LEVEL_SET, str(raw), "--out", str(tmp_path / "cal.h5"),
                             "--max-extension-mm", "16", "--json").output)
    assert not summary["extrapolated"] and summary["extension_limit_mm"] == 16.0


def test_fit_warns_of_an_underfitting_surface_with_the_numbers(raw_file, tmp_path):
    out = tmp_path / "cal.h5"
    result = CliRunner().invoke(cli, ["fit", *LEVEL_SET, str(raw_file), "--out", str(out),
                                         "--degree", "1"], catch_exceptions=False)
    assert result.exit_code == 0
    assert "warning   the surface under-fits: its CV RMSE" in result.stderr
    from whiskercal.artifacts.calibration import read_calibration

    warnings = _surface_warnings(read_calibration(out).metrics["warnings"])
    assert len(warnings) == 1 and "1.02 µT noise expected at the grid points" in warnings[0]
    good = json.loads(run("fit", *LEVEL_SET, str(raw_file), "--out", str(out), "--degree", "5",
                          "--force", "--json").output)
    assert _surface_warnings(good["warnings"]) == [] and good["cv_rmse"] < 2 * good["expected_noise_uT"]


def _surface_warnings(warnings):
    """The warnings apart from the tip-error estimate's (this analytic grid has no suspension)."""
    return [w for w in warnings if not w.startswith("the tip error cannot be estimated")]


def test_fit_reports_a_trace_length_option_that_overrides_the_recorded_one(raw_file, tmp_path):
    summary = json.loads(run("fit", *LEVEL_SET, str(raw_file), "--out", str(tmp_path / "cal.h5"),
                             "--trace-length-mm", "68", "--json").output)
    assert _surface_warnings(summary["warnings"]) == [
        "the trace length 68 mm of --trace-length-mm overrides the 70 mm of the raw grid's rig config"]
    from whiskercal.artifacts.calibration import read_calibration

    assert read_calibration(tmp_path / "cal.h5").trace_length_mm == 68.0


@pytest.mark.slow
def test_fit_reports_a_rig_config_that_disagrees_with_the_twin_sensor(tmp_path):
    from twin_grid import twin_grid
    from whiskercal.twin.params import DEFAULT_SENSOR

    grid = twin_grid(noise_uT=1.0, seed=2)
    raw = write_raw_grid(tmp_path / "raw.h5", grid.rod_center_mm, grid.z_uT, grid.rod_radius_mm,
                         DEFAULT_SENSOR.sensor_id,
                         config={"rig": {"rod_radius_mm": grid.rod_radius_mm,
                                         "trace_length_mm": 77.0}})
    summary = json.loads(run("fit", *LEVEL_SET, str(raw), "--out", str(tmp_path / "cal.h5"),
                             "--json").output)
    expected = (f"the trace length 77 mm of the raw grid's rig config overrides the "
                f"{DEFAULT_SENSOR.whisker.reach_mm:g} mm of the twin sensor "
                f"'{DEFAULT_SENSOR.sensor_id}'")
    assert expected in summary["warnings"]


RECORDED_GRID = Path(__file__).parents[2] / "data" / "twin-paper-75mm" / "raw_grid.h5"


@pytest.mark.slow
def test_fit_in_cartesian_degree_8_on_the_recorded_grid(tmp_path):
    # an entry crossing that fell exactly between the vectorized and the scalar surface's last
    # bits once made the root finder raise: the recorded grid at these options reproduced it
    result = run("fit", *LEVEL_SET, str(RECORDED_GRID), "--out", str(tmp_path / "c.h5"),
                 "--coordinates", "cartesian", "--degree", "8", "--json")
    assert result.exit_code == 0
    summary = json.loads(result.output)
    assert summary["degree"] == 8 and summary["lookup_vs_truth_rmse_mm"] < 1.0


def test_the_fit_summary_names_the_stage_offset_the_yz_model_found(capsys):
    from dataclasses import replace

    from whiskercal.artifacts.calibration import read_calibration
    from whiskercal.cli.commands.fit import _report

    data = read_calibration(FIXTURE.with_name("calibration-1.3.0-target.h5"))
    data = replace(data, metrics={**data.metrics, "field_table_estimated_tip_error_mm": 0.04,
                                  "field_table_held_estimated_tip_error_mm": 0.007,
                                  "field_table": {"stage_offset_mm": [-0.0096, 0.0102],
                                                  "tip_sweep_points": 21}})
    _report(data, 1.0, "cal.h5", as_json=True, timings_s={})
    assert json.loads(capsys.readouterr().out)["stage_offset_mm"] == [-0.0096, 0.0102]
    _report(data, 1.0, "cal.h5", as_json=False, timings_s={})
    assert "stage     rods found y +0.0102 mm off their recorded places (x -0.0096 mm" in \
        capsys.readouterr().out
    # from a grid alone x is not fitted: the summary says so rather than print a zero
    data.metrics["field_table"]["tip_sweep_points"] = 0
    _report(data, 1.0, "cal.h5", as_json=True, timings_s={})
    assert json.loads(capsys.readouterr().out)["stage_offset_mm"] == [None, 0.0102]
    _report(data, 1.0, "cal.h5", as_json=False, timings_s={})
    assert "(x not fitted: no tip sweep; backlash, origin)" in capsys.readouterr().out
