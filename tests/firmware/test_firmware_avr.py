"""Both sketches build for the ATmega328P and fit it with room for the stack."""

import re

from firmware_build import make


def test_sketches_fit_the_atmega328p():
    output = make("avr", "avr-gcc")  # the make target itself fails when a limit is exceeded
    programs = [int(v) for v in re.findall(r"Program:\s+(\d+) bytes", output)]
    data = [int(v) for v in re.findall(r"Data:\s+(\d+) bytes", output)]
    assert len(programs) == 2 and len(data) == 2, output
    assert all(p <= 30720 for p in programs), output   # 32 KiB less the 2 KiB bootloader
    assert all(d <= 1536 for d in data), output        # 75% of 2 KiB: the rest is stack
