"""``whiskercal sim serve --firmware grbl --homing xy``: stock grbl 1.1h on simavr behind the stage's
pty (the sensor stays the twin's Python board). Marked ``grbl``: skipped unless
WHISKERCAL_GRBL_SRC names a checkout of gnea/grbl v1.1h."""

import os

import pytest
import serial

from grbl_emulation import grbl_or_skip
from served_sim import sim_serve
from whiskercal.rig.stage import StageClient

pytestmark = pytest.mark.grbl


def test_sim_serve_runs_stock_grbl_behind_the_stage_pty():
    grbl_or_skip("xy")
    with sim_serve("--firmware", "grbl", "--homing", "xy") as info:
        assert info["firmware"] == "grbl" and os.path.exists(info["stage"])
        # generous timeout: it only guards against a hang on a busy host
        stage = StageClient(serial.Serial(info["stage"], 115200, timeout=1), timeout_s=30.0)
        settings = stage.settings()
        assert len(settings) == 34  # grbl 1.1h's own $$, not the twin's
        assert stage.identify().version.startswith("1.1h.20190825")
