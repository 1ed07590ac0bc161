"""The rosbridge link to a robot (through roslibpy) and the follower's ``Robot`` on it.

:class:`RosbridgeLink` connects, subscribes to the end effector's pose (geometry_msgs/PoseStamped)
and, when the sensor streams over ROS, to its sensor_msgs/MagneticField topic, and advertises the
twist topic (geometry_msgs/TwistStamped). Messages arrive on roslibpy's thread: the latest pose
is kept, field samples queue in order. A closed connection is noticed (``lost``) and never
reconnected: a run on a robot that went away ends.

:class:`RosbridgeRobot` answers the follower: ``pose()`` is the sensor's base frame (the end
effector's pose composed with the mount), ``command(velocity, turn)`` the base frame's motion
turned into the end effector's twist (its velocity differs from the base's by the turn times the
lever between them), clipped to the limits, and published, or only printed with ``dry_run``.
Leaving it (``with``, or :meth:`close`) sends a zero twist first, however the run ended.
"""

from __future__ import annotations

import queue
import threading
import time
from dataclasses import dataclass
from urllib.parse import urlparse

import numpy as np

from whiskercal.errors import DeviceError, UsageError
from whiskercal.mount import Mount
from whiskercal.protocol import rosbridge as ros
from whiskercal.robot.errors import ConnectionLostError
from whiskercal.robot.safety import Safety
from whiskercal.robot.samples import FieldSample


@dataclass(frozen=True)
class RobotTopics:
    """The topics of a robot run: the end effector's pose (a PoseStamped topic, or with
    ``tf_frames`` a tf2_msgs/TFMessage topic holding the transform parent -> child), the twist
    it obeys and the frame stamped on it (None: the pose messages' own frame), the field (None:
    the sensor is on a serial port)."""

    pose: str = "/whiskercal/pose"
    twist: str = "/whiskercal/twist"
    twist_frame: str | None = None
    field: str | None = "/whiskercal/field"
    tf_frames: tuple[str, str] | None = None  # (parent, child): the pose topic is TF (/tf)


def parse_url(url: str) -> tuple[str, int]:
    """(host, port) of ``rosbridge://HOST:PORT`` (ws:// is taken too)."""
    parsed = urlparse(url)
    if parsed.scheme not in ("rosbridge", "ws") or not parsed.hostname:
        raise UsageError(f"--robot must be rosbridge://HOST:PORT, not {url!r}")
    try:
        port = parsed.port or 9090
    except ValueError:
        raise UsageError(f"--robot {url!r} has a port that is not a number") from None
    return parsed.hostname, port


class RosbridgeLink:
    """One rosbridge connection and the run's topics (see the module's docstring)."""

    def __init__(self, url: str, topics: RobotTopics, connect_timeout_s: float = 10.0) -> None:
        import roslibpy

        self.url, self.topics = url, topics
        host, port = parse_url(url)
        self.samples: queue.Queue[FieldSample] = queue.Queue()
        self.lost = threading.Event()
        self._pose: tuple | None = None  # (pose, frame_id, received at, monotonic s)
        self.poses_received = 0
        self.ros = roslibpy.Ros(host, port)
        try:
            self.ros.run(timeout=connect_timeout_s)
        except Exception as error:  # roslibpy's timeout, or a refused connection
            self._give_up()
            raise DeviceError(f"no rosbridge server answered at {url} within "
                              f"{connect_timeout_s:g} s ({type(error).__name__})") from None
        self.ros.on("close", lambda *_: self.lost.set())
        self._subscriptions = [self._subscribe(topics.pose, ros.POSE_TYPE, self._on_pose)
                               if topics.tf_frames is None else
                               self._subscribe(topics.pose, ros.TF_TYPE, self._on_tf)]
        if topics.field is not None:
            self._subscriptions.append(self._subscribe(topics.field, ros.FIELD_TYPE, self._on_field))
        self.twist = roslibpy.Topic(self.ros, topics.twist, ros.TWIST_TYPE)
        self.twist.advertise()

    def _subscribe(self, name: str, kind: str, callback):
        import roslibpy

        topic = roslibpy.Topic(self.ros, name, kind, queue_length=0)
        topic.subscribe(callback)
        return topic

    def _on_pose(self, message: dict) -> None:
        try:
            pose = np.array(ros.planar_pose(message))
        except (KeyError, TypeError, ValueError):
            return  # a malformed pose is no pose: the watchdog sees the silence
        self._pose = (pose, message.get("header", {}).get("frame_id", ""), time.monotonic())
        self.poses_received += 1

    def _on_tf(self, message: dict) -> None:
        parent, child = self.topics.tf_frames
        try:
            pose = ros.planar_transform(message, parent, child)
        except (KeyError, TypeError, ValueError):
            return
        if pose is not None:  # /tf carries every frame's transforms: only ours is a pose
            self._pose = (np.array(pose), parent, time.monotonic())
            self.poses_received += 1

    def _on_field(self, message: dict) -> None:
        try:
            field = ros.field_uT(message)
        except (KeyError, TypeError, ValueError):
            return
        stamp = ros.stamp_s(message)
        self.samples.put(FieldSample(field, stamp, time.monotonic(), time.time() - stamp))

    def latest_pose(self) -> tuple[np.ndarray, str, float] | None:
        """The newest end-effector pose (x mm, y mm, heading rad), its frame, and when it came
        (``time.monotonic`` s); None before the first."""
        return self._pose

    def check(self) -> None:
        """ConnectionLostError once the connection has closed."""
        if self.lost.is_set() or not self.ros.is_connected:
            raise ConnectionLostError(f"the rosbridge connection to {self.url} was lost: stopped")

    def publish_twist(self, message: dict) -> None:
        """Publish one TwistStamped."""
        import roslibpy

        self.twist.publish(roslibpy.Message(message))

    def close(self) -> None:
        """Unsubscribe, unadvertise and close (what still can be, on a lost link)."""
        if self.ros.is_connected:
            try:
                for topic in self._subscriptions:
                    topic.unsubscribe()
                self.twist.unadvertise()
                self.ros.close(timeout=2.0)
            except Exception:  # closing a link that is going away: nothing more to do
                pass
        self._give_up()

    def _give_up(self) -> None:
        """No reconnection, ever: roslibpy's factory would retry a closed link."""
        try:
            self.ros.factory.stopTrying()
        except AttributeError:
            pass


class RosbridgeRobot:
    """The follower's ``Robot`` over a :class:`RosbridgeLink` (see the module's docstring).

    ``echo`` is called with one line per command in ``dry_run`` (and is how a dry run shows
    what it would send); ``stamp`` gives the commands' stamps (s; default the wall clock).
    """

    def __init__(self, link: RosbridgeLink, mount: Mount = Mount(), safety: Safety = Safety(),
                 dry_run: bool = False, echo=print) -> None:
        self.link, self.mount, self.safety = link, mount, safety
        self.dry_run, self.echo = dry_run, echo
        self.sent, self.clipped, self.zeros = 0, 0, 0
        self._last_command = (np.zeros(2), 0.0)

    def effector_pose(self) -> np.ndarray:
        """The newest end-effector pose; ConnectionLostError or RuntimeError without one."""
        latest = self.link.latest_pose()
        if latest is None:
            raise RuntimeError("no pose yet")  # the run waits for the first before it starts
        return latest[0]

    def pose(self) -> np.ndarray:
        """(x mm, y mm, heading rad) of the sensor's base frame in the pose topic's frame."""
        return self.mount.base_pose(self.effector_pose())

    def command(self, velocity_mm_s, turn_rad_s: float) -> None:
        """Send the base frame's velocity (mm/s) and turn rate (rad/s) as the end effector's
        twist, within the limits; outside the box a zero twist goes and WorkspaceError rises."""
        effector = self.effector_pose()
        try:
            self.safety.check_inside(effector)
        except Exception:
            self.stop()
            raise
        turn = float(turn_rad_s)
        velocity = self.mount.effector_velocity(effector, velocity_mm_s, turn)
        velocity, turn, cut = self.safety.clip(velocity, turn)
        self.clipped += cut
        self._send(velocity, turn)

    def stop(self) -> None:
        """A zero twist (printed instead in a dry run)."""
        self.zeros += 1
        self._send(np.zeros(2), 0.0)

    def _send(self, velocity: np.ndarray, turn: float) -> None:
        latest = self.link.latest_pose()
        frame = self.link.topics.twist_frame
        if frame is None:
            frame = latest[1] if latest is not None else ""
        message = ros.twist_message(velocity, turn, frame, time.time())
        self._last_command = (velocity, turn)
        if self.dry_run:
            self.echo(f"twist {self.link.topics.twist} [{frame}] vx {velocity[0]:+.3f} "
                      f"vy {velocity[1]:+.3f} mm/s  wz {turn:+.4f} rad/s (dry run: not sent)")
            return
        if self.link.ros.is_connected:
            self.link.publish_twist(message)
            self.sent += 1

    @property
    def last_command(self) -> tuple[np.ndarray, float]:
        """The end effector's last twist ((vx, vy) mm/s, turn rad/s), as sent or printed."""
        return self._last_command

    def close(self) -> None:
        """A zero twist, then the link closed; safe to call twice."""
        try:
            self.stop()
        finally:
            time.sleep(0.05)  # let the zero twist leave before the socket closes
            self.link.close()

    def __enter__(self) -> "RosbridgeRobot":
        return self

    def __exit__(self, *exc_info) -> None:
        self.close()

