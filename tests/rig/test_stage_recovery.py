"""StageClient.recover: grbl 1.1's order after a soft-limit alarm, against a board whose
``[MSG:Reset to continue]`` comes late and which loses a reset sent before it (grbl clears a
pending reset when it enters the alarm's pause)."""

import numpy as np
import pytest

from whiskercal.rig.stage import StageAlarmError, StageClient

BANNER = b"\r\nGrbl 1.1h ['$' for help]\r\n"
MESSAGE_DELAY_S = 0.3


class PausedGrbl:
    """A pyserial-like grbl 1.1 that answers any G-code line with ALARM:2 (a soft limit).

    Time is a fake clock that an empty read moves on by the read's timeout (s).
    """

    portstr = "paused-grbl"

    def __init__(self) -> None:
        self.timeout = 1.0
        self.clock_s = 0.0
        self.buffer = bytearray()
        self.writes: list[bytes] = []
        self.alarm_at_s: float | None = None
        self.paused = self.locked = False
        self.lost_resets = 0

    def now_s(self) -> float:
        return self.clock_s

    def write(self, data: bytes) -> int:
        self.writes.append(data)
        if data == b"\x18":
            self._reset()
        elif data == b"?":
            if not self.paused and self.alarm_at_s is None:
                self.buffer += b"<Alarm|MPos:-150.000,-120.000,0.000|FS:0,0>\r\n" if self.locked \
                    else b"<Idle|MPos:-150.000,-120.000,0.000|FS:0,0>\r\n"
        elif data.startswith(b"G") and self.alarm_at_s is None and not self.paused:
            self.buffer += b"ALARM:2\r\n"
            self.alarm_at_s = self.clock_s
        elif data == b"$X\n" and not self.paused:
            self.locked = False
            self.buffer += b"[MSG:Caution: Unlocked]\r\nok\r\n"
        return len(data)

    def _reset(self) -> None:
        if not self.paused:  # before "Reset to continue" grbl clears the pending reset
            self.lost_resets += 1
            return
        self.paused, self.locked = False, True
        self.buffer += BANNER + b"[MSG:'$H'|'$X' to unlock]\r\n"

    @property
    def in_waiting(self) -> int:
        return len(self.buffer)

    def read(self, size: int = 1) -> bytes:
        if self.alarm_at_s is not None and self.clock_s >= self.alarm_at_s + MESSAGE_DELAY_S:
            self.buffer += b"[MSG:Reset to continue]\r\n"
            self.alarm_at_s, self.paused = None, True
        data = bytes(self.buffer[:size])
        del self.buffer[:size]
        if len(data) < size:
            self.clock_s += min(self.timeout or 0.0, 0.05)
        return data

    def close(self) -> None:
        pass


def test_the_reset_waits_for_reset_to_continue_then_banner_unlock_message_and_unlock():
    port = PausedGrbl()
    stage = StageClient(port)
    with pytest.raises(StageAlarmError) as info:
        stage.command("G53 G1 X5.000 Y-120.000 F3000.0")
    assert info.value.code == 2
    stage.recover(info.value.code)
    assert port.lost_resets == 0  # the reset went out only after the message
    assert port.writes[1:] == [b"\x18", b"$X\n"]
    assert port.clock_s >= MESSAGE_DELAY_S
    status = stage.status()
    assert status.idle
    np.testing.assert_allclose(status.mpos_mm, [-150.0, -120.0])


def test_a_status_request_during_the_pause_is_dropped_and_recovery_still_follows():
    port = PausedGrbl()
    stage = StageClient(port, timeout_s=0.6)
    with pytest.raises(StageAlarmError):
        stage.command("G53 G1 X5.000 Y-120.000 F3000.0")
    with pytest.raises(Exception, match="status request"):
        stage.status()  # grbl serves no '?' in the pause; the client asks again and gives up
    stage.recover(2)
    assert stage.status().idle
