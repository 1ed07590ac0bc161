"""The moving-base twin solves against the outline's edges near the sensor only: the same
contact, bit for bit, as against the whole outline."""

import math

import numpy as np

from whiskercal.contour.run import start_pose
from whiskercal.twin.mobile import MobileSensor
from whiskercal.twin.outlines import outline
from whiskercal.twin.params import DEFAULT_SENSOR


def _pressed_and_slid(robot, heading_rad):
    """Press 10 mm into the object along the whisker's lean, then slide along it (mm/s, s)."""
    lean = heading_rad + math.radians(20.0)
    inward = np.array([math.cos(lean), math.sin(lean)])
    along = np.array([inward[1], -inward[0]])
    zs, kinds = [], []
    for velocity, seconds in ((5.0 * inward, 3.0), (6.0 * along, 1.5)):
        robot.command(velocity, 0.02)
        for _ in range(int(seconds * 300)):
            sample = robot.step(1.0 / 300.0)
            zs.append(sample.z_uT)
            kinds.append(sample.kind)
    return np.array(zs), kinds


def test_the_near_edges_give_the_same_contact_as_the_whole_outline():
    shape = outline("octagon")
    pose = start_pose(shape, 20.0, 5.0, np.random.default_rng(4), DEFAULT_SENSOR.whisker.reach_mm)
    culled = MobileSensor(DEFAULT_SENSOR, shape, pose, seed=2)
    whole = MobileSensor(DEFAULT_SENSOR, shape, pose, seed=2)
    whole._keep_mm = math.inf  # every edge is near: the whole outline every time
    z_culled, kinds = _pressed_and_slid(culled, pose[2])
    z_whole, _ = _pressed_and_slid(whole, pose[2])
    assert kinds.count("tip") > 600  # it did press on the object
    np.testing.assert_array_equal(z_culled, z_whole)
    first, part = culled._near_part(culled.pose()[:2])
    assert len(part.vertices_mm) < 0.5 * len(shape.obstacle().vertices_mm)  # and left edges out
