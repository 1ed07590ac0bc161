"""SensorClient against scripted byte pairs (docs/protocol.md, sensor)."""

import numpy as np
import pytest
from byte_pairs import expected_protocol

from whiskercal.errors import DeviceError
from whiskercal.protocol.frames import encode_sample, encode_text
from whiskercal.rig.sensor import SensorClient, SensorCommandError

CFG = encode_text("OK rate=300 gain=5 res=2 osr=0 filt=2")


def _samples(seqs, period_us=3333, start_us=0, counts=(10, -20, 30)):
    return b"".join(encode_sample(s, start_us + i * period_us, counts, 0) for i, s in enumerate(seqs))


def test_identify_and_config():
    pairs = [(b"ID\n", encode_text("OK whisker_nano fw=0.1.0 proto=1")), (b"CFG?\n", CFG)]
    with expected_protocol(SensorClient, pairs) as sensor:
        assert sensor.identify() == "whisker_nano fw=0.1.0 proto=1"
        config = sensor.config()
    assert (config.rate_hz, config.gain, config.res, config.osr, config.filt) == (300, 5, 2, 0, 2)


def test_configure_sends_each_setting_then_reads_back():
    pairs = [(b"RATE 200\n", encode_text("OK")), (b"GAIN 6\n", encode_text("OK")),
             (b"CFG?\n", encode_text("OK rate=200 gain=6 res=2 osr=0 filt=2"))]
    with expected_protocol(SensorClient, pairs) as sensor:
        assert sensor.configure(rate_hz=200, gain=6).rate_hz == 200


def test_error_answer_raises_with_table_text():
    pairs = [(b"RATE 500\n", encode_text("ERR:4"))]
    with expected_protocol(SensorClient, pairs) as sensor:
        with pytest.raises(SensorCommandError, match="ERR:4: Conversion time") as info:
            sensor.configure(rate_hz=500)
    assert info.value.code == 4


def test_stream_unwraps_seq_and_time_and_converts_to_uT():
    seqs = [65534, 65535, 0, 1]
    start_us = 2**32 - 5000
    pairs = [(b"CFG?\n", CFG), (b"START\n", encode_text("OK") + _samples(seqs, start_us=start_us))]
    with expected_protocol(SensorClient, pairs) as sensor:
        sensor.start()
        block = sensor.read(4, timeout_s=1)
    np.testing.assert_array_equal(block.seq, [65534, 65535, 65536, 65537])
    np.testing.assert_allclose(np.diff(block.t_s), 3333e-6)
    # GAIN_SEL 5, RES 2 (the CFG? answer): 1.000 µT/LSB on X/Y, 1.612 on Z
    np.testing.assert_allclose(block.field_uT[0], [10 * 1.000, -20 * 1.000, 30 * 1.612])
    assert block.dropped == 0 and block.corrupt == 0


def test_samples_during_a_command_are_kept_and_gaps_are_drops():
    pairs = [(b"CFG?\n", CFG), (b"START\n", encode_text("OK") + _samples([0, 1])),
             (b"STOP\n", _samples([2, 5, 6]) + encode_text("OK"))]
    with expected_protocol(SensorClient, pairs) as sensor:
        sensor.start()
        sensor.stop()
        block = sensor.read(5, timeout_s=1)
    np.testing.assert_array_equal(block.seq, [0, 1, 2, 5, 6])
    assert block.dropped == 2 and sensor.dropped == 2


def test_corrupt_frame_is_counted_and_skipped():
    good = [encode_sample(i, i * 3333, (i, i, i), 0) for i in range(4)]
    bad = bytearray(good[1])
    bad[8] ^= 0xFF
    pairs = [(b"CFG?\n", CFG), (b"START\n", encode_text("OK") + good[0] + bytes(bad) + good[2] + good[3])]
    with expected_protocol(SensorClient, pairs) as sensor:
        sensor.start()
        block = sensor.read(3, timeout_s=1)
    np.testing.assert_array_equal(block.seq, [0, 2, 3])
    assert block.corrupt == 1 and block.dropped == 1


def test_too_few_samples_time_out_clearly():
    pairs = [(b"CFG?\n", CFG), (b"START\n", encode_text("OK") + _samples([0, 1]))]
    with expected_protocol(SensorClient, pairs) as sensor:
        sensor.start()
        with pytest.raises(DeviceError, match="delivered 2 of 10 samples"):
            sensor.read(10, timeout_s=0.5)


def test_silent_board_times_out_after_three_tries():
    with expected_protocol(SensorClient, [(b"ID\n", None)] * 3) as sensor:
        with pytest.raises(DeviceError, match="did not answer 'ID'"):
            sensor.identify()


def test_identify_repeats_id_while_the_board_boots():
    pairs = [(b"ID\n", None), (b"ID\n", encode_text("OK whisker_nano fw=0.1.0 proto=1"))]
    with expected_protocol(SensorClient, pairs) as sensor:
        assert sensor.identify().startswith("whisker_nano")
