"""The robot-loop bench's helpers on small synthetic inputs: the server's announcement, the
robot run placed at the served outline, a row's assembly and the run's shapes and rates (no
server started, no contour run)."""

import io
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

import whiskercal.contour as contour
from whiskercal.artifacts.contour_run import ContourRunFile
from whiskercal.bench import robot_loop
from whiskercal.errors import UsageError
from whiskercal.twin.outlines import outline


def _server(lines, stderr=""):
    return SimpleNamespace(stdout=iter(lines), stderr=io.StringIO(stderr))


def test_the_announcement_is_the_json_printed_once_the_port_is_bound():
    info = robot_loop._announcement(_server(['{\n', '  "robot": "ws://127.0.0.1:9090",\n',
                                             '  "outline_pose": "0,0,0"\n', '}\n', 'later\n']))
    assert info == {"robot": "ws://127.0.0.1:9090", "outline_pose": "0,0,0"}
    with pytest.raises(UsageError, match="printed no address: port in use"):
        robot_loop._announcement(_server([], stderr="port in use\n"))


def _record(shape="cylinder", samples=12):
    columns = {"t_s": np.arange(samples) / 300.0}
    return ContourRunFile(shape=shape, core_mm=np.zeros((1, 2)), radius_mm=1.0, target_z_uT=-900.0,
                          seed=1, complete=True, wall_s=1.0, sensor_id="twin", columns=columns,
                          config={"robot": {"latency_ms": 4.5, "stopped_by": None}})


def test_the_robot_run_is_judged_against_the_served_outline(monkeypatch):
    judged = []
    monkeypatch.setattr(contour, "summarize", lambda run: judged.append(run) or {"mean_error_mm": 0.2})
    measured = robot_loop._measured(_record(shape="unknown"), "octagon", {"outline_pose": "0,0,0"})
    served = outline("octagon")
    (placed,) = judged
    assert placed.shape == "octagon" and placed.radius_mm == served.radius_mm
    np.testing.assert_array_equal(placed.core_mm, served.core_mm)
    assert measured == {"summary": {"mean_error_mm": 0.2}, "latency_ms": 4.5, "samples": 12,
                        "stopped_by": None}
    with pytest.raises(UsageError, match="not at the origin"):
        robot_loop._measured(_record(), "octagon", {"outline_pose": "5,0,0"})


def _summary(mean_mm):
    return {key: 0.0 for key in robot_loop.ROW_KEYS} | {"mean_error_mm": mean_mm}


def test_a_row_sets_the_robot_run_beside_the_in_process_run_at_the_same_rate(monkeypatch):
    asked = {}
    robot = {"summary": _summary(0.35), "latency_ms": 3.0, "samples": 2900, "stopped_by": None}
    monkeypatch.setattr(robot_loop, "robot_run", lambda *args: (robot, {"report": ["served"]}))

    def contour_record(shape, artifact, config, duration_s, seed):
        asked.update(shape=shape, rate_hz=config.rate_hz, duration_s=duration_s, seed=seed)
        return "in-process run"

    monkeypatch.setattr(contour, "contour_record", contour_record)
    monkeypatch.setattr(contour, "summarize", lambda run: _summary(0.25))
    row = robot_loop.compare("octagon", 30.0, Path("cal.h5"), 10.0, 3, Path("."))
    assert asked == {"shape": "octagon", "rate_hz": 30.0, "duration_s": 10.0, "seed": 3}
    assert row["robot_mean_error_mm"] == 0.35 and row["in_process_mean_error_mm"] == 0.25
    assert row["mean_error_difference_mm"] == pytest.approx(0.10)
    assert row["samples_expected"] == 300 and row["samples"] == 2900
    assert row["server"] == {"report": ["served"]}
    assert all(f"robot_{key}" in row and f"in_process_{key}" in row for key in robot_loop.ROW_KEYS)


def test_the_quick_run_is_the_octagon_at_both_rates(monkeypatch, tmp_path):
    calls = []
    monkeypatch.setattr(robot_loop, "compare",
                        lambda shape, rate, artifact, duration, seed, folder:
                        calls.append((shape, rate, duration, seed)) or {"shape": shape})
    # the run's scratch folder under the test's own
    monkeypatch.setattr(robot_loop.tempfile, "mkdtemp", lambda prefix: str(tmp_path / prefix))
    seen = []
    result = robot_loop.run(quick=True, progress=seen.append, artifact=tmp_path / "cal.h5", seed=2)
    assert calls == [("octagon", rate, 10.0, 2) for rate in robot_loop.RATES_HZ]
    assert seen == result["rows"] and result["duration_s"] == 10.0
    robot_loop.run(artifact=tmp_path / "cal.h5", duration_s=5.0)
    assert [call[0] for call in calls[2:]] == [s for s in robot_loop.SHAPES for _ in robot_loop.RATES_HZ]
