"""A short contour run on the cylinder, through the command line, measured against the truth."""

import json

import numpy as np
import pytest
from click.testing import CliRunner
from tests_follow_artifact import calibration_path

from whiskercal.cli import cli
from whiskercal.contour import read_contour_run


def _run_and_report(tmp_path, shape: str, duration_s: int, *options: str):
    """``contour run`` on the twin (seed 1) then ``contour report``: the run file and the summary."""
    run = tmp_path / f"{shape}.h5"
    result = CliRunner().invoke(cli, ["-q", "contour", "run", "--shape", shape, "--artifact",
                                      str(calibration_path()), "--duration", str(duration_s),
                                      "--seed", "1", "--out", str(run), "--json", *options],
                                catch_exceptions=False)
    assert result.exit_code == 0, result.output
    report = CliRunner().invoke(cli, ["contour", "report", str(run), "--out", str(tmp_path / "rep"),
                                      "--json"], catch_exceptions=False)
    return run, json.loads(report.output)


@pytest.mark.slow
def test_a_short_cylinder_run_follows_the_surface_at_the_target(tmp_path):
    run, summary = _run_and_report(tmp_path, "cylinder", 20)
    record = read_contour_run(run)
    assert record.complete and len(record.columns["t_s"]) == 20 * 300
    # against the twin's true outline, no alignment: sub-0.27 mm, all tip contacts, no loss
    assert summary["mean_error_mm"] < 0.27 and summary["tip_contact_share"] == 1.0
    assert summary["contacts_lost"] == 0 and summary["contacts"] > 4000
    assert summary["twin_slips"] == 0  # frictionless: the tip never sticks, so never slips
    following = record.columns["phase"] == "follow"
    settled = record.columns["z_uT"][following][following.sum() // 2:]  # after the first press
    assert abs(settled.mean() - record.target_z_uT) < 0.05 * abs(record.target_z_uT)
    assert (tmp_path / "rep" / "contour.png").stat().st_size > 0
    assert np.all(np.isfinite(record.columns["estimate_mm"][following]))


@pytest.mark.slow
def test_an_artifact_without_a_target_is_refused_with_one_line(tmp_path):
    from whiskercal.artifacts.raw_grid import read_raw_grid
    from whiskercal.fit import FitOptions, fit
    from tests_follow_artifact import DATASET

    plain = fit(read_raw_grid(DATASET / "raw_grid.h5"), FitOptions(field_table=False)
                ).write(tmp_path / "plain.h5")
    result = CliRunner().invoke(cli, ["contour", "run", "--shape", "octagon", "--artifact", str(plain),
                                      "--out", str(tmp_path / "run.h5")])
    assert result.exit_code == 2 and "has no deflection target" in result.stderr
    assert not (tmp_path / "run.h5").exists()


def test_a_short_wall_run_reports_an_open_outline(tmp_path):
    _, summary = _run_and_report(tmp_path, "wall", 10)
    assert summary["shape"] == "wall" and summary["time_to_go_round_s"] is None
    # the first 10 s press on and follow the step's top (y = 20 mm): on it, against the truth
    assert summary["contacts"] > 1500 and summary["mean_error_mm"] < 0.35
    assert 0.0 < summary["coverage"] < 0.2  # a few cm of the 410-460 mm from the start on


def test_a_short_stick_slip_run_records_the_twins_slips(tmp_path):
    run, summary = _run_and_report(tmp_path, "cylinder", 8, "--mu-static", "0.3", "--mu-kinetic", "0.22")
    record = read_contour_run(run)
    assert record.config["mu_static"] == 0.3 and record.config["mu_kinetic"] == 0.22
    slips = record.columns["twin_slips"]
    # the tip sticks and slips while the sensor follows: many slip events, on the surface
    assert summary["twin_slips"] == int(slips.sum()) > 100 and 0 < np.mean(slips > 0) < 1
    # between slips the tip stays glued to its point of the object, which stands still in the world
    tips, kinds = record.columns["true_tip_mm"], record.columns["kind"]
    held = (slips[1:] == 0) & (kinds[1:] == "tip") & (kinds[:-1] == "tip")
    moved = np.linalg.norm(np.diff(tips, axis=0), axis=1)
    assert held.sum() > 1000 and moved[held].max() < 1e-6
    assert np.median(moved[(slips[1:] > 0) & (kinds[:-1] == "tip")]) > 0.01  # and slides when it slips
    assert summary["tip_contact_share"] == 1.0 and summary["contacts_lost"] == 0
    assert summary["mean_error_mm"] < 0.6  # the friction offset dominates it (docs/contour.md)


@pytest.mark.parametrize("shape, options, message", [
    ("octagon", ["--mu-static", "0.2", "--mu-kinetic", "0.3"],
     "--mu-static (0.2) must be at least --mu-kinetic (0.3)"),
    ("octagon", ["--mu-static", "-0.1"], "--mu-static must be"),
    ("octagon", ["--mu-static", "nan"], "--mu-static must be"),
    ("cylinder", ["--mu-static", "0.3", "--mu-kinetic", "-1"], "--mu-kinetic must be"),
    ("wall", ["--mu-kinetic", "0.22"], "friction is not modelled on the wall"),
    ("wall", ["--mu-static", "0.3"], "friction is not modelled on the wall"),
])
def test_bad_friction_is_refused_with_one_line(tmp_path, shape, options, message):
    out = tmp_path / "run.h5"
    result = CliRunner().invoke(cli, ["contour", "run", "--shape", shape, "--artifact",
                                      str(tmp_path / "unread.h5"), "--out", str(out), *options])
    assert result.exit_code == 2 and message in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1 and not out.exists()
