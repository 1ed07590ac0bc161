"""A host that stalls while the stage moves must not average samples from before it arrived.

An operating system's serial driver holds more than it shows: Linux's tty layer lets a reader see
at most 4095 bytes (N_TTY's read buffer) while more frames wait in its flip buffers, and a USB
bridge keeps its own. A busy host that falls behind the 300 Hz stream therefore cannot "drain"
the backlog by reading what is available: frames taken while the stage was still moving are
still queued behind it. Here a driver of that kind sits between the host and the twin's sensor,
and the host stalls for a few seconds right after commanding a slow move onto a grid point;
every sample averaged for a point must still come from after the stage stood still there (the
twin's truth says where the stage was when each sample was converted).
"""

from __future__ import annotations

import uuid

import h5py
import numpy as np

from whiskercal.collect.config import load_config
from whiskercal.artifacts.raw_grid import read_raw_grid
from whiskercal.collect.plan import build_plan
from whiskercal.collect.run import collect
from whiskercal.rig.sensor import SensorClient
from whiskercal.rig.stage import StageClient
from whiskercal.study.truth import match_rows
from whiskercal.twin.devices import simport

from fast_collect import SMALL_BAND, SWEEP_OFF

VISIBLE_BYTES = 4095  # what Linux's tty layer lets a reader see at once
STALL_S = 2.0  # simulated s: longer than a step down a column, so the stage arrives meanwhile
CONFIG = SMALL_BAND + SWEEP_OFF + """
[motion]
travel_feed_mm_min = 3000.0
# 2.5 mm/s: a 3 mm step down a column takes 1.3 s, about 400 frames (7.6 kB) at 300 Hz
approach_feed_mm_min = 150.0
[acquisition]
settle_s = 0.05
samples_per_point = 5
baseline_samples = 30
"""


class QueuingDriver:
    """A simulated sensor port behind a driver that queues everything but shows little of it.

    ``stall(seconds)`` lets simulated time pass without the host reading: every byte the board
    sends meanwhile is kept, in order, and ``in_waiting`` never reports more than
    ``VISIBLE_BYTES``, as a tty does.
    """

    def __init__(self, port) -> None:
        self.port = port
        self.queue = bytearray()

    def __getattr__(self, name):
        return getattr(self.port, name)

    @property
    def timeout(self):
        return self.port.timeout

    @timeout.setter
    def timeout(self, value) -> None:
        self.port.timeout = value

    def stall(self, seconds: float) -> None:
        end = self.port.now_s() + seconds
        while (left := end - self.port.now_s()) > 0:
            self.port.timeout = min(left, 0.01)
            self.queue += self.port.read(4096)

    @property
    def in_waiting(self) -> int:
        return min(len(self.queue) + self.port.in_waiting, VISIBLE_BYTES)

    def read(self, size: int = 1) -> bytes:
        data = bytes(self.queue[:size])
        del self.queue[:size]
        if len(data) < size:
            data += self.port.read(size - len(data))
        return data


class StallingStage(StageClient):
    """A stage client whose host stalls right after commanding the first step down a column."""

    def __init__(self, port, driver: QueuingDriver, step_mm: float) -> None:
        super().__init__(port)
        self.driver, self.step_mm = driver, step_mm
        self.target_mm = np.full(2, np.nan)
        self.stalled = False

    def move_to(self, x_mm: float, y_mm: float, feed_mm_min: float) -> None:
        super().move_to(x_mm, y_mm, feed_mm_min)
        step = np.array([x_mm, y_mm]) - self.target_mm
        self.target_mm = np.array([x_mm, y_mm])
        if not self.stalled and np.allclose(step, [0.0, -self.step_mm]):  # default rig angle 0
            self.stalled = True
            self.driver.stall(STALL_S)


def test_a_stalled_host_averages_only_samples_taken_at_rest(tmp_path):
    config_path = tmp_path / "collect.toml"
    config_path.write_text(CONFIG)
    plan = build_plan(load_config(config_path))
    name = f"stale{uuid.uuid4().hex[:8]}"
    stage_port = simport.Serial(f"sim://{name}/stage?seed=5", timeout=1.0)
    driver = QueuingDriver(simport.Serial(f"sim://{name}/sensor", timeout=1.0))
    stage = StallingStage(stage_port, driver, plan.config.grid.step_mm)
    taken = []
    collect(None, None, tmp_path / "raw.h5", plan, stage_client=stage,
            sensor_client=SensorClient(driver), on_progress=lambda p: taken.append(p.done),
            stop_requested=lambda: len(taken) >= 3)
    assert stage.stalled and len(driver.queue) == 0  # the host stalled and caught up again

    truth = stage_port.world.truth.arrays()
    with h5py.File(tmp_path / "raw.h5") as handle:
        stream_t_s, stream_point = handle["stream/t_s"][()], handle["stream/point"][()]
        plan_index = handle["points/plan_index"][()]
    assert len(plan_index) == 3
    settle_s = plan.config.acquisition.settle_s
    for index in plan_index:
        sample_t_s = stream_t_s[stream_point == index]
        rows = match_rows(truth["t_s"], sample_t_s, 1e-5)  # board times are whole µs
        assert np.all(rows >= 0), index
        # where the stage was when each averaged sample was converted: at the point, at rest
        at_rest = truth["stage_mm"][rows[-1]]
        assert np.max(np.abs(truth["stage_mm"][rows] - at_rest)) < 1e-9, index
        assert np.max(np.abs(at_rest - plan.stage_mm[index])) < 0.05, index
        moving = np.flatnonzero(np.any(np.abs(truth["stage_mm"][:rows[0]] - at_rest) > 1e-9, axis=1))
        assert sample_t_s[0] >= truth["t_s"][moving[-1]] + settle_s, index  # and settled
    grid = read_raw_grid(tmp_path / "raw.h5")
    np.testing.assert_allclose(grid.z_uT, grid.truth["z_uT"], atol=5.0 * np.median(grid.z_std_uT))
