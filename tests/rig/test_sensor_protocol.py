"""SensorClient against scripted byte pairs (docs/protocol.md, sensor)."""

import numpy as np
import pytest
from byte_pairs import expected_protocol

from whiskercal.errors import DeviceError
from whiskercal.protocol.frames import encode_sample, encode_text
from whiskercal.rig.sensor import SYNC_TIMEOUT_S, SensorClient, SensorCommandError

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


def test_sync_marks_the_first_sample_behind_the_answer_plus_one_period():
    # samples 0..3 were converted before the board read the sync command, 4.. after it; more of
    # the old ones arrive with the answer than the host had seen (a backlog in the OS)
    before, after = _samples(range(0, 4)), _samples(range(4, 7), start_us=4 * 3333)
    pairs = [(b"CFG?\n", CFG), (b"START\n", encode_text("OK") + _samples([])),
             (b"START\n", before + encode_text("OK") + after)]
    with expected_protocol(SensorClient, pairs) as sensor:
        sensor.start()
        fresh_from_s = sensor.sync()
        block = sensor.read(7, timeout_s=1)
    # the first sample behind the answer may have been triggered up to a period before the
    # board read the command: from one period after it, every sample is newer than the sync
    assert fresh_from_s == pytest.approx((4 * 3333 + 1e6 / 300) * 1e-6)
    np.testing.assert_array_equal(block.seq, range(7))  # nothing read on the way was lost


def test_sync_waits_for_a_sample_behind_the_answer():
    pairs = [(b"CFG?\n", CFG), (b"START\n", encode_text("OK")),
             (b"START\n", _samples([0, 1]) + encode_text("OK"))]
    with expected_protocol(SensorClient, pairs) as sensor:
        sensor.start()
        with pytest.raises(DeviceError, match="did not answer a sample after the sync answer"):
            sensor.sync()
        assert len(sensor.read_available()) == 2


def test_sync_refuses_a_board_that_is_not_streaming():
    with expected_protocol(SensorClient, []) as sensor:
        with pytest.raises(DeviceError, match="not streaming"):
            sensor.sync()


def test_start_and_sync_wait_the_clients_timeout_when_it_is_longer():
    # a host given a generous timeout (a busy machine, a board emulated in real time) must not
    # give up on START after the default 5 s
    with expected_protocol(SensorClient, [], timeout_s=30.0) as patient:
        assert patient.sync_timeout_s == 30.0
    with expected_protocol(SensorClient, []) as default:
        assert default.sync_timeout_s == SYNC_TIMEOUT_S > default.timeout_s


def test_a_lost_sync_answer_is_asked_for_again_only_when_frames_were_lost():
    corrupted = bytearray(encode_text("OK"))
    corrupted[5] ^= 0xFF  # the answer fails its CRC
    pairs = [(b"CFG?\n", CFG), (b"START\n", encode_text("OK")),
             (b"START\n", _samples([0]) + bytes(corrupted)),
             (b"START\n", encode_text("OK") + _samples([1], start_us=3333))]
    with expected_protocol(SensorClient, pairs) as sensor:
        sensor.start()
        assert sensor.sync() == pytest.approx((3333 + 1e6 / 300) * 1e-6)
    silent = [(b"CFG?\n", CFG), (b"START\n", encode_text("OK")), (b"START\n", _samples([0]))]
    with expected_protocol(SensorClient, silent) as sensor:
        sensor.start()
        with pytest.raises(DeviceError, match="did not answer 'START'"):
            sensor.sync()  # nothing was lost: the board did not answer, and is not asked twice


def test_close_closes_the_port_and_works_as_a_context_manager():
    from byte_pairs import ExpectedProtocolPort

    closed = []
    port = ExpectedProtocolPort([])
    port.close = lambda: closed.append(True)
    with SensorClient(port) as sensor:
        assert sensor.transport.port is port
    assert closed == [True]
