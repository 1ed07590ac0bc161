"""collect on a stock grbl 1.1 board (the twin's stock mode): the grid mapped into grbl's
negative machine space reaches the same physical positions as on whiskercal's firmware, with
MPos or WPos reports, and a soft-limit alarm is recovered from in grbl's order."""

from __future__ import annotations

import uuid

import numpy as np
import pytest

from whiskercal.artifacts.raw_grid import read_raw_grid
from whiskercal.collect.config import load_config
from whiskercal.collect.plan import build_plan
from whiskercal.collect.run import collect
from whiskercal.errors import DeviceError
from whiskercal.rig.stage import StageClient
from whiskercal.twin.world import get_world

from fast_collect import FAST

SMALL_GRID = FAST + """
[grid]
reach_min_mm = 45
reach_max_mm = 52
expected_points = 0
"""
STEP_MM = 1.0 / 80.0  # the twin's stage: 80 steps/mm ($100/$101)


def _plan(tmp_path):
    path = tmp_path / "collect.toml"
    path.write_text(SMALL_GRID)
    return build_plan(load_config(path))


def _name() -> str:
    return f"s{uuid.uuid4().hex[:10]}"


def _true_positions(path) -> dict[int, np.ndarray]:
    grid = read_raw_grid(path)
    return dict(zip(grid.plan_index.tolist(), grid.truth["rod_center_mm"]))


@pytest.fixture(scope="module")
def firmware_run(tmp_path_factory):
    """The small grid on whiskercal's firmware (the twin's default board), seed 11."""
    tmp_path = tmp_path_factory.mktemp("firmware")
    name = _name()
    out = tmp_path / "raw.h5"
    summary = collect(f"sim://{name}/stage?seed=11", f"sim://{name}/sensor", out, _plan(tmp_path))
    assert summary.complete
    return out


def _assert_same_places(stock_out, firmware_out, plan) -> None:
    stock, firmware = _true_positions(stock_out), _true_positions(firmware_out)
    assert sorted(stock) == sorted(firmware) == list(range(len(plan)))
    difference = np.array([stock[i] - firmware[i] for i in stock])
    assert np.max(np.abs(difference)) <= STEP_MM, np.max(np.abs(difference))
    grid = read_raw_grid(stock_out)
    assert grid.encoders == "none"
    # open loop: the positions recorded are the commanded ones, in stage coordinates
    np.testing.assert_allclose(grid.rod_center_mm, grid.truth["rod_center_mm"], atol=0.02 + STEP_MM)


def test_stock_grbl_reaches_the_firmwares_positions_in_its_negative_machine_space(tmp_path,
                                                                                 firmware_run):
    name = _name()
    plan = _plan(tmp_path)
    out = tmp_path / "raw.h5"
    summary = collect(f"sim://{name}/stage?seed=11&stock=1&homing=xy", f"sim://{name}/sensor",
                      out, plan)
    assert summary.complete and len(plan) >= 10
    world = get_world(name)
    # the board was driven in grbl's -travel..0, as stock grbl 1.1 works after homing
    assert np.all(world.stage.machine_mm(world.now_s) < 0)
    _assert_same_places(out, firmware_run, plan)


def test_stock_grbl_reporting_wpos_reaches_the_same_positions(tmp_path, firmware_run):
    name = _name()
    url = f"sim://{name}/stage?seed=11&stock=1&homing=xy"
    with StageClient(url) as stage:  # set on the board beforehand, kept in its EEPROM
        stage.set_setting(10, 0)
    plan = _plan(tmp_path)
    out = tmp_path / "raw.h5"
    assert collect(url, f"sim://{name}/sensor", out, plan).complete
    world = get_world(name)
    assert np.all(world.stage.machine_mm(world.now_s) < 0)  # grbl's -travel..0
    with StageClient(f"sim://{name}/stage") as stage:
        assert stage.status().wco_mm is not None  # it reports WPos and WCO
    assert read_raw_grid(out).config["devices"]["stage_settings"]["10"] == 0
    _assert_same_places(out, firmware_run, plan)


def test_a_soft_limit_alarm_mid_run_is_recovered_and_the_run_resumes(tmp_path):
    name = _name()
    plan = _plan(tmp_path)
    out = tmp_path / "raw.h5"
    stage = StageClient(f"sim://{name}/stage?seed=11&stock=1&homing=xy")
    world = get_world(name)

    def shrink_travel(progress) -> None:  # the board's soft limits change under the run
        if progress.done == 3:
            world.stage.settings.update({130: 10.0, 131: 10.0})

    with pytest.raises(DeviceError, match=r"ALARM:2.*reset and unlocked at the same position.*"
                                          r"--resume") as info:
        collect(stage, f"sim://{name}/sensor", out, plan, on_progress=shrink_travel,
                stage_client=stage)
    assert "3 of" in str(info.value)  # the points taken are saved
    status = stage.status()
    assert status.idle  # reset and unlocked: grbl's pause is over
    np.testing.assert_allclose(world.stage.machine_mm(world.now_s) - stage.space.origin_mm,
                               status.mpos_mm)
    world.stage.settings.update({130: 200.0, 131: 200.0})
    summary = collect(stage, f"sim://{name}/sensor", out, plan, resume=True, stage_client=stage)
    assert summary.complete
    grid = read_raw_grid(out)
    assert sorted(grid.plan_index.tolist()) == list(range(len(plan)))
    np.testing.assert_allclose(grid.rod_center_mm, grid.truth["rod_center_mm"], atol=0.02 + STEP_MM)
    stage.close()
