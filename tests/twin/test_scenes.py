"""Scenes: the registry, each scene's own contact question, and a world that only asks the protocol."""

import itertools

import numpy as np
import pytest
from test_world_standin import RigidWhiskerPhysics

import whiskercal.rig  # noqa: F401  (registers sim://)
from whiskercal.errors import UsageError
from whiskercal.rig.sensor import SensorClient
from whiskercal.rig.stage import StageClient
from whiskercal.twin.physics.obstacles import Circle, Polygon, regular_polygon
from whiskercal.twin.scenes import (NoFixture, PlaneFixture, RodFixture, ShapeFixture,
                                    fixture_for_scene, scene_names)
from whiskercal.twin.world import create_world

_names = itertools.count()


def test_the_registry_builds_each_named_scene_with_the_url_options():
    assert scene_names() == ("rod", "plane", "none")
    assert fixture_for_scene("rod", rod_radius_mm=3.0) == RodFixture(3.0)
    assert fixture_for_scene("plane") == PlaneFixture()
    assert fixture_for_scene("none") == NoFixture()
    with pytest.raises(UsageError, match="unknown scene 'cube'; use one of rod, plane, none"):
        fixture_for_scene("cube")


def test_a_scene_refuses_a_bad_description_when_made_not_at_the_first_touch():
    with pytest.raises(UsageError, match="rod radius"):
        RodFixture(-1.0)
    with pytest.raises(UsageError, match="mu_static must be at least mu_kinetic"):
        PlaneFixture(mu_static=0.1)


def test_a_rod_keeps_the_side_it_arrived_from_and_a_fresh_copy_forgets_it():
    physics, rod = RigidWhiskerPhysics(), RodFixture()
    free = physics.free()
    touching = rod.solve(physics, np.array([60.0, -5.0]), free)  # arrives from -y
    assert rod._side == -1 and touching.in_contact
    rod.solve(physics, np.array([60.0, 5.0]), touching)  # still in contact: same side
    assert rod._side == -1
    assert rod.fresh()._side == 1 and rod.fresh() == rod


def test_a_plane_remembers_the_last_way_it_slid():
    plane = PlaneFixture()
    tangent = plane.tangent()
    start = np.array([60.0, -20.0])
    plane.moved(start, start - 2.0 * tangent)
    plane.moved(start, start - 3.0 * np.array([np.cos(plane.normal_rad), np.sin(plane.normal_rad)]))
    assert plane._motion_sign == -1  # a push straight in keeps the slide's direction
    assert plane.fresh()._motion_sign == 1


@pytest.mark.parametrize("shape", [Circle(np.array([0.0, 10.0]), 6.0),
                                   regular_polygon(np.array([0.0, 10.0]), 6.0, 8)])
def test_a_shape_is_carried_to_the_tool_and_asked_itself_whether_it_touches(shape):
    fixture, tool = ShapeFixture(shape), np.array([40.0, -8.0])  # centre 2 mm off the whisker
    moved = fixture.obstacle(tool)
    assert type(moved) is type(shape)
    whisker = np.column_stack([np.linspace(0, 78, 200), np.zeros(200)])
    assert fixture.touches(whisker, tool) and not fixture.touches(whisker, np.array([40.0, 20.0]))


class _CountingScene(NoFixture):
    """A scene the world knows only through the protocol: it touches everywhere."""

    def __init__(self):
        self.calls = {"moved": 0, "touches": 0, "solve": 0}

    def fresh(self):
        return self

    def moved(self, from_mm, to_mm):
        self.calls["moved"] += 1

    def touches(self, points_mm, tool_mm):
        self.calls["touches"] += 1
        return True

    def solve(self, physics, tool_mm, previous):
        self.calls["solve"] += 1
        return physics.free()


def test_the_world_asks_any_scene_through_the_protocol_alone():
    scene = _CountingScene()
    world = create_world(f"scene-test-{next(_names)}", physics=RigidWhiskerPhysics(), fixture=scene)
    assert world.scene is scene
    stage, sensor = StageClient(f"sim://{world.name}/stage"), SensorClient(f"sim://{world.name}/sensor")
    stage.home()
    sensor.start()
    stage.move_to(*world.stage_target_for([40.0, 30.0]), 3000)
    stage.wait_idle(60, on_poll=lambda status: sensor.read_available())
    sensor.read(10, timeout_s=1)
    # every step of the path is reported; the free whisker is asked about and solved at each
    assert scene.calls["moved"] == scene.calls["touches"] == scene.calls["solve"] > 100
    assert set(world.truth.kind) == {"free"}


def test_each_world_works_on_its_own_copy_of_a_shared_scene():
    shared = RodFixture()
    first = create_world(f"scene-test-{next(_names)}", physics=RigidWhiskerPhysics(), fixture=shared)
    second = create_world(f"scene-test-{next(_names)}", physics=RigidWhiskerPhysics(), fixture=shared)
    assert first.scene is not second.scene and first.scene is not shared
    assert first.config.fixture is shared and first.scene == shared


def test_a_polygon_seen_from_a_moved_frame_is_the_polygon_built_there():
    # the moving scene's shortcut: a rigid move's normals and offsets follow from the world's
    world = regular_polygon([150.0, -40.0], 90.0, 8, rotation_rad=0.3)
    angle, origin = 0.7, np.array([20.0, 35.0])
    turn = np.array([[np.cos(-angle), -np.sin(-angle)], [np.sin(-angle), np.cos(-angle)]])
    seen = world.seen_from(turn, origin)
    built = Polygon((world.vertices_mm - origin) @ turn.T)
    np.testing.assert_allclose(seen.vertices_mm, built.vertices_mm, atol=1e-12)
    np.testing.assert_allclose(seen.outward_normals, built.outward_normals, atol=1e-12)
    np.testing.assert_allclose(seen.edge_offsets_mm, built.edge_offsets_mm, atol=1e-9)
    wire = np.column_stack([np.linspace(0.0, 200.0, 30), np.zeros(30)])
    assert seen.crosses_polyline(wire) == built.crosses_polyline(wire)
