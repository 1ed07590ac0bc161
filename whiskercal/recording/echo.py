"""``rostopic echo`` / ``ros2 topic echo`` logs: YAML documents separated by ``---``, one message
each.

Read by a line parser for the plain block style those tools print (``key: value`` with nested
keys by indentation; sequences are skipped), not by a YAML loader: a log holds hundreds of
thousands of lines and nothing in it needs more. A message's time is its ``header.stamp``
(``secs``/``nsecs`` in ROS 1, ``sec``/``nanosec`` in ROS 2). The field is a
``sensor_msgs/MagneticField``'s ``magnetic_field.{x,y,z}`` (tesla, as the message defines) or a
custom message's ``magnetic_x``/``magnetic_y``/``magnetic_z`` (taken as µT, the unit such
messages carry; ``--field-unit`` overrides either). A pose is a ``PoseStamped``'s
``pose.position`` / ``pose.orientation``, an ``Odometry``'s ``pose.pose`` or a
``TransformStamped``'s ``transform`` (metres, a quaternion).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from whiskercal.errors import UsageError
from whiskercal.recording.types import FIELD_UNITS, Poses, Recording

STAMPS = (("header.stamp.secs", "header.stamp.nsecs"), ("header.stamp.sec", "header.stamp.nanosec"))
FIELD_KEYS = {"magnetic_field.": ("T", "sensor_msgs/MagneticField messages"),
              "magnetic_": ("uT", "messages with magnetic_x/y/z")}
POSE_KEYS = (("pose.pose.position.", "pose.pose.orientation."),
             ("pose.position.", "pose.orientation."),
             ("transform.translation.", "transform.rotation."))


def documents(path: str | Path) -> list[dict[str, str]]:
    """Each message of the log as a flat dict (``"header.stamp.secs"`` -> its text); a log with
    none is refused."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8-sig")
    except UnicodeDecodeError:
        raise UsageError(f"{path}: not a text log (not UTF-8)") from None
    except OSError as error:
        raise UsageError(f"{path}: cannot read the log: {error.strerror or error}") from None
    found, current, stack = [], {}, []
    for number, line in enumerate(text.splitlines(), 1):
        stripped = line.strip()
        if stripped in ("---", "..."):
            if current:
                found.append(current)
            current, stack = {}, []
            continue
        if not stripped or stripped.startswith(("#", "-")):
            continue
        key, colon, value = stripped.partition(":")
        if not colon:
            raise UsageError(f"{path}: line {number} is not a 'key: value' line of an echo log")
        indent = len(line) - len(line.lstrip())
        while stack and stack[-1][0] >= indent:
            stack.pop()
        stack.append((indent, key.strip()))
        if value.strip():
            current[".".join(name for _, name in stack)] = value.strip()
    if current:
        found.append(current)
    if not found:
        raise UsageError(f"{path}: the log holds no message")
    return found


def _number(document: dict, key: str, path: Path, index: int) -> float:
    try:
        return float(document[key].strip("'\""))
    except KeyError:
        raise UsageError(f"{path}: message {index + 1} has no {key}") from None
    except ValueError:
        raise UsageError(f"{path}: message {index + 1}, {key}: {document[key]!r} is not a "
                         "number") from None


def _times(docs: list[dict], path: Path) -> np.ndarray:
    for seconds, nanoseconds in STAMPS:
        if seconds in docs[0]:
            return np.array([_number(d, seconds, path, k) + 1e-9 * _number(d, nanoseconds, path, k)
                             for k, d in enumerate(docs)])
    raise UsageError(f"{path}: the messages have no header.stamp (keys: "
                     f"{', '.join(sorted(docs[0])[:8])})")


def read_echo(path: str | Path, field_unit: str | None = None) -> Recording:
    """The field messages of an echo log (three axes where it has X, Y and Z, else Y)."""
    path = Path(path)
    docs = documents(path)
    prefix = next((p for p in FIELD_KEYS if f"{p}y" in docs[0]), None)
    if prefix is None:
        raise UsageError(f"{path}: the messages hold no magnetic field (magnetic_field.x/y/z or "
                         f"magnetic_x/y/z; keys: {', '.join(sorted(docs[0])[:8])})")
    default_unit, kind = FIELD_KEYS[prefix]
    unit = field_unit or default_unit
    scale = FIELD_UNITS[unit]
    axes = [a for a in "xyz" if f"{prefix}{a}" in docs[0]]
    values = np.array([[_number(d, f"{prefix}{a}", path, k) for a in axes]
                       for k, d in enumerate(docs)]) * scale
    t_s = _times(docs, path)
    source = f"{path} ({len(docs)} {kind}, field in {unit})"
    if "z" not in axes:
        return Recording(t_s, values[:, axes.index("y")], source)
    x = values[:, 0] if "x" in axes else np.full(len(docs), np.nan)
    return Recording(t_s, np.column_stack([x, values[:, axes.index("y")], values[:, -1]]), source)


def read_echo_poses(path: str | Path) -> Poses:
    """The poses of an echo log of PoseStamped, Odometry or TransformStamped messages."""
    from whiskercal.recording.frames import poses_from_arrays

    path = Path(path)
    docs = documents(path)
    keys = next((k for k in POSE_KEYS if f"{k[0]}x" in docs[0]), None)
    if keys is None:
        raise UsageError(f"{path}: the messages hold no pose (pose.position, pose.pose.position or "
                         f"transform.translation; keys: {', '.join(sorted(docs[0])[:8])})")
    position = np.array([[_number(d, f"{keys[0]}{a}", path, k) for a in "xy"]
                         for k, d in enumerate(docs)])
    quaternion = np.array([[_number(d, f"{keys[1]}{a}", path, k) for a in "xyzw"]
                           for k, d in enumerate(docs)])
    return poses_from_arrays(_times(docs, path), position, quaternion,
                             f"{path} ({len(docs)} poses, metres)")
