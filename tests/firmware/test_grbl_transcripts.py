"""The transcripts recorded from stock grbl 1.1h on simavr (tests/data/grbl_transcripts) replayed
against the client: its status and settings parsers, its code tables, and StageClient itself on
the recorded bytes. Needs no emulator: these run everywhere."""

import re

import numpy as np
import pytest

from grbl_transcript import TRANSCRIPTS, last_mpos, read_transcript, step_kinds, transcripts
from transcript_port import TranscriptPort
from whiskercal.protocol.codes import StageAlarm, describe
from whiskercal.rig.stage import StageAlarmError, StageClient, parse_setting, parse_status

GRBL_STATES = {"Idle", "Run", "Hold:0", "Hold:1", "Jog", "Alarm", "Door:0", "Door:1", "Door:2", "Door:3",
               "Check", "Home", "Sleep"}
STEP_MM = 1 / 80  # one motor step of the twin's belt ($100 = $101 = 80 steps/mm)


def _load(name):
    return read_transcript(TRANSCRIPTS / f"{name}.jsonl")


def _board_lines(entries):
    return [e["bytes"].rstrip("\r\n") for e in entries if e["dir"] == "board"]


def _step_of(header, key, value):
    return next(i for i, step in enumerate(header["steps"]) if step.get(key) == value)


def test_every_behaviour_has_a_transcript():
    names = {path.stem for path in transcripts()}
    assert names >= {"banner_settings", "home_stock_config", "home_xy", "home_polled", "home_xy_origin", "status_wpos", "feed_hold", "dwell",
                      "soft_limit", "error_codes"}


@pytest.mark.parametrize("path", transcripts(), ids=lambda p: p.stem)
def test_every_status_report_parses_with_a_grbl_state(path):
    _, entries = read_transcript(path)
    wco, reports = None, 0
    for line in _board_lines(entries):
        if line.startswith("<"):
            status = parse_status(line, wco)
            wco = status.wco_mm
            assert status.state in GRBL_STATES, line
            assert status.alarm == (status.state == "Alarm") and status.idle == (status.state == "Idle")
            reports += 1
    assert reports >= 1


@pytest.mark.parametrize("path", transcripts(), ids=lambda p: p.stem)
def test_every_code_has_a_message_and_every_setting_parses(path):
    _, entries = read_transcript(path)
    for line in _board_lines(entries):
        if (code := re.fullmatch(r"(error|ALARM):(\d+)", line)) is not None:
            kind = "STAGE_ERROR" if code.group(1) == "error" else "STAGE_ALARM"
            assert not describe(kind, int(code.group(2))).startswith("unknown code"), line
        elif line.startswith("$"):
            assert parse_setting(line) is not None, line


def test_settings_listing_is_grbls_full_table():
    header, entries = _load("banner_settings")
    settings = dict(parse_setting(line) for line in _board_lines(entries) if line.startswith("$"))
    assert len(settings) == 34  # grbl 1.1h lists every setting, whatever the board uses
    for number, value in header["owner_settings"].items():
        assert settings[int(number[1:])] == value


def test_xy_homing_leaves_the_machine_at_minus_travel_plus_pull_off():
    header, entries = _load("home_xy")
    home = _step_of(header, "send", "$H\n")
    assert step_kinds(entries, home) == ["ok"]
    mpos = last_mpos(entries, home + 1)
    settings = header["owner_settings"]
    expected = [-settings["$130"] + settings["$27"], -settings["$131"] + settings["$27"]]
    np.testing.assert_allclose(mpos, expected, atol=1e-9)  # -199, -199: grbl's negative machine space
    # +10 mm is beyond the travel (soft limits on): ALARM:2; a reset sent during the 500 ms grbl
    # waits after every ALARM line is lost, and only one sent after "Reset to continue" counts
    assert step_kinds(entries, home + 2) == ["ALARM:2"]
    assert step_kinds(entries, home + 3) == ["[MSG:Reset to continue]"]
    assert step_kinds(entries, home + 4) == ["ok", "banner", "[MSG:'$H'|'$X' to unlock]"]
    assert step_kinds(entries, home + 5) == ["status:Alarm"]
    np.testing.assert_allclose(last_mpos(entries, home + 5), expected, atol=1e-9)  # the position is kept


def test_set_origin_build_homes_to_zero_and_works_in_plus_travel():
    header, entries = _load("home_xy_origin")
    home = _step_of(header, "send", "$H\n")
    assert step_kinds(entries, home) == ["ok"]
    np.testing.assert_allclose(last_mpos(entries, home + 1), [0.0, 0.0], atol=1e-9)
    np.testing.assert_allclose(last_mpos(entries, home + 3), [10.0, 10.0], atol=1e-9)  # +10 mm is inside
    assert step_kinds(entries, home + 4) == ["ALARM:2", "[MSG:Reset to continue]"]  # -1 mm is not


def test_stock_config_homing_fails_on_the_missing_z_switch():
    header, entries = _load("home_stock_config")
    home = _step_of(header, "send", "$H\n")
    kinds = step_kinds(entries, home)
    # the alarm, 500 ms later the ok of $H, then the reset that ends every failed homing cycle
    assert kinds == ["ALARM:9", "ok", "banner", "[MSG:'$H'|'$X' to unlock]"]
    sent = next(e["t"] for e in entries if e["step"] == home and e["dir"] == "host")
    alarm = next(e["t"] for e in entries if e["step"] == home and e["bytes"].startswith("ALARM"))
    # one trapezoidal move over 1.5 x $132 at $25 with Z's acceleration $122, then the alarm
    seek_mm_s, accel = 500 / 60, 10.0
    assert alarm - sent == pytest.approx(1.5 * 200 / seek_mm_s + seek_mm_s / accel, abs=0.1)
    assert step_kinds(entries, home + 1) == ["status:Alarm"]


def test_homing_serves_no_status_request_until_it_ends():
    header, entries = _load("home_polled")
    polls = _step_of(header, "poll_until", "^Idle$")
    asked = [e["t"] for e in entries if e["step"] == polls and e["dir"] == "host"]
    reports = [e for e in entries if e["step"] == polls and e["bytes"].startswith("<")]
    ok = next(e["t"] for e in entries if e["bytes"] == "ok\r\n")
    assert len(asked) >= 20  # a '?' every second for 25 s ...
    assert reports[0]["bytes"].startswith("<Home|") and ok - reports[0]["t"] < 0.05  # ... one answer, at the end
    assert [r["bytes"][:5] for r in reports] == ["<Home", "<Idle"]


def test_wpos_plus_wco_is_the_machine_position():
    header, entries = _load("status_wpos")
    polls = [i for i, step in enumerate(header["steps"]) if step.get("check_mpos")]
    positions = [last_mpos(entries, i) for i in polls]
    for mpos in positions:  # the stage stands at (-5, -3) throughout; G92 only moves the work origin
        np.testing.assert_allclose(mpos, [-5.0, -3.0], atol=1e-9)
    wpos_step = _step_of(header, "send", "$10=0\n") + 1
    lines = [e["bytes"] for e in entries if e["step"] == wpos_step and e["bytes"].startswith("<")]
    assert all("WPos:0.000,0.000" in line and "MPos" not in line for line in lines)
    assert sum("WCO:" in line for line in lines) >= 1


def test_feed_hold_reports_hold_1_while_moving_and_hold_0_at_rest():
    header, entries = _load("feed_hold")
    hold = _step_of(header, "send", "!")
    wco, seen = None, []
    for entry in entries:
        if entry["dir"] == "board" and entry["bytes"].startswith("<"):
            status = parse_status(entry["bytes"].strip(), wco)
            wco = status.wco_mm
            if entry["step"] > hold:
                seen.append((status.state, status.mpos_mm[1], status.feed_mm_min))
    states = [s for s, _, _ in seen]
    first_rest = states.index("Hold:0")
    assert "Hold:1" in states[:first_rest]
    moving = [y for s, y, _ in seen if s == "Hold:1"]
    assert moving[0] > moving[-1]  # still travelling towards -Y while Hold:1
    resting = [(y, f) for s, y, f in seen if s == "Hold:0"]
    assert all(y == resting[0][0] and f == 0 for y, f in resting)
    assert states[-1] == "Idle"


def test_dwell_ok_comes_after_the_move_and_the_dwell():
    header, entries = _load("dwell")
    dwell = _step_of(header, "send", "G4 P0.5\n")
    sent = next(e["t"] for e in entries if e["step"] == dwell and e["dir"] == "host")
    ok = next(e["t"] for e in entries if e["step"] == dwell and e["bytes"] == "ok\r\n")
    # 60 mm at 3000 mm/min with 200 mm/s²: 0.25 s up, 0.95 s cruise, 0.25 s down; then 0.5 s
    assert ok - sent == pytest.approx(1.45 + 0.5, abs=0.05)


def test_soft_limit_alarm_recovery_order():
    header, entries = _load("soft_limit")
    alarm_step = _step_of(header, "send", "G90 G0 X10\n")
    lines = [e for e in entries if e["dir"] == "board" and e["step"] >= alarm_step]
    kinds = [step_kinds([e], e["step"]) for e in lines]
    flat = [k[0] for k in kinds if k]
    assert flat[:6] == ["ALARM:2", "[MSG:Reset to continue]", "ok", "banner", "[MSG:'$H'|'$X' to unlock]",
                        "status:Alarm"]
    alarm_t, message_t = lines[0]["t"], lines[1]["t"]
    assert message_t - alarm_t == pytest.approx(0.5, abs=0.01)  # grbl waits 500 ms after every ALARM line
    poll = alarm_step + 1  # the '?' sent during that pause is never answered
    assert not [k for k in step_kinds(entries, poll) if k.startswith("status:")]


def test_client_explains_the_stock_homing_failure_from_the_recorded_bytes():
    _, entries = _load("home_stock_config")
    client = StageClient(TranscriptPort(entries), timeout_s=2.0)
    with pytest.raises(StageAlarmError) as raised:
        client.home(timeout_s=60.0)
    assert raised.value.code == StageAlarm.HOMING_FAIL_APPROACH
    assert "config.h" in str(raised.value) and "\n" not in str(raised.value)


def test_client_reads_the_recorded_xy_homing_and_status():
    _, entries = _load("home_xy")
    client = StageClient(TranscriptPort(entries), timeout_s=2.0)
    client.home(timeout_s=60.0)
    status = client.status()
    np.testing.assert_allclose(status.mpos_mm, [-199.0, -199.0])
    assert status.idle and status.enc_mm is None


def test_client_recovers_from_the_recorded_soft_limit_alarm():
    _, entries = _load("soft_limit")
    client = StageClient(TranscriptPort(entries), timeout_s=2.0)
    client.command("$X")
    client.command("$20=1")
    with pytest.raises(StageAlarmError) as raised:
        client.command("G90 G0 X10")
    assert raised.value.code == StageAlarm.SOFT_LIMIT
    assert client.reset().startswith("Grbl 1.1h")
    client.unlock()
    assert client.status().idle


@pytest.mark.parametrize("name", ["error_codes"])
def test_error_codes_are_grbls(name):
    header, entries = _load(name)
    answers = {header["steps"][e["step"]]["send"].strip(): e["bytes"].strip() for e in entries
               if e["dir"] == "board" and "send" in header["steps"][e["step"]] and e["bytes"].startswith(("ok", "error"))}
    assert answers["G0 X-1"] == "error:9"  # locked after power-up with homing on
    assert answers["G5"] == "error:20" and answers["$99=1"] == "error:3" and answers["G4"] == "error:28"
    assert answers["T300"] == "error:38" and answers["$H"] == "error:5"
