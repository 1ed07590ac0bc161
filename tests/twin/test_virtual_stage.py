"""The virtual stage board answers docs/protocol.md's stage protocol over sim://."""

import itertools
import time

import numpy as np
import pytest
import serial
from test_world_standin import RigidWhiskerPhysics

import whiskercal.rig  # noqa: F401  (registers sim://)
from whiskercal.rig.stage import StageAlarmError, StageClient, StageCommandError
from whiskercal.twin.world import create_world

_names = itertools.count()


def _world(**options):
    return create_world(f"stage-test-{next(_names)}", physics=RigidWhiskerPhysics(), **options)


def _port(world):
    return serial.serial_for_url(f"sim://{world.name}/stage", timeout=1.0)


def _lines_until(port, last, timeout_s=1.0, stop_on=("error:", "ALARM:")):
    """Read lines until one starts with ``last`` (or ``stop_on``); return them all."""
    lines, buffer = [], b""
    deadline = port.now_s() + timeout_s
    while port.now_s() <= deadline:
        buffer += port.read(1) + port.read(port.in_waiting)
        while b"\n" in buffer:
            line, buffer = buffer.split(b"\n", 1)
            lines.append(line.decode().rstrip("\r"))
            if lines[-1].startswith((last, *stop_on)):
                return lines
    raise AssertionError(f"no {last!r} within {timeout_s} s: {lines}")


def _send(port, line):
    port.write(line.encode() + b"\n")
    return _lines_until(port, "ok")


def _status(port):
    port.write(b"?")
    return _lines_until(port, "<")[-1]


def test_power_up_banner_and_alarm_lock():
    port = _port(_world())
    lines = _lines_until(port, "[MSG:")
    assert "Grbl 1.1h ['$' for help]" in lines and lines[-1] == "[MSG:'$H'|'$X' to unlock]"
    assert _status(port).startswith("<Alarm|MPos:0.000,0.000,0.000|FS:0,0|Enc:")
    assert _send(port, "G0 X1")[-1] == "error:9"
    assert _send(port, "$X") == ["[MSG:Caution: Unlocked]", "ok"]
    assert _status(port).startswith("<Idle|")


def test_build_info_and_settings():
    port = _port(_world())
    _lines_until(port, "[MSG:")
    assert _send(port, "$I") == ["[VER:1.1h.0.1.0:whiskercal-stage]", "[OPT:V,15,128]",
                                 "[PROTO:whiskercal-stage-1]", "ok"]
    settings = dict(line.split("=") for line in _send(port, "$$")[:-1])
    for number, default in {"$100": 80, "$110": 3000, "$120": 200, "$130": 200, "$200": 1,
                            "$201": 40, "$202": 0.5, "$20": 1, "$22": 1}.items():
        assert float(settings[number]) == default
    assert _send(port, "$110=2500") == ["ok"]
    assert "$110=2500.000" in _send(port, "$$")
    assert _send(port, "$999=1") == ["error:3"]
    assert _send(port, "$110=-5") == ["error:4"]
    assert _send(port, "$") [-1] == "ok"
    assert _send(port, "$Q") == ["error:3"]


@pytest.mark.parametrize("line, code", [
    ("G1 X10 Y10", 22), ("G1 X10 F-5", 4), ("G0 X500", 15), ("G0 Y-1", 15), ("G2 X1", 20),
    ("G0 G1 X1", 24), ("G0 X1 X2", 25), ("G4", 28), ("G4 G4 P1", 21), ("G90 G91", 21), ("G1", 22),
    ("G0 Z1", 20), ("G1 X1 F0", 22), ("G1 X1 F100 G0 X2", 24), ("M3", 20), ("G0 X1" + " " * 90, 11),
    ("G0 X", 2), ("12", 1),
])
def test_gcode_errors(line, code):
    port = _port(_world())
    _send(port, "$X")
    assert _send(port, line) == [f"error:{code}"]


def test_modal_moves_g90_g91_g21_and_dwell():
    world = _world()
    port = _port(world)
    _send(port, "$X")
    for line in ("G21", "G90 G0 X10 Y20", "G91 G1 X5 F600", "G4 P0.25", "G90"):
        assert _send(port, line) == ["ok"]
    while not _status(port).startswith("<Idle"):
        pass
    assert "MPos:15.000,20.000,0.000" in _status(port)


def test_dwell_comes_before_the_move_of_its_block():
    world = _world()
    port = _port(world)
    _send(port, "$X")
    assert _send(port, "G17 G21 G90 G94") == ["ok"]
    started_s = world.now_s
    assert _send(port, "G0 G4 P0.5 X10") == ["ok"]
    while world.now_s < started_s + 0.4:
        assert "MPos:0.000,0.000" in _status(port)  # still dwelling
    while not _status(port).startswith("<Idle"):
        pass
    assert "MPos:10.000,0.000,0.000" in _status(port)


def test_move_takes_trapezoid_time_and_little_wall_time():
    world = _world()
    stage = StageClient(f"sim://{world.name}/stage")
    stage.unlock()
    start_s = world.now_s
    wall = time.perf_counter()
    stage.move_to(50, 0, 3000)
    stage.wait_idle(10)
    wall = time.perf_counter() - wall
    simulated = world.now_s - start_s
    speed, accel = 3000 / 60, 200.0  # mm/s, mm/s² ($120)
    expected = 50 / speed + speed / accel  # cruise + the time lost accelerating and braking
    # the client notices Idle within one poll interval (20 ms) plus a status line on the wire
    assert expected <= simulated <= expected + 0.03
    assert wall < simulated / 5


def test_feed_hold_resume_and_status_while_moving():
    world = _world()
    stage = StageClient(f"sim://{world.name}/stage")
    stage.unlock()
    stage.move_to(100, 0, 1200)
    stage.transport.read_some(1, 1.0)  # let 1 s pass: ramped up and cruising
    moving = stage.status()
    assert moving.state == "Run" and moving.feed == pytest.approx(1200)
    stage.hold()
    reports = [stage.status() for _ in range(40)]
    states = [report.state for report in reports]
    assert states[0] == "Hold:1" and states[-1] == "Hold:0"  # GRBL 1.1: 1 decelerating, 0 complete
    first_rest = states.index("Hold:0")
    assert set(states[:first_rest]) == {"Hold:1"} and set(states[first_rest:]) == {"Hold:0"}
    assert not np.array_equal(reports[0].mpos_mm, reports[first_rest - 1].mpos_mm)  # still moving
    for report in reports[first_rest:]:
        np.testing.assert_array_equal(report.mpos_mm, reports[first_rest].mpos_mm)
    held = stage.status().mpos_mm
    stage.transport.read_some(1, 0.5)
    np.testing.assert_array_equal(stage.status().mpos_mm, held)
    stage.resume()
    final = stage.wait_idle(10)
    np.testing.assert_array_equal(final.mpos_mm, [100, 0])


def test_soft_reset_during_motion_alarms_and_reprints_banner():
    world = _world()
    stage = StageClient(f"sim://{world.name}/stage")
    stage.unlock()
    stage.move_to(100, 0, 3000)
    stage.transport.read_some(1, 0.3)
    port = stage.transport.port
    port.write(b"\x18")
    lines = _lines_until(port, "[MSG:", stop_on=())
    assert "ALARM:3" in lines and "Grbl 1.1h ['$' for help]" in lines
    assert _status(port).startswith("<Alarm")


def test_homing_sets_machine_zero_at_the_switches():
    world = _world()
    stage = StageClient(f"sim://{world.name}/stage")
    stage.home()
    status = stage.status()
    assert status.idle
    np.testing.assert_array_equal(status.mpos_mm, [0, 0])
    # machine zero is now the physical zero the rig geometry refers to
    np.testing.assert_allclose(world.stage_true_mm(world.now_s), [0, 0], atol=world.stage.backlash_mm)


def test_homing_disabled_is_refused():
    port = _port(_world())
    _send(port, "$X")
    _send(port, "$22=0")
    assert _send(port, "$H") == ["error:5"]


def test_stock_mode_has_no_encoder_field_or_proto():
    world = _world(stock=True)
    stage = StageClient(f"sim://{world.name}/stage")
    identity = stage.identify()
    assert not identity.has_encoder and identity.proto is None
    assert stage.status().enc_mm is None
    with pytest.raises(StageCommandError, match="error:3"):
        stage.set_setting(200, 1)


def _faulty_stage(**faults):
    from whiskercal.twin.devices.stage import StageFaults

    world = _world(stage_faults=StageFaults(**faults))
    stage = StageClient(f"sim://{world.name}/stage")
    stage.unlock()
    return world, stage


def test_missed_steps_raise_the_encoder_alarm():
    world, stage = _faulty_stage(missed_steps_at_s=0.5)
    stage.move_to(80, 0, 3000)
    with pytest.raises(StageAlarmError, match="ALARM:100") as info:
        stage.wait_idle(10)
    assert info.value.code == 100
    assert 0.5 <= world.now_s < 0.6
    assert stage.status().alarm


def test_stall_raises_alarm_10_once_the_disagreement_exceeds_tolerance():
    world, stage = _faulty_stage(stall_at_s=0.3)
    stage.move_to(80, 0, 3000)
    with pytest.raises(StageAlarmError, match="ALARM:100"):
        stage.wait_idle(10)
    status = stage.status()
    assert np.max(np.abs(status.mpos_mm - status.enc_mm)) > 0.5


def test_missing_encoder_magnet_raises_alarm_11_and_relocks_after_unlock():
    world, stage = _faulty_stage(encoder_magnet_at_s=0.2)
    stage.move_to(30, 0, 3000)
    with pytest.raises(StageAlarmError, match="ALARM:101"):
        stage.wait_idle(10)
    with pytest.raises(StageAlarmError, match="ALARM:101"):
        stage.unlock()
        stage.status()


def test_stock_grbl_does_not_notice_missed_steps():
    from whiskercal.twin.devices.stage import StageFaults

    world = _world(stock=True, stage_faults=StageFaults(missed_steps_at_s=0.5))
    stage = StageClient(f"sim://{world.name}/stage")
    stage.unlock()  # unhomed, stock grbl's machine space is still -travel..0 from power-up
    stage.move_to(0, -80, 3000)
    final = stage.wait_idle(10)
    assert final.idle and final.mpos_mm[1] == -80
    # the ground truth knows the carriage is 1 mm short
    start = np.asarray(world.config.stage_start_mm)
    assert start[1] - world.stage_true_mm(world.now_s)[1] == pytest.approx(79, abs=0.02)


def test_backlash_is_cancelled_by_approaching_from_one_side():
    world = _world(backlash_mm=0.1)
    stage = StageClient(f"sim://{world.name}/stage")
    stage.unlock()
    true_positions = []
    for via in (60, 40, 60):
        stage.move_to(via, 0, 3000)
        stage.wait_idle(10)
        stage.move_to(50, 0, 3000)
        stage.wait_idle(10)
        true_positions.append(world.stage_true_mm(world.now_s)[0])
    assert true_positions[0] == pytest.approx(true_positions[2], abs=1e-9)
    assert abs(true_positions[0] - true_positions[1]) == pytest.approx(0.1, abs=1e-9)


def test_encoder_reads_the_pulley_to_a_twelve_bit_step():
    world = _world()
    stage = StageClient(f"sim://{world.name}/stage")
    stage.unlock()
    stage.move_to(33.3333, 12.3456, 3000)
    status = stage.wait_idle(10)
    assert np.max(np.abs(status.enc_mm - status.mpos_mm)) <= 40 / 4096 / 2 + 1e-9
    # targets are whole steps (80 per mm); the report shows 3 decimals
    assert status.mpos_mm[0] == pytest.approx(round(33.3333 * 80) / 80, abs=5e-4)


def test_a_refused_block_changes_no_modal_state():
    port = _port(_world())
    _send(port, "$X")
    assert _send(port, "G91 G0 X1 M3") == ["error:20"]  # refused: G91 must not stick
    assert _send(port, "G0 X5") == ["ok"]
    assert _send(port, "G0 X5") == ["ok"]
    while not _status(port).startswith("<Idle"):
        pass
    assert "MPos:5.000,0.000" in _status(port)


def test_bad_setting_value_is_a_number_format_error():
    port = _port(_world())
    _lines_until(port, "[MSG:")
    assert _send(port, "$100=x") == ["error:2"]


def test_stock_homing_searches_z_first_then_alarms_9_and_resets_unless_the_board_homes_xy():
    port = _port(_world(stock=True))
    _lines_until(port, "[MSG:")  # the power-up banner
    port.write(b"$H\n")
    start = port.now_s()
    assert _lines_until(port, "ALARM:", timeout_s=60.0) == ["ALARM:9"]
    assert port.now_s() - start > 30.0  # 1.5 x 200 mm of Z searched at 500 mm/min
    after = _lines_until(port, "[MSG:", stop_on=())
    assert any(line.startswith("Grbl 1.1h") for line in after)  # reset after the failed cycle
    xy = StageClient(f"sim://{_world(stock=True, homing='xy').name}/stage")
    xy.home()
    assert xy.status().idle
