"""The twin's stock grbl 1.1 mode: grbl's machine space after homing and its soft-limit alarm.

What is asserted is gnea/grbl 1.1h's behaviour (limits_go_home, system_check_travel_limits,
limits_soft_check and protocol_exec_rt_system), for the twin's stage, whose homing switches sit
at the minimum of X and Y: $23=3, $27=1 mm, $130=$131=200 mm.
"""

import itertools

import numpy as np
import pytest
from test_world_standin import RigidWhiskerPhysics

import whiskercal.rig  # noqa: F401  (registers sim://)
from whiskercal.rig.stage import StageAlarmError, StageClient
from whiskercal.twin.world import create_world

_names = itertools.count()
BANNER = "Grbl 1.1h ['$' for help]"


def _world(**options):
    return create_world(f"stock-space-{next(_names)}", physics=RigidWhiskerPhysics(), stock=True,
                        homing="xy", **options)


def _lines(port, wait_s: float) -> list[str]:
    """Every line the board sends within ``wait_s`` simulated seconds."""
    buffer = b""
    deadline = port.now_s() + wait_s
    while port.now_s() < deadline:
        buffer += port.read(1) + port.read(port.in_waiting)
    return [line.decode().rstrip("\r") for line in buffer.split(b"\n") if line.strip()]


def test_after_homing_stock_grbl_stands_at_minus_travel_plus_pulloff_and_works_in_minus_travel_to_0():
    world = _world()
    stage = StageClient(f"sim://{world.name}/stage")
    stage.home()
    status = stage.status()
    np.testing.assert_allclose(status.mpos_mm, [-199.0, -199.0])  # -$130 + $27
    true_after_homing = world.stage_true_mm(world.now_s)
    stage.move_to(-150.0, -120.0, 3000)  # 49 mm and 79 mm from where homing ended
    np.testing.assert_allclose(stage.wait_idle(20).mpos_mm, [-150.0, -120.0])
    np.testing.assert_allclose(world.stage_true_mm(world.now_s) - true_after_homing, [49.0, 79.0],
                               atol=0.02)  # the belt's backlash
    with pytest.raises(StageAlarmError, match="ALARM:2"):
        stage.move_to(10.0, -120.0, 3000)  # inside 0..travel, outside grbl's -travel..0


def test_a_force_set_origin_build_homes_to_0_and_works_in_0_to_travel():
    stage = StageClient(f"sim://{_world(origin='set').name}/stage")
    stage.home()
    np.testing.assert_allclose(stage.status().mpos_mm, [0.0, 0.0])
    stage.move_to(50.0, 80.0, 3000)
    np.testing.assert_allclose(stage.wait_idle(20).mpos_mm, [50.0, 80.0])
    with pytest.raises(StageAlarmError, match="ALARM:2"):
        stage.move_to(-5.0, 80.0, 3000)


def test_homing_toward_the_maximum_finds_no_switch_on_this_stage():
    stage = StageClient(f"sim://{_world().name}/stage")
    stage.set_setting(23, 0)  # grbl's default: home toward +, where the stage has no switch
    with pytest.raises(StageAlarmError, match=r"ALARM:9.*\$23"):
        stage.home()


def test_a_soft_limit_while_moving_holds_then_alarms_and_only_a_reset_ends_the_pause():
    world = _world()
    stage = StageClient(f"sim://{world.name}/stage")
    stage.home()
    port = stage.transport.port  # the raw line from here on
    port.timeout = 0.01
    port.write(b"G53 G1 X-100 Y-199 F3000\n")  # 99 mm, about 2 s at 50 mm/s
    assert _lines(port, 0.5) == ["ok"]
    port.write(b"G53 G1 X5 Y-199 F3000\n")  # beyond machine 0: grbl's soft limit
    port.write(b"?")
    assert _lines(port, 0.05)[0].startswith("<Hold:1|")  # grbl's feed hold decelerates first
    alarm = _lines(port, 2.0)
    assert alarm == ["ALARM:2", "[MSG:Reset to continue]"]  # and the line gets no answer yet
    stopped = world.stage.machine_mm(world.now_s).copy()
    port.write(b"?")
    port.write(b"G53 G1 X-150\n")
    port.write(b"$X\n")
    assert _lines(port, 1.0) == []  # the pause: no report, no line taken
    port.write(b"\x18")  # grbl returns from the refused line (its ok), then resets
    assert _lines(port, 0.2) == ["ok", BANNER, "[MSG:'$H'|'$X' to unlock]"]
    port.write(b"?")
    assert _lines(port, 0.1)[0].startswith("<Alarm|")
    port.write(b"$X\n")
    assert _lines(port, 0.1) == ["[MSG:Caution: Unlocked]", "ok"]
    np.testing.assert_allclose(world.stage.machine_mm(world.now_s), stopped)  # position kept
    assert -199.0 < stopped[0] < -100.0  # stopped on the way, by the hold


def test_the_client_recovers_in_grbls_order_and_keeps_the_position():
    world = _world()
    stage = StageClient(f"sim://{world.name}/stage")
    stage.home()
    with pytest.raises(StageAlarmError) as info:
        stage.command("G53 G1 X5 Y-199 F3000")
    assert info.value.code == 2
    stage.recover(info.value.code)
    status = stage.status()
    assert status.idle
    np.testing.assert_allclose(status.mpos_mm, [-199.0, -199.0])
    stage.move_to(-190.0, -190.0, 3000)
    assert stage.wait_idle(10).idle


def test_grbls_own_z_first_homing_fails_then_answers_its_ok_and_resets_with_z_stepped_out():
    world = create_world(f"stock-space-{next(_names)}", physics=RigidWhiskerPhysics(), stock=True)
    stage = StageClient(f"sim://{world.name}/stage")
    stage.status()  # the power-up banner read
    port = stage.transport.port
    port.timeout = 0.01
    port.write(b"$H\n")
    port.write(b"?")  # grbl's homing cycle serves no report; the failed one none at all
    # config.h's Z cycle searches 1.5 x $132 = 300 mm at $25 = 500 mm/min: 36 s, in vain
    assert _lines(port, 35.9) == []
    assert _lines(port, 0.2) == ["ALARM:9"]
    port.write(b"?")  # lost in the alarm's pause
    assert _lines(port, 0.35) == []
    assert _lines(port, 0.1) == ["ok", BANNER, "[MSG:'$H'|'$X' to unlock]"]
    port.write(b"?")
    assert _lines(port, 0.1)[0].startswith("<Alarm|MPos:0.000,0.000,300.000|")  # Z's counter: 1.5 x $132
