"""RigSession against small scripted clients: frames, measuring by the sensor's clock, every exit."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from whiskercal.errors import DeviceError
from whiskercal.protocol.codes import StageAlarm
from whiskercal.protocol.sensor_config import SensorConfig
from whiskercal.rig.sensor import SampleBlock
from whiskercal.rig.stage import StageAlarmError, StageIdentity, StageStatus
from whiskercal.session import (EncoderMismatchError, RigFrame, RigSession, SessionConfig,
                                outside_travel)

RATE_HZ = 100


class Stage:
    """A stage that reaches every target after ``polls_per_move`` status polls."""

    def __init__(self, homed: bool = True, travel=(200.0, 200.0), polls_per_move: int = 3) -> None:
        self.state = "Idle" if homed else "Alarm"
        self.position = np.zeros(2)
        self.travel, self.polls_per_move = travel, polls_per_move
        self.log: list[str] = []
        self.alarm_on_arrival: int | None = None
        self.closed = False

    def identify(self) -> StageIdentity:
        return StageIdentity("1.1h.0", "stage", "V", "whiskercal-stage-1", True)

    def settings(self) -> dict[int, float]:
        return {} if self.travel is None else {130: self.travel[0], 131: self.travel[1]}

    def status(self) -> StageStatus:
        return StageStatus(self.state, self.position.copy(), self.position.copy(), 0.0)

    def home(self) -> None:
        self.log.append("$H")
        self.state = "Idle"

    def move_to(self, x_mm: float, y_mm: float, feed_mm_min: float) -> None:
        self.log.append(f"G1 X{x_mm:g} Y{y_mm:g}")
        self.target, self.state = np.array([x_mm, y_mm]), "Run"

    def wait_idle(self, timeout_s: float = 60.0, on_poll=None) -> StageStatus:
        for _ in range(self.polls_per_move):
            on_poll(self.status())
        if self.alarm_on_arrival is not None:
            self.state = "Alarm"
            raise StageAlarmError(self.alarm_on_arrival, "scripted")
        self.position, self.state = self.target, "Idle"
        status = self.status()
        on_poll(status)
        return status

    def hold(self) -> None:
        self.log.append("!")
        self.state = "Hold:0"

    def reset(self) -> None:
        self.log.append("reset")
        self.state = "Idle"

    def unlock(self) -> None:
        self.log.append("$X")

    def close(self) -> None:
        self.closed = True


class Sensor:
    """A sensor whose host is behind: ``backlog`` older samples come before any fresh one."""

    def __init__(self, backlog: int = 0) -> None:
        self.t_s, self.seq, self.backlog = 10.0, 0, backlog
        self.streaming = False
        self.log: list[str] = []
        self.dropped = self.corrupt = 0
        self.closed = False

    def identify(self) -> str:
        return "sensor"

    def configure(self, **settings) -> None:
        self.log.append(f"configure {settings['rate_hz']}")

    def start(self) -> None:
        self.log.append("START")
        self.streaming = True

    def stop(self) -> None:
        self.log.append("STOP")
        self.streaming = False

    def sync(self) -> float:
        """The backlog was converted before now; the board's clock runs ahead of the host's."""
        return self.t_s + (self.backlog + 1) / RATE_HZ

    def read(self, n: int, timeout_s: float = 1.0) -> SampleBlock:
        t_s = self.t_s + np.arange(1, n + 1) / RATE_HZ
        self.t_s, self.seq = float(t_s[-1]), self.seq + n
        counts = np.zeros((n, 3), int)
        return SampleBlock(np.arange(self.seq - n, self.seq), t_s, counts, counts * 1.0,
                           np.zeros(n, np.uint8))

    def close(self) -> None:
        self.closed = True


CONFIG = SessionConfig(frame=RigFrame.from_degrees((40.0, 100.0), 90.0),
                       sensor=SensorConfig(rate_hz=RATE_HZ), home_setting="motion.home")


def open_session(stage=None, sensor=None, config=CONFIG) -> RigSession:
    return RigSession.open(None, None, config, stage_client=stage or Stage(),
                           sensor_client=sensor or Sensor())


def test_frames_round_trip_and_turn_with_the_rig_angle():
    frame = RigFrame.from_degrees((40.0, 100.0), 90.0)
    points = np.array([[10.0, 0.0], [3.0, -4.0]])
    np.testing.assert_allclose(frame.to_stage(points), [[40.0, 110.0], [44.0, 103.0]])
    np.testing.assert_allclose(frame.to_whisker(frame.to_stage(points)), points, atol=1e-12)
    np.testing.assert_allclose(frame.vector_to_stage([1.0, 0.0]), [0.0, 1.0], atol=1e-12)
    np.testing.assert_allclose(frame.vector_to_whisker([0.0, 1.0]), [1.0, 0.0], atol=1e-12)
    assert outside_travel([[0.5, 50.0], [50.0, 50.0], [50.0, 199.5]], (200.0, 200.0), 1.0).tolist() == \
        [True, False, True]


def test_travel_comes_from_the_stage_else_from_the_config():
    with open_session(Stage(travel=(150.0, 120.0))) as rig:
        assert rig.travel_mm == (150.0, 120.0)
    with open_session(Stage(travel=None)) as rig:
        assert rig.travel_mm == (200.0, 200.0)


def test_start_homes_configures_and_starts_the_stream_then_exit_stops_it():
    stage, sensor = Stage(homed=False), Sensor()
    with open_session(stage, sensor) as rig:
        assert stage.log == [] and sensor.log == []  # nothing moves before start()
        rig.start()
    assert stage.log == ["$H"]
    assert sensor.log == ["STOP", "configure 100", "START", "STOP"]
    assert not stage.closed and not sensor.closed  # clients handed in are left open


def test_an_unhomed_stage_is_refused_when_homing_is_off():
    config = SessionConfig(frame=CONFIG.frame, home=False, home_setting="motion.home")
    with pytest.raises(DeviceError, match=r"not homed.*set motion.home = true"):
        with open_session(Stage(homed=False), config=config) as rig:
            rig.start()


def test_move_to_goes_to_the_stage_point_of_a_whisker_point():
    stage = Stage()
    with open_session(stage) as rig:
        rig.start()
        status = rig.move_to([10.0, 0.0], 600.0)
    assert stage.log[-1] == "G1 X40 Y110" and status.idle
    np.testing.assert_allclose(status.mpos_mm, [40.0, 110.0])


def test_the_encoder_alarm_gets_the_encoder_message():
    stage = Stage()
    stage.alarm_on_arrival = int(StageAlarm.ENCODER_MISMATCH)
    with open_session(stage) as rig:
        rig.start()
        with pytest.raises(EncoderMismatchError, match="disagree at point 3 \\(ALARM:100\\)"):
            rig.move_to([10.0, 0.0], 600.0, where=" at point 3")


@pytest.mark.parametrize("failure", [DeviceError("unplugged"), KeyboardInterrupt()])
def test_every_exit_halts_a_moving_stage_and_stops_the_stream(failure):
    stage, sensor = Stage(), Sensor()

    def fail(status):
        raise failure

    with pytest.raises(type(failure)):
        with open_session(stage, sensor) as rig:
            rig.start()
            rig.move_to([10.0, 0.0], 600.0, on_poll=fail)
    assert stage.log[-2:] == ["!", "reset"] and stage.state == "Idle"
    assert sensor.log[-1] == "STOP"


def test_ports_the_session_opened_are_closed(monkeypatch):
    import whiskercal.rig.sensor as sensor_module
    import whiskercal.rig.stage as stage_module

    made: list = []
    monkeypatch.setattr(stage_module, "StageClient", lambda port: made.append(Stage()) or made[-1])
    monkeypatch.setattr(sensor_module, "SensorClient", lambda port: made.append(Sensor()) or made[-1])
    with RigSession.open("stage-url", "sensor-url", CONFIG):
        pass
    assert [client.closed for client in made] == [True, True]


def test_measure_skips_the_backlog_and_the_settle_by_the_sensors_clock():
    sensor = Sensor(backlog=40)
    stale: list[SampleBlock] = []
    with open_session(sensor=sensor) as rig:
        rig.start()
        sync_s = sensor.sync()
        block = rig.measure(5, settle_s=0.095, on_stale=stale.append)
    assert len(block) == 5 and block.t_s[0] >= sync_s + 0.095
    assert block.t_s[0] - 1.0 / RATE_HZ < sync_s + 0.095  # and no later than needed
    older = SampleBlock.join(stale)
    assert len(older) == 40 + 10 and np.all(older.t_s < block.t_s[0])
    np.testing.assert_array_equal(np.concatenate([older.seq, block.seq]), np.arange(55))


def test_summary_counts_frames_and_times():
    sensor = Sensor()
    sensor.dropped, sensor.corrupt = 3, 1
    with open_session(sensor=sensor) as rig:
        summary = rig.summary()
    assert (summary.dropped, summary.corrupt) == (3, 1) and summary.wall_time_s >= 0.0


def test_the_session_imports_only_the_layers_below_it():
    import ast
    from pathlib import Path

    import whiskercal.session

    allowed = ("whiskercal.errors", "whiskercal.protocol", "whiskercal.rig", "whiskercal.session")
    for path in Path(whiskercal.session.__file__).parent.glob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom) and node.module.startswith("whiskercal"):
                assert node.module.startswith(allowed), f"{path.name} imports {node.module}"
            if isinstance(node, ast.Import):
                assert not any(a.name.startswith("whiskercal") for a in node.names), path.name


def test_a_failing_sensor_does_not_keep_the_stage_from_being_stopped():
    class SlowHold(Stage):
        def hold(self) -> None:
            super().hold()
            self.state, self.polls_to_rest = "Hold:1", 3  # GRBL 1.1: still decelerating

        def status(self) -> StageStatus:
            if self.state == "Hold:1":
                self.polls_to_rest -= 1
                if self.polls_to_rest == 0:
                    self.state = "Hold:0"
            return super().status()

    class Unplugged(Sensor):
        def read(self, n: int, timeout_s: float = 1.0) -> SampleBlock:
            raise DeviceError("sensor on scripted is disconnected")

    stage = SlowHold()
    with pytest.raises(DeviceError, match="disconnected"):
        with open_session(stage, Unplugged()) as rig:
            rig.start()
            rig.move_to([10.0, 0.0], 600.0)
    assert stage.log[-2:] == ["!", "reset"]


class StockGrblSpace(Stage):
    """A stock grbl 1.1 board homing X and Y toward their minimum ($23=3): machine -199 after $H."""

    def __init__(self, homed_mm=(-199.0, -199.0)) -> None:
        super().__init__()
        self.homed_mm = np.asarray(homed_mm, float)

    def identify(self) -> StageIdentity:
        return StageIdentity("1.1h.20190825", "", "V", None, False)  # stock: no encoders

    def settings(self) -> dict[int, float]:
        return {20: 1, 22: 1, 23: 3, 27: 1.0, 100: 80.0, 101: 80.0, 130: 200.0, 131: 200.0}

    def home(self) -> None:
        super().home()
        self.position = self.homed_mm.copy()


def test_a_stock_board_in_negative_machine_space_is_mapped_not_refused():
    stage = StockGrblSpace()
    with open_session(stage, config=dataclasses.replace(CONFIG, home=True)) as rig:
        assert rig.travel_mm == (199.0, 199.0)  # predicted from $$ before homing
        rig.start()
        assert stage.space.layout.startswith("stock")
        np.testing.assert_allclose(stage.space.origin_mm, [-199.0, -199.0])
        np.testing.assert_allclose(stage.space.to_machine([10.0, 20.0]), [-189.0, -179.0])
        assert rig.travel_mm == (199.0, 199.0)  # stage 0..199 is grbl's -199..0


def test_a_board_homed_where_no_layout_puts_it_is_refused_before_any_move():
    stage = StockGrblSpace(homed_mm=(-1.0, -1.0))  # $23=3 says -199; a force-set origin says 0
    with pytest.raises(DeviceError, match=r"fits neither stock grbl 1\.1.*HOMING_FORCE_SET_ORIGIN"):
        with open_session(stage, config=dataclasses.replace(CONFIG, home=True)) as rig:
            rig.start()
    assert not any(entry.startswith("G") for entry in stage.log)