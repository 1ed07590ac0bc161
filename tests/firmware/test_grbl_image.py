"""Stock grbl 1.1h itself (gnea/grbl, built by ``make grbl-sim`` from WHISKERCAL_GRBL_SRC) on simavr
as the twin's stage: ``sim://NAME/stage?firmware=grbl[&homing=xy]``. Skipped where the variable is
unset (grbl is not part of whiskercal)."""

import time
import uuid

import numpy as np
import pytest
import serial

from grbl_emulation import grbl_or_skip
from grbl_transcript import TRANSCRIPTS, read_transcript
from transcript_compare import differences, replay
from whiskercal.errors import WhiskercalError
from whiskercal.protocol.codes import StageAlarm
from whiskercal.rig.stage import StageAlarmError, StageClient

from fast_collect import FAST_MOTION

pytestmark = pytest.mark.grbl
STEP_MM = 1 / 80
BACKLASH_MM = 0.02  # the twin's default belt dead band
SMALL_GRID = FAST_MOTION + """
[grid]
reach_min_mm = 45
reach_max_mm = 52
expected_points = 0
"""


def _image_replay(name):
    header, recorded = read_transcript(TRANSCRIPTS / f"{name}.jsonl")
    grbl_or_skip("xy" if header["image"] != "stock" else "")
    query = "?firmware=grbl" + header["twin_url"].removeprefix("?stock=1")
    return differences(header, recorded, replay(header, f"sim://NAME/stage{query}"))


@pytest.mark.parametrize("name", ["banner_settings", "error_codes", "soft_limit", "status_wpos"])
def test_image_repeats_its_transcript(name):
    # the recording is reproducible: the same image, the same owner settings, the same answers
    assert _image_replay(name) == []


@pytest.mark.slow
@pytest.mark.parametrize("name", ["feed_hold", "dwell", "home_xy", "home_stock_config", "home_polled",
                                  "home_xy_origin"])
def test_image_repeats_its_motion_transcript(name):
    assert _image_replay(name) == []


def _stage(query):
    port = serial.serial_for_url(f"sim://grbl{uuid.uuid4().hex[:8]}/stage?{query}", timeout=1)
    return port, StageClient(port, timeout_s=5.0)


@pytest.mark.slow
def test_xy_homing_and_moves_reach_the_twins_positions():
    grbl_or_skip("xy")
    port, stage = _stage("seed=11&firmware=grbl&homing=xy")
    identity = stage.identify()
    assert identity.version == "1.1h.20190825" and not identity.has_encoder and identity.proto is None
    stage.home(timeout_s=120)
    status = stage.status()
    np.testing.assert_allclose(status.mpos_mm, [-199.0, -199.0])  # machine zero at the far end
    # the Python stage's homed zero is physical (0, 0): grbl's seek stops within a step of it
    np.testing.assert_allclose(port.world.stage_true_mm(port.now_s()), [0, 0], atol=STEP_MM + BACKLASH_MM)
    stage.move_to(-150.0, -120.0, 3000.0)
    stage.wait_idle(timeout_s=30)
    np.testing.assert_allclose(stage.status().mpos_mm, [-150.0, -120.0])
    np.testing.assert_allclose(port.world.stage_true_mm(port.now_s()), [49.0, 79.0], atol=STEP_MM + BACKLASH_MM)
    stage.close()


def test_client_recovers_from_a_soft_limit_alarm_on_the_image():
    grbl_or_skip("xy")
    port, stage = _stage("firmware=grbl&homing=xy")
    stage.identify()
    stage.unlock()
    with pytest.raises(StageAlarmError) as raised:
        stage.move_to(10.0, 0.0, 3000.0)  # +10 mm: beyond grbl's -200..0 machine space
    assert raised.value.code == StageAlarm.SOFT_LIMIT
    stage.recover(raised.value.code)  # grbl's order: its message, then the reset, the banner, $X
    assert stage.banner.startswith("Grbl 1.1h") and stage.status().idle
    stage.close()


@pytest.mark.slow
def test_stock_config_homing_is_one_clear_line_not_a_hang():
    grbl_or_skip("")
    port, stage = _stage("firmware=grbl")
    started = port.now_s()
    with pytest.raises(StageAlarmError) as raised:
        stage.home(timeout_s=120)
    assert raised.value.code == StageAlarm.HOMING_FAIL_APPROACH
    message = str(raised.value)
    assert "\n" not in message and "config.h" in message and isinstance(raised.value, WhiskercalError)
    assert port.now_s() - started < 40  # grbl gives up after 1.5 x $132 of Z travel at $25: 36 s
    stage.close()


def _collect(tmp_path, stage_query, wpos_reports=False):
    from whiskercal.artifacts.raw_grid import read_raw_grid
    from whiskercal.collect.config import load_config
    from whiskercal.collect.plan import build_plan
    from whiskercal.collect.run import collect

    config_path = tmp_path / "collect.toml"
    config_path.write_text(SMALL_GRID)
    plan = build_plan(load_config(config_path))
    name, out = f"grblgrid{uuid.uuid4().hex[:8]}", tmp_path / f"raw{uuid.uuid4().hex[:6]}.h5"
    stage_url = f"sim://{name}/stage?seed=11" + stage_query
    if wpos_reports:  # the board's owner left $10=0 (WPos reports); the EEPROM keeps it
        with StageClient(stage_url, timeout_s=5.0) as board:
            board.identify()
            board.set_setting(10, 0)
    summary = collect(stage_url, f"sim://{name}/sensor", out, plan)
    return summary, read_raw_grid(out)


@pytest.mark.slow
@pytest.mark.parametrize("wpos_reports", [False, True], ids=["mpos", "wpos"])
def test_small_grid_through_stock_grbl_matches_the_python_boards(tmp_path, wpos_reports):
    grbl_or_skip("xy")
    _, python = _collect(tmp_path, "")
    started = time.perf_counter()
    summary, grbl = _collect(tmp_path, "&firmware=grbl&homing=xy", wpos_reports)
    print(f"grbl grid: {time.perf_counter() - started:.1f} s wall")
    assert summary.complete and summary.dropped == 0 and summary.corrupt == 0
    np.testing.assert_array_equal(grbl.plan_index, python.plan_index)
    np.testing.assert_allclose(grbl.truth["stage_mm"], python.truth["stage_mm"], atol=STEP_MM + BACKLASH_MM)
    assert np.abs(grbl.z_uT - python.z_uT).max() <= 20.0
