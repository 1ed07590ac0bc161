"""`whiskercal collect` against the digital twin (sim://), its ground truth and its faults.

Dwell and samples per point are cut (100 Hz, 5 samples, 50 ms settle) and the feeds raised so
that the twin, which simulates every converted sample, runs a whole grid in seconds; nothing
asserted here depends on the dwell.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
import uuid
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from whiskercal.artifacts.raw_grid import read_raw_grid
from whiskercal.cli import cli
from whiskercal.collect.config import load_config
from whiskercal.collect.journal import journal_path
from whiskercal.collect.plan import build_plan
from whiskercal.collect.run import collect
from whiskercal.errors import DeviceError

from fast_collect import FAST, SMALL_BAND

# A band of a few dozen points for the tests that run the grid more than once.
SMALL = FAST + SMALL_BAND
# The default grid with FAST spends about 38..129 s of simulated time on its points.
MID_GRID_S = 60.0


def fast_config(tmp_path: Path, text: str = FAST) -> Path:
    path = tmp_path / "collect.toml"
    path.write_text(text)
    return path


def urls(query: str = "", sensor_query: str = "") -> tuple[str, str]:
    """Stage and sensor URLs of a new world; options go on the first port opened (stage)."""
    name = f"c{uuid.uuid4().hex[:10]}"
    stage = f"sim://{name}/stage" + (f"?{query}" if query else "")
    sensor = f"sim://{name}/sensor" + (f"?{sensor_query}" if sensor_query else "")
    return stage, sensor


def run_cli(*args: str):
    return CliRunner().invoke(cli, ["collect", *args])


def assert_matches_truth(grid) -> None:
    """Measured z against the twin's noise-free z, within the noise of the two averages.

    z is a point's mean minus the baseline's mean; the per-sample noise is estimated from the
    points' own spread, so nothing here assumes the twin's noise level.
    """
    per_sample_uT = float(np.median(grid.z_std_uT))
    n_baseline = grid.config["acquisition"]["baseline_samples"]
    sigma_uT = per_sample_uT * np.sqrt(1.0 / grid.n_samples + 1.0 / n_baseline)
    error = grid.z_uT - grid.truth["z_uT"]
    assert np.all(np.abs(error) < 5.0 * sigma_uT), (np.abs(error).max(), sigma_uT.max())


@pytest.mark.slow
def test_full_grid_on_the_twin_with_truth(tmp_path):
    stage, sensor = urls()
    out = tmp_path / "raw.h5"
    result = run_cli("--stage", stage, "--sensor", sensor, "--out", str(out),
                     "--config", str(fast_config(tmp_path)), "--json")
    assert result.exit_code == 0, result.output
    summary = json.loads(result.stdout)
    assert summary["points"] == 180 and summary["complete"]
    assert summary["dropped"] == 0 and summary["corrupt"] == 0
    assert abs(summary["baseline_drift_uT"]) < 5.0
    grid = read_raw_grid(out)
    assert grid.complete and sorted(grid.plan_index) == list(range(180))
    assert grid.sensor_id == "twin-paper-75mm" and set(grid.truth["kind"]) == {"shaft"}
    assert_matches_truth(grid)
    # the encoders see the carriage within their quantization and the belt's backlash
    np.testing.assert_allclose(grid.rod_center_mm, grid.truth["rod_center_mm"], atol=0.05)
    # the grid spans the deflections a tip lookup needs (the paper's target is -8760 µT)
    assert grid.z_uT.min() < -8760.0 and grid.z_uT.max() > -1000.0
    # and stays inside the overload guard
    assert np.abs(grid.truth["z_uT"]).max() < grid.config["safety"]["overload_z_uT"]


def test_stock_grbl_twin_collects_with_commanded_positions(tmp_path):
    stage, sensor = urls("stock=1&homing=xy")
    config = load_config(fast_config(tmp_path, SMALL))
    plan = build_plan(config)
    summary = collect(stage, sensor, tmp_path / "raw.h5", plan)
    grid = read_raw_grid(tmp_path / "raw.h5")
    assert summary.complete and len(grid) == len(plan) >= 20
    assert np.isnan(grid.encoder_mm).all()
    assert grid.config["devices"]["stage"]["proto"] is None
    assert grid.encoders == "none"  # the file says its positions are open loop
    assert sum("no encoders" in warning for warning in summary.warnings) == 1
    from whiskercal.cli.commands.inspect import inspect_file
    assert inspect_file(tmp_path / "raw.h5")["encoders"] == "none"
    np.testing.assert_allclose(grid.rod_center_mm, plan.rod_center_mm[grid.plan_index])
    assert_matches_truth(grid)


def test_the_rod_is_placed_by_the_step_count_the_encoder_confirms(small_twin_grid):
    """The step count resolves the carriage far finer than the encoder's quantum (40/4096 mm):
    the recorded rod centres sit on the true ones but for the belt's constant backlash offset
    (the plan approaches every point from one side), spread far below the quantum's 0.0028 mm
    RMS that recording the encoder gave."""
    grid = read_raw_grid(small_twin_grid[0])  # SMALL collected on a default world
    offset = grid.rod_center_mm - grid.truth["rod_center_mm"]
    assert np.all(offset.std(axis=0) < 0.001), offset.std(axis=0)
    encoder_quantum_mm = 40.0 / 4096
    assert np.abs(grid.encoder_mm - grid.commanded_mm).max() < encoder_quantum_mm


def test_corrupt_bytes_and_dropped_frames_are_counted(tmp_path):
    stage, sensor = urls("corrupt=0.01&drop=0.01&seed=3")
    plan = build_plan(load_config(fast_config(tmp_path, SMALL)))
    summary = collect(stage, sensor, tmp_path / "raw.h5", plan)
    grid = read_raw_grid(tmp_path / "raw.h5")
    assert summary.complete and summary.dropped > 0 and summary.corrupt > 0
    import h5py

    with h5py.File(tmp_path / "raw.h5") as handle:
        per_point = handle["points/dropped"][()].sum(), handle["points/corrupt"][()].sum()
        seq = handle["stream/seq"][()]
    assert 0 < per_point[0] <= summary.dropped and 0 < per_point[1] <= summary.corrupt
    assert len(seq) > 0
    assert_matches_truth(grid)  # lost frames cost samples, never wrong values


def test_missed_steps_stop_the_run_with_the_encoder_message(tmp_path):
    stage, sensor = urls(f"fault=missed_steps@{MID_GRID_S}:1.0")
    out = tmp_path / "raw.h5"
    result = run_cli("--stage", stage, "--sensor", sensor, "--out", str(out),
                     "--config", str(fast_config(tmp_path)))
    assert result.exit_code == DeviceError.exit_code
    message = result.output.strip().splitlines()[-1]
    assert message.startswith("error: stage encoder and step positions disagree")
    assert "missed steps or a stall" in message and "points saved" in message
    assert 0 < len(read_raw_grid(out)) < 180


def test_unplugged_sensor_saves_the_points_and_exits_non_zero(tmp_path):
    stage, sensor = urls("", f"fault=disconnect@{MID_GRID_S}")
    out = tmp_path / "raw.h5"
    result = run_cli("--stage", stage, "--sensor", sensor, "--out", str(out),
                     "--config", str(fast_config(tmp_path)))
    assert result.exit_code == DeviceError.exit_code
    assert "disconnected" in result.output and "continue with --resume" in result.output
    grid = read_raw_grid(out)
    assert 0 < len(grid) < 180 and not grid.complete
    assert journal_path(out).exists()


def _journal_points(path: Path) -> int:
    try:
        return path.read_bytes().count(b'"type":"point"')
    except FileNotFoundError:
        return 0


def _collect_process(stage: str, sensor: str, out: Path, config: Path, *extra: str):
    command = [sys.executable, "-m", "whiskercal", "collect", "--stage", stage, "--sensor", sensor,
               "--out", str(out), "--config", str(config), "--json", *extra]
    env = {**os.environ, "CI": "1"}
    return subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env)


@pytest.mark.slow
def test_killed_run_resumes_with_every_point_exactly_once(tmp_path):
    rng = np.random.default_rng(20260101)
    config = fast_config(tmp_path, SMALL)
    planned = len(build_plan(load_config(config)))
    kill_after = int(rng.integers(2, planned - 5))
    out = tmp_path / "raw.h5"
    process = _collect_process(*urls(), out, config)
    deadline = time.monotonic() + 60.0
    while _journal_points(journal_path(out)) < kill_after and process.poll() is None:
        assert time.monotonic() < deadline, "the run never reached the kill point"
        time.sleep(0.005)
    time.sleep(rng.uniform(0.0, 0.05))  # anywhere in the next point: moving, settling, writing
    process.send_signal(signal.SIGKILL)
    process.wait()
    assert process.returncode == -signal.SIGKILL
    resumed = _collect_process(*urls(), out, config, "--resume")
    stdout, stderr = resumed.communicate(timeout=120)
    assert resumed.returncode == 0, stderr.decode()
    summary = json.loads(stdout)
    grid = read_raw_grid(out)
    assert summary["complete"] and grid.complete
    assert sorted(grid.plan_index) == list(range(planned))  # each planned point exactly once
    assert planned - summary["taken_this_run"] >= kill_after  # nothing journalled was lost
    assert np.all(np.diff(grid.t_mid_s) > 0)
    assert_matches_truth(grid)
    assert not journal_path(out).exists()


def test_resume_refuses_another_config_before_opening_ports(tmp_path):
    from whiskercal.collect.checkpoint import Checkpoint
    from whiskercal.collect.loop import Devices
    from whiskercal.collect.run import make_header

    plan = build_plan(load_config(fast_config(tmp_path)))
    out = tmp_path / "raw.h5"
    Checkpoint.start(out, make_header(plan, Devices({}, "nano", True), "twin")).close()
    other = tmp_path / "other.toml"
    other.write_text(FAST.replace("samples_per_point = 5", "samples_per_point = 6"))
    # the ports do not exist: the refusal must come before anything is opened
    result = run_cli("--stage", "/dev/nonexistent-stage", "--sensor", "/dev/nonexistent-sensor",
                     "--out", str(out), "--config", str(other), "--resume")
    assert result.exit_code == 2
    assert "different plan or configuration" in result.output
    result = run_cli("--stage", "/dev/nonexistent-stage", "--sensor", "/dev/nonexistent-sensor",
                     "--out", str(out), "--config", str(fast_config(tmp_path)), "--resume")
    assert result.exit_code == DeviceError.exit_code and "cannot open serial port" in result.output


def test_overload_guard_holds_the_stage_and_lifts_the_rod_on_the_twin(tmp_path):
    from whiskercal.rig.overload import OverloadError
    from whiskercal.rig.sensor import SensorClient
    from whiskercal.rig.stage import StageClient

    plan = build_plan(load_config(fast_config(tmp_path)).replace(safety={"overload_z_uT": 5000.0, "on_overload": "stop"}))
    stage_url, sensor_url = urls()
    stage, sensor = StageClient(stage_url), SensorClient(sensor_url)
    with pytest.raises(OverloadError, match="5000 µT; the rod was backed off"):
        collect(None, None, tmp_path / "raw.h5", plan, stage_client=stage, sensor_client=sensor)
    truth = sensor.transport.port.world.truth.arrays()
    assert truth["kind"][-1] == "free"  # whisker released
    assert truth["tool_mm"][-1][1] >= plan.config.approach.safe_y_mm - 0.05
    assert stage.status().idle  # unlocked and usable again


def _serve_ptys(*args: str):
    """Start `whiskercal sim serve --json` and return the process and its pty paths."""
    process = subprocess.Popen([sys.executable, "-m", "whiskercal", "sim", "serve", "--json", *args],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    text = ""
    while not text.startswith("{") or not text.rstrip().endswith("}"):
        line = process.stdout.readline()
        assert line, f"sim serve ended early: {process.stderr.read()}"
        text += line
    return process, json.loads(text)


def _warm_up(sensor_port: str) -> None:
    """Let the served world load its physics first: on a busy machine its first conversions take
    a second or two and hold up every answer of both served boards, which real boards never do."""
    from whiskercal.rig.sensor import SensorClient

    with SensorClient(sensor_port, timeout_s=30.0) as sensor:
        sensor.start()
        sensor.read(1, timeout_s=30.0)
        sensor.stop()


@pytest.mark.slow
def test_collect_over_sim_serve_ptys_like_real_ports(tmp_path):
    # the boards behind pseudo-terminals, as a real rig's /dev/ttyUSB* would be: no sim:// and
    # no ground truth, the world paced at 10x real time; on a busy machine the host falls behind
    # the stream, and each point must still average samples taken at rest
    process, ports = _serve_ptys("--seed", "4", "--speed", "10", "--duration", "300")
    try:
        _warm_up(ports["sensor"])
        config = fast_config(tmp_path, SMALL)
        planned = len(build_plan(load_config(config)))
        result = run_cli("--stage", ports["stage"], "--sensor", ports["sensor"],
                         "--out", str(tmp_path / "raw.h5"), "--config", str(config), "--json")
    finally:
        process.terminate()
        process.wait(5)
    assert result.exit_code == 0, result.output
    assert json.loads(result.stdout)["points"] == planned
    grid = read_raw_grid(tmp_path / "raw.h5")
    assert grid.complete and grid.truth is None and len(grid.z_uT) == planned
    assert np.all(grid.z_uT < 0)  # every point pushes the whisker to -y


def test_a_truncated_file_without_its_journal_says_so_on_resume(tmp_path, small_twin_grid):
    out = tmp_path / "raw.h5"
    out.write_bytes(small_twin_grid[0].read_bytes()[:20000])  # SMALL's complete file, torn
    stage, sensor = urls("")
    result = run_cli("--stage", stage, "--sensor", sensor, "--out", str(out),
                     "--config", str(fast_config(tmp_path, SMALL)), "--resume")
    assert result.exit_code == 2
    assert "truncated: 20000 of" in result.output and "journal" in result.output


def test_stock_grbl_homing_z_first_gives_one_line_naming_the_fix(tmp_path):
    stage, sensor = urls("stock=1")  # stock config.h: Z first, and this stage has no Z switch
    result = run_cli("--stage", stage, "--sensor", sensor, "--out", str(tmp_path / "raw.h5"),
                     "--config", str(fast_config(tmp_path, SMALL)))
    assert result.exit_code == DeviceError.exit_code
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "ALARM:9" in lines[0]
    assert "homes Z first" in lines[0] and "config.h" in lines[0] and "home = false" in lines[0]
