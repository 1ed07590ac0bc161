"""Protocol codecs and clients for the stage and the sensor, the shared code table, port discovery.

Clients take a port name/URL (``/dev/ttyUSB0``, ``sim://NAME/stage``) or an open pyserial object.
Importing this package registers the twin's ``sim://`` scheme with ``serial.serial_for_url``.
"""

import serial

if "whiskercal.rig" not in serial.protocol_handler_packages:
    serial.protocol_handler_packages.append("whiskercal.rig")

from whiskercal.rig.sensor import SampleBlock, SensorClient, SensorCommandError, SensorConfig
from whiskercal.rig.stage import (StageAlarmError, StageClient, StageCommandError, StageIdentity,
                                  StageStatus)

__all__ = ["SampleBlock", "SensorClient", "SensorCommandError", "SensorConfig", "StageAlarmError",
           "StageClient", "StageCommandError", "StageIdentity", "StageStatus"]
