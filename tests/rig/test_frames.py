"""Sensor frame codec: CRC, round trips, resynchronization after corruption."""

import numpy as np

from whiskercal.protocol.frames import (SAMPLE_FRAME_BYTES, FrameDecoder, Sample, crc16_ccitt_false,
                                   encode_sample, encode_text)


def test_crc_check_value():
    # the catalogue check value of CRC-16/CCITT-FALSE over "123456789"
    assert crc16_ccitt_false(b"123456789") == 0x29B1


def test_sample_frame_layout():
    frame = encode_sample(0x1234, 0xDEADBEEF, (-1, 2, -3), 4)
    assert len(frame) == SAMPLE_FRAME_BYTES == 19
    assert frame[:4] == b"\xa5\x5a\x01\x0d"
    assert frame[4:6] == b"\x34\x12"


def test_round_trip_with_wrapping_fields():
    decoder = FrameDecoder()
    frames = decoder.feed(encode_sample(70000, 2**32 + 5, (100, -200, 300), 1) + encode_text("OK"))
    assert frames == [Sample(70000 - 65536, 5, 100, -200, 300, 1), "OK"]
    assert decoder.corrupt == 0


def test_byte_by_byte_feed():
    decoder = FrameDecoder()
    stream = b"".join(encode_sample(i, i * 3333, (i, -i, 0), 0) for i in range(5))
    frames = [f for byte in stream for f in decoder.feed(bytes([byte]))]
    assert [f.seq for f in frames] == list(range(5))


def test_corruption_costs_one_frame_and_is_counted():
    rng = np.random.default_rng(7)
    frames = [encode_sample(i, i * 3333, (i, 2 * i, 3 * i), 0) for i in range(50)]
    damaged = {5, 17, 33}
    stream = bytearray()
    for i, frame in enumerate(frames):
        frame = bytearray(frame)
        if i in damaged:
            frame[int(rng.integers(2, len(frame)))] ^= 0x40
        stream += frame
    decoder = FrameDecoder()
    seqs = [f.seq for f in decoder.feed(bytes(stream))]
    assert seqs == [i for i in range(50) if i not in damaged]
    assert decoder.corrupt == len(damaged)


def test_garbage_between_frames_and_sync_lookalikes():
    decoder = FrameDecoder()
    stream = b"\x00\xa5\x5a\xff" + encode_sample(1, 10, (1, 1, 1), 0) + b"\xa5" + encode_sample(2, 20, (2, 2, 2), 0)
    assert [f.seq for f in decoder.feed(stream)] == [1, 2]
    assert decoder.corrupt == 2
