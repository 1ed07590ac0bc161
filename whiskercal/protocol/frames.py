"""The sensor's binary frame format (docs/protocol.md): encode, decode, resynchronize.

A frame is ``A5 5A | type u8 | length u8 | payload | CRC-16/CCITT-FALSE u16 LE`` with the CRC
over type, length and payload. The decoder takes arbitrary chunks of bytes, returns the frames
that check and counts what it had to skip, so a corrupted byte costs one frame, not the stream.
"""

from __future__ import annotations

import binascii
import struct
from dataclasses import dataclass

SYNC = b"\xa5\x5a"
TYPE_SAMPLE = 0x01
TYPE_TEXT = 0x02
SAMPLE_PAYLOAD = struct.Struct("<HIhhhB")
SAMPLE_FRAME_BYTES = len(SYNC) + 2 + SAMPLE_PAYLOAD.size + 2
_HEADER_BYTES = len(SYNC) + 2
_KNOWN_LENGTHS = {TYPE_SAMPLE: {SAMPLE_PAYLOAD.size}, TYPE_TEXT: set(range(1, 256))}


def crc16_ccitt_false(data: bytes, crc: int = 0xFFFF) -> int:
    """CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF, no reflection, no final xor)."""
    return binascii.crc_hqx(data, crc)


def encode_frame(frame_type: int, payload: bytes) -> bytes:
    """One frame around ``payload`` (at most 255 bytes)."""
    if not 0 < len(payload) <= 255:
        raise ValueError(f"frame payload must be 1..255 bytes, got {len(payload)}")
    body = bytes((frame_type, len(payload))) + payload
    return SYNC + body + struct.pack("<H", crc16_ccitt_false(body))


def encode_sample(seq: int, t_us: int, counts: tuple[int, int, int], status: int) -> bytes:
    """A sample frame; ``seq`` and ``t_us`` wrap at 16 and 32 bits as on the board."""
    payload = SAMPLE_PAYLOAD.pack(seq & 0xFFFF, t_us & 0xFFFFFFFF, *counts, status)
    return encode_frame(TYPE_SAMPLE, payload)


def encode_text(text: str) -> bytes:
    """A text frame carrying an ASCII reply."""
    return encode_frame(TYPE_TEXT, text.encode("ascii"))


@dataclass(frozen=True)
class Sample:
    """One decoded sample: wrapped ``seq`` (u16), wrapped board time ``t_us`` (u32), raw counts."""

    seq: int
    t_us: int
    x: int
    y: int
    z: int
    status: int


class FrameDecoder:
    """Incremental decoder: feed bytes, get ``Sample`` objects and text strings back in order.

    ``corrupt`` counts corruption events: each run of bytes skipped between two good frames
    (frames failing their CRC or header, stray bytes) counts once, however many frames it
    spoiled; the frames lost show up as gaps in ``seq``. ``skipped_bytes`` counts the bytes
    thrown away to find the next good frame.
    """

    def __init__(self) -> None:
        self._buffer = bytearray()
        self.corrupt = 0
        self.skipped_bytes = 0
        self._resyncing = False

    def feed(self, data: bytes) -> list[Sample | str]:
        """Add received bytes; return every complete frame that checks, oldest first."""
        self._buffer += data
        frames: list[Sample | str] = []
        while True:
            frame = self._next_frame()
            if frame is None:
                return frames
            frames.append(frame)

    def _skip(self, count: int) -> None:
        # one run of bad bytes between good frames is one corruption event, however long
        if not self._resyncing:
            self.corrupt += 1
            self._resyncing = True
        del self._buffer[:count]
        self.skipped_bytes += count

    def _next_frame(self) -> Sample | str | None:
        while True:
            start = self._buffer.find(SYNC)
            if start < 0:
                # keep a trailing 0xA5: it may be the first half of the next sync
                keep = 1 if self._buffer.endswith(SYNC[:1]) else 0
                if len(self._buffer) - keep > 0:
                    self._skip(len(self._buffer) - keep)
                return None
            if start > 0:
                self._skip(start)
            if len(self._buffer) < _HEADER_BYTES:
                return None
            frame_type, length = self._buffer[2], self._buffer[3]
            if length not in _KNOWN_LENGTHS.get(frame_type, ()):
                self._reject()
                continue
            total = _HEADER_BYTES + length + 2
            if len(self._buffer) < total:
                return None
            body = bytes(self._buffer[2:total - 2])
            (crc,) = struct.unpack_from("<H", self._buffer, total - 2)
            if crc != crc16_ccitt_false(body):
                self._reject()
                continue
            del self._buffer[:total]
            self._resyncing = False
            return _payload(frame_type, body[2:])

    def _reject(self) -> None:
        # drop only the first sync byte: the real frame may start inside the rejected one
        self._skip(1)


def _payload(frame_type: int, payload: bytes) -> Sample | str:
    if frame_type == TYPE_TEXT:
        return payload.decode("ascii", errors="replace")
    return Sample(*SAMPLE_PAYLOAD.unpack(payload))
