"""StageClient against scripted byte pairs (docs/protocol.md, stage)."""

import numpy as np
import pytest
from byte_pairs import expected_protocol

from whiskercal.errors import DeviceError
from whiskercal.rig.stage import StageAlarmError, StageClient, StageCommandError, parse_status

IDLE_ENC = b"<Idle|MPos:12.000,-3.000,0.000|FS:0,0|Enc:11.998,-3.004>\r\n"


def test_identify_whiskercal_firmware_with_banner():
    pairs = [(None, b"\r\nGrbl 1.1h ['$' for help]\r\n"),
             (b"$I\n", b"[VER:1.1h.20190825:whiskercal-stage]\r\n[OPT:V,15,128]\r\n"
                       b"[PROTO:whiskercal-stage-1]\r\nok\r\n"),
             (b"?", IDLE_ENC)]
    with expected_protocol(StageClient, pairs) as stage:
        identity = stage.identify()
    assert identity.whiskercal_firmware and identity.has_encoder
    assert identity.proto == "whiskercal-stage-1"
    assert identity.name == "whiskercal-stage"
    assert identity.banner.startswith("Grbl 1.1h")


def test_identify_stock_grbl_has_no_encoder():
    pairs = [(b"$I\n", b"[VER:1.1h.20190825:]\r\n[OPT:V,15,128]\r\nok\r\n"),
             (b"?", b"<Idle|MPos:0.000,0.000,0.000|FS:0,0|WCO:0.000,0.000,0.000>\r\n")]
    with expected_protocol(StageClient, pairs) as stage:
        identity = stage.identify()
    assert not identity.whiskercal_firmware and not identity.has_encoder


def test_status_fields():
    with expected_protocol(StageClient, [(b"?", IDLE_ENC)]) as stage:
        status = stage.status()
    assert status.state == "Idle" and status.idle
    np.testing.assert_array_equal(status.mpos_mm, [12.0, -3.0])
    np.testing.assert_array_equal(status.enc_mm, [11.998, -3.004])


def test_status_ignores_unknown_fields_in_any_order():
    status = parse_status("<Run|FS:1500,0|Ov:100,100,100|MPos:1.5,2.5,0.0|Pn:X>")
    assert status.state == "Run" and status.feed == 1500 and status.pins == "X"
    assert status.enc_mm is None


def test_move_and_wait_idle_polls_until_idle():
    polled = []
    pairs = [(b"G90 G1 X50.000 Y10.000 F3000.0\n", b"ok\r\n"),
             (b"?", b"<Run|MPos:10.000,2.000,0.000|FS:3000,0|Enc:10.000,2.000>\r\n"),
             (b"?", b"<Run|MPos:40.000,8.000,0.000|FS:3000,0|Enc:40.000,8.000>\r\n"),
             (b"?", b"<Idle|MPos:50.000,10.000,0.000|FS:0,0|Enc:50.000,10.000>\r\n")]
    with expected_protocol(StageClient, pairs) as stage:
        stage.move_to(50, 10, 3000)
        final = stage.wait_idle(10, on_poll=polled.append)
    assert [s.state for s in polled] == ["Run", "Run", "Idle"]
    np.testing.assert_array_equal(final.mpos_mm, [50, 10])


def test_pushed_alarm_during_wait_raises_with_table_text():
    pairs = [(b"?", b"<Run|MPos:10.000,2.000,0.000|FS:3000,0|Enc:9.000,2.000>\r\nALARM:100\r\n")]
    with expected_protocol(StageClient, pairs) as stage:
        with pytest.raises(StageAlarmError, match="ALARM:100: Encoder and step positions disagree") as info:
            stage.wait_idle(10)
    assert info.value.code == 100


def test_error_reply_raises_with_table_text():
    pairs = [(b"G90 G1 X500.000 Y0.000 F1000.0\n", b"error:15\r\n")]
    with expected_protocol(StageClient, pairs) as stage:
        with pytest.raises(StageCommandError, match="error:15: Target exceeds machine travel"):
            stage.move_to(500, 0, 1000)


def test_settings_home_unlock_hold_resume_reset():
    pairs = [(b"$$\n", b"$20=1\r\n$100=80.000\r\n$201=40.000\r\nok\r\n"),
             (b"$110=2500\n", b"ok\r\n"),
             (b"$H\n", b"ok\r\n"),
             (b"$X\n", b"[MSG:Caution: Unlocked]\r\nok\r\n"),
             (b"!", None), (b"~", None),
             (b"\x18", b"\r\nGrbl 1.1h ['$' for help]\r\n"),
             (None, b"[MSG:'$H'|'$X' to unlock]\r\n"),
             (b"G4 P0.500\n", b"ok\r\n")]
    with expected_protocol(StageClient, pairs) as stage:
        assert stage.settings() == {20: 1.0, 100: 80.0, 201: 40.0}
        stage.set_setting(110, 2500)
        stage.home()
        stage.unlock()
        stage.hold()
        stage.resume()
        assert stage.reset().startswith("Grbl 1.1h")
        stage.dwell(0.5)


def test_silence_times_out_with_clear_message_after_asking_again():
    with expected_protocol(StageClient, [(b"?", None)] * 3) as stage:
        with pytest.raises(DeviceError, match="did not answer the status request '.' within 2 s"):
            stage.status()


def test_an_unanswered_status_request_is_sent_again():
    # grbl drops a '?' during an alarm's pause; the second one is answered
    report = b"<Alarm|MPos:1.000,2.000,0.000|FS:0,0>\r\n"
    with expected_protocol(StageClient, [(b"?", None), (b"?", report)]) as stage:
        status = stage.status()
    assert status.state == "Alarm" and status.alarm


def test_wait_idle_raises_in_alarm_state():
    pairs = [(b"?", b"<Alarm|MPos:0.000,0.000,0.000|FS:0,0>\r\n")]
    with expected_protocol(StageClient, pairs) as stage:
        with pytest.raises(DeviceError, match="in alarm"):
            stage.wait_idle(5)


def test_close_closes_the_port_and_works_as_a_context_manager():
    from byte_pairs import ExpectedProtocolPort

    closed = []
    port = ExpectedProtocolPort([])
    port.close = lambda: closed.append(True)
    with StageClient(port) as stage:
        assert stage.transport.port is port
    assert closed == [True]


def test_wpos_reports_give_the_machine_position_through_the_last_wco():
    first = parse_status("<Idle|WPos:1.000,2.000,0.000|FS:0,0|WCO:10.000,-5.000,0.000>")
    np.testing.assert_allclose(first.mpos_mm, [11.0, -3.0])
    later = parse_status("<Run|WPos:3.000,4.000,0.000|FS:600,0>", first.wco_mm)
    np.testing.assert_allclose(later.mpos_mm, [13.0, -1.0])
    np.testing.assert_allclose(later.wco_mm, [10.0, -5.0])  # kept for the next report


def test_the_twin_reports_wpos_and_wco_when_dollar_10_asks_and_the_client_follows():
    import uuid

    from whiskercal.twin.world import create_world

    world = create_world(f"wpos{uuid.uuid4().hex[:8]}", stock=True)
    stage = StageClient(f"sim://{world.name}/stage")
    stage.identify()
    stage.command("$10=0")
    stage.unlock()
    stage.move_to(-12.0, -7.0, 1200)  # stock grbl's machine space is -travel..0
    stage.wait_idle(10)
    reports = [stage.status() for _ in range(25)]
    assert reports[-1].idle
    np.testing.assert_allclose(reports[-1].mpos_mm, [-12.0, -7.0], atol=1e-3)
    assert all(report.wco_mm is not None for report in reports)


def test_stock_grbl_answers_g4_after_the_queued_moves_and_the_dwell_and_the_client_waits():
    import uuid

    from whiskercal.twin.world import create_world

    times = {}
    for stock in (True, False):
        world = create_world(f"dwell{uuid.uuid4().hex[:8]}", stock=stock)
        stage = StageClient(f"sim://{world.name}/stage")
        stage.identify()
        stage.unlock()
        start = stage.transport.now_s()
        # 3 s of motion at 20 mm/s (plus the ramps); stock grbl works in -travel..0
        stage.move_to(-60.0 if stock else 60.0, 0.0, 1200)
        stage.dwell(1.0)
        times[stock] = stage.transport.now_s() - start
        assert stage.status().idle == stock  # grbl's ok means the moves and the dwell are done
    assert times[True] > 4.0  # waited for the move (> 3 s) and then the dwell (1 s)
    assert times[False] < 0.5  # whiskercal's firmware queues the dwell and answers at once
