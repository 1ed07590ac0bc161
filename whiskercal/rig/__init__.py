"""Protocol codecs and clients for the stage and the sensor, the shared code table, port discovery.

Clients take a port name/URL (``/dev/ttyUSB0``, ``sim://NAME/stage``) or an open pyserial object.
``sim://`` URLs reach the twin through ``whiskercal.sim``, registered when ``whiskercal`` is imported.
"""

from whiskercal.rig.sensor import SampleBlock, SensorClient, SensorCommandError, SensorConfig
from whiskercal.rig.stage import (StageAlarmError, StageClient, StageCommandError, StageIdentity,
                                  StageStatus)

__all__ = ["SampleBlock", "SensorClient", "SensorCommandError", "SensorConfig", "StageAlarmError",
           "StageClient", "StageCommandError", "StageIdentity", "StageStatus"]
