"""The stage's code table reads a stock grbl 1.1 board as grbl means it."""

from whiskercal.protocol.codes import STAGE_ALARM_TEXT, STAGE_ERROR_TEXT, StageAlarm, describe

# grbl 1.1 (gnea/grbl v1.1h): error codes 1..38 but for the unused 18 and 19; alarms 1..10
GRBL_ERRORS = set(range(1, 39)) - {18, 19}
GRBL_ALARMS = set(range(1, 11))


def test_every_grbl_1_1_error_and_alarm_has_a_message():
    assert GRBL_ERRORS <= set(STAGE_ERROR_TEXT)
    assert GRBL_ALARMS <= set(STAGE_ALARM_TEXT)
    for code in GRBL_ERRORS:
        assert not describe("STAGE_ERROR", code).startswith("unknown code")


def test_grbl_alarm_10_is_the_dual_axis_homing_failure_not_an_encoder():
    assert "Homing fail" in describe("STAGE_ALARM", 10)
    assert StageAlarm.HOMING_FAIL_DUAL_APPROACH == 10


def test_whiskercal_own_alarms_collide_with_no_grbl_code():
    own = {StageAlarm.ENCODER_MISMATCH, StageAlarm.ENCODER_MAGNET, StageAlarm.ENCODER_BUS}
    # grblHAL's alarms stay below 30; grbl 1.1's end at 10
    assert min(own) >= 100 and not own & GRBL_ALARMS
