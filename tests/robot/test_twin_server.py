"""The twin's rosbridge server speaks the protocol's topic ops to a raw WebSocket client."""

import json
import time

import numpy as np
import pytest
from served_twin import serve, twin_server
from websockets.sync.client import connect

from whiskercal.protocol import rosbridge as ros

pytestmark = pytest.mark.timeout(60)


def _until(ws, predicate, timeout_s: float = 5.0) -> dict:
    """The first message satisfying ``predicate`` within ``timeout_s``."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        message = json.loads(ws.recv(timeout=timeout_s))
        if predicate(message):
            return message
    raise AssertionError("no such message")


def _ops(ws, *ops) -> None:
    for op in ops:
        ws.send(json.dumps(op))


def test_subscribers_get_pose_and_field_at_the_rate_in_ros_units():
    server = twin_server(rate_hz=100.0)
    with serve(server), connect(f"ws://127.0.0.1:{server.port}") as ws:
        _ops(ws, {"op": "subscribe", "topic": "/whiskercal/pose", "type": "geometry_msgs/msg/PoseStamped"},
             {"op": "subscribe", "id": "f", "topic": "/whiskercal/field"})
        fields = [_until(ws, lambda m: m.get("topic") == "/whiskercal/field")["msg"] for _ in range(30)]
        pose = _until(ws, lambda m: m.get("topic") == "/whiskercal/pose")["msg"]
    stamps = np.array([ros.stamp_s(m) for m in fields])
    # the stream's own clock, 100 Hz: whole periods apart (more than one where a busy machine
    # made the twin skip samples), most one
    periods = np.diff(stamps) / 0.01
    assert np.allclose(periods, np.round(periods), atol=1e-4) and np.all(periods >= 1 - 1e-4)
    assert np.median(periods) == pytest.approx(1.0)
    assert abs(stamps[-1] - time.time()) < 5.0  # stamped by the wall clock
    # the whole field in tesla (rest included), as a board streams it; the pose in metres
    y_uT = np.array([ros.field_uT(m)[1] for m in fields])
    assert abs(np.median(y_uT) - server.rest_uT[1]) < 5.0 and np.ptp(y_uT) < 60.0  # noise only
    assert 1e-4 < abs(fields[0]["magnetic_field"]["y"]) < 1e-2
    x_mm, y_mm, heading = ros.planar_pose(pose)
    assert np.allclose([x_mm, y_mm], server.mobile.pose()[:2], atol=1e-6)
    assert abs(pose["pose"]["position"]["x"] * 1e3 - x_mm) < 1e-9 and pose["header"]["frame_id"] == "world"


def test_a_published_twist_moves_the_base_and_holds_until_the_next():
    server = twin_server(rate_hz=100.0)
    with serve(server), connect(f"ws://127.0.0.1:{server.port}") as ws:
        start = server.mobile.pose()
        _ops(ws, {"op": "advertise", "topic": "/whiskercal/twist", "type": "geometry_msgs/TwistStamped"},
             {"op": "publish", "topic": "/whiskercal/twist",
              "msg": ros.twist_message((-5.0, 0.0), 0.0, "world", time.time())})
        time.sleep(1.0)
        moved = server.mobile.pose() - start
        _ops(ws, {"op": "publish", "topic": "/whiskercal/twist",
                  "msg": ros.twist_message((0.0, 0.0), 0.0, "world", time.time())})
        time.sleep(0.2)
        held = server.mobile.pose()
        time.sleep(0.3)
        still = server.mobile.pose() - held
    # 5 mm/s away from the object for about a second of wall time, then it stays put
    assert -6.0 < moved[0] < -4.0 and abs(moved[1]) < 1e-9 and server.twists == 2
    assert np.allclose(still, 0.0)


def test_refusals_come_as_error_status_messages():
    server = twin_server(rate_hz=50.0)
    with serve(server), connect(f"ws://127.0.0.1:{server.port}") as ws:
        is_status = lambda m: m.get("op") == "status"
        _ops(ws, {"op": "publish", "id": "p1", "topic": "/nowhere", "msg": {}})
        unknown_topic = _until(ws, is_status)
        _ops(ws, {"op": "advertise", "topic": "/whiskercal/twist", "type": "std_msgs/String"})
        wrong_type = _until(ws, is_status)
        _ops(ws, {"op": "teleport"})
        unknown_op = _until(ws, is_status)
        ws.send("not json")
        garbled = _until(ws, is_status)
        _ops(ws, {"op": "publish", "topic": "/whiskercal/twist", "msg": {"twist": {"linear": {}}}})
        bad_twist = _until(ws, is_status)
    assert unknown_topic["level"] == "error" and unknown_topic["id"] == "p1" and "/nowhere" in unknown_topic["msg"]
    assert "TwistStamped" in wrong_type["msg"] and "teleport" in unknown_op["msg"]
    assert garbled["level"] == "error" and "base stopped" in bad_twist["msg"]
    assert server.refused == 5 and server.twists == 0


def test_unsubscribe_stops_the_messages_and_rosapi_lists_the_topics():
    server = twin_server(rate_hz=100.0)
    with serve(server), connect(f"ws://127.0.0.1:{server.port}") as ws:
        _ops(ws, {"op": "subscribe", "id": "a", "topic": "/whiskercal/pose"})
        _until(ws, lambda m: m.get("topic") == "/whiskercal/pose")
        _ops(ws, {"op": "unsubscribe", "id": "a", "topic": "/whiskercal/pose"},
             {"op": "call_service", "id": "s", "service": "/rosapi/topics"})
        listed = _until(ws, lambda m: m.get("op") == "service_response")
        time.sleep(0.1)  # what was in flight before the unsubscribe
        while True:  # drain it, then nothing more comes
            try:
                ws.recv(timeout=0.3)
            except TimeoutError:
                break
    assert listed["result"] is True and listed["id"] == "s"
    assert set(listed["values"]["topics"]) >= {"/whiskercal/pose", "/whiskercal/twist", "/whiskercal/field"}


def test_the_server_binds_to_loopback_only():
    server = twin_server(rate_hz=10.0)
    with serve(server):
        assert server.url.startswith("rosbridge://127.0.0.1:")


def test_a_twist_in_the_end_effectors_frame_is_turned_into_the_world():
    import math

    server = twin_server(rate_hz=10.0, pose=[-200.0, 0.0, math.pi / 2])
    message = ros.twist_message((2.0, 0.0), 0.0, server.topics.effector_frame, 0.0)
    before = server.mobile.pose()
    server.apply_twist(message)
    server.mobile.step(0.5)
    # the end effector's x axis points along the world's +y: 2 mm/s for 0.5 s there
    assert np.allclose(server.mobile.pose() - before, [0.0, 1.0, 0.0], atol=1e-12)
