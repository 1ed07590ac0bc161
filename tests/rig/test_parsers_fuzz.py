"""Property-based tests of the serial parsers: any input gives a valid result or a DeviceError.

Runs are short and derandomized (hypothesis derives its examples from each test's source), so the
suite stays fast and every run sees the same inputs.
"""

import math

import numpy as np
import pytest
from byte_pairs import expected_protocol
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from whiskercal.errors import DeviceError
from whiskercal.protocol.frames import (SAMPLE_FRAME_BYTES, FrameDecoder, encode_sample,
                                        encode_text)
from whiskercal.rig.stage import StageClient, parse_setting, parse_status

FUZZ = settings(max_examples=400, derandomize=True, deadline=None,
                suppress_health_check=[HealthCheck.too_slow])

# text that looks like a status report often enough to reach every branch
_PIECES = st.sampled_from(["<", ">", "|", ":", ",", "Idle", "Run", "MPos", "WPos", "Enc", "FS",
                           "F", "Pn", "1", "-2.5", "0.000", "nan", "inf", "1e999", "", " ", "X",
                           "١", "²", "_", "."])
_STATUSLIKE = st.lists(_PIECES, max_size=30).map("".join)
_FINITE = st.floats(allow_nan=False, allow_infinity=False, min_value=-1e6, max_value=1e6)


def _status_or_error(line: str):
    try:
        return parse_status(line)
    except DeviceError:
        return None


@FUZZ
@given(st.one_of(st.text(max_size=80), _STATUSLIKE))
def test_any_status_line_parses_to_finite_positions_or_raises_device_error(line):
    status = _status_or_error(line)
    if status is not None:
        assert status.mpos_mm.shape == (2,) and np.all(np.isfinite(status.mpos_mm))
        assert status.enc_mm is None or (status.enc_mm.shape == (2,)
                                         and np.all(np.isfinite(status.enc_mm)))
        assert math.isfinite(status.feed_mm_min) and status.feed_mm_min >= 0


@FUZZ
@given(st.lists(_FINITE, min_size=3, max_size=3), st.lists(_FINITE, min_size=2, max_size=2),
       st.floats(min_value=0, max_value=1e5))
def test_well_formed_status_reports_round_trip(mpos, enc, feed):
    line = (f"<Run|MPos:{mpos[0]!r},{mpos[1]!r},{mpos[2]!r}|FS:{feed!r},0|"
            f"Enc:{enc[0]!r},{enc[1]!r}>")
    status = parse_status(line)
    assert status.mpos_mm.tolist() == mpos[:2] and status.enc_mm.tolist() == enc
    assert status.feed_mm_min == feed


@pytest.mark.parametrize("line", [
    "<Idle|MPos:1.0|FS:0,0>",                       # one coordinate
    "<Idle|MPos:1.0,2.0|FS:0,0>",                   # no z
    "<Idle|MPos:nan,2.0,0.0|FS:0,0>",
    "<Idle|MPos:1.0,inf,0.0|FS:0,0>",
    "<Idle|MPos:1e999,2.0,0.0|FS:0,0>",             # overflows to inf
    "<Idle|MPos:1,2,0|WPos:1,nan,0|FS:0,0>",
    "<Idle|MPos:1,2,0|Enc:1|FS:0,0>",
    "<Idle|MPos:1,2,0|Enc:nan,1|FS:0,0>",
    "<Idle|MPos:1,2,0|FS:-5,0>",
    "<Idle|MPos:1,2,0|FS:nan,0>",
    "<Idle|MPos:1_0,2,0|FS:0,0>",                   # float() would read 10
])
def test_untrustworthy_positions_are_refused(line):
    with pytest.raises(DeviceError, match="status report"):
        parse_status(line)


def test_a_wpos_only_report_says_how_to_get_mpos():
    with pytest.raises(DeviceError, match=r"\$10=1"):
        parse_status("<Idle|WPos:1.0,2.0,0.0|FS:0,0>")


_SETTINGLIKE = st.lists(st.sampled_from(["$", "1", "20", "=", "0.5", " ", "(x)", "nan", "-", "e",
                                         "²", "١", "N", "\t", "inf", "1e999"]),
                        max_size=12).map("".join)


@FUZZ
@given(st.one_of(st.text(max_size=40), _SETTINGLIKE))
def test_any_setting_line_gives_a_setting_none_or_device_error(line):
    try:
        parsed = parse_setting(line)
    except DeviceError:
        return
    if parsed is not None:
        number, value = parsed
        assert isinstance(number, int) and number >= 0 and math.isfinite(value)


@pytest.mark.parametrize("line", ["$20=", "$20= ", "$20=abc", "$20=nan", "$20=inf", "$1=1e999",
                                  "$20=(soft limits)"])
def test_malformed_setting_lines_raise_device_error(line):
    with pytest.raises(DeviceError, match="setting"):
        parse_setting(line)


@pytest.mark.parametrize("line, expected", [("$20=1", (20, 1.0)), ("$100=80.000", (100, 80.0)),
                                            ("$0=10 (step pulse, usec)", (0, 10.0)),
                                            ("[MSG:'$H'|'$X' to unlock]", None),
                                            ("$N0=", None), ("$²=1", None)])
def test_setting_lines(line, expected):
    assert parse_setting(line) == expected


def test_settings_with_a_malformed_line_raise_device_error():
    pairs = [(b"$$\n", b"$20=1\r\n$100=\r\nok\r\n")]
    with expected_protocol(StageClient, pairs) as stage:
        with pytest.raises(DeviceError, match=r"\$100="):
            stage.settings()


# -- the sensor frame decoder ------------------------------------------------------------------

def _feed_in_chunks(data: bytes, cuts: list[int]) -> tuple[list, int, int]:
    decoder, frames, start = FrameDecoder(), [], 0
    for cut in sorted(set(c % (len(data) + 1) for c in cuts)) + [len(data)]:
        frames += decoder.feed(data[start:cut])
        start = cut
    return frames, decoder.corrupt, decoder.skipped_bytes


_SAMPLES = st.builds(encode_sample, st.integers(0, 0xFFFF), st.integers(0, 0xFFFFFFFF),
                     st.tuples(*[st.integers(-32768, 32767)] * 3), st.integers(0, 255))
_TEXTS = st.text(st.characters(min_codepoint=32, max_codepoint=126), min_size=1,
                 max_size=60).map(encode_text)
_FRAMES = st.one_of(_SAMPLES, _TEXTS)
# garbage rich in sync bytes and valid-looking headers
_NOISE = st.lists(st.sampled_from([b"\xa5", b"\x5a", b"\xa5\x5a", b"\x01\x0c", b"\x02", b"\x00",
                                   b"\xff"]), max_size=20).map(b"".join)


@FUZZ
@given(st.lists(st.one_of(st.binary(max_size=40), _NOISE, _FRAMES), max_size=12).map(b"".join),
       st.lists(st.integers(0, 10_000), max_size=8))
def test_any_bytes_in_any_chunking_decode_alike_and_never_raise(data, cuts):
    whole = _feed_in_chunks(data, [])
    assert _feed_in_chunks(data, cuts) == whole
    frames, corrupt, skipped = whole
    assert 0 <= skipped <= len(data) and corrupt <= skipped
    # a text frame decodes one character per payload byte; 6 bytes of sync, header and CRC
    encoded = sum(len(f) + 6 if isinstance(f, str) else SAMPLE_FRAME_BYTES for f in frames)
    assert encoded + skipped <= len(data)


@FUZZ
@given(st.lists(_FRAMES, min_size=1, max_size=10),
       st.lists(st.binary(min_size=1, max_size=20).filter(lambda b: b"\xa5" not in b),
                min_size=10, max_size=10),
       st.lists(st.booleans(), min_size=10, max_size=10),
       st.lists(st.integers(0, 10_000), max_size=8))
def test_frames_survive_stray_bytes_between_them(frames, noise, between, cuts):
    """Stray bytes without a sync byte cost no frame, and each run is one corruption event."""
    data = b"".join((noise[i] if between[i] else b"") + frame for i, frame in enumerate(frames))
    decoded, corrupt, skipped = _feed_in_chunks(data, cuts)
    assert len(decoded) == len(frames)
    assert corrupt == sum(between[:len(frames)])
    assert skipped == sum(len(noise[i]) for i in range(len(frames)) if between[i])
