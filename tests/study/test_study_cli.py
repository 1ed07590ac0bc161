"""`whiskercal optimal-depth run` and `report` end to end: output, exit codes, one-line errors."""

import json

import h5py
import pytest
from click.testing import CliRunner

from whiskercal.artifacts.plane_study import read_study
from whiskercal.cli import cli

SMALL = """
[trials]
depths_mm = [5.0, 10.0, 15.0]
travel_mm = 5.0
slide_start_mm = -2.5
approach_speed_mm_s = 30.0
rapid_speed_mm_s = 60.0
retract_mm = 3.0
[contact]
search_step_mm = 0.5
samples_per_step = 5
baseline_samples = 30
"""


def _invoke(*args):
    return CliRunner().invoke(cli, list(args), catch_exceptions=False)


def test_run_then_resume_after_an_unplugged_sensor(tmp_path):
    config = tmp_path / "small.toml"
    config.write_text(SMALL)
    out = tmp_path / "STUDY.h5"
    cut = _invoke("optimal-depth", "run", "--stage", "sim://cli-a/stage?scene=plane",
                  "--sensor", "sim://cli-a/sensor?fault=disconnect@9", "--out", str(out),
                  "--config", str(config), "--json")
    assert cut.exit_code == 3
    assert cut.output.count("\n") == 1 and cut.output.startswith("error: ")
    kept = [t.depth_mm for t in read_study(out).trials]
    assert len(kept) < 3
    resumed = _invoke("optimal-depth", "run", "--stage", "sim://cli-b/stage?scene=plane",
                      "--sensor", "sim://cli-b/sensor", "--out", str(out), "--config", str(config),
                      "--resume", "--json")
    assert resumed.exit_code == 0, resumed.output
    summary = json.loads(resumed.output)
    assert summary["complete"] and summary["trials_skipped"] == kept
    assert sorted(kept + summary["trials_done"]) == [5.0, 10.0, 15.0]


@pytest.mark.slow
def test_report_json_and_the_artifact_with_the_target(tmp_path, twin_study, twin_calibration):
    result = _invoke("optimal-depth", "report", str(twin_study[0]), "--artifact",
                     str(twin_calibration), "--out", str(tmp_path), "--json")
    assert result.exit_code == 0
    payload = json.loads(result.output)
    assert len(payload["trials"]) == 10 and payload["failing_depths_mm"]
    assert payload["choice"]["depth_mm"] not in payload["failing_depths_mm"]
    assert payload["artifact"] == str(tmp_path / "CAL-target.h5")
    assert sorted(p.name for p in tmp_path.glob("*.png")) == ["errors.png", "estimates.png",
                                                              "z_over_time.png"]


def test_report_names_missing_trials_in_one_line(tmp_path, twin_study, twin_calibration):
    partial = tmp_path / "partial.h5"
    partial.write_bytes(twin_study[0].read_bytes())
    with h5py.File(partial, "r+") as handle:
        del handle["trials/depth_40.00mm"], handle["trials/depth_45.00mm"]
    result = _invoke("optimal-depth", "report", str(partial), "--artifact", str(twin_calibration),
                     "--no-figures")
    assert result.exit_code == 4
    assert result.output == (f"error: {partial}: the study lacks the trials at 40, 45 mm (8 of 10 "
                             "done); finish it with `whiskercal optimal-depth run --resume` or pass "
                             "--allow-missing\n")


@pytest.mark.parametrize("args, code, message", [
    (["optimal-depth", "report", "nowhere.h5", "--artifact", "nowhere-cal.h5"], 4, "no such file"),
    (["optimal-depth", "run", "--stage", "sim://x/stage", "--sensor", "sim://x/sensor",
      "--out", "o.h5", "--config", "missing.toml"], 2, "no such config file"),
])
def test_bad_inputs_end_with_one_line(tmp_path, monkeypatch, args, code, message):
    monkeypatch.chdir(tmp_path)
    result = _invoke(*args)
    assert result.exit_code == code and message in result.output
    assert result.output.count("\n") == 1


def test_a_twin_without_the_plane_is_refused(tmp_path):
    result = _invoke("optimal-depth", "run", "--stage", "sim://cli-rod/stage?scene=rod",
                     "--sensor", "sim://cli-rod/sensor", "--out", str(tmp_path / "s.h5"))
    assert result.exit_code == 2
    assert result.output == ("error: the simulated rig carries a RodFixture, not the plane: open "
                             "the stage as sim://NAME/stage?scene=plane\n")
    assert not (tmp_path / "s.h5").exists()


def test_overload_on_the_twin_backs_off_and_keeps_the_finished_trials(tmp_path):
    from whiskercal.twin.world import get_world

    config = tmp_path / "overload.toml"
    config.write_text(SMALL.replace("15.0]", "25.0]") + "[safety]\noverload_uT = 4000.0\n")
    out = tmp_path / "STUDY.h5"
    result = _invoke("optimal-depth", "run", "--stage", "sim://cli-ov/stage?scene=plane",
                     "--sensor", "sim://cli-ov/sensor", "--out", str(out), "--config", str(config))
    assert result.exit_code == 3 and "over the safe limit of 4000 µT" in result.output
    assert [t.depth_mm for t in read_study(out).trials] == [5.0, 10.0]
    assert get_world("cli-ov").truth.arrays()["kind"][-1] == "free"  # the whisker was unloaded
