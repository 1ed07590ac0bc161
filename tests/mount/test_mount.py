"""The mount: the sensor's base frame composed onto the end effector's pose."""

import math

import numpy as np
import pytest

from whiskercal.errors import UsageError
from whiskercal.mount import Mount, read_mount, write_mount


def test_a_point_on_the_whisker_reaches_the_world_through_offset_and_yaw():
    mount = Mount(x_mm=10.0, y_mm=0.0, yaw_deg=90.0)
    effector = np.array([100.0, 50.0, math.pi / 2])  # pointing along world +y
    # the base sits 10 mm along the effector's x (world +y), its x axis along world -x
    np.testing.assert_allclose(mount.base_pose(effector), [100.0, 60.0, math.pi], atol=1e-12)
    np.testing.assert_allclose(mount.to_world(effector, [5.0, 0.0]), [95.0, 60.0], atol=1e-12)


def test_the_identity_mount_leaves_poses_alone_for_many_samples():
    poses = np.random.default_rng(0).normal(size=(7, 3))
    np.testing.assert_allclose(Mount().base_pose(poses), poses)


def test_a_mount_file_round_trips(tmp_path):
    path = tmp_path / "mount.toml"
    write_mount(path, Mount(1.5, -2.0, 3.0), comment="from a test")
    assert read_mount(path) == Mount(1.5, -2.0, 3.0)


@pytest.mark.parametrize("text, words", [
    ("x_mm = 1\n", "no [mount] table"),
    ("[mount]\nz_mm = 1\n", "z_mm: unknown key"),
    ("[mount]\nx_mm = true\n", "must be a number"),
    ("[mount]\nx_mm = 5000.0\n", "x_mm: must be"),
    ("[mount]\nyaw_deg = nan\n", "yaw_deg: must be"),
])
def test_a_bad_mount_file_is_one_error_naming_the_key(tmp_path, text, words):
    path = tmp_path / "mount.toml"
    path.write_text(text)
    with pytest.raises(UsageError, match=words.replace("[", r"\[").replace("]", r"\]")):
        read_mount(path)
