"""A serial port that answers from a recorded grbl transcript (tests/data/grbl_transcripts), so
the client can be run against what the real image sent.

Each write must be the bytes of a later host entry of the transcript (host entries in between
are skipped: the client need not poll as the recorder did); the board lines recorded after it,
up to the next host entry, then arrive at their recorded times on the port's own clock (s).
"""

from __future__ import annotations

from collections import deque


class TranscriptPort:
    """pyserial-like: ``write``, ``read``, ``in_waiting``, ``timeout``, ``now_s``."""

    portstr = "transcript"

    def __init__(self, entries: list[dict]) -> None:
        self.entries = entries
        self.position = 0
        self.now = 0.0
        self.timeout: float | None = 1.0
        self._arrivals: deque[tuple[float, bytes]] = deque()
        self._queue_board_lines()

    def now_s(self) -> float:
        return self.now

    def _queue_board_lines(self) -> None:
        while self.position < len(self.entries) and self.entries[self.position]["dir"] == "board":
            entry = self.entries[self.position]
            self._arrivals.append((entry["t"], entry["bytes"].encode("latin-1")))
            self.position += 1

    def write(self, data: bytes) -> int:
        text = data.decode("latin-1")
        for index in range(self.position, len(self.entries)):
            entry = self.entries[index]
            if entry["dir"] == "host" and entry["bytes"] == text:
                self.now = max(self.now, entry["t"])
                for skipped in self.entries[self.position:index]:  # what came meanwhile still came
                    if skipped["dir"] == "board":
                        self._arrivals.append((skipped["t"], skipped["bytes"].encode("latin-1")))
                self.position = index + 1
                self._queue_board_lines()
                return len(data)
        raise AssertionError(f"the client sent {text!r}, which the transcript has no host entry for "
                             f"after entry {self.position}")

    @property
    def in_waiting(self) -> int:
        return sum(len(data) for t, data in self._arrivals if t <= self.now)

    def read(self, size: int = 1) -> bytes:
        if self._arrivals and self._arrivals[0][0] > self.now:
            wait = self._arrivals[0][0] - self.now
            self.now += min(wait, self.timeout if self.timeout is not None else wait)
        if not self._arrivals or self._arrivals[0][0] > self.now:
            if not self._arrivals:
                self.now += self.timeout or 0.0
            return b""
        data = bytearray()
        while self._arrivals and self._arrivals[0][0] <= self.now and len(data) < size:
            t, chunk = self._arrivals.popleft()
            take = chunk[:size - len(data)]
            data += take
            if len(take) < len(chunk):
                self._arrivals.appendleft((t, chunk[len(take):]))
        return bytes(data)

    def close(self) -> None:
        pass
