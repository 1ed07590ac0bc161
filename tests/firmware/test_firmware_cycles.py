"""CPU cycle budgets of the firmware's hot paths, counted under simavr (deterministic, not timed).

The budgets are the assumptions docs/firmware.md builds on: the step interrupt at its 10 kHz cap
must stay under 40% of the CPU, and a sensor sample's CPU work plus its I2C transfers must leave
the conversion room within the 300 Hz period.
"""

import re

from firmware_build import make

CPU_HZ = 16_000_000
STEP_RATE_CAP_HZ = 10_000
STEP_PULSE_CYCLES = 48          # 1 µs direction set-up + 2 µs pulse
CONVERSION_S = 1.84e-3          # OSR 0, DIG_FILT 2 (datasheet)
I2C_EXCHANGE_S = 0.36e-3        # SM + RM at 400 kHz with the Wire library's overhead


def _cycles():
    output = make("bench", "simavr")
    return {name: int(value) for name, value in re.findall(r"^(\w+) (\d+)$", output, re.MULTILINE)}


def test_step_interrupt_fits_its_rate_cap():
    cycles = _cycles()
    # A segment load (once per 10 ms, so once per 100 steps at the cap) adds well under 1%.
    per_step = cycles["stepper_isr_step_max"] + cycles["stepper_isr_segment_load"] / 100
    assert (per_step + STEP_PULSE_CYCLES) * STEP_RATE_CAP_HZ / CPU_HZ <= 0.40, cycles


def test_sensor_sample_fits_300_hz():
    cycles = _cycles()
    cpu_s = (cycles["sampler_read_and_send"] + cycles["sampler_start_conversion"]
             + cycles["sampler_idle_poll"]) / CPU_HZ
    assert CONVERSION_S + I2C_EXCHANGE_S + cpu_s <= 1 / 300, cycles
    assert cycles["frame_encode_sample"] < cycles["sampler_read_and_send"], cycles
