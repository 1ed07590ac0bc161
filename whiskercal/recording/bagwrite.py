"""Writing a ROS 2 bag (MCAP storage, ROS 2 Humble message types) as a robot's recorder would:
the field stream (``sensor_msgs/msg/MagneticField``, tesla), poses
(``geometry_msgs/msg/PoseStamped``, metres) and points (``geometry_msgs/msg/PointStamped``,
metres). Foxglove and ``ros2 bag`` open it; :func:`whiskercal.recording.read_recording` reads it.

The bag is a folder (``metadata.yaml`` and ``NAME.mcap``), written under a temporary name beside
its destination and renamed onto it when complete: a crash leaves no half-written bag there.
"""

from __future__ import annotations

import contextlib
import heapq
import os
import shutil
import tempfile
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from whiskercal.errors import UsageError
from whiskercal.recording.frames import M_TO_MM, quaternion_of

FIELD_TOPIC = "/whisker/field"
POSE_TOPIC = "/whisker/base_pose"
CONTACT_TOPIC = "/whisker/contact"
WORLD_FRAME = "world"
SENSOR_FRAME = "whisker_sensor"
UT_TO_T = 1e-6


@dataclass
class Series:
    """One topic's samples: times (n,) s and values (n, k) in whiskercal's units (µT for a
    field, mm and rad for a pose (x, y, heading), mm for a point (x, y)); NaN rows are left
    out."""

    topic: str
    kind: str  # "field", "pose" or "point"
    t_s: np.ndarray
    values: np.ndarray
    frame_id: str = WORLD_FRAME


def _messages(typestore, series: Series):
    """(stamp ns, message) for every finite row."""
    types = typestore.types
    keep = np.all(np.isfinite(series.values), axis=1) & np.isfinite(series.t_s)
    for t, row in zip(series.t_s[keep], series.values[keep]):
        ns = int(round(float(t) * 1e9))
        header = types["std_msgs/msg/Header"](types["builtin_interfaces/msg/Time"](
            ns // 1_000_000_000, ns % 1_000_000_000), series.frame_id)
        yield ns, _message(types, series.kind, header, row)


def _tagged(typestore, series: Series, connection):
    """(stamp ns, connection, message type, message) for every finite row of ``series``."""
    for ns, message in _messages(typestore, series):
        yield ns, connection, MESSAGE_TYPES[series.kind], message


def _message(types, kind: str, header, row: np.ndarray):
    point = types["geometry_msgs/msg/Point"]
    if kind == "field":
        tesla = row * UT_TO_T
        return types["sensor_msgs/msg/MagneticField"](
            header, types["geometry_msgs/msg/Vector3"](*map(float, tesla)), np.zeros(9))
    if kind == "pose":
        q = types["geometry_msgs/msg/Quaternion"](*map(float, quaternion_of(row[2])))
        pose = types["geometry_msgs/msg/Pose"](point(row[0] / M_TO_MM, row[1] / M_TO_MM, 0.0), q)
        return types["geometry_msgs/msg/PoseStamped"](header, pose)
    return types["geometry_msgs/msg/PointStamped"](header, point(row[0] / M_TO_MM,
                                                                 row[1] / M_TO_MM, 0.0))


MESSAGE_TYPES = {"field": "sensor_msgs/msg/MagneticField", "pose": "geometry_msgs/msg/PoseStamped",
                 "point": "geometry_msgs/msg/PointStamped"}


def write_bag(path: str | Path, series: list[Series], replace: bool = False) -> Path:
    """Write ``series`` as a rosbag2 folder at ``path`` (refused where ``path`` exists, unless
    ``replace``: then the old bag is removed once the new one is in place)."""
    with staged_bag(path, series, replace):
        pass
    return Path(path)


@contextlib.contextmanager
def staged_bag(path: str | Path, series: list[Series], replace: bool = False) -> Iterator[Path]:
    """Write the bag of ``series`` under a temporary name beside ``path`` and yield it; when the
    block ends without an exception the bag is renamed onto ``path``, else removed.

    A command writing a bag with other files (``atomic.atomic_set``) opens both, so a failure
    while writing any of them leaves the old bag and the old files whole.
    """
    path = Path(path)
    if path.exists() and not replace:
        raise UsageError(f"{path} exists: choose another bag name (a bag is never overwritten)")
    try:
        scratch = Path(tempfile.mkdtemp(prefix=f".{path.name}.", suffix=".partial",
                                        dir=path.parent))
    except OSError as error:
        raise UsageError(f"cannot write the bag {path}: {error.strerror or error}") from None
    try:
        _write_rosbag(scratch / path.name, series)
        yield scratch / path.name
        _move_into_place(scratch, path)
    except OSError as error:
        raise UsageError(f"cannot write the bag {path}: {error.strerror or error}") from None
    finally:
        shutil.rmtree(scratch, ignore_errors=True)


def _write_rosbag(path: Path, series: list[Series]) -> None:
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    typestore = get_typestore(Stores.ROS2_HUMBLE)
    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        streams = []
        for one in series:  # in time order across topics, as a recorder receives them
            connection = writer.add_connection(one.topic, MESSAGE_TYPES[one.kind],
                                               typestore=typestore)
            streams.append(_tagged(typestore, one, connection))
        for ns, connection, msgtype, message in heapq.merge(*streams, key=lambda m: m[0]):
            writer.write(connection, ns, typestore.serialize_cdr(message, msgtype))


def _move_into_place(scratch: Path, path: Path) -> None:
    """Rename the finished bag (``scratch/NAME``) onto ``path``; an old bag there goes aside
    into ``scratch`` first and is removed with it."""
    if path.exists():
        os.replace(path, scratch / f"{path.name}.old")
    os.replace(scratch / path.name, path)
