"""Conformance script for the sensor protocol (docs/protocol.md, "Sensor").

Frames are decoded here from the protocol text alone (sync, type, length, payload, CRC-16/
CCITT-FALSE), independently of the host's decoder. Each ``check_*`` function takes an open port
and runs against the host-built firmware and the twin's virtual sensor alike.
"""

from __future__ import annotations

import re
import struct
from dataclasses import dataclass

SYNC = b"\xa5\x5a"
SAMPLE, TEXT = 0x01, 0x02
DEFAULT_CONFIG = "OK rate=300 gain=5 res=2 osr=0 filt=2"


def crc16_ccitt_false(data: bytes) -> int:
    """CRC-16/CCITT-FALSE: polynomial 0x1021, initial value 0xFFFF, no reflection."""
    crc = 0xFFFF
    for byte in data:
        crc ^= byte << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x1021) & 0xFFFF if crc & 0x8000 else (crc << 1) & 0xFFFF
    return crc


@dataclass
class Sample:
    seq: int
    t_us: int
    counts: tuple[int, int, int]
    status: int


class SensorLink:
    """Frames from a sensor port, commands to it, waits in device seconds."""

    def __init__(self, port) -> None:
        self.port = port
        self.buffer = bytearray()
        self.samples: list[Sample] = []
        self.texts: list[str] = []
        self.bad_frames = 0

    def _parse(self) -> None:
        while True:
            start = self.buffer.find(SYNC)
            if start < 0:
                del self.buffer[:-1]
                return
            del self.buffer[:start]
            if len(self.buffer) < 6 or len(self.buffer) < 6 + self.buffer[3]:
                return
            n = self.buffer[3]
            frame = bytes(self.buffer[:6 + n])
            if struct.unpack_from("<H", frame, 4 + n)[0] != crc16_ccitt_false(frame[2:4 + n]):
                self.bad_frames += 1
                del self.buffer[:1]  # resynchronize on the next sync bytes
                continue
            del self.buffer[:6 + n]
            self._keep(frame[2], frame[4:4 + n])

    def _keep(self, kind: int, payload: bytes) -> None:
        if kind == SAMPLE:
            assert len(payload) == 13, f"sample payload of {len(payload)} bytes"
            seq, t_us, x, y, z, status = struct.unpack("<HIhhhB", payload)
            self.samples.append(Sample(seq, t_us, (x, y, z), status))
        elif kind == TEXT:
            self.texts.append(payload.decode("ascii"))
        else:
            raise AssertionError(f"unknown frame type {kind:#04x}")

    def pump(self, seconds: float) -> None:
        """Collect frames for ``seconds`` of device time."""
        deadline = self.port.now_s() + seconds
        while (remaining := deadline - self.port.now_s()) > 0:
            self.port.timeout = min(remaining, 0.02)
            self.buffer += self.port.read(max(1, self.port.in_waiting))
            self._parse()

    def command(self, line: str, timeout_s: float = 1.0) -> str:
        """Send a command; return its text answer (samples meanwhile are kept)."""
        seen = len(self.texts)
        self.port.write(line.encode("ascii") + b"\n")
        deadline = self.port.now_s() + timeout_s
        while len(self.texts) == seen:
            assert self.port.now_s() < deadline, f"no answer to {line!r} within {timeout_s} s"
            self.pump(0.01)
        assert len(self.texts) == seen + 1, f"{line!r} got several answers: {self.texts[seen:]}"
        return self.texts[-1]

    def stop_and_drain(self) -> None:
        """STOP, then drop what was still on its way."""
        assert self.command("STOP") == "OK"
        self.pump(0.05)
        self.samples.clear()


def stream_for(link: SensorLink, seconds: float) -> list[Sample]:
    assert link.command("START") == "OK"
    link.samples.clear()
    link.pump(seconds)
    samples = list(link.samples)
    link.stop_and_drain()
    return samples


def check_identify(port) -> None:
    link = SensorLink(port)
    answer = link.command("ID")
    assert re.fullmatch(r"OK whisker_nano fw=\d+\.\d+\.\d+ proto=1", answer), answer


def check_default_configuration(port) -> None:
    assert SensorLink(port).command("CFG?") == DEFAULT_CONFIG


def check_stream_at_300_hz(port) -> None:
    link = SensorLink(port)
    samples = stream_for(link, 1.0)
    assert link.bad_frames == 0
    # Counted against the board's own clock (t_us): a simulator may lag the host's clock.
    assert len(samples) >= 200, len(samples)
    for before, after in zip(samples, samples[1:]):
        assert after.seq == (before.seq + 1) & 0xFFFF, "gap in seq without a fault"
        period_us = (after.t_us - before.t_us) & 0xFFFFFFFF
        assert 3233 <= period_us <= 3433, f"{period_us} µs between samples"
    mean_period = ((samples[-1].t_us - samples[0].t_us) & 0xFFFFFFFF) / (len(samples) - 1)
    assert abs(mean_period - 1e6 / 300) < 5, mean_period
    assert all(s.status & 0x02 == 0 for s in samples), "NO_SENSOR with a sensor present"


def check_stop_ends_the_stream(port) -> None:
    link = SensorLink(port)
    stream_for(link, 0.1)
    link.pump(0.2)
    assert link.samples == [], f"{len(link.samples)} samples after STOP"


def check_settings_refused_while_streaming(port) -> None:
    link = SensorLink(port)
    assert link.command("START") == "OK"
    assert link.command("GAIN 3") == "ERR:3"
    assert link.command("RATE 100") == "ERR:3"
    link.stop_and_drain()
    assert link.command("CFG?") == DEFAULT_CONFIG


def _pump_until(link: SensorLink, count: int, timeout_s: float = 5.0) -> None:
    """Collect frames until ``count`` samples are kept (a simulator may lag the host's clock)."""
    deadline = link.port.now_s() + timeout_s
    while len(link.samples) < count:
        assert link.port.now_s() < deadline, f"{len(link.samples)} of {count} samples"
        link.pump(0.01)


def check_start_while_streaming_is_a_sync_marker(port) -> None:
    # the host's sync exchange (docs/protocol.md): START while streaming answers OK and changes
    # nothing; the stream goes on through the answer without a restart or a gap
    link = SensorLink(port)
    assert link.command("START") == "OK"
    _pump_until(link, 10)
    assert link.command("START") == "OK"
    _pump_until(link, len(link.samples) + 10)
    samples = list(link.samples)
    link.stop_and_drain()
    for earlier, later in zip(samples, samples[1:]):
        assert later.seq == (earlier.seq + 1) & 0xFFFF, "the stream restarted or lost a sample"
        assert 3233 <= (later.t_us - earlier.t_us) & 0xFFFFFFFF <= 3433


def check_bad_commands(port) -> None:
    link = SensorLink(port)
    assert link.command("GAIN 8") == "ERR:2"
    assert link.command("RES 4") == "ERR:2"
    assert link.command("RATE 0") == "ERR:2"
    assert link.command("RATE 501") == "ERR:2"
    assert link.command("GAIN x") == "ERR:2"
    assert link.command("HELLO") == "ERR:1"
    assert link.command("X" * 40) == "ERR:6"
    assert link.command("CFG?") == DEFAULT_CONFIG


def check_conversion_time_limits_the_rate(port) -> None:
    link = SensorLink(port)
    assert link.command("OSR 1") == "ERR:4"     # DF2/OSR1: 3.00 ms + I2C > 3.33 ms
    assert link.command("RATE 455") == "ERR:4"  # DF2/OSR0: 1.84 ms + 0.36 ms > 2.198 ms
    assert link.command("RATE 454") == "OK"
    assert link.command("RATE 100") == "OK"
    assert link.command("OSR 3") == "ERR:4"     # DF2/OSR3: 9.91 ms + I2C > 10 ms
    assert link.command("FILT 1") == "OK"
    assert link.command("OSR 3") == "OK"        # DF1/OSR3: 6.84 ms
    assert link.command("CFG?") == "OK rate=100 gain=5 res=2 osr=3 filt=1"


def check_rate_setting_changes_the_period(port) -> None:
    link = SensorLink(port)
    assert link.command("RATE 100") == "OK"
    samples = stream_for(link, 0.5)
    assert len(samples) >= 30, len(samples)
    periods = [(b.t_us - a.t_us) & 0xFFFFFFFF for a, b in zip(samples, samples[1:])]
    assert all(9900 <= p <= 10100 for p in periods), periods[:10]


SENSOR_CHECKS = [check_identify, check_default_configuration, check_stream_at_300_hz,
                 check_stop_ends_the_stream, check_settings_refused_while_streaming,
                 check_start_while_streaming_is_a_sync_marker, check_bad_commands,
                 check_conversion_time_limits_the_rate, check_rate_setting_changes_the_period]
