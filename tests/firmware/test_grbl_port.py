"""``firmware=grbl`` on a sim:// port without the images, or on the wrong port: one clear line."""

import uuid

import pytest
import serial

from whiskercal.errors import DeviceError, UsageError
from whiskercal.rig.stage import StageClient


def test_unbuilt_grbl_image_names_the_build_command(tmp_path, monkeypatch):
    monkeypatch.setenv("WHISKERCAL_FIRMWARE_BUILD", str(tmp_path))
    (tmp_path / "sim").mkdir()
    (tmp_path / "sim" / "avr_harness").write_text("")  # the harness is there, grbl is not
    with pytest.raises(DeviceError) as raised:
        StageClient(f"sim://nogrbl{uuid.uuid4().hex[:8]}/stage?firmware=grbl&homing=xy")
    message = str(raised.value)
    assert "WHISKERCAL_GRBL_SRC" in message and "make grbl-sim" in message and "\n" not in message


def test_grbl_is_a_stage_firmware():
    with pytest.raises(UsageError, match="stage"):
        serial.serial_for_url(f"sim://grblsensor{uuid.uuid4().hex[:8]}/sensor?firmware=grbl")


def test_set_origin_image_homes_x_and_y():
    with pytest.raises(UsageError, match="homing=xy"):
        StageClient(f"sim://grblorigin{uuid.uuid4().hex[:8]}/stage?firmware=grbl&origin=set")
