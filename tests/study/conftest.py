"""Shared fixtures of the study tests: one twin calibration and one short twin study per session."""

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))  # the helpers next to the tests (study_fakes, twin_calibration)

# A short study that keeps what the assertions need: the nine default depths and one at 48 mm
# (past the default sensor's slip into tangential contact near 45.4 mm), the paper's 300 Hz (the
# kink test needs dense push-in samples), a 10 mm slide instead of 80 mm, faster moves off the
# slide, a coarser first-contact search.
TEST_CONFIG = """
[trials]
depths_mm = [5.0, 10.0, 15.0, 20.0, 25.0, 30.0, 35.0, 40.0, 45.0, 48.0]
travel_mm = 10.0
slide_start_mm = -5.0
approach_speed_mm_s = 30.0
rapid_speed_mm_s = 60.0
retract_mm = 3.0
[contact]
search_step_mm = 0.25
samples_per_step = 5
baseline_samples = 60
"""


@pytest.fixture(scope="session")
def twin_calibration(tmp_path_factory) -> Path:
    """A calibration artifact fitted to a grid simulated on the default twin sensor."""
    from twin_calibration import write_twin_calibration

    return write_twin_calibration(tmp_path_factory.mktemp("cal") / "CAL.h5")


@pytest.fixture(scope="session")
def twin_study(tmp_path_factory):
    """The nine-trial study run on the twin through the serial clients; (path, config)."""
    from twin_calibration import run_twin_study

    path, config, _world = run_twin_study(tmp_path_factory.mktemp("study"), TEST_CONFIG, "study-test", 7)
    return path, config
