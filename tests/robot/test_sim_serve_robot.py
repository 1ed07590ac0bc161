"""``whiskercal sim serve --robot``: what it prints, how long it serves, what it refuses."""

import json
import os
import re
import subprocess
import sys
import time
from pathlib import Path

import pytest
from click.testing import CliRunner
from websockets.sync.client import connect

from whiskercal.cli import cli

pytestmark = pytest.mark.timeout(90)
REPO = Path(__file__).resolve().parents[2]


def test_it_prints_the_url_topics_and_outline_then_serves_for_its_duration():
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    started = time.monotonic()
    server = subprocess.Popen([sys.executable, "-m", "whiskercal", "sim", "serve", "--robot",
                               "--shape", "rounded-rect", "--port", "0", "--rate-hz", "30",
                               "--duration", "4", "--json"], stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True, env=env)
    try:
        lines = []
        for line in server.stdout:
            lines.append(line)
            if line.startswith("}"):
                break
        info = json.loads("".join(lines))
        assert info["robot"].startswith("rosbridge://127.0.0.1:")
        assert info["topics"] == {"field": "/whiskercal/field", "pose": "/whiskercal/pose",
                                  "twist": "/whiskercal/twist"}
        assert info["outline"] == "rounded-rect:w=160,h=160,r=40" and info["outline_pose"] == "0,0,0"
        port = int(info["robot"].rsplit(":", 1)[1])
        with connect(f"ws://127.0.0.1:{port}") as ws:
            ws.send(json.dumps({"op": "subscribe", "topic": info["topics"]["field"]}))
            assert json.loads(ws.recv(timeout=5))["topic"] == info["topics"]["field"]
        _, err = server.communicate(timeout=30)
    finally:
        server.kill()
    served = re.search(r"served (\d+) samples, skipped (\d+)", err)
    # 4 s at 30 Hz by the wall clock: each taken, or skipped when the machine was too busy
    assert server.returncode == 0 and int(served[1]) + int(served[2]) == 120 and int(served[1]) > 60
    assert time.monotonic() - started >= 4.0


def test_a_mount_error_carries_the_sensor_off_the_nominal_mount(tmp_path):
    from whiskercal.mount import Mount, write_mount

    nominal = tmp_path / "nominal.toml"
    write_mount(nominal, Mount(0.0, 30.0, 90.0))
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    server = subprocess.Popen([sys.executable, "-m", "whiskercal", "sim", "serve", "--robot",
                               "--shape", "cylinder", "--port", "0", "--rate-hz", "30",
                               "--duration", "1", "--mount", str(nominal),
                               "--mount-error", "1.5,-0.5,2", "--json"], stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True, env=env)
    try:
        out, _ = server.communicate(timeout=60)
    finally:
        server.kill()
    assert server.returncode == 0
    assert json.loads(out)["true_mount"] == {"x_mm": 1.5, "y_mm": 29.5, "yaw_deg": 92.0}


@pytest.mark.parametrize("words, message", [
    (["--robot"], "give --shape"),
    (["--robot", "--shape", "octagon", "--mount-error", "1,2"], "--mount-error must be DX,DY,DEG"),
    (["--mount-error", "1,2,3"], "--mount-error is for --robot"),
    (["--shape", "octagon"], "--shape is for --robot"),
    # given at its default value is still given, either way round
    (["--port", "9090"], "--port is for --robot"),
    (["--rate-hz", "30"], "--rate-hz is for --robot"),
    (["--robot", "--shape", "octagon", "--scene", "plane"], "--scene is for the rig's boards"),
    (["--robot", "--shape", "octagon", "--speed", "1"], "--speed is for the rig's boards"),
    (["--robot", "--shape", "octagon", "--fault", "stall@1"], "--fault is for the rig's boards"),
    (["--robot", "--shape", "octagon", "--rate-hz", "0"], "--rate-hz must be"),
    (["--robot", "--shape", "wall"], "Invalid value for '--shape'"),
])
def test_bad_serve_options_are_one_line(words, message):
    result = CliRunner().invoke(cli, ["sim", "serve", *words, "--duration", "1"])
    assert result.exit_code == 2 and message in result.stderr
