"""The study's configuration and plane geometry."""

import numpy as np
import pytest

from whiskercal.errors import UsageError
from whiskercal.study.config import PlaneGeometry, load_config
from whiskercal.twin.physics.obstacles import plane_for_depth
from whiskercal.twin.params import DEFAULT_SENSOR


def test_defaults_are_the_papers_study():
    config = load_config()
    assert config["trials"]["depths_mm"] == [5.0 * k for k in range(1, 10)]
    assert config["trials"]["speed_mm_s"] == 10.0 and config["trials"]["travel_mm"] == 80.0
    assert config["sensor"]["rate_hz"] == 300 and config["contact"]["threshold_uT"] == 300.0


@pytest.mark.parametrize("text, message", [
    ("[trials]\nspeed = 3\n", r"\[trials\] speed: unknown key"),
    ("[trials]\ndepths_mm = [10.0, 5.0]\n", r"\[trials\]: depths_mm must be increasing$"),
    ("[safety]\noverload_uT = 100.0\n", "must exceed contact.threshold_uT"),
    ("trials = 3\n", r"\[trials\]: must be a table of keys, not 3$"),
])
def test_bad_configurations_are_refused(tmp_path, text, message):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(UsageError, match=message):
        load_config(path)


def test_waypoints_push_in_by_the_depth_and_slide_the_travel():
    config = load_config()
    geometry = PlaneGeometry.from_config(config)
    contact = geometry.contact_guess_stage_mm()
    points = geometry.trial_waypoints_stage_mm(contact, 30.0, config)
    depth = lambda p: float(geometry.depth_of_stage_mm(p, contact)[0])
    assert depth(points["slide_start"]) == pytest.approx(30.0)
    assert depth(points["slide_end"]) == pytest.approx(30.0)
    assert depth(points["retracted_start"]) == pytest.approx(-10.0)
    assert np.linalg.norm(points["slide_end"] - points["slide_start"]) == pytest.approx(80.0)


def test_plane_line_is_the_twins_plane_at_the_same_depth():
    """Pushing the stage d past the geometric contact puts the plane where the twin's
    ``plane_for_depth`` has it (same line, same slide direction)."""
    geometry = PlaneGeometry.from_config(load_config())
    whisker = DEFAULT_SENSOR.whisker
    contact = geometry.origin_stage_mm + geometry.to_stage_vector([whisker.reach_mm, 0.0])
    push = geometry.to_stage_vector(geometry.push_whisker)
    point, normal = geometry.plane_line_whisker(contact + 25.0 * push)
    twin = plane_for_depth(whisker, 25.0, 0.0)
    assert normal[0] == pytest.approx(twin.normal)
    assert float(twin.normal @ (point[0] - twin.point_mm)) == pytest.approx(0.0, abs=1e-9)
    assert geometry.slide_whisker == pytest.approx(twin.tangent)
