"""The flat plane through the simulated rig: push-ins through the switch to tangential contact
without a failed sample, and stick-slip along a slide, judged on the world's ground truth."""

import itertools
from dataclasses import replace

import numpy as np
import pytest

import whiskercal.rig  # noqa: F401  (registers sim://)
from whiskercal.rig.sensor import SensorClient
from whiskercal.rig.stage import StageClient
from whiskercal.twin.physics import mechanics
from whiskercal.twin.scenes import fixture_for_scene
from whiskercal.twin.world import create_world

_names = itertools.count()


def _plane_rig():
    """A homed rig carrying the plane, the sensor streaming at 300 Hz, the plane clear."""
    world = create_world(f"world-plane-{next(_names)}", fixture=fixture_for_scene("plane"), seed=5)
    stage = StageClient(f"sim://{world.name}/stage")
    sensor = SensorClient(f"sim://{world.name}/sensor")
    stage.home()
    sensor.configure(rate_hz=300)
    sensor.start()
    return world, stage, sensor


def _at(world, depth_mm, along_mm=0.0):
    """Stage target putting the plane `depth_mm` past the undeflected tip, slid `along_mm`."""
    fixture = world.config.fixture
    normal = np.array([np.cos(fixture.normal_rad), np.sin(fixture.normal_rad)])
    tip = np.array([world.sensor.whisker.reach_mm, 0.0])
    return world.stage_target_for(tip + depth_mm * normal + along_mm * fixture.tangent())


def _move(stage, sensor, target, speed_mm_s):
    stage.move_to(*target, 60.0 * speed_mm_s)
    stage.wait_idle(120, on_poll=lambda status: sensor.read_available())


@pytest.mark.parametrize("speed_mm_s", [5.0, 20.0, 40.0])
def test_push_in_through_the_switch_to_tangential_never_fails(speed_mm_s):
    world, stage, sensor = _plane_rig()
    _move(stage, sensor, _at(world, -10.0), 40.0)   # beyond the tip, the plate clear
    _move(stage, sensor, _at(world, 40.0), 40.0)
    start = len(world.truth)
    _move(stage, sensor, _at(world, 50.0), speed_mm_s)
    kinds = world.truth.arrays()["kind"][start:]
    assert world.solver_failures == 0 and "failed" not in set(kinds)
    switch = list(kinds).index("tangential")
    assert set(kinds[:switch]) == {"tip"} and set(kinds[switch:]) == {"tangential"}


def test_a_slide_saws_as_the_mechanics_do():
    world, stage, sensor = _plane_rig()
    _move(stage, sensor, _at(world, -10.0, -5.0), 40.0)
    _move(stage, sensor, _at(world, 40.0, -5.0), 5.0)
    start = len(world.truth)
    _move(stage, sensor, _at(world, 40.0, 5.0), 10.0)
    truth = {k: v[start:] for k, v in world.truth.arrays().items()}
    slid_mm = (truth["tool_mm"] - truth["tool_mm"][0]) @ world.config.fixture.tangent()
    steady = slid_mm > 1.0                              # past the push-in's friction state
    slips = truth["slips"][steady]
    assert set(truth["kind"]) == {"tip"} and slips.sum() > 20
    assert np.all(slips <= 1)                           # one slip per sample at most: it re-sticks
    # the same sawtooth as the mechanics stepped finely along the same slide
    plane = mechanics.plane_for_depth(world.sensor.whisker, 40.0, motion_sign=1)
    previous, events = None, 0
    for i in range(int(8.0 / 0.005)):
        plane = replace(plane, slide_mm=i * 0.005)
        previous = mechanics.solve_plane(world.sensor.whisker, plane, previous)
        events += previous.slips if i * 0.005 > 1.0 else 0
    world_per_mm = slips.sum() / np.ptp(slid_mm[steady])
    assert world_per_mm == pytest.approx(events / 7.0, rel=0.1)
    # z jumps one way at every slip and creeps back while stuck: a sawtooth, not a steady slide
    moving = np.diff(slid_mm[steady]) > 0.01           # not the stop at the end
    z_steps = np.diff(truth["z_true_uT"][steady])[moving]
    slipped = slips[1:][moving] > 0
    jump_sign = np.sign(np.median(z_steps[slipped]))
    assert np.all(np.sign(z_steps[slipped]) == jump_sign)
    assert np.all(np.sign(z_steps[~slipped]) == -jump_sign)
    assert np.min(np.abs(z_steps[slipped])) > 1.5 * np.max(np.abs(z_steps[~slipped]))


def test_the_fixture_passes_its_friction_to_the_plane():
    from whiskercal.twin.scenes import PlaneFixture

    tool = np.array([60.0, -20.0])
    default = PlaneFixture().obstacle(tool, -1)
    custom = PlaneFixture(mu_static=0.4, slip_rebound=0.0).obstacle(tool, -1)
    assert (default.mu_static, default.slip_rebound) == (0.30, 0.9)
    assert (custom.mu_static, custom.mu_kinetic, custom.slip_rebound) == (0.4, 0.22, 0.0)
    assert custom.motion_sign == -1
    # the surface passes through the tool point; sliding is measured along the tangent
    assert custom.normal @ tool == pytest.approx(custom.offset_mm)
    assert custom.slide_mm == pytest.approx(PlaneFixture().tangent() @ tool)


def test_the_end_to_end_benchmark_measures_the_slides():
    from whiskercal.bench.twin_speed import world_study_scene

    result = world_study_scene(depths_mm=(20.0,), travel_mm=3.0, name="bench-plane-test")
    # 3 mm at 10 mm/s plus the acceleration ramps; 300 samples a simulated second
    assert 0.3 <= result["world_slides_simulated_s"] < 0.5
    assert result["world_samples"] == pytest.approx(300 * result["world_total_simulated_s"], rel=0.02)
    assert result["world_solver_failures"] == 0
    assert result["world_slides_realtime_factor"] > 0 and result["world_total_cpu_s"] > 0
