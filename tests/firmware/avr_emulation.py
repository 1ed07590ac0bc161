"""Builds the emulation harness and the .hex images (``make -C firmware sim``) for the tests that
run the compiled firmware on simavr, or skips them with the reason the emulation cannot run."""

from __future__ import annotations

import shutil
import subprocess

import pytest

from firmware_build import make
from whiskercal.twin.devices.avr_harness import unavailable_reason


def emulation_or_skip(board: str = "sensor") -> None:
    """Build what ``sim://NAME/BOARD?firmware=avr`` needs; skip when simavr or its library is absent."""
    for tool in ("simavr", "avr-gcc", "pkg-config"):
        if shutil.which(tool) is None:
            pytest.skip(f"{tool} is not installed: cannot run the firmware on simavr")
    if subprocess.run(["pkg-config", "--exists", "simavr"]).returncode != 0:
        pytest.skip("libsimavr-dev is not installed: cannot build the emulation harness")
    make("sim", "avr-gcc")
    reason = unavailable_reason(board)
    if reason:
        pytest.skip(reason)
