"""Facts both ends of a rosbridge link share: the ROS message types whiskercal speaks, and the
planar view of each (rosbridge v2 carries ROS messages as JSON over a WebSocket).

ROS states lengths in metres, fields in tesla and times as (sec, nanosec); whiskercal works in
mm, µT and s, so every conversion happens here, once. The plane is the world's x-y plane: a pose
is (x mm, y mm, heading rad) with the heading the yaw about z; a twist is a planar velocity
(mm/s) and a turn rate about z (rad/s).
"""

from __future__ import annotations

import math

POSE_TYPE = "geometry_msgs/PoseStamped"
TWIST_TYPE = "geometry_msgs/TwistStamped"
FIELD_TYPE = "sensor_msgs/MagneticField"
TF_TYPE = "tf2_msgs/TFMessage"
TOPIC_TYPES = ("pose", "twist", "field")

MM_PER_M = 1000.0
UT_PER_T = 1e6


def same_type(a: str, b: str) -> bool:
    """ROS 1 (``pkg/Type``) and ROS 2 (``pkg/msg/Type``) names of one message type match."""
    return a.replace("/msg/", "/") == b.replace("/msg/", "/")


def header(frame_id: str, stamp_s: float) -> dict:
    """A std_msgs/Header (ROS 2 field names) at ``stamp_s`` seconds."""
    sec = math.floor(stamp_s)
    return {"frame_id": frame_id, "stamp": {"sec": int(sec), "nanosec": int(round((stamp_s - sec) * 1e9)) % 1_000_000_000}}


def stamp_s(message: dict) -> float:
    """A message's header stamp in seconds (ROS 2 ``sec``/``nanosec`` or ROS 1 ``secs``/``nsecs``)."""
    stamp = message.get("header", {}).get("stamp", {})
    sec = stamp.get("sec", stamp.get("secs", 0))
    nanosec = stamp.get("nanosec", stamp.get("nsecs", 0))
    return float(sec) + 1e-9 * float(nanosec)


def pose_message(pose, frame_id: str, stamp: float) -> dict:
    """geometry_msgs/PoseStamped of a planar pose (x mm, y mm, heading rad)."""
    x_mm, y_mm, heading = (float(v) for v in pose)
    return {"header": header(frame_id, stamp),
            "pose": {"position": {"x": x_mm / MM_PER_M, "y": y_mm / MM_PER_M, "z": 0.0},
                     "orientation": {"x": 0.0, "y": 0.0, "z": math.sin(heading / 2),
                                     "w": math.cos(heading / 2)}}}


def planar_pose(message: dict) -> tuple[float, float, float]:
    """(x mm, y mm, heading rad) of a geometry_msgs/PoseStamped (or a bare Pose): the position
    on the plane and the yaw of its orientation. KeyError/TypeError/ValueError when malformed."""
    pose = message["pose"] if "pose" in message else message
    position, q = pose["position"], pose["orientation"]
    x, y, z, w = (float(q[k]) for k in ("x", "y", "z", "w"))
    yaw = math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
    return float(position["x"]) * MM_PER_M, float(position["y"]) * MM_PER_M, yaw


def planar_transform(message: dict, parent: str, child: str) -> tuple[float, float, float] | None:
    """(x mm, y mm, heading rad) of ``child`` in ``parent`` from a tf2_msgs/TFMessage, or None
    when it holds no transform between exactly those two frames (a chain is not composed)."""
    for transform in message.get("transforms", ()):
        if (transform.get("header", {}).get("frame_id", "").lstrip("/") == parent.lstrip("/")
                and transform.get("child_frame_id", "").lstrip("/") == child.lstrip("/")):
            body = transform["transform"]
            return planar_pose({"position": body["translation"], "orientation": body["rotation"]})
    return None


def twist_message(velocity_mm_s, turn_rad_s: float, frame_id: str, stamp: float) -> dict:
    """geometry_msgs/TwistStamped of a planar velocity (mm/s) and turn rate (rad/s)."""
    vx, vy = (float(v) / MM_PER_M for v in velocity_mm_s)
    return {"header": header(frame_id, stamp),
            "twist": {"linear": {"x": vx, "y": vy, "z": 0.0},
                      "angular": {"x": 0.0, "y": 0.0, "z": float(turn_rad_s)}}}


def planar_twist(message: dict) -> tuple[tuple[float, float], float]:
    """((vx, vy) mm/s, turn rad/s) of a geometry_msgs/TwistStamped (or a bare Twist)."""
    twist = message["twist"] if "twist" in message else message
    linear = twist["linear"]
    return ((float(linear["x"]) * MM_PER_M, float(linear["y"]) * MM_PER_M),
            float(twist["angular"]["z"]))


def field_message(field_uT, frame_id: str, stamp: float) -> dict:
    """sensor_msgs/MagneticField of a 3-axis reading in µT (covariance unknown: zeros)."""
    x, y, z = (float(v) / UT_PER_T for v in field_uT)
    return {"header": header(frame_id, stamp), "magnetic_field": {"x": x, "y": y, "z": z},
            "magnetic_field_covariance": [0.0] * 9}


def field_uT(message: dict) -> tuple[float, float, float]:
    """The (x, y, z) reading of a sensor_msgs/MagneticField, µT."""
    field = message["magnetic_field"]
    return tuple(float(field[k]) * UT_PER_T for k in ("x", "y", "z"))
