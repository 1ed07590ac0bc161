"""The open wall scene: its outline's geometry, and the moving-base twin's contact against its
pieces, which on the straight part is the contact against a half-plane."""

import math

import numpy as np
import pytest

from whiskercal.contour.metrics import coverage, distances_mm
from whiskercal.twin.mobile import MobileSensor, rotation
from whiskercal.twin.outlines import outline, recorded
from whiskercal.twin.params import DEFAULT_SENSOR
from whiskercal.twin.physics.obstacles import Polygon
from whiskercal.twin.physics.sensor import TwinPhysics


@pytest.mark.parametrize("point, expected_mm", [
    ((75.0, 5.0), 5.0),                            # above the wall (y = 0)
    ((145.0, 10.0), 5.0),                          # in front of the step's face (x = 150)
    ((140.0, 30.0), math.hypot(13, 13) - 3.0),     # off the step's rounded top edge (r = 3 mm)
    ((225.0, 32.0), 12.0),                         # above the step's top (y = 20)
    ((20.0, 100.0), 20.0),                         # beside the second wall (x = 0)
    ((200.0, 63.0), 43.0)])                        # on where a closing chord would run
def test_the_wall_outline_measures_distances_to_its_surface(point, expected_mm):
    distance, _ = distances_mm(np.array([point]), outline("wall").dense())
    assert distance[0] == pytest.approx(expected_mm, abs=0.05)


def test_the_wall_is_open_and_as_long_as_its_parts():
    wall = outline("wall")
    assert not wall.closed and outline("octagon").closed
    assert wall.perimeter_mm == pytest.approx((150 - 3) + (20 - 3) + 150 + 150 + 1.5 * math.pi, abs=1e-3)
    again = recorded("wall", wall.core_mm, wall.radius_mm)  # as a run file gives it back
    np.testing.assert_array_equal(again.dense(), wall.dense())
    straight = np.column_stack([np.linspace(0, 150, 400), np.zeros(400)])  # the wall before the step
    assert coverage(straight, wall.dense()) == pytest.approx(150 / wall.perimeter_mm, abs=0.01)


def test_a_whisker_pressed_on_the_straight_wall_meets_a_half_plane():
    heading = math.radians(-110.0)  # leaning 20° back from the wall's inward normal (-y)
    pose = np.array([75.0, 62.0, heading])  # the undeflected tip ~8 mm past the surface
    robot = MobileSensor(DEFAULT_SENSOR, outline("wall"), pose, seed=3)
    sample = robot.step(0.0)
    half_plane = np.array([[-1e4, -1e4], [1e4, -1e4], [1e4, 0.0], [-1e4, 0.0]])  # y <= 0, world
    seen = Polygon((half_plane - pose[:2]) @ rotation(-heading).T)
    truth = TwinPhysics(DEFAULT_SENSOR).solve_shape(seen, None)
    assert sample.kind == truth.kind == "tip"
    assert sample.contact_mm[1] == pytest.approx(0.0, abs=1e-6)
    np.testing.assert_allclose(sample.tip_mm, robot.to_world(truth.tip_mm), atol=1e-6)


def test_a_wall_run_starts_at_the_step_top_facing_it():
    from whiskercal.contour.run import start_pose

    wall = outline("wall")
    for seed in range(5):
        x, y, heading = start_pose(wall, 20.0, 5.0, np.random.default_rng(seed), 75.0)
        # the outline point the whisker aims at, reach + standoff (80 mm) from the base
        aimed = np.array([x, y]) + 80.0 * np.array([math.cos(heading), math.sin(heading)])
        assert 240.0 <= aimed[0] <= 290.0  # 10-60 mm along the step's top from x = 300 mm
        assert aimed[1] == pytest.approx(20.0, abs=1e-6)
        assert heading == pytest.approx(math.radians(-110.0))  # 20° back from the normal (-y)


def _mirrored(polygon_mm: np.ndarray) -> np.ndarray:
    """A polygon's mirror image across the whisker's axis (y -> -y), still counter-clockwise."""
    return (polygon_mm * np.array([1.0, -1.0]))[::-1]


@pytest.mark.parametrize("depth_mm", [4.0, 12.0])
def test_a_half_plane_pressing_from_the_minus_y_side_gives_the_mirror_image(depth_mm):
    physics = TwinPhysics(DEFAULT_SENSOR)
    # the surface 20° from square to the whisker, pressed depth_mm past the undeflected tip
    normal = np.array([-math.cos(math.radians(20.0)), -math.sin(math.radians(20.0))])
    along = np.array([-normal[1], normal[0]])
    point = np.array([DEFAULT_SENSOR.whisker.reach_mm, 0.0]) + depth_mm * normal
    plane = np.array([point - 1e4 * along, point + 1e4 * along, point + 1e4 * along - 1e4 * normal,
                      point - 1e4 * along - 1e4 * normal])  # counter-clockwise
    above = physics.solve_shape(Polygon(plane), None)
    below = physics.solve_shape(Polygon(_mirrored(plane), side=-1), None)
    assert above.kind == below.kind == "tip" and above.root_rotation_rad < -0.01
    assert below.root_rotation_rad == pytest.approx(-above.root_rotation_rad, abs=1e-9)
    np.testing.assert_allclose(below.tip_mm, above.tip_mm * [1.0, -1.0], atol=1e-6)
    np.testing.assert_allclose(below.root_shift_mm, above.root_shift_mm * [1.0, -1.0], atol=1e-9)
    np.testing.assert_allclose(below.force_n, above.force_n * [1.0, -1.0], atol=1e-9)


def test_the_wall_met_from_the_whiskers_minus_y_side_pushes_it_back_not_through():
    # pointing down along the second wall (x = 0), leaning into it: that wall is on the
    # whisker's -y side, as in the concave corner with the tip ahead
    heading = math.radians(-110.0)
    pose = np.array([20.0, 100.0, heading])  # the undeflected tip ~6.7 mm inside (x < 0)
    robot = MobileSensor(DEFAULT_SENSOR, outline("wall"), pose, seed=3)
    sample = robot.step(0.0)
    side_wall = np.array([[-1e4, -1e4], [0.0, -1e4], [0.0, 1e4], [-1e4, 1e4]])  # x <= 0, world
    seen = Polygon((side_wall - pose[:2]) @ rotation(-heading).T, side=-1)
    truth = TwinPhysics(DEFAULT_SENSOR).solve_shape(seen, None)
    assert sample.kind == truth.kind == "tip" and truth.root_rotation_rad > 0.01
    assert sample.tip_mm[0] == pytest.approx(0.0, abs=1e-6)  # on the surface, not inside it
    np.testing.assert_allclose(sample.tip_mm, robot.to_world(truth.tip_mm), atol=1e-6)
    assert sample.z_uT * robot.step(0.0).z_uT > 0  # held: the same contact next period


@pytest.mark.parametrize("heading_deg, tip_mm, velocity_mm_s, corner_mm", [
    (-110.0, (15.0, -5.0), (-8.0, 0.0), (0.0, 0.0)),    # along the wall into the corner at the origin
    (-20.0, (153.0, 8.0), (0.0, -8.0), (150.0, 0.0))])  # down the step's face into its foot
def test_a_tip_driven_into_a_concave_corner_is_held_there(heading_deg, tip_mm, velocity_mm_s, corner_mm):
    heading = math.radians(heading_deg)
    base = np.array(tip_mm) - 78.0 * np.array([math.cos(heading), math.sin(heading)])
    robot = MobileSensor(DEFAULT_SENSOR, outline("wall"), [*base, heading], seed=1)
    robot.command(np.array(velocity_mm_s), 0.0)
    pieces = outline("wall").obstacle()
    z = []
    for _ in range(300):  # 1 s at 8 mm/s: the tip reaches the corner after 0.1-0.6 s
        sample = robot.step(1 / 300)
        z.append(sample.z_uT)
        wire = np.array([robot.to_world(point) for point in robot._previous.shape_mm(32)[1:]])
        assert not any(piece.crosses_polyline(wire, 1e-3) for piece in pieces)  # never inside
    assert sample.kind == "tip"
    np.testing.assert_allclose(sample.tip_mm, corner_mm, atol=1e-6)  # held, not slid past
    assert z[0] < -500 and z[-1] > 500  # the base moves on: the whisker is bent the other way


def test_a_sensor_driven_into_the_wall_is_a_collision_not_a_contact():
    heading = math.radians(-110.0)
    robot = MobileSensor(DEFAULT_SENSOR, outline("wall"), np.array([75.0, -5.0, heading]), seed=3)
    assert robot.step(0.0).kind == "collision"  # the base 5 mm inside the wall before the step
    robot = MobileSensor(DEFAULT_SENSOR, outline("wall"), np.array([75.0, 62.0, heading]), seed=3)
    assert robot.step(0.0).kind == "tip"
