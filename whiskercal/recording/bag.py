"""ROS bags through ``rosbags`` (pure Python, no ROS install): rosbag2 folders (MCAP or sqlite3
storage) and ROS 1 ``.bag`` files.

A topic is chosen by name or found by its type: the field from ``sensor_msgs/msg/MagneticField``
(tesla, as the message defines), or any message with ``magnetic_x/y/z`` (µT) when named; poses
from ``geometry_msgs/msg/PoseStamped``, ``nav_msgs/msg/Odometry``,
``geometry_msgs/msg/TransformStamped``, or ``tf2_msgs/msg/TFMessage`` (``/tf``) with the parent
and child frame names. A message's time is its header stamp (the bag's own time stamp where the
header is zero). A bag without a usable topic is refused with the topics and types it holds.
"""

from __future__ import annotations

import contextlib
import json
import struct
from pathlib import Path

import numpy as np

from whiskercal.errors import UsageError
from whiskercal.recording.files import BAG_METADATA, bag_folder, regular_file
from whiskercal.recording.frames import poses_from_arrays
from whiskercal.recording.types import FIELD_UNITS, Poses, Recording

FIELD_TYPE = "sensor_msgs/msg/MagneticField"
POSE_TYPES = ("geometry_msgs/msg/PoseStamped", "nav_msgs/msg/Odometry",
              "geometry_msgs/msg/TransformStamped", "tf2_msgs/msg/TFMessage")


def _bag_errors() -> tuple[type[BaseException], ...]:
    from rosbags.highlevel import AnyReaderError
    from rosbags.rosbag1 import ReaderError as Reader1Error
    from rosbags.rosbag2 import ReaderError as Reader2Error

    return (AnyReaderError, Reader1Error, Reader2Error, struct.error, ValueError, KeyError,
            IndexError, OSError, AssertionError)


def _one_line(error: BaseException) -> str:
    return " ".join(str(error).split())[:300]


@contextlib.contextmanager
def open_bag(path: str | Path):
    """An open ``rosbags`` AnyReader over the bag at ``path``; any failure of the bag itself is
    one UsageError naming it."""
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    path = Path(path)
    target = bag_folder(path) or regular_file(path, "the bag")
    errors = _bag_errors()
    stack = contextlib.ExitStack()
    try:
        if target.suffix != ".bag" and target.is_file():  # an MCAP file alone
            target = stack.enter_context(_mcap_as_bag(target))
        reader = AnyReader([target], default_typestore=get_typestore(Stores.ROS2_HUMBLE))
        reader.open()
    except errors as error:
        short = ("; the MCAP file ends short (its recorder stopped before closing it): "
                 "`mcap recover` rebuilds it") if "end magic" in str(error) else ""
        stack.close()
        raise UsageError(f"{path}: not a readable bag ({_one_line(error)}){short}") from None
    try:
        yield reader
    except errors as error:
        raise UsageError(f"{path}: a message of the bag cannot be read "
                         f"({_one_line(error)})") from None
    finally:
        reader.close()
        stack.close()


@contextlib.contextmanager
def _mcap_as_bag(path: Path):
    """A temporary rosbag2 folder around an MCAP file alone (as Foxglove or the ``mcap`` tool
    write it): a link to the file and the ``metadata.yaml`` its channels describe."""
    import tempfile

    from rosbags.rosbag2.storage_mcap import McapReader

    storage = McapReader(path)
    storage.open()
    try:
        topics = [{"topic_metadata": {"name": c.topic, "type": c.msgtype,
                                      "serialization_format": "cdr", "offered_qos_profiles": []},
                   "message_count": c.msgcount} for c in storage.connections]
        meta = storage.metadata
    finally:
        storage.close()
    with tempfile.TemporaryDirectory(prefix="whiskercal-mcap-") as folder:
        (Path(folder) / path.name).symlink_to(path.resolve())
        info = {"version": 9, "storage_identifier": "mcap", "relative_file_paths": [path.name],
                "duration": {"nanoseconds": meta.duration},
                "starting_time": {"nanoseconds_since_epoch": meta.start_time},
                "message_count": meta.message_count, "topics_with_message_count": topics,
                "compression_format": "", "compression_mode": ""}
        (Path(folder) / BAG_METADATA).write_text(json.dumps(
            {"rosbag2_bagfile_information": info}), encoding="utf-8")  # JSON is YAML
        yield Path(folder)


def topics_text(reader) -> str:
    """``topic (type, n messages)`` for every topic, for messages that list them."""
    seen = {}
    for connection in reader.connections:
        seen.setdefault((connection.topic, connection.msgtype), 0)
        seen[(connection.topic, connection.msgtype)] += connection.msgcount
    return "; ".join(f"{topic} ({msgtype}, {count})" for (topic, msgtype), count in
                     sorted(seen.items())) or "none"


def _connections(reader, path: Path, topic: str | None, types: tuple[str, ...], what: str,
                 option: str) -> list:
    if topic is not None:
        chosen = [c for c in reader.connections if c.topic == topic]
        if not chosen:
            raise UsageError(f"{path}: no topic {topic!r} in the bag; it holds: "
                             f"{topics_text(reader)}")
        return chosen
    found = sorted({c.topic for c in reader.connections if c.msgtype in types})
    if len(found) != 1:
        many = f"{len(found)} topics of" if found else "no topic of"
        raise UsageError(f"{path}: {many} {what} ({', '.join(types)}): name one with {option}; "
                         f"the bag holds: {topics_text(reader)}")
    return [c for c in reader.connections if c.topic == found[0]]


def _stamp_s(message, bag_ns: int) -> float:
    stamp = getattr(getattr(message, "header", None), "stamp", None)
    if stamp is None or (stamp.sec == 0 and stamp.nanosec == 0):
        return bag_ns * 1e-9
    return stamp.sec + 1e-9 * stamp.nanosec


def _field_of(message, path: Path, topic: str) -> tuple[tuple[float, float, float], str]:
    vector = getattr(message, "magnetic_field", None)
    if vector is not None:
        return (vector.x, vector.y, vector.z), "T"
    if all(hasattr(message, f"magnetic_{a}") for a in "xyz"):
        return (message.magnetic_x, message.magnetic_y, message.magnetic_z), "uT"
    raise UsageError(f"{path}: topic {topic!r} holds no magnetic field (magnetic_field or "
                     "magnetic_x/y/z)")


def read_bag(path: str | Path, field_topic: str | None = None,
             field_unit: str | None = None) -> Recording:
    """The field stream of a bag (three axes), from ``field_topic`` or its one MagneticField
    topic."""
    path = Path(path)
    with open_bag(path) as reader:
        connections = _connections(reader, path, field_topic, (FIELD_TYPE,), "magnetic field",
                                   "--field-topic")
        t_s, values, unit = [], [], "T"
        for connection, bag_ns, raw in reader.messages(connections=connections):
            message = reader.deserialize(raw, connection.msgtype)
            field, unit = _field_of(message, path, connection.topic)
            t_s.append(_stamp_s(message, bag_ns))
            values.append(field)
    if not t_s:
        raise UsageError(f"{path}: topic {connections[0].topic!r} holds no message")
    unit = field_unit or unit
    order = np.argsort(np.asarray(t_s), kind="stable")
    return Recording(np.asarray(t_s)[order], np.asarray(values, float)[order] * FIELD_UNITS[unit],
                     f"{path} (topic {connections[0].topic}, {len(t_s)} messages, field in {unit})")


def read_bag_poses(path: str | Path, topic: str | None = None,
                   frames: tuple[str, str] | None = None) -> Poses:
    """Poses from ``topic`` (or the bag's one pose topic; with ``frames``, its one transform
    tree); a TFMessage topic needs ``frames`` (parent, child)."""
    path = Path(path)
    with open_bag(path) as reader:
        # found by type: a transform tree when frames are named, else a pose topic
        types = POSE_TYPES[3:] if frames else POSE_TYPES[:3]
        connections = _connections(reader, path, topic, types, "poses", "--poses TOPIC")
        rows = []
        for connection, bag_ns, raw in reader.messages(connections=connections):
            message = reader.deserialize(raw, connection.msgtype)
            rows += _poses_of(message, bag_ns, frames, path, connection.topic)
    name = connections[0].topic
    if not rows:
        what = f" from {frames[0]} to {frames[1]}" if frames else ""
        raise UsageError(f"{path}: topic {name!r} holds no pose{what}")
    rows.sort(key=lambda row: row[0])
    table = np.asarray(rows, float)
    return poses_from_arrays(table[:, 0], table[:, 1:3], table[:, 3:7],
                             f"{path} (topic {name}, {len(rows)} poses)")


def _poses_of(message, bag_ns: int, frames, path: Path, topic: str) -> list[tuple]:
    """(t s, x m, y m, qx, qy, qz, qw) rows of one message."""
    if hasattr(message, "transforms"):  # TFMessage
        if frames is None:
            raise UsageError(f"{path}: topic {topic!r} is a transform tree: name the frames with "
                             "--pose-frames PARENT,CHILD")
        return [row for t in message.transforms
                if (t.header.frame_id.lstrip("/"), t.child_frame_id.lstrip("/")) == frames
                for row in _poses_of(t, bag_ns, None, path, topic)]
    if hasattr(message, "transform"):  # TransformStamped
        position, rotation = message.transform.translation, message.transform.rotation
    else:
        pose = message.pose.pose if hasattr(message.pose, "pose") else message.pose  # Odometry
        position, rotation = pose.position, pose.orientation
    return [(_stamp_s(message, bag_ns), position.x, position.y, rotation.x, rotation.y,
             rotation.z, rotation.w)]
