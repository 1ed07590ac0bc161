"""``whiskercal sim serve --firmware avr``: the compiled images on simavr behind two ptys."""

import os

import numpy as np
import pytest
import serial

from avr_emulation import emulation_or_skip
from served_sim import sim_serve
from whiskercal.rig.sensor import SensorClient
from whiskercal.rig.stage import StageClient


@pytest.mark.slow
def test_sim_serve_runs_the_images_behind_ptys():
    emulation_or_skip("stage")
    emulation_or_skip("sensor")
    with sim_serve("--firmware", "avr") as info:
        assert info["firmware"] == "avr" and os.path.exists(info["stage"])
        # generous timeouts: they only guard against a hang on a busy host
        stage = StageClient(serial.Serial(info["stage"], 115200, timeout=1), timeout_s=30.0)
        sensor = SensorClient(serial.Serial(info["sensor"], 115200, timeout=1), timeout_s=30.0)
        assert stage.identify().name == "stage_stepper"  # the image's own $I, not the twin's
        assert sensor.identify() == "whisker_nano fw=0.1.0 proto=1"
        sensor.start()
        block = sensor.read(150, timeout_s=30)
        sensor.stop()
        np.testing.assert_array_equal(np.diff(block.seq), 1)
        assert block.dropped == 0 and block.corrupt == 0
