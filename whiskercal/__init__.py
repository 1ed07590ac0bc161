"""whiskercal: calibration and characterization of magnetically transduced whisker sensors.

Units throughout: mm, s, µT, rad, N.
"""

__version__ = "0.1.0"
