"""whiskercal: calibration and characterization of magnetically transduced whisker sensors.

Units throughout: mm, s, µT, rad, N.
"""

__version__ = "0.1.0"

import serial as _serial

# pyserial imports ``whiskercal.sim.protocol_sim`` when a sim:// URL is opened, so the twin's
# boards answer sim://NAME/stage and sim://NAME/sensor without rig importing the twin.
if "whiskercal.sim" not in _serial.protocol_handler_packages:
    _serial.protocol_handler_packages.append("whiskercal.sim")
