"""A short shaft study on the twin, end to end through the command line: run, resume, report."""

import json

import numpy as np
import pytest
from click.testing import CliRunner

from whiskercal.artifacts.shaft_study import read_shaft_study
from whiskercal.cli import cli

CONFIG = """
[trials]
fractions = [0.5, 0.7]
approach_deg = [0.0, 30.0]
slide_mm = 8.0
"""


def _calibration(tmp_path):
    from twin_calibration import write_twin_calibration

    return write_twin_calibration(tmp_path / "CAL.h5")


@pytest.mark.slow
def test_run_and_report_on_the_twin(tmp_path):
    (tmp_path / "shaft.toml").write_text(CONFIG)
    out = tmp_path / "RUN.h5"
    runner = CliRunner()
    run = ["shaft-study", "run", "--stage", "sim://shaft-test/stage", "--sensor",
           "sim://shaft-test/sensor", "--config", str(tmp_path / "shaft.toml"), "--out", str(out)]
    result = runner.invoke(cli, run + ["--json"])
    assert result.exit_code == 0, result.output
    study = read_shaft_study(out)
    assert study.complete and len(study.trials) == 4
    for trial in study.trials:  # the stage's reported positions follow the twin's true rod
        gap = np.abs(trial.stream["position_mm"] - trial.truth["rod_center_mm"])
        assert np.nanmax(gap) < 0.1
        assert np.sum(trial.truth["kind"] == "shaft") > 300

    again = runner.invoke(cli, run + ["--resume"])
    assert again.exit_code == 0 and "0 trials done, 4 kept" in again.output

    report = runner.invoke(cli, ["shaft-study", "report", str(out), "--artifact",
                                 str(_calibration(tmp_path)), "--out", str(tmp_path / "rep"),
                                 "--json"])
    assert report.exit_code == 0, report.output
    rows = json.loads(report.output)["trials"]
    assert {round(r["radial_mm"], 1) for r in rows} == {39.0, 54.6}
    for row in rows:  # against the twin's true contact point, after 5 mm of travel
        assert row["median_error_mm"] < 1.0, row
        assert row["kind_accuracy"] > 0.97, row
        # keeps up with the sensor's 300 Hz stream; the 1 ms goal is the bench's to report, as
        # CPU speed moves it
        assert 0.0 < row["ms_per_sample"] < 1000.0 / 300.0
    assert all((tmp_path / "rep" / name).exists()
               for name in ("shaft_error_vs_travel.png", "shaft_estimates.png"))


def test_a_twin_without_the_rod_is_refused_before_a_file_is_written(tmp_path):
    out = tmp_path / "RUN.h5"
    result = CliRunner().invoke(cli, ["shaft-study", "run", "--stage",
                                      "sim://shaft-plane/stage?scene=plane", "--sensor",
                                      "sim://shaft-plane/sensor", "--out", str(out)])
    assert result.exit_code != 0 and "not the rod" in result.output
    assert not out.exists()
