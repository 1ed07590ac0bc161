"""The overload guard: a saturated axis, Z as much as Y, stops the run; so does a large |z|."""

from __future__ import annotations

import numpy as np
import pytest

from collect_fakes import FakeSensor, FakeStage, FakeWorld
from test_loop import small_plan
from whiskercal.collect.recorder import StreamRecorder
from whiskercal.rig.overload import OverloadError
from whiskercal.collect.run import collect
from whiskercal.errors import DeviceError
from whiskercal.protocol.codes import SensorStatus
from whiskercal.rig.sensor import SampleBlock

RATE_HZ = 300
LSB_UT = np.array([1.000, 1.000, 1.612])  # GAIN_SEL 5, RES 2


class ScriptedSensor:
    """Hands out the given counts (n, 3) and status bytes once, as one block."""

    def __init__(self, counts, status=None) -> None:
        self.counts = np.asarray(counts, int)
        self.status = np.zeros(len(self.counts), np.uint8) if status is None else np.asarray(status, np.uint8)

    def read(self, n: int, timeout_s: float = 1.0) -> SampleBlock:
        return SampleBlock(seq=np.arange(n), t_s=np.arange(n) / RATE_HZ, counts=self.counts[:n],
                           field_uT=self.counts[:n] * LSB_UT, status=self.status[:n])


def _guarded(counts, status=None, res: int = 2) -> StreamRecorder:
    recorder = StreamRecorder(ScriptedSensor(counts, status), RATE_HZ, res)
    recorder.static_y_uT = 1160.0
    recorder.overload_z_uT = 15000.0
    return recorder


# Y -8760 µT below rest and Z -34.6 mT: the deepest readings of the default grid, unsaturated.
DEEP = [0, 1160 - 8760, round(-34600 / 1.612)]


def test_deep_but_unsaturated_readings_pass():
    recorder = _guarded([DEEP, [0, 1160, -16900]])
    assert len(recorder.read(2).t_s) == 2


@pytest.mark.parametrize("axis, count, name", [(2, -32768, "Z"), (2, 32767, "Z"), (1, -32768, "Y"),
                                               (0, 32767, "X")])
def test_a_saturated_axis_stops_the_run(axis, count, name):
    row = list(DEEP)
    row[axis] = count
    with pytest.raises(OverloadError, match=f"sensor's {name} axis saturated"):
        _guarded([DEEP, row]).read(2)


def test_several_saturated_axes_are_all_named():
    with pytest.raises(OverloadError, match="the sensor's X and Z axes saturated"):
        _guarded([[32767, 0, 0], [0, 0, -32768]]).read(2)


def test_the_saturation_count_follows_the_resolution():
    row = [0, 0, -16384]  # RES 3 spans 15 bits: the end of its range, mid-range at RES 2
    with pytest.raises(OverloadError, match="Z axis"):
        _guarded([row], res=3).read(1)
    _guarded([row], res=2).read(1)


def test_the_status_bit_alone_counts_as_saturated():
    with pytest.raises(OverloadError, match="one of the sensor's axes saturated"):
        _guarded([DEEP], status=[int(SensorStatus.SATURATED)]).read(1)


def test_invalid_samples_and_unguarded_reads_are_not_judged():
    error = int(SensorStatus.MLX_ERROR)
    _guarded([DEEP, [0, 0, -32768]], status=[0, error]).read(2)  # no measurement at all
    _guarded([[0, 0, -32768]]).read(1, guard=False)


def test_large_z_still_trips_the_guard():
    with pytest.raises(OverloadError, match="reached 15840 µT, over the safe limit of 15000 µT"):
        _guarded([[0, 1160 - 15840, -20000]]).read(1)


class SaturatingSensor(FakeSensor):
    """The fake sensor with a Z axis that hits the end of its range below ``z_below_uT``."""

    def __init__(self, world, z_below_uT: float) -> None:
        super().__init__(world)
        self.z_below_uT = z_below_uT

    def read(self, n: int, timeout_s: float = 1.0) -> SampleBlock:
        block = super().read(n, timeout_s)
        if self.world.z_uT(self.world.stage.true_mm) <= self.z_below_uT:
            block.counts[:, 2] = -32768
        return block


def test_the_loop_backs_off_when_z_saturates_mid_grid(tmp_path):
    world = FakeWorld()
    stage = FakeStage(world)
    with pytest.raises(OverloadError, match="Z axis saturated"):
        collect(None, None, tmp_path / "raw.h5", small_plan(safety={"on_overload": "stop"}), stage_client=stage,
                sensor_client=SaturatingSensor(world, z_below_uT=-3000.0))
    assert "!" in stage.commands  # the move was held, then the rod lifted


def test_a_baseline_with_a_saturated_axis_blames_the_settings(tmp_path):
    world = FakeWorld()
    with pytest.raises(DeviceError, match="Z axis saturated with the whisker at rest at GAIN_SEL 5"):
        collect(None, None, tmp_path / "raw.h5", small_plan(), stage_client=FakeStage(world),
                sensor_client=SaturatingSensor(world, z_below_uT=np.inf))
