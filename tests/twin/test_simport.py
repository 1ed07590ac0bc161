"""sim:// ports: disconnects, reopening resets a board, and `sim serve` ptys for any serial tool."""

import itertools
import json
import os
import subprocess
import sys
import time

import numpy as np
import pytest
import serial
from test_world_standin import RigidWhiskerPhysics

import whiskercal.rig  # noqa: F401  (registers sim://)
from whiskercal.errors import DeviceError
from whiskercal.rig.sensor import SensorClient
from whiskercal.rig.stage import StageClient
from whiskercal.twin.world import create_world

_names = itertools.count()


def _world():
    return create_world(f"simport-test-{next(_names)}", physics=RigidWhiskerPhysics())


def test_stage_unplugged_mid_move_raises_a_clear_device_error():
    world = _world()
    stage = StageClient(f"sim://{world.name}/stage?fault=disconnect@0.8")
    stage.unlock()
    stage.move_to(100, 0, 3000)
    with pytest.raises(DeviceError, match=r"stage on sim://.* is disconnected .*unplugged at t=0.8"):
        stage.wait_idle(10)
    with pytest.raises(DeviceError, match="disconnected"):
        stage.status()


def test_reopening_a_port_resets_its_board_like_an_arduino():
    world = _world()
    stage = StageClient(f"sim://{world.name}/stage")
    stage.unlock()
    stage.move_to(10, 0, 3000)
    stage.wait_idle(5)
    stage.transport.port.close()
    again = StageClient(f"sim://{world.name}/stage")
    identity = again.identify()
    assert identity.banner.startswith("Grbl 1.1h")
    status = again.status()
    assert status.alarm  # locked again, homing lost
    np.testing.assert_array_equal(status.mpos_mm, [0, 0])


def test_clients_accept_an_open_serial_object():
    world = _world()
    port = serial.serial_for_url(f"sim://{world.name}/sensor", timeout=0.1)
    assert SensorClient(port).identify().startswith("whisker_nano")


def _start_server(*args):
    process = subprocess.Popen([sys.executable, "-m", "whiskercal", "sim", "serve", "--json", *args],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    text = ""
    while True:
        line = process.stdout.readline()
        assert line, f"sim serve ended early: {process.stderr.read()}"
        text += line
        if line.startswith("}"):
            return process, json.loads(text)


@pytest.mark.slow
def test_sim_serve_ptys_work_with_pyserial():
    process, info = _start_server("--seed", "2", "--speed", "20", "--duration", "30")
    try:
        assert os.path.exists(info["stage"]) and os.path.exists(info["sensor"])
        # Timeouts only guard against a hang: a busy host may leave the server unscheduled for
        # seconds. Pacing is checked on a 6.25 s move, which 20x pacing runs in about 0.3 s.
        stage = StageClient(serial.Serial(info["stage"], 115200, timeout=1), timeout_s=30.0)
        sensor = SensorClient(serial.Serial(info["sensor"], 115200, timeout=1), timeout_s=30.0)
        assert stage.identify().whiskercal_firmware
        assert sensor.identify().startswith("whisker_nano")
        stage.unlock()
        started = time.monotonic()
        stage.move_to(150, 0, 1500)  # 6.25 simulated s
        stage.wait_idle(60)
        assert time.monotonic() - started < 6.25  # paced faster than real time
        sensor.start()
        block = sensor.read(300, timeout_s=30)
        sensor.stop()
        np.testing.assert_array_equal(np.diff(block.seq), 1)
        np.testing.assert_allclose(np.diff(block.t_s), 1 / 300, atol=1.01e-6)
    finally:
        process.terminate()
        process.wait(5)


def test_speed_option_paces_the_clock_against_real_time():
    name = f"simport-test-{next(_names)}"
    sensor = SensorClient(f"sim://{name}/sensor?speed=2")
    sensor.start()
    started_wall, started_sim = time.monotonic(), sensor.transport.now_s()
    sensor.read(60, timeout_s=1)  # 0.2 simulated seconds
    simulated = sensor.transport.now_s() - started_sim
    assert time.monotonic() - started_wall >= 0.9 * simulated / 2


def test_sim_serve_refuses_a_bad_fault():
    from click.testing import CliRunner

    from whiskercal.cli import cli

    result = CliRunner().invoke(cli, ["sim", "serve", "--fault", "melt@3", "--duration", "0"])
    assert result.exit_code == 2
    assert "bad fault 'melt@3'" in result.output


def _sensor_file(tmp_path, name="my sensor+1.toml"):
    path = tmp_path / name
    path.write_text('sensor_id = "lab-url"\n[whisker]\nlength_mm = 90\n', encoding="utf-8")
    return path


def test_sensor_option_takes_a_percent_encoded_file_path(tmp_path):
    import urllib.parse

    path = _sensor_file(tmp_path)  # a space and a plus: both must be encoded in a URL
    name = f"simport-test-{next(_names)}"
    port = serial.serial_for_url(f"sim://{name}/sensor?sensor={urllib.parse.quote(str(path))}", timeout=0.1)
    assert port.world.sensor.sensor_id == "lab-url"
    assert port.world.sensor.whisker.length_mm == 90.0
    port.close()


def test_sensor_option_still_takes_a_shipped_id_and_names_a_bad_file(tmp_path):
    from whiskercal.errors import UsageError
    from whiskercal.twin.params import SECOND_SENSOR

    port = serial.serial_for_url(f"sim://simport-test-{next(_names)}/sensor?sensor=twin-short-60mm")
    assert port.world.sensor is SECOND_SENSOR
    port.close()
    bad = tmp_path / "bad.toml"
    bad.write_text('sensor_id = "lab"\n[magnetometer]\ngain = 9\n', encoding="utf-8")
    with pytest.raises(UsageError, match=r"bad.toml \[magnetometer\] gain: must be an integer in 0..7, not 9$"):
        serial.serial_for_url(f"sim://simport-test-{next(_names)}/sensor?sensor={bad}")


def test_sim_serve_takes_a_sensor_file(tmp_path):
    from click.testing import CliRunner

    from whiskercal.cli import cli

    path = _sensor_file(tmp_path, "lab.toml")
    result = CliRunner().invoke(cli, ["sim", "serve", "--sensor", str(path), "--duration", "0", "--json"],
                                catch_exceptions=False)
    assert result.exit_code == 0, result.output
    assert json.loads(result.output)["sensor_id"] == "lab-url"
    missing = CliRunner().invoke(cli, ["sim", "serve", "--sensor", str(tmp_path / "no.toml"), "--duration", "0"])
    assert missing.exit_code == 2
    assert "no.toml: no such sensor file" in missing.output
