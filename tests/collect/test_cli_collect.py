"""`whiskercal collect` on the command line: dry-run, options, refusals."""

from __future__ import annotations

import json

import numpy as np
import pytest
from click.testing import CliRunner

from whiskercal.cli import cli


def invoke(*args):
    return CliRunner().invoke(cli, ["collect", *args], catch_exceptions=False)


def test_dry_run_json_summarizes_the_default_plan():
    result = invoke("--dry-run", "--json")
    assert result.exit_code == 0, result.output
    summary = json.loads(result.output)
    assert summary["points"] == 208 and summary["limits_ok"] and summary["problems"] == []
    assert summary["tip_sweep_points"] == 28  # after the paper's 180
    assert summary["columns"] == 17 + 28  # every sweep point its own approach
    assert summary["whisker_x_mm"][0] == 21.0 and summary["whisker_y_mm"][1] == 0.0
    # a sweep point lies on a ray at most 40 deg below the axis, at most the trace length out
    assert summary["whisker_x_mm"][1] == pytest.approx(78.0 * np.cos(np.radians(5.0)))
    assert summary["whisker_y_mm"][0] == pytest.approx(-78.0 * np.sin(np.radians(40.0)))
    # 208 points at 0.4 s of dwell each plus moves of ~0.4-6 s: minutes, not seconds or hours
    assert 120.0 < summary["estimated_stage_time_s"] < 900.0
    assert summary["path_length_mm"] > 180 * 3.0


def test_dry_run_text_names_points_time_and_limits():
    result = invoke("--dry-run")
    assert result.exit_code == 0
    lines = result.output.splitlines()
    assert lines[0] == "points           208 in 45 columns"
    assert lines[1] == "tip sweep        the last 28 of them"
    assert any(line.startswith("stage time") and line.endswith("s (estimated, without the homing cycle)")
               for line in lines)
    assert "limits           ok (travel 200 x 200 mm)" in lines


def test_dry_run_reports_a_plan_outside_the_travel(tmp_path):
    config = tmp_path / "far.toml"
    config.write_text("[rig]\norigin_stage_mm = [150.0, 100.0]\n")
    result = CliRunner().invoke(cli, ["collect", "--dry-run", "--config", str(config)])
    assert result.exit_code == 2
    assert "VIOLATED" in result.output
    assert "error: the plan leaves the stage travel" in result.output


def test_unknown_config_key_is_one_clear_error(tmp_path):
    config = tmp_path / "typo.toml"
    config.write_text("[grid]\nstep_m = 2.0\n")
    result = CliRunner().invoke(cli, ["collect", "--dry-run", "--config", str(config)])
    assert result.exit_code == 2
    assert result.output.strip().startswith("error:") and "[grid] step_m: unknown key" in result.output
    assert len(result.output.strip().splitlines()) == 1


def test_a_run_needs_both_ports_and_an_output():
    result = CliRunner().invoke(cli, ["collect", "--stage", "sim://x/stage"])
    assert result.exit_code == 2
    assert "needs --stage, --sensor and --out" in result.output


def test_every_option_has_help_text():
    from whiskercal.cli.commands.collect import command

    assert command.help
    for option in command.params:
        assert option.help, option.name


def test_dry_run_reads_the_travel_from_a_connected_stage(tmp_path):
    import uuid

    config = tmp_path / "small_travel.toml"
    config.write_text("[safety]\ntravel_mm = [150.0, 150.0]\n")
    alone = json.loads(invoke("--dry-run", "--json", "--config", str(config)).output)
    assert alone["travel_mm"] == [150.0, 150.0]
    result = invoke("--dry-run", "--json", "--config", str(config),
                    "--stage", f"sim://d{uuid.uuid4().hex[:8]}/stage")
    assert result.exit_code == 0, result.output
    # the twin's stage reports its own $130/$131 travel, which replaces the configured one
    assert json.loads(result.output)["travel_mm"] == [200.0, 200.0]
    stock = invoke("--dry-run", "--json", "--config", str(config),
                   "--stage", f"sim://d{uuid.uuid4().hex[:8]}/stage?stock=1&homing=xy")
    # stock grbl works in -200..0 and homing leaves it at -199 ($27 = 1 mm), whiskercal's 0
    assert json.loads(stock.output)["travel_mm"] == [199.0, 199.0]


def test_progress_is_drawn_only_on_a_watched_terminal(monkeypatch):
    from whiskercal.cli.app import App
    from whiskercal.cli.progress import progress_bar

    monkeypatch.setattr("sys.stderr.isatty", lambda: True, raising=False)
    monkeypatch.setenv("CI", "1")
    with progress_bar(App(), "points") as bar:
        assert bar is None
    monkeypatch.delenv("CI")
    with progress_bar(App(), "points", as_json=True) as bar:
        assert bar is None
    with progress_bar(App(quiet=True), "points") as bar:
        assert bar is None
    with progress_bar(App(), "points") as bar:
        assert bar is not None


def test_progress_shows_done_rate_and_time_left():
    import io
    import re

    from rich.console import Console

    from whiskercal.cli.app import App
    from whiskercal.cli.progress import progress_bar
    from whiskercal.progress import Progress

    out, clock = io.StringIO(), [0.0]
    console = Console(file=out, force_terminal=True, width=120, color_system=None)
    with progress_bar(App(), "points", description="collect", console=console,
                      get_time=lambda: clock[0]) as bar:
        # 40 points were taken before a resume: the rate counts only this session's points
        bar.update(Progress(done=40, total=180, taken_now=0, elapsed_s=0.0))
        for taken in (10, 20):
            clock[0] += 10.0
            bar.update(Progress(done=40 + taken, total=180, taken_now=taken, elapsed_s=clock[0]))
    lines = [line for line in re.split(r"[\r\n]", out.getvalue()) if "collect" in line]
    last = re.sub(r"\x1b\[[0-9;?]*[A-Za-z]", "", lines[-1])
    # 10 points in 10 s since the previous update: 1 point/s, 120 points (2 min) to go
    assert re.search(r"collect .* 60/180 points 1\.00 points/s 0:00:20 0:02:00 left", last), last


FIRST_CTRL_C_STOPS = """
import signal
from whiskercal.cli.commands.collect import _stop_on_ctrl_c

with _stop_on_ctrl_c() as stop_requested:
    before = stop_requested()
    signal.raise_signal(signal.SIGINT)
    after = stop_requested()
    try:
        signal.raise_signal(signal.SIGINT)
        second = "none"
    except KeyboardInterrupt:
        second = "KeyboardInterrupt"
print(before, after, second)
"""


def test_first_ctrl_c_asks_to_stop_and_second_interrupts():
    from ctrl_c import printed_with_ctrl_c_as_from_a_terminal

    printed = printed_with_ctrl_c_as_from_a_terminal(FIRST_CTRL_C_STOPS)
    assert printed.split() == ["False", "True", "KeyboardInterrupt"]


def test_named_steps_count_as_done_when_the_next_begins():
    import io

    from rich.console import Console

    from whiskercal.cli.app import App
    from whiskercal.cli.progress import progress_bar

    console = Console(file=io.StringIO(), force_terminal=True)
    with progress_bar(App(), "datasets", description="regress", total=2, console=console) as bar:
        seen = []
        for key, text in (("first", "first: fit"), ("first", "first: study report"),
                          ("second", "second: fit")):
            bar.step(key, text)
            seen.append((bar.task.description, bar.task.completed))
        bar.finish()
        seen.append((bar.task.description, bar.task.completed))
    assert seen == [("first: fit", 0), ("first: study report", 0), ("second: fit", 1), ("regress", 2)]
