"""The robot's commands without a network: the mount between the base frame and the end
effector on both ends of the link, the limits, the box, the options' checks."""

import math
import time

import numpy as np
import pytest
from click.testing import CliRunner
from served_twin import twin_server

from whiskercal.cli import cli
from whiskercal.errors import UsageError
from whiskercal.mount import Mount
from whiskercal.protocol import rosbridge as ros
from whiskercal.robot import RobotTopics, RosbridgeRobot, Safety, WorkspaceError, parse_url
from whiskercal.robot.safety import parse_box


class FakeLink:
    """A link with a fixed end-effector pose that keeps what it would publish."""

    def __init__(self, effector_pose) -> None:
        self.topics = RobotTopics(twist_frame="world")
        self.pose = np.asarray(effector_pose, float)
        self.published: list[dict] = []
        self.ros = type("Ros", (), {"is_connected": True})()

    def latest_pose(self):
        return self.pose, "world", time.monotonic()

    def publish_twist(self, message: dict) -> None:
        self.published.append(message)

    def close(self) -> None:
        pass


MOUNT = Mount(x_mm=40.0, y_mm=-12.0, yaw_deg=25.0)


def test_the_base_frame_is_the_end_effector_composed_with_the_mount():
    link = FakeLink([100.0, 50.0, math.radians(30.0)])
    robot = RosbridgeRobot(link, MOUNT)
    base = robot.pose()
    assert np.allclose(base, MOUNT.base_pose(link.pose))
    assert math.isclose(base[2], math.radians(55.0))


def test_a_base_frame_command_reaches_the_twins_base_through_the_end_effectors_twist():
    effector = np.array([-150.0, -40.0, math.radians(10.0)])
    link = FakeLink(effector)
    velocity, turn = np.array([3.0, -1.5]), 0.2
    RosbridgeRobot(link, MOUNT).command(velocity, turn)
    message = link.published[-1]
    assert message["header"]["frame_id"] == "world"
    # the twist is the end effector's: it differs from the base's by the turn times the lever
    (vx, vy), wz = ros.planar_twist(message)
    assert wz == pytest.approx(turn) and not np.allclose([vx, vy], velocity)
    # the twin carrying its base on the same mount moves the base exactly as commanded
    server = twin_server(pose=MOUNT.base_pose(effector), mount=MOUNT)
    assert np.allclose(server.effector_pose(), effector)
    before = server.mobile.pose()
    server.apply_twist(message)
    server.mobile.step(0.01)
    assert np.allclose(server.mobile.pose() - before, [*(velocity * 0.01), turn * 0.01], atol=1e-12)


def test_speed_and_turn_are_clipped_along_their_direction():
    safety = Safety(speed_mm_s=10.0, turn_rad_s=0.3)
    velocity, turn, cut = safety.clip([30.0, -40.0], -2.0)
    assert np.allclose(velocity, [6.0, -8.0]) and turn == -0.3 and cut
    velocity, turn, cut = safety.clip([3.0, 4.0], 0.1)
    assert np.allclose(velocity, [3.0, 4.0]) and turn == 0.1 and not cut
    with pytest.raises(ValueError):
        safety.clip([math.nan, 0.0], 0.0)


def test_a_command_outside_the_box_sends_a_zero_twist_and_stops():
    link = FakeLink([100.0, 0.0, 0.0])
    robot = RosbridgeRobot(link, safety=Safety(box_mm=(-50.0, 50.0, -50.0, 50.0)))
    with pytest.raises(WorkspaceError, match="left the workspace box"):
        robot.command([5.0, 0.0], 0.0)
    (vx, vy), wz = ros.planar_twist(link.published[-1])
    assert len(link.published) == 1 and vx == vy == wz == 0.0


def test_a_dry_run_publishes_nothing():
    link, lines = FakeLink([0.0, 0.0, 0.0]), []
    robot = RosbridgeRobot(link, dry_run=True, echo=lines.append)
    robot.command([1.0, 0.0], 0.0)
    robot.close()
    assert link.published == [] and len(lines) == 2 and "+1.000" in lines[0]


@pytest.mark.parametrize("text", ["1,2,3", "0,1,a,2", "5,1,0,1", "0,1,inf,2"])
def test_a_bad_box_is_one_usage_error(text):
    with pytest.raises(UsageError, match="--box"):
        Safety(box_mm=parse_box(text))


@pytest.mark.parametrize("url", ["http://localhost:9090", "rosbridge://", "localhost:9090",
                                 "rosbridge://host:port"])
def test_a_robot_url_must_be_rosbridge(url):
    with pytest.raises(UsageError, match="--robot"):
        parse_url(url)


@pytest.mark.parametrize("words, message", [
    (["--dry-run"], "--dry-run drives a robot: give --robot too"),
    # given at its default value is still given (click's parameter source, not a comparison)
    (["--watchdog-ms", "200", "--shape", "octagon"], "--watchdog-ms drives a robot"),
    (["--pose-topic", "/whiskercal/pose", "--shape", "octagon"], "--pose-topic drives a robot"),
    # (--mount is the twin's too: the nominal mount it drives through, with --mount-error)
    ([], "give --shape"),
    (["--robot", "ws2://x"], "--robot must be rosbridge://HOST:PORT"),
    (["--robot", "rosbridge://127.0.0.1:9", "--shape", "octagon"], "a robot follows what is in front of it"),
    (["--robot", "rosbridge://127.0.0.1:9", "--watchdog-ms", "0"], "--watchdog-ms must be"),
    (["--robot", "rosbridge://127.0.0.1:9", "--box", "1,0,0,1"], "--box must be"),
])
def test_bad_robot_options_are_refused_with_one_line(tmp_path, words, message):
    from served_twin import CALIBRATION

    result = CliRunner().invoke(cli, ["contour", "run", "--artifact", str(CALIBRATION), "--out",
                                      str(tmp_path / "r.h5"), *words])
    assert result.exit_code == 2, result.output
    assert message in result.stderr and result.stderr.count("\n") == 1
    assert not (tmp_path / "r.h5").exists()


def test_the_sensor_on_its_serial_port_streams_samples_at_the_boards_rate():
    from whiskercal.robot import SerialSamples

    samples = SerialSamples("sim://robot-serial/sensor")
    try:
        got = [samples.next(0.5) for _ in range(31)]
    finally:
        samples.close()
    stamps = np.array([sample.stamp_s for sample in got])
    assert np.allclose(np.diff(stamps), 1 / 300, rtol=0.05)  # the board's clock, 300 Hz
    assert all(len(sample.field_uT) == 3 for sample in got) and abs(got[0].field_uT[1]) > 100


def test_the_end_effectors_pose_is_read_from_tf_between_the_named_frames_only():
    pose = ros.pose_message([120.0, -30.0, 0.7], "base_link", 0.0)["pose"]
    transform = {"header": {"frame_id": "base_link"}, "child_frame_id": "tool0",
                 "transform": {"translation": pose["position"], "rotation": pose["orientation"]}}
    other = {**transform, "child_frame_id": "camera"}
    assert np.allclose(ros.planar_transform({"transforms": [other, transform]}, "base_link", "tool0"),
                       [120.0, -30.0, 0.7])
    assert ros.planar_transform({"transforms": [other]}, "base_link", "tool0") is None


def test_bad_tf_frames_are_one_line(tmp_path):
    from served_twin import CALIBRATION

    result = CliRunner().invoke(cli, ["contour", "run", "--artifact", str(CALIBRATION), "--out",
                                      str(tmp_path / "r.h5"), "--robot", "rosbridge://127.0.0.1:9",
                                      "--tf-frames", "base_link"])
    assert result.exit_code == 2 and "--tf-frames must be PARENT,CHILD" in result.stderr
