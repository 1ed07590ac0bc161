"""A byte-pair transport in the style of pymeasure's ``expected_protocol``.

The script is a list of ``(written, reply)`` pairs: each write must equal the next ``written``
(``None`` means the device speaks unasked), after which ``reply`` becomes readable. Leaving a
pair unused fails the test. Reads never block: an empty read moves a fake clock on by the
timeout, so timeouts are tested without waiting.
"""

from __future__ import annotations

from contextlib import contextmanager


class ExpectedProtocolPort:
    """A pyserial-like object that checks writes against a script and feeds scripted replies."""

    portstr = "expected-protocol"

    def __init__(self, pairs):
        self._pairs = list(pairs)
        self._buffer = bytearray()
        self.timeout = 1.0
        self._clock_s = 0.0
        self._release_unasked()

    def now_s(self) -> float:
        return self._clock_s

    def _release_unasked(self) -> None:
        while self._pairs and self._pairs[0][0] is None:
            self._buffer += self._pairs.pop(0)[1] or b""

    def write(self, data: bytes) -> int:
        assert self._pairs, f"unexpected write {data!r}: the script is finished"
        expected, reply = self._pairs.pop(0)
        assert data == expected, f"wrote {data!r}, the script expected {expected!r}"
        self._buffer += reply or b""
        self._release_unasked()
        return len(data)

    @property
    def in_waiting(self) -> int:
        return len(self._buffer)

    def read(self, size: int = 1) -> bytes:
        data = bytes(self._buffer[:size])
        del self._buffer[:size]
        if len(data) < size:
            self._clock_s += self.timeout or 0.0
        return data

    def assert_done(self) -> None:
        assert not self._pairs, f"script pairs left unused: {self._pairs!r}"
        assert not self._buffer, f"reply bytes left unread: {bytes(self._buffer)!r}"


@contextmanager
def expected_protocol(client_class, pairs, **kwargs):
    """Yield ``client_class(port)`` on a scripted port; fail if any pair is left unused."""
    port = ExpectedProtocolPort(pairs)
    yield client_class(port, **kwargs)
    port.assert_done()
