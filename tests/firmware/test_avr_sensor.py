"""whisker_nano.hex on simavr (``sim://NAME/sensor?firmware=avr``) against the Python sensor board
of a world with the same seed, and against the world's ground truth."""

import itertools

import numpy as np
import pytest

from avr_emulation import emulation_or_skip
from whiskercal.rig.sensor import SensorClient
from whiskercal.twin.world import create_world

_names = itertools.count()
FRAMES = 900  # 3 s at 300 frames/s


def _stream(firmware: str, seed: int, frames: int):
    world = create_world(f"avr-sensor-{next(_names)}", seed=seed)
    query = "?firmware=avr" if firmware == "avr" else ""
    sensor = SensorClient(f"sim://{world.name}/sensor{query}")
    try:
        assert sensor.identify() == "whisker_nano fw=0.1.0 proto=1"
        assert sensor.command("CFG?") == "rate=300 gain=5 res=2 osr=0 filt=2"
        sensor.start()
        block = sensor.read(frames, timeout_s=frames / 300 + 1)
        sensor.stop()
    finally:
        sensor.close()
    return world, block


@pytest.fixture(scope="module")
def streams():
    emulation_or_skip("sensor")
    return {firmware: _stream(firmware, seed=11, frames=FRAMES) for firmware in ("python", "avr")}


def test_no_frame_lost_or_flagged_at_300_frames_per_s(streams):
    _, block = streams["avr"]
    np.testing.assert_array_equal(block.seq, np.arange(FRAMES))
    assert block.dropped == 0 and block.corrupt == 0
    # no MLX error (read before ready), saturation, lateness or transmit overflow
    np.testing.assert_array_equal(block.status, 0)
    # the board's µs clock: every period 1/300 s within the loop's polling jitter
    periods = np.diff(block.t_s)[1:]  # the first conversion also configures the chip
    assert np.abs(periods - 1 / 300).max() < 40e-6, (periods.min(), periods.max())


def test_counts_agree_with_the_python_board_and_the_truth(streams):
    _, python = streams["python"]
    world, avr = streams["avr"]
    lsb_z = avr.field_uT[0, 2] / avr.counts[0, 2]
    dz = (avr.field_uT[:, 2] - avr.field_uT[0, 2]) - (python.field_uT[:, 2] - python.field_uT[0, 2])
    assert np.abs(dz).max() <= 20.0, np.abs(dz).max()
    # against the ground truth of the conversions the emulated chip was asked for
    truth = {key: value[:FRAMES] for key, value in world.truth.arrays().items()}
    residual = avr.field_uT - truth["field_true_uT"]
    noise = world.sensor.magnetometer.effective_noise_uT()
    assert np.all(np.abs(residual.mean(axis=0)) < 4 * noise / np.sqrt(FRAMES) + lsb_z)
    np.testing.assert_allclose(residual.std(axis=0), noise, rtol=0.15)
    # each frame's board time trails the truth's (the SM command) by the same I2C latency
    lag = truth["t_s"] - (avr.t_s - avr.t_s[0] + truth["t_s"][0])
    assert np.ptp(lag[1:]) < 60e-6, np.ptp(lag[1:])


def test_stack_and_interrupt_latency_of_the_sensor_image(streams):
    world, _ = streams["avr"]
    harness = world.sensor_board.harness
    stack, untouched = harness.stack_use()  # painted SRAM read back after 3 s of streaming
    assert 0 < stack and untouched > 512, (stack, untouched)
    latency = harness.interrupt_latency()
    assert {16, 24} <= set(latency)  # TIMER0_OVF (micros) and TWI ran
    # every interrupt within one UART byte time (85 µs at 117,647 baud): the receiver holds only
    # two bytes, so a slower one could lose host input
    longest_us = max(longest for _, longest, _ in latency.values()) / 16
    assert longest_us < 85, latency
