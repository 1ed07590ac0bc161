"""Two depths of the flat-plane study through both compiled images on simavr agree with the
Python boards of a world with the same seed."""

import uuid
from pathlib import Path

import numpy as np
import pytest

from avr_emulation import emulation_or_skip

from short_study import short_study
from whiskercal.artifacts.plane_study import PHASE_SLIDE, read_study
from whiskercal.study.config import load_config
from whiskercal.study.run import run_study
from whiskercal.twin.devices import simport

# tests/study/conftest.py's short study, at two depths
TWO_DEPTHS = short_study([10.0, 30.0])


def _study(folder: Path, emulated: bool):
    folder.mkdir()
    (folder / "study.toml").write_text(TWO_DEPTHS)
    config = load_config(folder / "study.toml")
    name = f"avrstudy{uuid.uuid4().hex[:8]}"
    firmware = "&firmware=avr" if emulated else ""
    stage = simport.Serial(f"sim://{name}/stage?scene=plane&seed=7{firmware}", timeout=1.0)
    sensor = simport.Serial(f"sim://{name}/sensor" + ("?firmware=avr" if emulated else ""), timeout=1.0)
    run_study(stage, sensor, folder / "STUDY.h5", config)
    return read_study(folder / "STUDY.h5")


@pytest.mark.slow
def test_two_study_depths_through_the_emulated_boards(tmp_path):
    emulation_or_skip("stage")
    emulation_or_skip("sensor")
    python, avr = _study(tmp_path / "python", False), _study(tmp_path / "avr", True)
    assert avr.complete and [t.depth_mm for t in avr.trials] == [10.0, 30.0]
    apart_y = []
    for ours, theirs in zip(avr.trials, python.trials):
        slide = ours.stream["phase"] == PHASE_SLIDE
        assert slide.sum() > 250
        np.testing.assert_array_equal(ours.stream["status"], 0)
        median = np.median(ours.stream["field_uT"][slide], axis=0)
        reference = np.median(theirs.stream["field_uT"][theirs.stream["phase"] == PHASE_SLIDE], axis=0)
        assert abs(median[2] - reference[2]) <= 20.0, (ours.depth_mm, median, reference)
        apart_y.append(abs(median[1] - reference[1]))
    if max(apart_y) > 20.0:
        # seen on one machine with Debian's avr-gcc 5.4.0 and simavr: the emulated stage's
        # microstep staircase moves the stuck tip's stick-slip, and with it the first contact
        # the study extrapolates (0.24 mm), deterministically; on others within 7 µT
        # (docs/firmware.md)
        pytest.xfail(f"the emulated slides' Y medians are {max(apart_y):.0f} µT from the "
                     "Python boards' (limit 20 µT): open, docs/firmware.md")
