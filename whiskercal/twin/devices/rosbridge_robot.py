"""The twin's mobile base behind a rosbridge v2 WebSocket (``sim serve --robot``).

Any rosbridge client (roslibpy, Foxglove's rosbridge connection, ``contour run --robot``) sees
what a ROS robot carrying the sensor would show: the end effector's pose
(geometry_msgs/PoseStamped) and the magnetometer's reading (sensor_msgs/MagneticField: the whole
field, rest included, as a real board streams it) published at the sensor's rate, and a twist
topic (geometry_msgs/TwistStamped) it obeys. A twist holds until the next one, as a Cartesian
velocity controller's does.

Simulated time is wall time: sample k is stamped and taken ``k / rate_hz`` s after the start
(by the wall clock), each period's motion integrated under the twist in force. When the solver
falls behind (a busy machine), the samples it has no time for are skipped (``skipped``) and the
motion is integrated over the whole gap, so the twin's clock never falls behind the wall's;
``lag_max_s`` is the latest a sample was taken after its stamp.

The ops served (ROSBRIDGE_PROTOCOL.md): ``advertise``, ``unadvertise``, ``publish``,
``subscribe``, ``unsubscribe``, ``call_service`` for ``/rosapi/topics`` (others answer
``result: false``), and ``status`` messages for what is refused. Only 127.0.0.1 is bound: the
twin is for this machine.
"""

from __future__ import annotations

import asyncio
import json
import math
import threading
import time
from dataclasses import dataclass

import numpy as np

from whiskercal.protocol import rosbridge as ros
from whiskercal.twin.carried import CarriedSensor

HOST = "127.0.0.1"


@dataclass(frozen=True)
class Topics:
    """The topic names served; frames: the world (poses, world-frame twists), the end
    effector's (twists in it are turned into the world), the magnetometer's."""

    pose: str = "/whiskercal/pose"
    twist: str = "/whiskercal/twist"
    field: str = "/whiskercal/field"
    world_frame: str = "world"
    effector_frame: str = "end_effector"
    sensor_frame: str = "magnetometer"


class RobotTwinServer:
    """A ``twin.mobile.MobileSensor`` served over rosbridge (see the module's docstring).

    Parameters
    ----------
    mobile
        The twin's sensor on its mobile base, at its start pose.
    rate_hz
        Samples (pose and field) per second.
    topics
        Names and frames.
    mount
        The sensor's true base frame on the end effector (``whiskercal.mount.Mount``-like:
        ``x_mm``, ``y_mm``, ``yaw_deg``; ``twin.carried``); the pose published is the end
        effector's, the twists taken are the end effector's. None: the end effector is the
        base frame.
    """

    def __init__(self, mobile, rate_hz: float, topics: Topics = Topics(), mount=None,
                 port: int = 0) -> None:
        self.mobile, self.rate_hz, self.topics = mobile, float(rate_hz), topics
        self.port = int(port)
        self.carried = CarriedSensor(mobile, (0.0, 0.0, 0.0) if mount is None else (
            mount.x_mm, mount.y_mm, mount.yaw_deg))
        rest = mobile.physics.field_uT(mobile.physics.free())
        self.rest_uT = np.asarray(rest, float)
        self.types = {topics.pose: ros.POSE_TYPE, topics.twist: ros.TWIST_TYPE,
                      topics.field: ros.FIELD_TYPE}
        self._subscriptions: dict = {}  # connection -> {topic: set of subscription ids}
        self.samples, self.skipped, self.twists, self.refused = 0, 0, 0, 0
        self.lag_max_s = 0.0  # the latest a sample was taken after its stamp, s
        self.publishing = True  # False: the twin goes silent (a stalled driver), still obeying
        # the end effector's last twist taken ((vx, vy) mm/s, turn rad/s) and its fastest, mm/s
        self.last_twist, self.fastest_mm_s = None, 0.0
        self.last_sample = None
        self._loop: asyncio.AbstractEventLoop | None = None
        self._stopping: asyncio.Event | None = None  # made on the loop that runs the server

    @property
    def url(self) -> str:
        """The rosbridge:// address clients connect to."""
        return f"rosbridge://{HOST}:{self.port}"

    # -- the end effector and the base --------------------------------------------------------
    def effector_pose(self) -> np.ndarray:
        """The end effector's world pose (x mm, y mm, heading rad) for the base's pose."""
        return self.carried.effector_pose()

    def apply_twist(self, message: dict) -> None:
        """Command the base from an end-effector twist (world frame, or the end effector's)."""
        (vx, vy), turn = ros.planar_twist(message)
        self.last_twist = ((vx, vy), turn)
        self.fastest_mm_s = max(self.fastest_mm_s, math.hypot(vx, vy))
        frame = message.get("header", {}).get("frame_id", "")
        effector = self.effector_pose()
        if frame == self.topics.effector_frame:
            c, s = math.cos(effector[2]), math.sin(effector[2])
            vx, vy = c * vx - s * vy, s * vx + c * vy
        elif frame not in ("", self.topics.world_frame):
            raise ValueError(f"twist in frame {frame!r}: this twin takes "
                             f"{self.topics.world_frame!r} or {self.topics.effector_frame!r}")
        self.carried.command_effector(np.array([vx, vy]), turn)
        self.twists += 1

    # -- the simulation -----------------------------------------------------------------------
    async def simulate(self, duration_s: float | None) -> None:
        """Step the twin at ``rate_hz`` against the wall clock, publishing each sample."""
        loop = asyncio.get_running_loop()
        dt, start, start_wall = 1.0 / self.rate_hz, loop.time(), time.time()
        count = math.inf if duration_s is None else int(round(duration_s * self.rate_hz))
        sample = self.mobile.step(0.0)
        k = 0
        while k < count and not self._stopping.is_set():
            if self.publishing:
                self._publish_sample(sample, start_wall + k * dt)
            due = k + 1
            gone = int((loop.time() - start) / dt)  # whole periods of wall time since the start
            if gone > due:  # the solver fell behind: the samples it had no time for are skipped
                self.skipped += gone - due
                due = gone
            await asyncio.sleep(max(start + due * dt - loop.time(), 0.0))  # (0: serve connections)
            sample = self.mobile.step((due - k) * dt)  # the motion over the whole gap
            k = due
            self.lag_max_s = max(self.lag_max_s, loop.time() - (start + k * dt))

    def _publish_sample(self, sample, stamp: float) -> None:
        self.samples += 1
        self.last_sample = sample
        field = self.rest_uT + np.array([0.0, sample.z_uT, sample.axial_uT])
        self._broadcast(self.topics.pose, ros.pose_message(self.effector_pose(),
                                                           self.topics.world_frame, stamp))
        self._broadcast(self.topics.field, ros.field_message(field, self.topics.sensor_frame, stamp))

    def _broadcast(self, topic: str, message: dict) -> None:
        from websockets.asyncio.server import broadcast

        listeners = [c for c, topics in self._subscriptions.items() if topics.get(topic)]
        if listeners:
            broadcast(listeners, json.dumps({"op": "publish", "topic": topic, "msg": message}))

    # -- the protocol -------------------------------------------------------------------------
    async def handle(self, connection) -> None:
        """One client: its ops until it goes."""
        self._subscriptions[connection] = {}
        try:
            async for text in connection:
                reply = self.answer(connection, text)
                if reply is not None:
                    await connection.send(json.dumps(reply))
        except Exception:  # a client gone mid-message is the client's end, not the twin's
            pass
        finally:
            self._subscriptions.pop(connection, None)

    def answer(self, connection, text) -> dict | None:
        """Do one op; the reply to send (a status or a service response), if any."""
        try:
            op = json.loads(text)
            name = op.get("op") if isinstance(op, dict) else None
            handler = _OPS.get(name)
            if handler is None:
                return self._status(op if isinstance(op, dict) else {}, "error",
                                    f"unknown op {name!r}")
            return handler(self, connection, op)
        except (ValueError, KeyError, TypeError, AttributeError) as error:
            return self._status({}, "error", f"refused: {error}")

    def _status(self, op: dict, level: str, text: str) -> dict:
        if level == "error":
            self.refused += 1
        reply = {"op": "status", "level": level, "msg": text}
        if "id" in op:
            reply["id"] = op["id"]
        return reply

    def _subscribe(self, connection, op: dict) -> dict | None:
        topic, kind = op["topic"], op.get("type")
        known = self.types.get(topic)
        if known is None and kind is None:
            return self._status(op, "error", f"no topic {topic!r} to infer a type from")
        if known is not None and kind and not ros.same_type(known, kind):
            return self._status(op, "error", f"{topic} is {known}, not {kind}")
        self.types.setdefault(topic, kind)
        self._subscriptions[connection].setdefault(topic, set()).add(op.get("id", ""))
        return None

    def _unsubscribe(self, connection, op: dict) -> dict | None:
        ids = self._subscriptions[connection].get(op["topic"])
        if not ids:
            return self._status(op, "warning", f"not subscribed to {op['topic']}")
        if "id" in op:
            ids.discard(op["id"])
        else:
            ids.clear()
        return None

    def _advertise(self, connection, op: dict) -> dict | None:
        topic, kind = op["topic"], op["type"]
        known = self.types.get(topic)
        if known is not None and not ros.same_type(known, kind):
            return self._status(op, "error", f"{topic} is {known}, not {kind}")
        self.types[topic] = kind
        return None

    def _publish(self, connection, op: dict) -> dict | None:
        topic = op["topic"]
        if topic not in self.types:
            return self._status(op, "error", f"no topic {topic!r}: advertise it first")
        if topic == self.topics.twist:
            try:
                self.apply_twist(op["msg"])
            except (KeyError, TypeError, ValueError) as error:
                self.mobile.command(np.zeros(2), 0.0)  # a twist it cannot read stops the base
                return self._status(op, "error", f"twist refused, base stopped: {error}")
        self._broadcast(topic, op["msg"])
        return None

    def _call_service(self, connection, op: dict) -> dict:
        reply = {"op": "service_response", "service": op["service"], "result": True}
        if "id" in op:
            reply["id"] = op["id"]
        if op["service"] == "/rosapi/topics":
            reply["values"] = {"topics": list(self.types), "types": list(self.types.values())}
        else:
            reply.update(result=False, values=f"no service {op['service']!r} on the twin")
        return reply

    # -- running ------------------------------------------------------------------------------
    async def run(self, duration_s: float | None = None, on_ready=None) -> None:
        """Serve until ``duration_s`` s of samples have gone out, or :meth:`stop`."""
        from websockets.asyncio.server import serve

        self._loop, self._stopping = asyncio.get_running_loop(), asyncio.Event()
        async with serve(self.handle, HOST, self.port, compression=None) as server:
            self.port = server.sockets[0].getsockname()[1] if server.sockets else self.port
            if on_ready is not None:
                on_ready(self)
            await self.simulate(duration_s)

    def stop(self) -> None:
        """End :meth:`run` from any thread (its connections close)."""
        if self._loop is not None and not self._loop.is_closed():
            self._loop.call_soon_threadsafe(self._stopping.set)


_OPS = {"subscribe": RobotTwinServer._subscribe, "unsubscribe": RobotTwinServer._unsubscribe,
        "advertise": RobotTwinServer._advertise, "publish": RobotTwinServer._publish,
        "unadvertise": lambda self, connection, op: None,
        "call_service": RobotTwinServer._call_service,
        "set_level": lambda self, connection, op: None}


class ServedInThread:
    """A :class:`RobotTwinServer` running on its own thread and event loop (for tests and
    benches in one process); ``with`` stops it."""

    def __init__(self, server: RobotTwinServer, duration_s: float | None = None,
                 timeout_s: float = 10.0) -> None:
        self.server, self.error = server, None
        ready = threading.Event()
        self._thread = threading.Thread(target=self._main, args=(duration_s, ready), daemon=True)
        self._thread.start()
        if not ready.wait(timeout_s):
            raise RuntimeError(f"the twin's rosbridge server did not start: {self.error!r}")

    def _main(self, duration_s, ready) -> None:
        try:
            asyncio.run(self.server.run(duration_s, lambda _: ready.set()))
        except Exception as error:  # reported by whoever waits on it
            self.error = error
            ready.set()

    def stop(self, timeout_s: float = 10.0) -> None:
        """Stop the server and wait for its thread."""
        self.server.stop()
        self._thread.join(timeout_s)

    def __enter__(self) -> "ServedInThread":
        return self

    def __exit__(self, *exc_info) -> None:
        self.stop()
