"""Builds stock grbl 1.1h for the emulator (``make -C firmware grbl``, from the checkout named by
WHISKERCAL_GRBL_SRC) for the tests marked ``grbl``, or skips them with the reason."""

from __future__ import annotations

import os

import pytest

from avr_emulation import emulation_or_skip
from firmware_build import make
from whiskercal.twin.devices.avr_harness import grbl_image, unavailable_reason


def grbl_or_skip(homing: str = "xy") -> None:
    """Build both grbl images and the harness; skip when grbl's source or the emulator is absent."""
    if not os.environ.get("WHISKERCAL_GRBL_SRC"):
        pytest.skip("WHISKERCAL_GRBL_SRC is not set: stock grbl 1.1h (gnea/grbl, GPL, not part of "
                    "whiskercal) cannot be built for the emulator")
    emulation_or_skip("stage")
    make("grbl", "avr-gcc")
    reason = unavailable_reason("stage", grbl_image(homing))
    if reason:
        pytest.skip(reason)
