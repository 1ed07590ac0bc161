"""The moving-base twin ends a run as a collision where its contact model ends, never with an
error mid-run."""

import pytest

from whiskercal.twin.mobile import MobileSensor
from whiskercal.twin.outlines import outline
from whiskercal.twin.params import DEFAULT_SENSOR


@pytest.mark.parametrize("base_mm, kind", [
    ((0.0, -50.0), "collision"),  # the base inside the cylinder, its centre beside the clamp
    ((30.0, -78.0), "free"),      # the cylinder behind the clamp, clear of the wire
    ((0.0, -90.0), "free"),       # beside it, clear of the wire's line
])
def test_a_cylinder_short_of_the_clamp_is_a_collision_or_clear_never_an_error(base_mm, kind):
    # a sensor driven round beside the Ø160 mm cylinder (centre at the origin), heading +x: the
    # contact model takes objects beyond the rigid clamp only, and runs once ended there with
    # an error
    robot = MobileSensor(DEFAULT_SENSOR, outline("cylinder"), [*base_mm, 0.0])
    sample = robot.step(0.0)
    assert sample.kind == kind
    assert robot.collided == (kind == "collision")
