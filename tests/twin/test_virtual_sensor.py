"""The virtual sensor board: frames, commands, faults, the host's receive buffer."""

import itertools

import numpy as np
import pytest
from test_world_standin import RigidWhiskerPhysics

from whiskercal.errors import DeviceError
from whiskercal.rig.sensor import SensorClient, SensorCommandError
from whiskercal.twin.devices.virtual_sensor import SensorFaults
from whiskercal.twin.world import create_world

_names = itertools.count()


def _sensor(**options):
    world = create_world(f"sensor-test-{next(_names)}", physics=RigidWhiskerPhysics(), **options)
    return world, SensorClient(f"sim://{world.name}/sensor")


def test_commands_answer_as_documented():
    world, sensor = _sensor()
    assert sensor.identify() == "whisker_nano fw=0.1.0 proto=1"
    assert sensor.command("CFG?") == "rate=300 gain=5 res=2 osr=0 filt=2"
    assert sensor.configure(rate_hz=400).rate_hz == 400  # 1.84 + 0.36 ms fit 2.5 ms
    for command, code in (("RATE 0", 2), ("RATE 501", 2), ("RATE 500", 4), ("GAIN 8", 2), ("RES x", 2),
                          ("OSR 3", 4), ("FILT 7", 4), ("BOGUS", 1), ("ID" + "D" * 40, 6)):
        with pytest.raises(SensorCommandError, match=f"ERR:{code}"):
            sensor.command(command)
    sensor.start()
    with pytest.raises(SensorCommandError, match="ERR:3"):
        sensor.command("GAIN 6")
    sensor.stop()


@pytest.mark.parametrize("rate_hz", [300, 100])
def test_frames_have_consecutive_seq_and_the_configured_period(rate_hz):
    world, sensor = _sensor()
    sensor.configure(rate_hz=rate_hz)
    sensor.start()
    block = sensor.read(rate_hz, timeout_s=2)
    np.testing.assert_array_equal(np.diff(block.seq), 1)
    # board time is in whole µs
    np.testing.assert_allclose(np.diff(block.t_s), 1 / rate_hz, atol=1.01e-6)
    assert block.dropped == 0 and block.corrupt == 0
    # one second of samples took one simulated second (plus the first period)
    assert world.now_s == pytest.approx(1 + 1 / rate_hz, abs=0.01)


def test_counts_match_the_ground_truth_within_noise():
    world, sensor = _sensor(seed=5)
    sensor.start()
    block = sensor.read(600, timeout_s=3)
    truth = {k: v[:600] for k, v in world.truth.arrays().items()}  # one more may be in flight
    np.testing.assert_allclose(block.t_s, truth["t_s"], atol=1e-6)
    residual = block.field_uT[:, 1] - truth["field_true_uT"][:, 1]
    noise = world.sensor.magnetometer.effective_noise_uT()[1]
    assert abs(residual.mean()) < 4 * noise / np.sqrt(600) + 0.3
    assert residual.std() == pytest.approx(np.hypot(noise, 1.000 / np.sqrt(12)), rel=0.15)


def test_link_faults_are_detected_and_counted():
    world, sensor = _sensor(seed=3, sensor_faults=SensorFaults(corrupt_rate=0.02, drop_rate=0.02))
    sensor.start()
    total = 0
    for _ in range(6):
        total += len(sensor.read(300, timeout_s=3))
    board = world.sensor_board
    assert board.frames_corrupted > 0 and board.frames_lost > 0
    # every lost or corrupted frame is a gap in seq; corrupted ones also count as corruption
    # events (adjacent corrupted frames form one event)
    lost_before_last = board.frames_lost + board.frames_corrupted
    assert sensor.dropped == pytest.approx(lost_before_last, abs=2)
    assert 0 < sensor.corrupt <= board.frames_corrupted


def test_a_host_that_does_not_read_loses_frames_in_its_4k_buffer():
    world, sensor = _sensor()
    sensor.start()
    sensor.read(10, timeout_s=1)
    world.advance_to(world.now_s + 2.0)  # 600 frames = 11 kB arrive; the buffer holds 4 KiB
    block = sensor.read_available()
    assert 200 <= len(block) <= 4096 // 19 + 1
    block = sensor.read(300, timeout_s=2)
    assert sensor.dropped > 300
    assert sensor.transport.port.overrun_bytes > 0


def test_disconnect_raises_a_clear_device_error():
    world = create_world(f"sensor-test-{next(_names)}", physics=RigidWhiskerPhysics())
    sensor = SensorClient(f"sim://{world.name}/sensor?fault=disconnect@1.5")
    sensor.start()
    sensor.read(300, timeout_s=2)
    with pytest.raises(DeviceError, match="sensor on sim://.* is disconnected"):
        sensor.read(300, timeout_s=2)
    assert world.now_s == pytest.approx(1.5)
