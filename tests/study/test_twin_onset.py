"""Distance 0 of the study, found by its contact search on the twin, against the twin's first touch.

The step where |z| first passes the 300 µT collision threshold lies threshold/slope past the
first touch: 1.0 mm on the default sensor, 4.2 mm on long-110mm (about 70 µT per mm there). The
study places distance 0 where z leaves zero instead (``study.detect.contact_onset_mm``).
"""

from pathlib import Path

import numpy as np
import pytest

from whiskercal.artifacts.plane_study import read_study
from whiskercal.study.config import PlaneGeometry, load_config
from whiskercal.study.run import run_study
from whiskercal.twin.devices import simport
from whiskercal.twin.physics.obstacles import plane_for_depth
from whiskercal.twin.sensor_file import resolve_sensor

SENSORS = Path(__file__).resolve().parents[2] / "sensors"

# One shallow trial with a 1 mm slide: what is under test is the contact search before it, with
# the study's default search (0.1 mm steps, 15 samples a step)
ONE_TRIAL = """
[trials]
depths_mm = [2.0]
travel_mm = 1.0
slide_start_mm = -0.5
approach_speed_mm_s = 30.0
rapid_speed_mm_s = 60.0
retract_mm = 3.0
[geometry]
tip_reach_mm = {guess_mm}
[contact]
baseline_samples = 60
"""


def _onset_past_first_touch_mm(folder: Path, sensor_file: str, world: str) -> float:
    """Run the study's contact search on the twin; how far (mm, along the push) its distance 0
    lies past where the plane first touches the undeflected tip."""
    sensor = resolve_sensor(str(SENSORS / sensor_file))
    # the search starts 5 mm before the guess: 1.5 mm off, so the result cannot echo it
    (folder / "study.toml").write_text(ONE_TRIAL.format(guess_mm=sensor.whisker.reach_mm + 1.5))
    config = load_config(folder / "study.toml")
    query = f"scene=plane&seed=3&sensor={SENSORS / sensor_file}"
    run_study(simport.Serial(f"sim://{world}/stage?{query}", timeout=1.0),
              simport.Serial(f"sim://{world}/sensor", timeout=1.0), folder / "study.h5", config)
    geometry = PlaneGeometry.from_config(config)
    zero_stage = read_study(folder / "study.h5").header["first_contact_stage_mm"]
    point = geometry.plane_line_whisker(zero_stage)[0][0]
    first_touch = plane_for_depth(sensor.whisker, 0.0, tilt_rad=geometry.tilt_rad)
    return float((point - first_touch.point_mm) @ first_touch.normal)


@pytest.mark.parametrize("sensor_file", ["twin-paper-75mm.toml", "long-110mm.toml"])
def test_distance_zero_is_the_twins_first_touch(tmp_path, sensor_file):
    offset = _onset_past_first_touch_mm(tmp_path, sensor_file, f"onset-{sensor_file[:-5]}")
    assert abs(offset) < 0.1, offset  # the search's step; the threshold step lay 1.0 / 4.2 mm in
