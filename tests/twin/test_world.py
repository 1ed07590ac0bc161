"""The simulated world: geometry, shared clock, equilibrium along the path, ground truth."""

import itertools

import numpy as np
import pytest
import serial
from test_world_standin import FIELD_PER_RAD_UT, RigidWhiskerPhysics

import whiskercal.rig  # noqa: F401  (registers sim://)
from whiskercal.errors import UsageError
from whiskercal.rig.sensor import SensorClient
from whiskercal.rig.stage import StageClient
from whiskercal.twin.geometry import RigGeometry
from whiskercal.twin.scenes import fixture_for_scene
from whiskercal.twin.world import create_world, get_world

_names = itertools.count()


def _name():
    return f"world-test-{next(_names)}"


def test_geometry_round_trip_and_rotation():
    geometry = RigGeometry(origin_stage_mm=(40.0, 100.0), angle_rad=np.pi / 2)
    np.testing.assert_allclose(geometry.to_whisker([40.0, 110.0]), [10.0, 0.0], atol=1e-12)
    points = np.array([[20.0, -40.0], [75.0, 10.0]])
    np.testing.assert_allclose(geometry.to_whisker(geometry.to_stage(points)), points, atol=1e-12)


def test_default_geometry_fits_grid_approach_and_plane_in_travel():
    geometry = RigGeometry()
    grid = np.array([[x, y] for x in (20.0, 75.0) for y in (-40.0, 10.0, 30.0)])  # 30: rod approach
    plane_normal = np.array([np.cos(np.pi + np.radians(20)), np.sin(np.pi + np.radians(20))])
    tangent = np.array([-plane_normal[1], plane_normal[0]])
    plane = np.array([[78.0, 0.0] + d * plane_normal + s * tangent for d in (5, 45) for s in (-45, 45)])
    for points in (grid, plane):
        stage = geometry.to_stage(points)
        assert np.all(stage >= 0) and np.all(stage <= 200), stage


def test_ports_with_the_same_name_share_one_world_and_clock():
    name = _name()
    world = create_world(name, physics=RigidWhiskerPhysics())
    stage_port = serial.serial_for_url(f"sim://{name}/stage", timeout=0.5)
    sensor_port = serial.serial_for_url(f"sim://{name}/sensor", timeout=0.5)
    assert stage_port.world is world is sensor_port.world is get_world(name)
    sensor_port.read(10)  # nothing streams: waits out the 0.5 s timeout
    assert stage_port.now_s() == pytest.approx(0.5)
    with pytest.raises(serial.SerialException, match="already exists with other options"):
        serial.serial_for_url(f"sim://{name}/sensor?seed=4")


def test_url_options_build_the_world():
    name = _name()
    port = serial.serial_for_url(f"sim://{name}/stage?scene=plane&seed=3&stock=1&fault=stall@2.5")
    world = port.world
    assert type(world.config.fixture).__name__ == "PlaneFixture"
    assert world.config.seed == 3 and world.config.stock
    assert world.config.stage_faults.stall_at_s == 2.5
    with pytest.raises(serial.SerialException, match="unknown sim:// option"):
        serial.serial_for_url(f"sim://{_name()}/stage?colour=red")
    with pytest.raises(UsageError, match="bad fault"):
        serial.serial_for_url(f"sim://{_name()}/stage?fault=melt@3")
    with pytest.raises(UsageError, match="seed must be an integer"):
        serial.serial_for_url(f"sim://{_name()}/stage?seed=abc")
    with pytest.raises(UsageError, match="speed .* must be a finite number"):
        serial.serial_for_url(f"sim://{_name()}/stage?speed=nan")
    with pytest.raises(serial.SerialException, match="expected sim://NAME/stage"):
        serial.serial_for_url(f"sim://{_name()}/printer")


def _rig(physics="stand-in", **options):
    """A homed rig; ``physics=None`` is the twin's real physics."""
    physics = RigidWhiskerPhysics() if physics == "stand-in" else physics
    world = create_world(_name(), physics=physics, **options)
    stage = StageClient(f"sim://{world.name}/stage")
    sensor = SensorClient(f"sim://{world.name}/sensor")
    stage.home()
    _move(world, stage, sensor, [-30.0, 60.0], feed=3000)  # behind the root, on the +y side
    return world, stage, sensor


def _move(world, stage, sensor, whisker_mm, feed=1500):
    target = world.stage_target_for(whisker_mm)
    stage.move_to(*target, feed)
    stage.wait_idle(60, on_poll=lambda status: sensor.read_available())


def test_rod_push_is_recorded_as_ground_truth():
    world, stage, sensor = _rig()
    sensor.start()
    _move(world, stage, sensor, [60.0, 20.0])  # above the whisker: approach from +y
    _move(world, stage, sensor, [60.0, -10.0], feed=300)
    block = sensor.read(60, timeout_s=1)
    truth = world.truth.arrays()
    recent = {k: v[-60:] for k, v in truth.items()}
    assert set(recent["kind"]) == {"shaft"}
    np.testing.assert_allclose(recent["tool_mm"], [[60.0, -10.0]] * 60, atol=0.02)  # backlash/2 + step
    # the rigid stand-in turns until the whisker is tangent to the rod
    expected_angle = np.arctan2(-10.0, 60.0) - np.arcsin(1.5 / np.hypot(60.0, 10.0))
    np.testing.assert_allclose(recent["root_rotation_rad"], expected_angle, atol=5e-4)
    np.testing.assert_allclose(recent["z_true_uT"], FIELD_PER_RAD_UT * recent["root_rotation_rad"])
    measured_z = block.field_uT[:, 1].mean() - world.static_field_uT[1]
    assert measured_z == pytest.approx(recent["z_true_uT"].mean(), abs=3.0)
    # the approach from +y went free -> shaft, never a failed solve
    assert "free" in set(truth["kind"]) and world.solver_failures == 0


def test_equilibrium_follows_the_path_in_small_steps():
    physics = RigidWhiskerPhysics()
    world, stage, sensor = _rig(physics)
    _move(world, stage, sensor, [60.0, 5.0], feed=3000)
    solves = physics.solves
    sensor.start()
    _move(world, stage, sensor, [60.0, -15.0], feed=3000)  # 20 mm, only the last 16.5 in contact
    contact_steps = physics.solves - solves
    assert contact_steps >= 16.5 / world.config.max_step_mm


@pytest.mark.slow  # the first use of the real physics builds its field table
def test_real_physics_rod_contact_matches_a_direct_solve():
    from whiskercal.twin.physics import mechanics

    world, stage, sensor = _rig(physics=None)
    sensor.start()
    _move(world, stage, sensor, [50.0, 15.0], feed=3000)
    _move(world, stage, sensor, [50.0, -12.0], feed=600)
    sensor.read(10, timeout_s=1)
    truth = world.truth.arrays()
    tool = truth["tool_mm"][-1]
    direct = mechanics.solve_rod(world.sensor.whisker, tool, 1.5)
    assert truth["kind"][-1] == direct.kind != "free"
    np.testing.assert_allclose(truth["tip_mm"][-1], direct.tip_mm, atol=1e-3)
    assert truth["z_true_uT"][-1] < -100  # pushed toward -y reads negative
    assert world.solver_failures == 0


@pytest.mark.slow  # the first use of the real physics builds its field table
def test_a_wire_that_slipped_past_the_rod_meets_it_again_once_it_has_cleared():
    world, stage, sensor = _rig(physics=None)
    reach = world.sensor.whisker.reach_mm
    sensor.start()
    _move(world, stage, sensor, [reach - 1.0, 8.0], feed=3000)
    _move(world, stage, sensor, [reach - 1.0, -20.0], feed=600)  # the tip springs past the rod
    sensor.read_available()
    kinds = list(world.truth.arrays()["kind"])
    assert {"shaft", "tip"} & set(kinds) and kinds[-1] == "free"
    # round the tip, well clear of the wire, and back over it from +y: it meets the rod again
    for point in ([reach + 15.0, -20.0], [reach + 15.0, 8.0], [reach - 1.0, 8.0]):
        _move(world, stage, sensor, point, feed=3000)
    _move(world, stage, sensor, [reach - 1.0, -2.0], feed=600)
    again = world.equilibrium_at(world.now_s)
    assert again.kind in ("shaft", "tip") and not again.slipped_past
    assert world.solver_failures == 0


def test_plane_scene_contacts_at_the_tip():
    world, stage, sensor = _rig(physics=None, fixture=fixture_for_scene("plane"))
    normal = np.array([np.cos(np.pi + np.radians(20)), np.sin(np.pi + np.radians(20))])
    tip = np.array([world.sensor.whisker.reach_mm, 0.0])
    sensor.start()
    _move(world, stage, sensor, tip - 30 * normal, feed=3000)  # beyond the tip, plate clear
    _move(world, stage, sensor, tip - 5 * normal, feed=3000)
    _move(world, stage, sensor, tip + 10 * normal, feed=300)  # 10 mm deep
    sensor.read(10, timeout_s=1)
    truth = world.truth.arrays()
    assert truth["kind"][-1] in ("tip", "tangential")
    assert truth["z_true_uT"][-1] < -100


def test_a_rod_arriving_from_below_pushes_the_whisker_up():
    world, stage, sensor = _rig(physics=None)
    sensor.start()
    _move(world, stage, sensor, [-30.0, -30.0], feed=3000)  # round the root to the -y side
    _move(world, stage, sensor, [50.0, -15.0], feed=3000)
    _move(world, stage, sensor, [50.0, 10.0], feed=600)
    sensor.read(10, timeout_s=1)
    truth = world.truth.arrays()
    assert truth["kind"][-1] == "shaft" and truth["tip_mm"][-1][1] > 5
    assert truth["z_true_uT"][-1] > 100 and world.solver_failures == 0


def test_a_shape_rides_on_the_end_effector():
    from whiskercal.twin.physics.obstacles import Circle
    from whiskercal.twin.scenes import ShapeFixture

    # a 6 mm disc centred 10 mm to the +y side of the end effector
    world, stage, sensor = _rig(fixture=ShapeFixture(Circle(np.array([0.0, 10.0]), 6.0)))
    sensor.start()
    _move(world, stage, sensor, [40.0, 30.0], feed=3000)
    _move(world, stage, sensor, [40.0, -8.0], feed=600)
    sensor.read(10, timeout_s=1)
    truth = world.truth.arrays()
    assert truth["kind"][-1] == "shaft"
    # the stand-in turns the whisker tangent to the disc at (40, 2), radius 6
    expected = np.arctan2(2.0, 40.0) - np.arcsin(6.0 / np.hypot(40.0, 2.0))
    assert truth["root_rotation_rad"][-1] == pytest.approx(expected, abs=5e-4)


def test_sensor_settings_are_reported_back():
    world, stage, sensor = _rig()
    config = sensor.configure(rate_hz=200, gain=5, res=1, osr=1, filt=1)
    assert (config.rate_hz, config.gain, config.res, config.osr, config.filt) == (200, 5, 1, 1, 1)
    sensor.start()
    block = sensor.read(20, timeout_s=1)
    # counts convert with the new sensitivity (GAIN_SEL 5, RES 1: 0.501 µT/LSB on Y)
    np.testing.assert_allclose(block.field_uT[:, 1], block.counts[:, 1] * 0.250 * 2)
    np.testing.assert_allclose(np.diff(block.t_s), 1 / 200, atol=1.01e-6)
