"""The twin's calibration data and truth, shared by ``whiskercal bench`` and the tests.

``twin_grid``: z-only rod grids from the twin's physics and its true tips; ``fields``: (Y, Z)
rod grids and tip sweeps for any build, the twin's own mechanics in a fit's parameters, tip
contacts against tilted planes with friction, and the errors a calibration reads on them.
Nothing here is shipped to a robot: it judges calibrations against what the twin knows.
"""
