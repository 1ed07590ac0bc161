"""ROS bags in: a bag written with rosbags' own writer as a robot's recorder would (MCAP and
sqlite3 storage, and a ROS 1 bag), topics found by type or named, /tf with frame names, and the
bags and topics that are refused in one line."""

import numpy as np
import pytest
from rosbags.rosbag1 import Writer as Writer1
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore

from whiskercal.errors import UsageError
from whiskercal.recording import RecordingOptions, read_poses, read_recording
from whiskercal.recording.bagwrite import Series, write_bag

STORE = get_typestore(Stores.ROS2_HUMBLE)
T = STORE.types
N = 40
RATE_HZ = 250.0
START_NS = 1_722_857_963_000_000_000


def _header(ns: int, frame: str):
    return T["std_msgs/msg/Header"](T["builtin_interfaces/msg/Time"](ns // 10**9, ns % 10**9), frame)


def _field(k: int, ns: int, tesla_per_unit: float = 1e-6):
    vector = T["geometry_msgs/msg/Vector3"](-9000.0 * tesla_per_unit,
                                            (5100.0 - 10.0 * k) * tesla_per_unit,
                                            16000.0 * tesla_per_unit)
    return T["sensor_msgs/msg/MagneticField"](_header(ns, "mag"), vector, np.zeros(9))


def _pose(k: int, ns: int):
    heading = 0.02 * k
    pose = T["geometry_msgs/msg/Pose"](T["geometry_msgs/msg/Point"](0.001 * k, 0.5, 0.0),
                                       T["geometry_msgs/msg/Quaternion"](0.0, 0.0, np.sin(heading / 2),
                                                                        np.cos(heading / 2)))
    return T["geometry_msgs/msg/PoseStamped"](_header(ns, "world"), pose)


def _tf(k: int, ns: int):
    def transform(parent, child, x):
        return T["geometry_msgs/msg/TransformStamped"](_header(ns, parent), child, T[
            "geometry_msgs/msg/Transform"](T["geometry_msgs/msg/Vector3"](x, 0.0, 0.0),
                                          T["geometry_msgs/msg/Quaternion"](0.0, 0.0, 0.0, 1.0)))
    return T["tf2_msgs/msg/TFMessage"]([transform("world", "base", 1.0 + 0.001 * k),
                                        transform("base", "ee", 0.2)])


def _robot_bag(path, storage=StoragePlugin.MCAP, extra_field=False, field_scale=1e-6):
    """Field at 250 Hz, a pose and a transform tree at every fifth sample."""
    with Writer(path, version=9, storage_plugin=storage) as writer:
        topics = [("/imu/mag", "sensor_msgs/msg/MagneticField")] + \
            ([("/imu/mag2", "sensor_msgs/msg/MagneticField")] if extra_field else []) + \
            [("/robot/pose", "geometry_msgs/msg/PoseStamped"), ("/tf", "tf2_msgs/msg/TFMessage")]
        connections = {topic: writer.add_connection(topic, kind, typestore=STORE)
                       for topic, kind in topics}
        for k in range(N):
            ns = START_NS + int(k * 1e9 / RATE_HZ)
            for topic in [t for t, _ in topics if "mag" in t]:
                writer.write(connections[topic], ns, STORE.serialize_cdr(
                    _field(k, ns, field_scale), "sensor_msgs/msg/MagneticField"))
            if k % 5 == 0:
                writer.write(connections["/robot/pose"], ns, STORE.serialize_cdr(
                    _pose(k, ns), "geometry_msgs/msg/PoseStamped"))
                writer.write(connections["/tf"], ns, STORE.serialize_cdr(_tf(k, ns),
                                                                         "tf2_msgs/msg/TFMessage"))
    return path


@pytest.mark.parametrize("storage", [StoragePlugin.MCAP, StoragePlugin.SQLITE3])
def test_a_robots_rosbag2_reads_back_field_poses_and_tf(tmp_path, storage):
    bag = _robot_bag(tmp_path / "run", storage)
    recording = read_recording(bag)
    assert recording.axes == 3 and len(recording) == N
    np.testing.assert_allclose(recording.field_uT[3], [-9000.0, 5070.0, 16000.0], rtol=1e-12)
    # epoch seconds as float64 resolve 0.24 µs, far below a sample's 4 ms
    np.testing.assert_allclose(np.diff(recording.t_s), 1 / RATE_HZ, atol=1e-6)
    poses = read_poses("auto", bag)  # the one PoseStamped topic (the /tf needs frames)
    assert len(poses) == N // 5
    np.testing.assert_allclose(poses.pose[1], [5.0, 500.0, 0.1], atol=1e-9)  # m -> mm
    tree = read_poses("/tf", bag, frames=("world", "base"))
    np.testing.assert_allclose(tree.pose[:, 0], 1000.0 + 5.0 * np.arange(N // 5), atol=1e-9)
    with pytest.raises(UsageError, match="transform tree: name the frames with --pose-frames"):
        read_poses("/tf", bag)
    with pytest.raises(UsageError, match="holds no pose from world to ee"):
        read_poses("/tf", bag, frames=("world", "ee"))


def test_a_ros1_bag_reads_the_same(tmp_path):
    store = get_typestore(Stores.ROS1_NOETIC)
    path = tmp_path / "run.bag"
    with Writer1(path) as writer:
        connection = writer.add_connection("/mag", "sensor_msgs/msg/MagneticField", typestore=store)
        for k in range(N):
            ns = START_NS + int(k * 1e9 / RATE_HZ)
            message = store.types["sensor_msgs/msg/MagneticField"](
                store.types["std_msgs/msg/Header"](k, store.types["builtin_interfaces/msg/Time"](
                    ns // 10**9, ns % 10**9), "mag"),
                store.types["geometry_msgs/msg/Vector3"](0.0, 5.1e-3, 1.6e-2), np.zeros(9))
            writer.write(connection, ns, store.serialize_ros1(message,
                                                              "sensor_msgs/msg/MagneticField"))
    recording = read_recording(path)
    np.testing.assert_allclose(recording.field_uT[0], [0.0, 5100.0, 16000.0])
    assert recording.t_s[0] == pytest.approx(START_NS * 1e-9)


def test_whiskercals_own_bag_round_trips(tmp_path):
    t = np.arange(30) / 300.0
    field = np.column_stack([np.full(30, -9000.0), 5100.0 - 10.0 * np.arange(30), np.full(30, 16000.0)])
    pose = np.column_stack([8.0 * t, np.zeros(30), np.linspace(-3.0, 3.0, 30)])
    bag = write_bag(tmp_path / "out", [Series("/f", "field", t, field, "sensor"),
                                       Series("/p", "pose", t, pose)])
    recording, poses = read_recording(bag), read_poses("/p", bag)
    np.testing.assert_allclose(recording.field_uT, field, rtol=1e-12)
    np.testing.assert_allclose(recording.t_s, t, atol=1e-9)
    np.testing.assert_allclose(poses.pose, pose, atol=1e-9)
    alone = tmp_path / "copied" / "alone.mcap"  # the MCAP file without its bag's metadata
    alone.parent.mkdir()
    alone.write_bytes((bag / "out.mcap").read_bytes())
    np.testing.assert_array_equal(read_recording(alone).field_uT, recording.field_uT)
    np.testing.assert_array_equal(read_poses("auto", alone).pose, poses.pose)
    with pytest.raises(UsageError, match="exists: choose another bag name"):
        write_bag(bag, [Series("/f", "field", t, field)])
    assert sorted(p.name for p in tmp_path.iterdir()) == ["copied", "out"]  # no partial bag left


def test_bags_and_topics_that_cannot_be_used_get_one_line(tmp_path):
    bag = _robot_bag(tmp_path / "two", extra_field=True)
    with pytest.raises(UsageError, match=r"2 topics of magnetic field.*--field-topic.*"
                                         r"/robot/pose \(geometry_msgs/msg/PoseStamped, 8\)"):
        read_recording(bag)
    assert len(read_recording(bag, RecordingOptions(field_topic="/imu/mag2"))) == N
    with pytest.raises(UsageError, match="no topic '/nope' in the bag; it holds: /imu/mag "):
        read_recording(bag, RecordingOptions(field_topic="/nope"))
    with pytest.raises(UsageError, match="holds no magnetic field"):
        read_recording(bag, RecordingOptions(field_topic="/robot/pose"))
    wrong = _robot_bag(tmp_path / "wrong", field_scale=1.0)  # µT numbers in a tesla message
    with pytest.raises(UsageError, match="implausibly large.*µT written as tesla"):
        read_recording(wrong)
    storage = wrong / "wrong.mcap"
    storage.write_bytes(storage.read_bytes()[:-100])  # a recorder killed before closing its file
    with pytest.raises(UsageError, match="ends short.*mcap recover"):
        read_recording(wrong)
    (bag / "metadata.yaml").write_text("rosbag2_bagfile_information: [not, a, mapping\n")
    with pytest.raises(UsageError, match="not a readable bag") as raised:
        read_recording(bag)
    assert "\n" not in str(raised.value)
