"""The twin's sensor on an end effector at a true mount: the effector's pose and twists are the
true mount's, and a loop driving through a nominal mount moves the sensor the nominal way only
where nominal and true agree."""

import numpy as np

from whiskercal.contour.mounted import MountedTwin
from whiskercal.mount import Mount
from whiskercal.twin.carried import CarriedSensor
from whiskercal.twin.mobile import MobileSensor
from whiskercal.twin.outlines import outline
from whiskercal.twin.params import DEFAULT_SENSOR

START = np.array([-250.0, 10.0, 0.3])


def _mobile():
    return MobileSensor(DEFAULT_SENSOR, outline("cylinder"), START, seed=0)


def test_the_effector_carries_the_base_at_the_true_mount():
    mount = Mount(3.0, 31.5, 88.0)
    carried = CarriedSensor(_mobile(), (mount.x_mm, mount.y_mm, mount.yaw_deg))
    assert np.allclose(mount.base_pose(carried.effector_pose()), START)
    before = carried.effector_pose()
    carried.command_effector(np.array([4.0, -2.0]), 0.2)
    for _ in range(30):
        carried.step(0.01)
    after = carried.effector_pose()
    # the effector went where its twist says, the base with it (the base's velocity is held
    # while the lever turns: 0.06 rad on a 32 mm lever is off by about 0.06 mm)
    assert np.allclose(after[:2] - before[:2], [1.2, -0.6], atol=0.1)
    assert np.isclose(after[2] - before[2], 0.06)
    assert np.allclose(mount.base_pose(after), carried.mobile.pose())


def test_a_nominal_mount_that_is_the_true_one_drives_the_base_as_commanded():
    twin = MountedTwin(_mobile(), Mount(0.0, 30.0, 90.0))
    assert np.allclose(twin.pose(), START)
    twin.command(np.array([5.0, 0.0]), 0.1)
    for _ in range(20):
        twin.step(0.01)
    moved = twin.pose()
    assert np.allclose(moved, twin.carried.mobile.pose())
    assert np.allclose(moved[:2] - START[:2], [1.0, 0.0], atol=0.02)


def test_a_mount_error_moves_the_true_base_off_the_one_the_loop_believes():
    twin = MountedTwin.placed(_mobile(), Mount(0.0, 30.0, 90.0), (1.5, -1.0, 2.0))
    assert twin.truth()["true"] == {"x_mm": 1.5, "y_mm": 29.0, "yaw_deg": 92.0}
    believed, true = twin.pose(), twin.carried.mobile.pose()
    assert np.isclose(true[2] - believed[2], np.radians(2.0))
    assert np.isclose(np.hypot(*(true[:2] - believed[:2])), np.hypot(1.5, 1.0))
