"""Simulated time, and the serial line that carries bytes through it.

The clock only moves when someone waits: a read with a timeout on a simulated port advances it
to the moment the requested bytes exist (or by the timeout). With ``speed`` > 0 the clock is
paced against real time (1 = real time, 10 = ten times faster); with ``speed`` = 0 it runs as
fast as the CPU allows.
"""

from __future__ import annotations

import math
import time
from collections import deque
from dataclasses import dataclass, field

SERIAL_BITS_PER_BYTE = 10  # 8N1: start bit, 8 data bits, stop bit


@dataclass
class SimClock:
    """Simulated time in s since the world was made."""

    speed: float = 0.0
    now_s: float = 0.0
    _wall_start: float | None = None

    def advance_to(self, t: float) -> None:
        """Move time forward to ``t`` s (never back), sleeping first when paced."""
        if t <= self.now_s:
            return
        if self.speed > 0:
            self._pace(t)
        self.now_s = t

    def _pace(self, t: float) -> None:
        # real-time mode: simulated time t may not run ahead of wall time x speed
        if self._wall_start is None:
            self._wall_start = time.monotonic() - self.now_s / self.speed
        delay = self._wall_start + t / self.speed - time.monotonic()
        if delay > 0:
            time.sleep(delay)

    def paced_now_s(self, max_step_s: float = math.inf) -> float:
        """Where simulated time should be now by the wall clock (paced mode only), at most
        ``max_step_s`` ahead of ``now_s``.

        A simulation slower than real time (an emulated board on a busy CPU) would otherwise be
        asked for ever longer spans, each taking longer than the last to compute, and bytes from
        the host would wait for the whole span: time would run away from the host. Past the
        bound the clock gives up the lag instead of catching up, so simulated time runs slower
        than the wall while the CPU cannot keep up, and every span stays short.
        """
        if self._wall_start is None:
            self._wall_start = time.monotonic() - self.now_s / self.speed
        target = (time.monotonic() - self._wall_start) * self.speed
        if target - self.now_s > max_step_s:
            self._wall_start += (target - self.now_s - max_step_s) / self.speed
            target = self.now_s + max_step_s
        return target


@dataclass
class SerialLine:
    """One direction of a UART: bytes queued at a time arrive after their transmission time.

    ``arrival(t)`` chunks are what the receiving side can read at time t. The line is busy
    while earlier bytes are still being shifted out, which is how a board that talks too much
    falls behind.
    """

    baud: int = 115200
    busy_until_s: float = 0.0
    _chunks: deque = field(default_factory=deque)

    def byte_time_s(self, count: int) -> float:
        """How long ``count`` bytes take on the wire, s."""
        return count * SERIAL_BITS_PER_BYTE / self.baud

    def send(self, data: bytes, t: float) -> float:
        """Queue ``data`` at time ``t``; return when its last byte has arrived (s)."""
        if not data:
            return t
        start = max(t, self.busy_until_s)
        self.busy_until_s = start + self.byte_time_s(len(data))
        self._chunks.append((self.busy_until_s, bytes(data)))
        return self.busy_until_s

    def backlog_bytes(self, t: float) -> int:
        """Bytes queued but not yet arrived at time ``t``."""
        return sum(len(data) for arrival, data in self._chunks if arrival > t)

    def next_arrival_s(self) -> float | None:
        """When the next queued chunk arrives (None if nothing is queued)."""
        return self._chunks[0][0] if self._chunks else None

    def receive(self, t: float) -> bytes:
        """Everything that has arrived by time ``t``."""
        out = bytearray()
        while self._chunks and self._chunks[0][0] <= t:
            out += self._chunks.popleft()[1]
        return bytes(out)

    def clear(self) -> None:
        """Drop everything in flight."""
        self._chunks.clear()
