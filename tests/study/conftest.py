"""Shared fixtures of the study tests: one twin calibration and one short twin study per session."""

from pathlib import Path

import pytest

from short_study import short_study

# A short study that keeps what the assertions need: the nine default depths and one at 50 mm
# (past the default sensor's slip into tangential contact near 45.4 mm, with push-in enough
# beyond it for the kink test's confirming window: a 48 mm trial leaves it only the push-in's
# last window), the paper's 300 Hz (the kink test needs dense push-in samples), a 10 mm slide
# instead of 80 mm, faster moves off the slide, a coarser first-contact search.
TEST_CONFIG = short_study([5, 10, 15, 20, 25, 30, 35, 40, 45, 50])


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
