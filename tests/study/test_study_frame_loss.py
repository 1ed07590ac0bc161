"""A study on a lossy sensor link warns above [safety] max_frame_loss, and stays quiet below it."""

import uuid

import pytest
from click.testing import CliRunner

from whiskercal.artifacts.plane_study import read_study
from whiskercal.cli import cli
from whiskercal.errors import UsageError

ONE_TRIAL = """
[trials]
depths_mm = [5.0]
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


def _run(tmp_path, query: str, extra: str = ""):
    config = tmp_path / "study.toml"
    config.write_text(ONE_TRIAL + extra)
    name = f"s{uuid.uuid4().hex[:8]}"
    out = tmp_path / f"{name}.h5"
    result = CliRunner().invoke(cli, ["optimal-depth", "run", "--stage",
                                      f"sim://{name}/stage?scene=plane&{query}", "--sensor",
                                      f"sim://{name}/sensor", "--out", str(out),
                                      "--config", str(config)])
    return result, out


def test_a_lossy_link_warns_with_dropped_and_corrupt_apart(tmp_path):
    result, out = _run(tmp_path, "drop=0.03&corrupt=0.01&seed=6")
    assert result.exit_code == 0, result.output
    warnings = [line for line in result.output.splitlines() if line.startswith("warning:")]
    assert len(warnings) == 1 and "dropped" in warnings[0] and "corrupt" in warnings[0]
    trial = read_study(out).trials[0]
    assert trial.attrs["dropped"] > 0 and trial.attrs["corrupt"] > 0


def test_a_raised_limit_or_a_clean_link_do_not_warn(tmp_path):
    result, _ = _run(tmp_path, "drop=0.03&corrupt=0.01&seed=6", "[safety]\nmax_frame_loss = 0.5\n")
    assert result.exit_code == 0 and "warning:" not in result.output
    result, _ = _run(tmp_path, "seed=6")
    assert result.exit_code == 0 and "warning:" not in result.output


def test_a_study_resumes_with_another_frame_loss_limit(tmp_path):
    from whiskercal.artifacts.plane_study import StudyWriter
    from whiskercal.study.config import load_config

    config = tmp_path / "study.toml"
    config.write_text(ONE_TRIAL)
    first = load_config(config)
    StudyWriter(tmp_path / "s.h5", first, "twin")
    config.write_text(ONE_TRIAL + "[safety]\nmax_frame_loss = 0.3\n")
    StudyWriter(tmp_path / "s.h5", load_config(config), "twin", resume=True)  # not refused
    config.write_text(ONE_TRIAL + "[safety]\noverload_uT = 9000.0\n")
    with pytest.raises(UsageError, match="another configuration"):
        StudyWriter(tmp_path / "s.h5", load_config(config), "twin", resume=True)
