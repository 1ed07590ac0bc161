"""whiskercal: calibration and characterization of magnetically transduced whisker sensors.

Units throughout: mm, s, µT, rad, N.
"""

__version__ = "0.1.0"

from whiskercal.sim import register as _register_sim_urls

_register_sim_urls()  # sim://NAME/stage and sim://NAME/sensor open the twin's boards
